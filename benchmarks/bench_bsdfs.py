"""Reflectance models (issue 22): BSDF sampling as an estimator choice, vrlab side by side with
Mitsuba 3 (``scalar_rgb`` and ``llvm_ad_rgb``) in one run.

    python benchmarks/bench_bsdfs.py [--spp 16 64 --ref-spp 4096 --budget 1.0 --rounds 3]
                                     [--parts veach row vndf]

1. **Veach's plates with rough plastic.**  The four plates of vrlab's ``veach_mis`` scene as
   ``roughplastic`` (GGX, alpha 0.005 ... 0.1, a dark diffuse base), lit by the four spheres;
   vrlab ``bsdf``, ``light``, ``mis-balance``, ``mis-power`` and ``mis-optimal`` against
   Mitsuba's ``direct`` integrator: one BSDF sample, one light sample, and one of each (power
   heuristic), in ``scalar_rgb`` and, where Dr.Jit finds an LLVM library, ``llvm_ad_rgb``.
2. **A plastic / metal / glass row.**  Spheres of ``plastic``, ``roughconductor`` (gold),
   ``dielectric`` and ``roughdielectric`` over a diffuse floor, a rectangle light and a
   constant sky; the same methods.
3. **Visible normals against the full NDF.**  A ``roughconductor`` and a ``roughplastic``
   sphere, ``sample_visible`` true and false, under ``bsdf`` and ``mis-power``.

relMSE = mean((img - ref)^2 / (ref^2 + 0.01)) against a Mitsuba ``scalar_rgb`` reference at
``--ref-spp``; each method's CPU time t(spp) = a + b spp is fitted from its two ``--spp`` runs
and it gets spp = (budget - a) / b at equal time (the machinery of ``bench_lights.py``:
one process, fastest of ``--rounds``, vrlab ``workers=1``, Mitsuba one thread).  The LLVM
variant is timed in wall-clock seconds after its first (compiling) render and needs a
libLLVM >= 16 (Debian 12: ``apt install libllvm19`` and
``DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so``); without one its rows are
left out with a note.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

import bench_lights as bl  # noqa: E402  (W, H, measure, references, timing)
from vrlab.estimators import MIS  # noqa: E402

W, H = bl.W, bl.H
VEACH_ALPHAS = (0.1, 0.05, 0.02, 0.005)       # the built-in scene's plates, far to near


def veach_scene(integrator: str = "") -> str:
    """vrlab's ``veach_mis`` with its plates as GGX rough plastic (dark diffuse base)."""
    from vrlab.render.builtin import builtin_scene_path

    xml = builtin_scene_path("veach_mis").read_text()
    for a in VEACH_ALPHAS:
        start = xml.index(f'<float name="alpha" value="{a}"/>')
        lo, hi = xml.rindex('<bsdf type="roughconductor">', 0, start), xml.index("</bsdf>", start) + len("</bsdf>")
        xml = xml[:lo] + (f'<bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" '
                          f'value="{a}"/><rgb name="diffuse_reflectance" value="0.05"/></bsdf>') + xml[hi:]
    xml = xml.replace('<default name="width" value="400"/>', f'<default name="width" value="{W}"/>')
    xml = xml.replace('<default name="height" value="300"/>', f'<default name="height" value="{H}"/>')
    if integrator:
        import re

        xml = re.sub(r"<integrator.*?</integrator>", integrator, xml, count=1, flags=re.S)
    return xml


ROW = {"plastic": '<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.1, 0.27, 0.36"/></bsdf>',
       "gold": '<bsdf type="roughconductor"><string name="material" value="Au"/><float name="alpha" value="0.15"/></bsdf>',
       "glass": '<bsdf type="dielectric"/>',
       "rough glass": '<bsdf type="roughdielectric"><string name="distribution" value="ggx"/>'
                      '<float name="alpha" value="0.2"/></bsdf>'}


def row_scene(integrator: str = '<integrator type="direct"/>') -> str:
    spheres = "".join(f'<shape type="sphere"><point name="center" value="{x}, 0.45, 0"/><float name="radius" '
                      f'value="0.42"/>{b}</shape>' for x, b in zip((-1.35, -0.45, 0.45, 1.35), ROW.values()))
    return (f'<scene version="3.0.0">{integrator}' + bl.CAMERA.format(fov=45, origin="0, 1.6, 4.2", target="0, 0.4, 0")
            + bl.FLOOR.format(s=6) + spheres
            + '<shape type="rectangle"><transform name="to_world"><scale x="1.2" y="0.4"/><rotate x="1" angle="70"/>'
              '<translate x="0.3" y="2.6" z="-1.2"/></transform><emitter type="area"><rgb name="radiance" '
              'value="12, 11, 10"/></emitter></shape><emitter type="constant"><rgb name="radiance" value="0.25"/>'
              '</emitter></scene>')


def vndf_scene(kind: str, visible: bool, integrator: str = '<integrator type="direct"/>') -> str:
    vis = f'<boolean name="sample_visible" value="{str(visible).lower()}"/>'
    bsdf = {"roughconductor": f'<bsdf type="roughconductor"><float name="alpha" value="0.3"/>{vis}</bsdf>',
            "roughplastic": f'<bsdf type="roughplastic"><float name="alpha" value="0.3"/>{vis}</bsdf>'}[kind]
    return (f'<scene version="3.0.0">{integrator}' + bl.CAMERA.format(fov=35, origin="0, 1.4, 3.4", target="0, 0.45, 0")
            + bl.FLOOR.format(s=6) + f'<shape type="sphere"><point name="center" value="0, 0.5, 0"/>'
            f'<float name="radius" value="0.5"/>{bsdf}</shape>'
            '<shape type="sphere"><point name="center" value="1.2, 1.6, 0.8"/><float name="radius" value="0.15"/>'
            '<emitter type="area"><rgb name="radiance" value="60"/></emitter></shape>'
            '<emitter type="constant"><rgb name="radiance" value="0.2"/></emitter></scene>')


# ----------------------------------------------------------------------------- Mitsuba runs
def llvm_available() -> str:
    """'' if Mitsuba's llvm_ad_rgb renders here, else why not."""
    import subprocess

    code = ("import mitsuba as mi; mi.set_variant('llvm_ad_rgb'); "
            "mi.render(mi.load_dict(mi.cornell_box()), spp=1)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    return "" if r.returncode == 0 else (r.stderr.strip().splitlines() or ["failed"])[-1][:160]


def mitsuba_methods(xml: str, variants: list) -> dict:
    """Mitsuba ``direct`` with (emitter, bsdf) samples (1, 1), (0, 1), (1, 0), per variant."""
    import drjit as dr
    import mitsuba as mi

    out = {}
    for variant in variants:
        mi.set_variant(variant)
        for label, (ne, nb) in {"direct (MIS power)": (1, 1), "bsdf": (0, 1), "light": (1, 0)}.items():
            if variant != "scalar_rgb" and label != "direct (MIS power)":
                continue
            integ = (f'<integrator type="direct"><integer name="emitter_samples" value="{ne}"/>'
                     f'<integer name="bsdf_samples" value="{nb}"/></integrator>')
            import re

            scene = mi.load_string(re.sub(r"<integrator[^>]*/>|<integrator[^>]*[^/]>.*?</integrator>", integ, xml,
                                          count=1, flags=re.S))
            dr.set_thread_count(1)
            name = f"Mitsuba {variant} {label}"
            if variant == "scalar_rgb":
                out[name] = bl.mitsuba_run(scene)
            else:                                        # wall time after compiling once
                mi.render(scene, spp=4, seed=0)
                out[name] = _llvm_run(scene, variant)
    mi.set_variant("scalar_rgb")
    return out


def _llvm_run(scene, variant):
    import mitsuba as mi

    def run(spp):
        mi.set_variant(variant)
        t = time.perf_counter()
        img = np.array(mi.render(scene, spp=spp, seed=1), dtype=np.float64)[..., :3]
        wall = time.perf_counter() - t
        mi.set_variant("scalar_rgb")
        return img, wall, wall
    return run


def reference(xml: str, spp: int) -> tuple[np.ndarray, float]:
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    import drjit as dr

    dr.set_thread_count(os.cpu_count() or 1)
    ref = bl.mitsuba_reference(mi.load_string(xml), spp)
    dr.set_thread_count(1)
    return ref


def vrlab_methods(xml: str, which=("bsdf", "light", "mis-balance", "mis-power", "mis-optimal")) -> dict:
    from vrlab.render import load_scene

    scene = load_scene(xml)
    est = {"mis-optimal": MIS(["light", "bsdf"], heuristic="optimal")}
    return {f"vrlab {m}": bl.vrlab_run(scene, est.get(m, m)) for m in which}


def table(name: str, res: dict, spps: list, base: str) -> list[str]:
    b = res[base]
    head = ("| scene | method | " + " | ".join(f"relMSE {s} spp" for s in spps) + " | µs/sample | equal time: spp | "
            "relMSE | vs Mitsuba scalar MIS |")
    out = [head, "|" + "---|" * (head.count("|") - 1)]
    for m, r in res.items():
        out.append(f"| {name} | {m} | " + " | ".join(f"{r[s][1]:.3g}" for s in spps)
                   + f" | {1e6 * r['fit'][1] / (W * H):.3g} | {r['eq'][0]} | {r['eq'][1]:.3g} | "
                   f"{r['eq'][1] / b['eq'][1]:.2f} |")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spp", nargs=2, type=int, default=[16, 64])
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--budget", type=float, default=1.0, help="CPU seconds per image at equal time")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--parts", nargs="*", default=["veach", "row", "vndf"], choices=["veach", "row", "vndf"])
    args = ap.parse_args(argv)
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    why = llvm_available()
    variants = ["scalar_rgb"] + ([] if why else ["llvm_ad_rgb"])
    t0 = time.perf_counter()
    print(f"command: python benchmarks/bench_bsdfs.py {' '.join(argv or sys.argv[1:])}")
    print(f"mitsuba {mi.__version__}; vrlab workers=1; {W}x{H}; reference: Mitsuba scalar_rgb direct, "
          f"{args.ref_spp} spp; budget {args.budget} s; fastest of {args.rounds} rounds; llvm_ad_rgb: "
          + ("yes (wall time, one thread)" if not why else f"not run ({why})"))
    print(f"load average at start {os.getloadavg()}")
    jobs = []
    vrlab_all = ("bsdf", "light", "mis-balance", "mis-power", "mis-optimal")
    if "veach" in args.parts:
        jobs.append(("veach, rough plastic", veach_scene(), vrlab_all))
    if "row" in args.parts:        # delta lobes: vrlab refuses light sampling alone (Mitsuba's misses them)
        jobs.append(("plastic / gold / glass / rough glass", row_scene(), tuple(m for m in vrlab_all if m != "light")))
    for name, xml, which in jobs:
        ref, floor = reference(xml, args.ref_spp)
        methods = {**vrlab_methods(xml, which), **mitsuba_methods(xml, variants)}
        res = bl.measure(methods, args.spp, args.budget, args.rounds, ref)
        print(f"\n# {name}: ref floor {floor:.2g}")
        print("\n".join(table(name, res, args.spp, "Mitsuba scalar_rgb direct (MIS power)")))
    if "vndf" in args.parts:
        for kind in ("roughconductor", "roughplastic"):
            ref, floor = reference(vndf_scene(kind, True), args.ref_spp)
            methods = {}
            for visible in (True, False):
                for m in ("bsdf", "mis-power"):
                    methods[f"vrlab {m}, {'visible normals' if visible else 'full NDF'}"] = \
                        vrlab_methods(vndf_scene(kind, visible), (m,))[f"vrlab {m}"]
            methods.update(mitsuba_methods(vndf_scene(kind, True), ["scalar_rgb"]))
            res = bl.measure(methods, args.spp, args.budget, args.rounds, ref)
            print(f"\n# visible normals vs full NDF, {kind}: ref floor {floor:.2g}")
            print("\n".join(table(kind, res, args.spp, "Mitsuba scalar_rgb direct (MIS power)")))
    print(f"\nload average at end {os.getloadavg()}; total {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
