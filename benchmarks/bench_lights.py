"""Lights (issue 21): environment-map lighting and triangle-mesh area lights, vrlab's sampling
techniques side by side with Mitsuba 3 in one run.

    python benchmarks/bench_lights.py [--spp 16 64 --ref-spp 4096 --budget 1.0 --rounds 3]

1. **Environment map.** A sphere (diffuse, or ``roughconductor`` with alpha 0.15) on a diffuse
   floor under an EXR latitude-longitude map (64 x 128: a smooth sky and a 2 x 3-pixel sun 100x
   brighter than the sky's mean), 128 x 96 pixels.  vrlab with ``bsdf``, ``light`` on the map
   sampled uniformly (the vrlab envmap parameter ``sampling="uniform"``) and by luminance
   (the default), ``mis-balance``, ``mis-power`` and optimal MIS; Mitsuba 3 ``scalar_rgb`` with
   its ``direct`` integrator (one light and one BSDF sample, power heuristic).  relMSE =
   mean((img - ref)^2 / (ref^2 + 0.01)) (``vrlab.metrics.rel_mse``) against a high-spp Mitsuba
   reference, at equal spp and at equal CPU time (there also on the sphere's pixels alone, found
   by rendering the sphere as a lone emitter, and on the others), and the ratio of relMSE x CPU
   time to Mitsuba's.
2. **Triangle-mesh lights.** An emissive OBJ (a 2-triangle quad panel, or an 80-triangle
   icosphere) whose lowest point is 0.1 above a diffuse floor; the camera sees the floor next
   to it (*near*: the light spans a large solid angle) or 3.5-10 units away (*far*; radiance 5
   near, 500 (quad) and 5000 (ball) far, so that the floor's pixels are about 0.5).  vrlab
   ``light`` with the emitter's ``triangle_sampling="area"`` (Mitsuba's way) against
   ``"spherical"`` (Arvo 1995), at equal CPU time.

**Optimal MIS.**  ``MIS(["light", "bsdf"], heuristic="optimal")``: per unit one light and one
BSDF sample, the balance value Y = sum f / (p_l + p_b) and the control H = sum p_l / (p_l + p_b)
(mean 1), Y regressed on H - 1 per pixel and channel over the pixel's spp units
(Kondapaneni et al. 2019 in its control-variate form; ``vrlab.estimators.MIS.unit_outputs``).

**Timing.**  Everything runs in this process: vrlab with ``workers=1``, Mitsuba with one
thread (``drjit.set_thread_count(1)`` after every scene is loaded).  A time is the CPU time
(``time.process_time``) of the render call, the fastest of ``--rounds`` runs that take turns
round after round (the machine is shared).  Each method's cost is fitted as t(spp) = a + b spp
from its runs at the two ``--spp`` (a can come out slightly negative: cost per spp is not
quite constant); at equal time it gets spp = floor((budget - a) / b), at least 3.
The references (Mitsuba ``direct``, batches of 256 spp summed in float64, 2 threads) are made
once per run and kept in a temporary folder; their own noise (batch-to-batch) is printed as
*ref floor*: the relMSE a perfect image would score.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from vrlab.estimators import MIS  # noqa: E402
from vrlab.metrics import rel_mse  # noqa: E402

W, H = 128, 96
REF_BATCH = 256        # spp per Mitsuba call of a reference (its float32 film drifts over many samples)


# ----------------------------------------------------------------------------- scenes
def write_envmap(path: Path) -> Path:
    """A 64 x 128 sky (bluish, brighter at the zenith, a darker ground below the horizon, 30 %
    texel noise) with a 2 x 3-texel sun of 100x the sky's mean radiance, 35-40 degrees high."""
    from vrlab.render.image import save_image

    rng = np.random.default_rng(0)
    h, w = 64, 128
    theta = (np.arange(h) + 0.5) / h * np.pi
    img = np.empty((h, w, 3), np.float32)
    img[:] = np.clip(0.4 + 0.4 * np.cos(theta), 0.1, None)[:, None, None] * np.array([0.6, 0.8, 1.0])
    ground = theta > np.pi / 2
    img[ground] = np.array([0.25, 0.2, 0.15])
    img *= 1 + 0.3 * rng.random((h, w, 1))
    img[18:20, 60:63] = np.array([1.0, 0.95, 0.85]) * 100 * img.mean()
    return save_image(path, img)


CAMERA = ('<sensor type="perspective"><float name="fov" value="{fov}"/><transform name="to_world">'
          '<lookat origin="{origin}" target="{target}" up="0, 1, 0"/></transform><sampler type="independent"/>'
          f'<film type="hdrfilm"><integer name="width" value="{W}"/><integer name="height" value="{H}"/>'
          '<rfilter type="box"/></film></sensor>')
FLOOR = ('<shape type="rectangle"><transform name="to_world"><scale value="{s}"/><rotate x="1" angle="-90"/>'
         '</transform><bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.5, 0.4"/></bsdf></shape>')
BSDFS = {"diffuse": '<bsdf type="diffuse"><rgb name="reflectance" value="0.7"/></bsdf>',
         "glossy": '<bsdf type="roughconductor"><float name="alpha" value="0.15"/></bsdf>'}


def env_scene(kind: str, env: Path, sampling: str | None) -> str:
    """The envmap scene; ``sampling`` None leaves out vrlab's parameter (for Mitsuba)."""
    extra = "" if sampling is None else f'<string name="sampling" value="{sampling}"/>'
    return ('<scene version="3.0.0"><integrator type="direct"/>'
            + CAMERA.format(fov=50, origin="0.3, 2.2, 3.4", target="0, 0.3, 0") + FLOOR.format(s=6)
            + f'<shape type="sphere"><point name="center" value="0, 0.5, 0"/><float name="radius" value="0.5"/>'
            f'{BSDFS[kind]}</shape><emitter type="envmap"><string name="filename" value="{env}"/>{extra}'
            '</emitter></scene>')


def sphere_mask() -> np.ndarray:
    """(H, W) bool: the pixels of the envmap scenes mostly covered by the sphere (Mitsuba renders
    it as a lone emitter of radiance 1: the covered fraction of each pixel)."""
    import mitsuba as mi

    xml = ('<scene version="3.0.0"><integrator type="direct"/>'
           + CAMERA.format(fov=50, origin="0.3, 2.2, 3.4", target="0, 0.3, 0")
           + '<shape type="sphere"><point name="center" value="0, 0.5, 0"/><float name="radius" value="0.5"/>'
           '<emitter type="area"><rgb name="radiance" value="1"/></emitter></shape></scene>')
    return np.array(mi.render(mi.load_string(xml), spp=64, seed=3))[..., 0] > 0.5


def icosphere() -> tuple[np.ndarray, np.ndarray]:
    """An icosahedron subdivided once (42 vertices, 80 faces) on the unit sphere, faces outward."""
    t = (1 + 5 ** 0.5) / 2
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                  [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
                  [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
                  [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), 1)
    uniq, inv = np.unique(edges, axis=0, return_inverse=True)
    mid = len(v) + inv.reshape(3, -1).T                       # midpoints of edges (ab, bc, ca)
    v = np.concatenate([v, (v[uniq[:, 0]] + v[uniq[:, 1]]) / 2])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    a, b, c = f.T
    ab, bc, ca = mid.T
    f = np.concatenate([np.stack(s, 1) for s in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))])
    outward = np.einsum("ij,ij->i", np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), v[f].sum(1)) > 0
    f[~outward] = f[~outward][:, ::-1]
    return v, f


def write_meshes(folder: Path) -> dict:
    """OBJ files: a 2 x 1 quad panel facing +z, lower edge 0.1 above the floor, and an icosphere
    of radius 0.3 centred 0.4 above it (vertex normals = its radial directions)."""
    quad = np.array([[-1, 0.1, 0], [1, 0.1, 0], [1, 1.1, 0], [-1, 1.1, 0]], float)
    v, f = icosphere()
    out = {}
    for name, verts, faces, normals in (("quad", quad, np.array([[0, 1, 2], [0, 2, 3]]), None),
                                        ("ball", v * 0.3 + [0, 0.4, 0], f, v)):
        lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in verts]
        if normals is not None:
            lines += [f"vn {x:.9g} {y:.9g} {z:.9g}" for x, y, z in normals]
        fmt = "{0}//{0}" if normals is not None else "{0}"
        lines += ["f " + " ".join(fmt.format(i + 1) for i in face) for face in faces]
        (folder / f"{name}.obj").write_text("\n".join(lines) + "\n")
        out[name] = folder / f"{name}.obj"
    return out


#: view -> mesh -> (camera origin, target, radiance): far lights are brighter, so that the floor's
#: pixels are about 0.5 and relMSE (whose denominator has + 0.01) stays relative there
MESH_VIEWS = {"near": dict(quad=("0, 1.8, 2.0", "0, 0, 0.6", 5), ball=("0, 1.2, 2.2", "0, 0.2, 0", 5)),
              "far": dict(quad=("0, 2.5, 2", "0, 0, 6", 500), ball=("0, 2.5, 2", "0, 0, 6", 5000))}


def mesh_scene(mesh: str, view: str, obj: Path, sampling: str | None) -> str:
    extra = "" if sampling is None else f'<string name="triangle_sampling" value="{sampling}"/>'
    origin, target, radiance = MESH_VIEWS[view][mesh]
    return ('<scene version="3.0.0"><integrator type="direct"/>'
            + CAMERA.format(fov=50, origin=origin, target=target) + FLOOR.format(s=12)
            + f'<shape type="obj"><string name="filename" value="{obj}"/><emitter type="area">'
            f'<rgb name="radiance" value="{radiance}"/>{extra}</emitter></shape></scene>')


# ----------------------------------------------------------------------------- renderers
def mitsuba_reference(mscene, spp: int) -> tuple[np.ndarray, float]:
    """(mean image float64, its relMSE noise floor mean(se^2 / (mean^2 + 0.01))) from batches of
    ``REF_BATCH`` spp with seeds k x stride (Mitsuba's scalar variants seed pixel i of block b with
    seed W H + b B^2 + i, B <= 32: such seeds never share a pixel's stream)."""
    import mitsuba as mi

    k = max(2, -(-spp // REF_BATCH))
    stride = -(-(W + 31) * (H + 31) // (W * H))
    s1 = s2 = 0.0
    for b in range(k):
        img = np.array(mi.render(mscene, spp=REF_BATCH, seed=(b + 1) * stride), dtype=np.float64)[..., :3]
        s1, s2 = s1 + img, s2 + img * img
    mean = s1 / k
    se2 = np.maximum(s2 / k - mean * mean, 0.0) / (k - 1)
    return mean, float(np.mean(se2 / (mean * mean + 0.01)))


def timed(fn):
    c, t = time.process_time(), time.perf_counter()
    img = fn()
    return img, time.process_time() - c, time.perf_counter() - t


def vrlab_run(scene, estimator):
    from vrlab.render import render

    return lambda spp: timed(lambda: np.asarray(render(scene, spp, estimator, rng=1, workers=1).value, np.float64))


def mitsuba_run(mscene):
    import mitsuba as mi

    return lambda spp: timed(lambda: np.array(mi.render(mscene, spp=spp, seed=1), dtype=np.float64)[..., :3])


def measure(methods: dict, spps: list, budget: float, rounds: int, ref: np.ndarray, mask=None) -> dict:
    """Per method: {key: (spp, relMSE, fastest CPU s, its wall s, relMSE on (mask, ~mask))} for
    key = each of ``spps`` and "eq" (equal time), the runs of all methods interleaved round by round
    (a seeded render gives the same image every round: its relMSE is taken from the first)."""
    res = {m: {} for m in methods}

    def go(m, spp, key):
        img, cpu, wall = methods[m](spp)
        old = res[m].get(key)
        if old is None:
            parts = () if mask is None else (rel_mse(img, ref, mask=mask), rel_mse(img, ref, mask=~mask))
            err = (rel_mse(img, ref), parts)
        else:
            err = (old[1], old[4])
        if old is None or cpu < old[2]:
            res[m][key] = (spp, err[0], cpu, wall, err[1])

    for _ in range(rounds):
        for spp in spps:
            for m in methods:
                go(m, spp, spp)
    lo, hi = spps[0], spps[1]
    for m in methods:
        b = max((res[m][hi][2] - res[m][lo][2]) / (hi - lo), 1e-9)
        a = res[m][lo][2] - b * lo
        res[m]["fit"] = (a, b)
        res[m]["eq_spp"] = max(3, int((budget - a) // b))
    for _ in range(rounds):
        for m in methods:
            go(m, res[m]["eq_spp"], "eq")
    return res


# ----------------------------------------------------------------------------- tables
def env_table(name: str, res: dict, spps: list, base: str) -> list[str]:
    """Rows of the environment-map table (a header first); ratios against method ``base``."""
    hi = spps[-1]
    b = res[base]
    head = ("| scene | method | " + " | ".join(f"relMSE {s} spp" for s in spps) + f" | CPU s ({hi} spp) | "
            "fit t = a s + b µs/sample | relMSE x s vs Mitsuba | equal time: spp | CPU s | relMSE | "
            "relMSE vs Mitsuba | sphere pixels | other pixels |")
    out = [head, "|" + "---|" * (head.count("|") - 1)]
    for m, r in res.items():
        eff = (r[hi][1] * r[hi][2]) / (b[hi][1] * b[hi][2])
        eq, (fa, fb) = r["eq"], r["fit"]
        out.append(f"| {name} | {m} | " + " | ".join(f"{r[s][1]:.3g}" for s in spps)
                   + f" | {r[hi][2]:.2f} | {fa:.2f} + {1e6 * fb / (W * H):.2f} | {eff:.2f} | {eq[0]} | "
                   f"{eq[2]:.2f} | {eq[1]:.3g} | {eq[1] / b['eq'][1]:.2f} | {eq[4][0]:.3g} | {eq[4][1]:.3g} |")
    return out


def mesh_rows(name: str, res: dict, spps: list, floor: float) -> list[str]:
    """Rows of the mesh-light table; ratios against ``"area"``."""
    a, hi = res["area"], spps[-1]
    out = []
    for m, r in res.items():
        out.append(f"| {name} | {m} | {r[hi][1]:.3g} | {1e6 * r['fit'][1] / (W * H):.3g} | {r['eq'][0]} | "
                   f"{r['eq'][2]:.2f} | {r['eq'][1]:.3g} | {r['eq'][1] / a['eq'][1]:.2f} | {floor:.2g} |")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spp", nargs=2, type=int, default=[16, 64], help="the two equal-spp levels")
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--budget", type=float, default=1.0, help="CPU seconds per image at equal time")
    ap.add_argument("--rounds", type=int, default=3, help="runs per configuration; the fastest is kept")
    ap.add_argument("--parts", nargs="*", default=["env", "mesh"], choices=["env", "mesh"])
    args = ap.parse_args(argv)
    try:
        import drjit as dr
        import mitsuba as mi
    except ImportError:
        print("mitsuba is not installed (pip install mitsuba); skipping bench_lights")
        return 0
    mi.set_variant("scalar_rgb")
    from vrlab.render import load_scene

    spps = sorted(args.spp)
    t_start, load0 = time.perf_counter(), os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        env = write_envmap(tmp / "sky.exr")
        objs = write_meshes(tmp)
        jobs = []          # (part, name, mitsuba scene, {method: (vrlab scene xml, estimator)})
        if "env" in args.parts:
            for kind in BSDFS:
                lum, uni = env_scene(kind, env, "luminance"), env_scene(kind, env, "uniform")
                jobs.append(("env", kind, env_scene(kind, env, None), {
                    "vrlab bsdf": (lum, "bsdf"), "vrlab light, uniform map": (uni, "light"),
                    "vrlab light, luminance map": (lum, "light"), "vrlab mis-balance": (lum, "mis-balance"),
                    "vrlab mis-power": (lum, "mis-power"),
                    "vrlab mis-optimal": (lum, MIS(["light", "bsdf"], heuristic="optimal"))}))
        if "mesh" in args.parts:
            for mesh in ("quad", "ball"):
                for view in MESH_VIEWS:
                    jobs.append(("mesh", f"{mesh}, {view}", mesh_scene(mesh, view, objs[mesh], None), {
                        s: (mesh_scene(mesh, view, objs[mesh], s), "light") for s in ("area", "spherical")}))
        # references first, with Mitsuba's default threads; loading after set_thread_count(1) hangs here
        refs = {}
        for part, name, mxml, _ in jobs:
            msc = mi.load_string(mxml)
            path = tmp / f"ref_{part}_{name.replace(', ', '_')}.npy"
            t = time.perf_counter()
            ref, floor = mitsuba_reference(msc, args.ref_spp)
            np.save(path, ref)
            refs[name] = (msc, path, floor, time.perf_counter() - t)
        masks = {"env": sphere_mask()} if "env" in args.parts else {}
        dr.set_thread_count(1)
        env_lines, mesh_lines, floors = [], [], []
        for part, name, _, methods in jobs:
            msc, path, floor, ref_s = refs[name]
            ref = np.load(path)
            runs = {m: vrlab_run(load_scene(x), e) for m, (x, e) in methods.items()}
            if part == "env":
                runs["Mitsuba direct (MIS power)"] = mitsuba_run(msc)
                mi.render(msc, spp=1, seed=99)                      # warm-up
            res = measure(runs, spps, args.budget, args.rounds, ref, masks.get(part))
            print(f"# {name}: reference {args.ref_spp} spp in {ref_s:.1f} s, ref floor {floor:.2g}", flush=True)
            if part == "env":
                env_lines += env_table(name, res, spps, "Mitsuba direct (MIS power)")[(2 if env_lines else 0):]
                floors.append(f"{name} {floor:.2g}")
            else:
                mesh_lines += mesh_rows(name, res, spps, floor)
        load1 = os.getloadavg()
    print(f"\ncommand: python benchmarks/bench_lights.py {' '.join(sys.argv[1:] if argv is None else argv)}")
    print(f"mitsuba {mi.__version__} scalar_rgb, 1 thread; vrlab workers=1; {W}x{H}; reference: Mitsuba direct, "
          f"{args.ref_spp} spp; budget {args.budget} CPU s; fastest of {args.rounds} rounds (time.process_time)")
    print(f"load average (1/5/15 min) at start {load0[0]:.2f}/{load0[1]:.2f}/{load0[2]:.2f}, at end "
          f"{load1[0]:.2f}/{load1[1]:.2f}/{load1[2]:.2f}; total {time.perf_counter() - t_start:.0f} s\n")
    if env_lines:
        print("\n".join(env_lines))
        print(f"\nrelMSE of a perfect image against the references (their own noise): {', '.join(floors)}\n")
    if mesh_lines:
        print(f"| scene | triangle_sampling | relMSE {spps[-1]} spp | CPU µs per sample | equal time: spp | CPU s | "
              "relMSE | relMSE vs area | ref floor |\n|---|---|---|---|---|---|---|---|---|")
        print("\n".join(mesh_lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
