"""Ray queries side by side: the NumPy paths, the compiled BVH walk (Numba, ``kernels="numba"``,
``vrlab.render.accel.traverse_kernel``) and Embree (``embreex``), in rays per second (issue 31).

    python benchmarks/bench_rays.py [--mesh 1000000] [--rounds 3] [--render-spp 16] [--no-render]

Rows:

* **many_lights camera rays, closest + hit data** (256 x 192, one float32 ray per pixel, as the
  renderer traces them; t, shape, normal and triangle of each hit): the NumPy path the
  renderer takes (all pairs: float32 planar pass, culled float64 spheres), the NumPy BVH over
  the same primitives, the compiled walk, and Embree, which has no spheres: each sphere is a
  stand-in icosphere of 320 triangles (Embree traces those and the floor);
* **many_lights shadow rays, any hit**: from the camera rays' hits (offset 1e-4 along the
  normal) towards the centre of a random sphere light, up to its near side, through the whole
  scene (the target included);
* **triangles, closest** and **any hit** (t_max: the closest t times a uniform in [0, 2),
  else 10: about half the rays occluded): a tessellated
  unit sphere of about ``--mesh`` triangles (``bench_accel.sphere_mesh``) without Embree (NumPy
  BVH against the compiled walk) and with it; rays from a sphere of radius 3 towards points
  near the centre (about 90 % hit); also at 10^3, 10^4, 10^5 triangles (where Embree starts
  to pay: ``EMBREE_FROM`` in ``vrlab.render.accel.geometry``);
* **render** (unless ``--no-render``): many_lights at 128 x 96, ``--render-spp`` spp, one
  worker, ``kernels="numpy"`` against ``"numba"`` (whole ``render`` call, plan included).

Fastest of ``--rounds`` wall times in this process, one thread; the kernels are compiled or
loaded before timing.  Build times of the BVHs are printed apart.  Prints a markdown table.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_accel import sphere_mesh  # noqa: E402

from vrlab.render import render  # noqa: E402
from vrlab.render.accel.embree import embree_available  # noqa: E402
from vrlab.render.accel.geometry import SceneGeometry  # noqa: E402
from vrlab.render.accel.groups import Planar, unit  # noqa: E402
from vrlab.render.accel.scene_bvh import Accel  # noqa: E402
from vrlab.render import plan  # noqa: E402


def best_of(rounds: int, f) -> float:
    out = np.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        f()
        out = min(out, time.perf_counter() - t0)
    return out


def icosphere(level: int = 2) -> np.ndarray:
    """Triangles ``(20 * 4^level, 3, 3)`` of a unit icosphere (320 at level 2)."""
    g = (1 + 5 ** 0.5) / 2
    v = np.array([[-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0], [0, -1, g], [0, 1, g], [0, -1, -g], [0, 1, -g],
                  [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1]], float)
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6],
         [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
         [8, 6, 7], [9, 8, 1]]
    tri = v[np.array(f)]
    tri /= np.linalg.norm(tri, axis=-1, keepdims=True)
    for _ in range(level):
        a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
        ab, bc, ca = (unit(x) for x in (a + b, b + c, c + a))
        tri = np.concatenate([np.stack(t, 1) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))])
    return tri


def closest_rate(acc: Accel, o, d, rounds: int) -> float:
    n = len(o)
    T, S, N, P = np.full(n, np.inf), np.full(n, -1), np.zeros((n, 3), o.dtype), np.zeros(n, np.int64)
    return n / best_of(rounds, lambda: acc.closest(o, d, 0.0, T.copy(), S, N, P))


def many_lights(rounds: int) -> tuple[list, dict]:
    sc = plan("many_lights", 1, width=256, height=192, kernels="numpy").scene
    geo = {k: SceneGeometry(sc, kernels=k) for k in ("numpy", "numba")}
    rng = np.random.default_rng(1)
    pix = np.stack(np.divmod(np.arange(256 * 192), 256), -1)
    o, d = sc.sensor.pixel_rays(pix, rng.random((len(pix), 2)), dtype=np.float32)
    d = np.ascontiguousarray(d.reshape(-1, 3))
    o = np.ascontiguousarray(np.broadcast_to(o.reshape(-1, 3), d.shape))
    g = geo["numpy"]
    accs = {"numpy": Accel(g.planar, g.quadrics, g.disks, backend="numpy"), "numba": geo["numba"].accel}
    # Embree: the floor and 320-triangle icospheres in place of the spheres
    ico = icosphere(2)
    q = g.quadrics
    mats = np.linalg.inv(q.minv)
    tri = (q.c[:, None, None] + np.einsum("kab,tvb->ktva", mats, ico)).reshape(-1, 3, 3)
    v0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    stand_in = Planar(v0, e1, e2, unit(np.cross(e1, e2)), np.repeat(q.shape, len(ico)), False, dense=False)
    if embree_available():
        accs["embree"] = Accel([*g.planar, stand_in], None, None, backend="embree")
        accs["embree"].closest(o[:1], d[:1], 0.0, np.full(1, np.inf), np.full(1, -1), np.zeros((1, 3), np.float32))
    rows = [{"query": "many_lights camera rays, closest + hit data",
             "numpy (renderer's)": len(o) / best_of(rounds, lambda: g.intersect(o, d)),
             **{k: closest_rate(a, o, d, rounds) for k, a in accs.items()}}]
    h = geo["numba"].intersect(o, d)
    hit = np.flatnonzero(h.shape >= 0)
    p = (h.p[hit] + 1e-4 * h.n[hit]).astype(np.float32)
    k = rng.integers(0, len(q), len(hit))
    r = np.linalg.norm(mats[k], 2, axis=(1, 2))
    w = (q.c[k] - p).astype(np.float32)
    dist = np.linalg.norm(w, axis=1)
    t_max = np.maximum(1.0 - r / dist, 0.0)
    rows.append({"query": "many_lights shadow rays, any hit",
                 "numpy (renderer's)": len(p) / best_of(rounds, lambda: g.occluded(p, w, t_max)),
                 **{k: len(p) / best_of(rounds, lambda a=a: a.occluded(p, w, 0.0, t_max)) for k, a in accs.items()}})
    return rows, {}


def triangles(P: int, n: int, rounds: int) -> tuple[list, dict]:
    rng = np.random.default_rng(2)
    t = sphere_mesh(P)
    v0, e1, e2 = t[:, 0], t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    group = Planar(v0, e1, e2, unit(np.cross(e1, e2)), np.zeros(len(t), np.int64), False, dense=False)
    accs, build = {}, {}
    for name, kw in (("numpy", dict(backend="numpy")), ("numba", dict(backend="numpy", kernels="numba")),
                     ("embree", dict(backend="embree"))):
        if name == "embree" and not embree_available():
            continue
        t0 = time.perf_counter()
        accs[name] = Accel([group], None, None, **kw)
        if name == "embree":
            accs[name].occluded(np.zeros((1, 3)), np.ones((1, 3)), 0.0, np.ones(1))      # builds Embree's scene
        build[name] = time.perf_counter() - t0
    o = rng.normal(size=(n, 3))
    o *= 3 / np.linalg.norm(o, axis=1, keepdims=True)
    d = rng.normal(size=(n, 3)) * 0.3 - o
    T, S, N = np.full(n, np.inf), np.full(n, -1), np.zeros((n, 3))
    accs["numba"].closest(o, d, 0.0, T, S, N)
    t_max = np.where(np.isfinite(T), T * rng.uniform(0.0, 2.0, n), 10.0)       # about half occluded
    label = f"{len(t):.3g} triangles"
    rows = [{"query": f"{label}, closest", **{k: closest_rate(a, o, d, rounds) for k, a in accs.items()}},
            {"query": f"{label}, any hit",
             **{k: n / best_of(rounds, lambda a=a: a.occluded(o, d, 0.0, t_max)) for k, a in accs.items()}}]
    return rows, {label: build}


def render_times(spp: int, rounds: int) -> dict:
    out = {}
    for k in ("numpy", "numba"):
        render("many_lights", 1, kernels=k, width=8, height=6, rng=0)            # compile / load, caches
        out[k] = best_of(rounds, lambda k=k: render("many_lights", spp, kernels=k, width=128, height=96, rng=1,
                                                   workers=1))
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mesh", type=int, default=1_000_000)
    ap.add_argument("--rays", type=int, default=65536)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--render-spp", type=int, default=16)
    ap.add_argument("--no-render", action="store_true")
    a = ap.parse_args(argv)
    rows, builds = many_lights(a.rounds)
    for P in sorted({1000, 10_000, 100_000, a.mesh}):
        if P <= a.mesh:
            r, b = triangles(P, a.rays, a.rounds)
            rows += r
            builds.update(b)
            print(r, b, flush=True)
    cols = ["numpy (renderer's)", "numpy", "numba", "embree"]
    print("\nrays/s, one thread; numpy = the NumPy BVH; embree for many_lights: 320-triangle icospheres "
          "in place of the spheres\n")
    print("| query | " + " | ".join(cols) + " | numba / numpy BVH | numba / embree |")
    print("|---" * (len(cols) + 3) + "|")
    for r in rows:
        cells = [f"{r[c]:.3g}" if c in r else "" for c in cols]
        ratio = f"{r['numba'] / r['numpy']:.1f}x"
        emb = f"{r['numba'] / r['embree']:.2f}x" if "embree" in r else ""
        print(f"| {r['query']} | " + " | ".join(cells) + f" | {ratio} | {emb} |")
    print("\nbuild seconds:", {k: {n: round(s, 3) for n, s in v.items()} for k, v in builds.items()})
    if not a.no_render:
        t = render_times(a.render_spp, min(a.rounds, 2))
        px = 128 * 96 * a.render_spp
        print(f"\nmany_lights render 128 x 96, {a.render_spp} spp, 1 worker: "
              + ", ".join(f"{k} {s:.2f} s ({s / px * 1e6:.3f} us/sample)" for k, s in t.items())
              + f"; numba / numpy speed-up {t['numpy'] / t['numba']:.2f}x")


if __name__ == "__main__":
    main()
