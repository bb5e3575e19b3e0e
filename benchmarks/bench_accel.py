"""Ray intersection against primitive count: vrlab's NumPy BVH (``vrlab.render.accel.scene_bvh``), its
all-pairs kernels, Embree through ``embreex`` (``vrlab.render.accel.embree``: what large triangle
scenes use where it is installed) and Mitsuba 3 side by side, from 10 to 10^6 primitives
(issue 24).

    python benchmarks/bench_accel.py [--rays 32768] [--max 1000000] [--rounds 3] [--no-mitsuba]

Scenes: a tessellated unit sphere of P triangles (rays from a sphere of radius 3 towards
points near the centre: about 90 % hit) and P random small spheres in a 10^3 box (rays
from random points in random directions).  Per P: the build time of the BVH, closest-hit
rays/s and shadow (any-hit, t_max = half the closest t or 1) rays/s through
``SceneGeometry``'s BVH, rays/s of the all-pairs path (float32 kernels for triangles, the
culling products for spheres; up to the P where it takes more than ~5 s), and, with
Mitsuba 3 installed, ``scene.ray_intersect`` rays/s of a mesh shape in ``llvm_ad_rgb`` (one
vectorised call; wall-clock after a first compiling call; needs libLLVM, see
``bench_bsdfs.py``) and ``scalar_rgb`` (one ray per Python call, shown for completeness: it
measures the Python loop, not Mitsuba's kernels).  Fastest of ``--rounds``; one process.
Prints a markdown table; ``ratio`` columns are vrlab BVH / peer rays/s.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vrlab.render.accel.scene_bvh import Accel  # noqa: E402
from vrlab.render.accel.embree import embree_available  # noqa: E402
from vrlab.render.accel.groups import Planar, Quadrics, unit  # noqa: E402


def sphere_mesh(P: int) -> np.ndarray:
    """About P triangles ``(P, 3, 3)`` of a UV sphere (degenerate pole triangles dropped)."""
    k = max(int(np.sqrt(P / 2)), 2)
    th, ph = np.meshgrid(np.linspace(0, np.pi, k + 1), np.linspace(0, 2 * np.pi, k + 1), indexing="ij")
    v = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
    a, b, c, d = v[:-1, :-1], v[1:, :-1], v[1:, 1:], v[:-1, 1:]
    t = np.concatenate([np.stack([a, b, c], -2).reshape(-1, 3, 3), np.stack([a, c, d], -2).reshape(-1, 3, 3)])
    return t[np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1) > 1e-12]


def best_of(rounds: int, f) -> float:
    out = np.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        f()
        out = min(out, time.perf_counter() - t0)
    return out


def triangles(P: int, n: int, rounds: int, dense_limit: float, rng) -> dict:
    t = sphere_mesh(P)
    v0, e1, e2 = t[:, 0], t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    ids = np.zeros(len(t), np.int64)
    t0 = time.perf_counter()
    group = Planar(v0, e1, e2, unit(np.cross(e1, e2)), ids, False, dense=False)
    acc = Accel([group], None, None, backend="numpy")
    build = time.perf_counter() - t0
    o = rng.normal(size=(n, 3))
    o *= 3 / np.linalg.norm(o, axis=1, keepdims=True)
    d = rng.normal(size=(n, 3)) * 0.3 - o
    row = {"kind": "triangles", "P": len(t), "build s": build}
    T, S, N = np.full(n, np.inf), np.full(n, -1), np.zeros((n, 3))
    row["bvh closest"] = n / best_of(rounds, lambda: acc.closest(o, d, 0.0, T.copy(), S, N))
    acc.closest(o, d, 0.0, T, S, N)
    t_max = np.where(np.isfinite(T), 0.5 * T, 1.0)
    row["bvh any-hit"] = n / best_of(rounds, lambda: acc.occluded(o, d, 0.0, t_max))
    if embree_available():
        t0 = time.perf_counter()
        emb = Accel([group], None, None, backend="embree")
        emb.closest(o[:1], d[:1], 0.0, np.full(1, np.inf), np.full(1, -1), np.zeros((1, 3)))   # builds Embree's BVH
        row["embree build s"] = time.perf_counter() - t0
        row["embree closest"] = n / best_of(rounds, lambda: emb.closest(o, d, 0.0, np.full(n, np.inf), S, N))
        row["embree any-hit"] = n / best_of(rounds, lambda: emb.occluded(o, d, 0.0, t_max))
    if len(t) <= dense_limit:
        dense = Planar(v0, e1, e2, unit(np.cross(e1, e2)), ids, False)
        o4 = np.ones((4, n), np.float32)
        o4[:3] = o.T
        dd = np.ascontiguousarray(d.T, dtype=np.float32)
        row["all pairs"] = n / best_of(rounds, lambda: dense.dense(o4, dd, 0.0, True))
    row["_mesh"], row["_rays"] = t, (o, d)
    return row


def spheres(P: int, n: int, rounds: int, dense_limit: float, rng) -> dict:
    c = rng.random((P, 3)) * 10
    r = 0.5 * 10 / np.cbrt(P) * rng.random(P) + 0.01
    quad = Quadrics([(k, c[k], np.eye(3) / r[k], 1.0) for k in range(P)])
    t0 = time.perf_counter()
    acc = Accel([], quad, None)
    build = time.perf_counter() - t0
    o, d = rng.random((n, 3)) * 10, rng.normal(size=(n, 3))
    row = {"kind": "spheres", "P": P, "build s": build}
    T, S, N = np.full(n, np.inf), np.full(n, -1), np.zeros((n, 3))
    row["bvh closest"] = n / best_of(rounds, lambda: acc.closest(o, d, 0.0, T.copy(), S, N))
    acc.closest(o, d, 0.0, T, S, N)
    t_max = np.where(np.isfinite(T), 0.5 * T, 1.0)
    row["bvh any-hit"] = n / best_of(rounds, lambda: acc.occluded(o, d, 0.0, t_max))
    if P <= dense_limit:
        row["all pairs"] = n / best_of(rounds, lambda: quad.closest(o, d, 0.0, T.copy(), S.copy(), N))
    return row


def write_ply(path: Path, tri: np.ndarray) -> None:
    """A binary little-endian PLY of the triangles ``(F, 3, 3)`` (3 F vertices)."""
    F = len(tri)
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {3 * F}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {F}\nproperty list uchar int vertex_indices\nend_header\n")
    faces = np.zeros(F, dtype=[("n", "u1"), ("i", "<i4", 3)])
    faces["n"], faces["i"] = 3, np.arange(3 * F).reshape(F, 3)
    with open(path, "wb") as f:
        f.write(head.encode())
        f.write(tri.reshape(-1, 3).astype("<f4").tobytes())
        f.write(faces.tobytes())


def mitsuba_rates(mesh: np.ndarray, rays, rounds: int) -> dict:
    """Mitsuba 3 rays/s on the same mesh and rays (llvm_ad_rgb vectorised, scalar_rgb per ray)."""
    import drjit as dr
    import mitsuba as mi

    out = {}
    o, d = rays
    path = Path(tempfile.mkdtemp()) / "mesh.ply"
    write_ply(path, mesh)
    for variant in ("llvm_ad_rgb", "scalar_rgb"):
        try:
            mi.set_variant(variant)
        except Exception:  # noqa: BLE001 - no LLVM library: the row says so
            continue
        scene = mi.load_dict({"type": "scene", "mesh": {"type": "ply", "filename": str(path)}})
        if variant == "llvm_ad_rgb":
            ray = mi.Ray3f(mi.Point3f(*(mi.Float(o[:, k].astype(np.float32)) for k in range(3))),
                           mi.Vector3f(*(mi.Float(d[:, k].astype(np.float32)) for k in range(3))))

            def run():
                si = scene.ray_intersect(ray)
                dr.eval(si.t)
                dr.sync_thread()                       # the LLVM backend launches asynchronously
                return si
            run()                                                          # compile
            out[variant] = len(o) / best_of(rounds, run)
        else:
            k = min(len(o), 2000)
            rs = [mi.Ray3f(mi.Point3f(*o[i]), mi.Vector3f(*d[i])) for i in range(k)]
            out[variant] = k / best_of(rounds, lambda: [scene.ray_intersect(r) for r in rs])
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rays", type=int, default=32768)
    ap.add_argument("--max", type=int, default=1_000_000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--no-mitsuba", action="store_true")
    a = ap.parse_args(argv)
    rng = np.random.default_rng(0)
    sizes = [s for s in (10, 100, 1_000, 10_000, 100_000, 1_000_000) if s <= a.max]
    rows = []
    for P in sizes:
        row = triangles(P, a.rays, a.rounds, 20_000, rng)
        mesh, rays = row.pop("_mesh"), row.pop("_rays")
        if not a.no_mitsuba:
            try:
                row.update({f"mitsuba {k}": v for k, v in mitsuba_rates(mesh, rays, a.rounds).items()})
            except ImportError:
                pass
        rows.append(row)
        print(row, flush=True)
    for P in sizes:
        rows.append(spheres(P, a.rays, a.rounds, 100_000, rng))
        print(rows[-1], flush=True)
    cols = ["kind", "P", "build s", "bvh closest", "bvh any-hit", "all pairs", "embree build s", "embree closest",
            "embree any-hit", "mitsuba llvm_ad_rgb", "mitsuba scalar_rgb"]
    print("\nrays/s (build in seconds); ratios: NumPy BVH / all pairs, Embree / Mitsuba llvm_ad_rgb")
    print("\n| " + " | ".join(cols + ["bvh / all pairs", "embree / llvm"]) + " |")
    print("|" + "---|" * (len(cols) + 2))
    for r in rows:
        cells = [r["kind"], str(r["P"])] + [f"{r[c]:.3g}" if c in r else "" for c in cols[2:]]
        cells.append(f"{r['bvh closest'] / r['all pairs']:.2f}" if "all pairs" in r else "")
        ok = "mitsuba llvm_ad_rgb" in r and "embree closest" in r
        cells.append(f"{r['embree closest'] / r['mitsuba llvm_ad_rgb']:.2f}" if ok else "")
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
