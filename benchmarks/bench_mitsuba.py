"""vrlab vs Mitsuba 3 on veach_mis, cornell_box and many_lights: speed and error.

Renders each scene at the same resolution and spp with vrlab (each in a child process,
so the whole-process time includes Python start-up, imports and scene loading; 1 and 2
worker processes) and with
Mitsuba 3's ``direct`` integrator (``scalar_rgb``; ``llvm_ad_rgb`` too when it runs --
it is tried in a subprocess because drjit's LLVM backend aborts the process on systems
whose libLLVM is too old).  Reports wall time (render call and whole process), samples/s (pixels x spp / s), and the
relMSE = mean((img - ref)^2 / (ref^2 + 0.01)) of each image against a high-spp Mitsuba
``scalar_rgb`` reference.  The scene files get the same in-memory edits as in
``experiments/mitsuba_references.py`` (resolution; black BSDF on emitters).  Skips
gracefully without mitsuba.

    python benchmarks/bench_mitsuba.py [--width 128 --height 96 --spp 64 --ref-spp 4096 --repeat 3]

Each configuration runs ``--repeat`` times, interleaved with the others (round after
round, since this machine's speed drifts over minutes), and the run with the shortest
whole-process time is reported, for Mitsuba and vrlab alike.  vrlab's children import it from this
checkout after its bytecode is compiled (``compileall``), as in an installed package:
with ``PYTHONDONTWRITEBYTECODE`` set, every child would otherwise recompile every module
(about 0.1 s).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

SCENES = ("veach_mis", "cornell_box", "many_lights")
# vrlab strategies per scene: (strategy, light_selection, ris_candidates)
VRLAB_RUNS = {"veach_mis": [("mis-power", "uniform", 8)], "cornell_box": [("mis-power", "uniform", 8),
                                                                         ("cv", "uniform", 8)],
              "many_lights": [("mis-power", "uniform", 8), ("light", "power", 8), ("ris", "uniform", 16),
                              ("ris", "power", 16)]}


def relmse(img, ref):
    from vrlab.metrics import rel_mse

    return rel_mse(img, ref)


def mitsuba_render(variant, name, w, h, spp, seed=0, out=None):
    """(image, seconds) rendered by Mitsuba ``variant`` (in this process)."""
    import mitsuba as mi
    from mitsuba_references import load
    mi.set_variant(variant)
    scene = load(mi, name, w, h)
    np.array(mi.render(scene, spp=1, seed=seed + 999))   # warm-up (JIT compilation, threads)
    t = time.perf_counter()
    img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)[..., :3]
    dt = time.perf_counter() - t
    if out:
        np.save(out, img)
    return img, dt


def mitsuba_subprocess(variant, name, w, h, spp, tmp):
    """Like mitsuba_render, in a child process (survives an LLVM abort); None on failure."""
    out = Path(tmp) / f"{variant}_{name}.npy"
    code = (f"import sys; sys.path[:0] = {[str(ROOT), str(ROOT / 'benchmarks')]!r}; "
            f"import bench_mitsuba as b, json; _, dt = b.mitsuba_render({variant!r}, {name!r}, "
            f"{w}, {h}, {spp}, out={str(out)!r}); print(json.dumps(dt))")
    t = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    wall = time.perf_counter() - t
    if p.returncode != 0 or not out.exists():
        return None, (p.stderr.strip().splitlines() or ["?"])[0][:100], None
    return np.load(out), json.loads(p.stdout.strip().splitlines()[-1]), wall


def vrlab_subprocess(name, w, h, spp, strategy, selection, m, workers, tmp):
    """(image, render seconds, whole-process seconds) of vrlab in a child process."""
    out = Path(tmp) / f"vrlab_{name}_{strategy}_{selection}_{workers}.npy"
    code = ("import time, json; t0 = time.perf_counter(); import numpy as np; "
            "from vrlab.render import builtin_scene_path, load_scene, render; "
            f"sc = load_scene(builtin_scene_path({name!r})); "
            f"sc = sc.with_size({w}, {h}); t = time.perf_counter(); "
            f"img = render(sc, {spp}, {strategy!r}, rng=1, light_selection={selection!r}, "
            f"ris_candidates={m}, workers={workers}).value; dt = time.perf_counter() - t; "
            f"np.save({str(out)!r}, img); print(json.dumps([dt, time.perf_counter() - t0]))")
    t = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=str(ROOT))
    wall = time.perf_counter() - t
    if p.returncode != 0:
        raise RuntimeError(p.stderr)
    dt, _ = json.loads(p.stdout.strip().splitlines()[-1])
    return np.load(out), dt, wall


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--width", type=int, default=128)
    ap.add_argument("--height", type=int, default=96)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--scenes", nargs="*", default=list(SCENES))
    ap.add_argument("--workers", nargs="*", type=int, default=[1, 2])
    ap.add_argument("--variants", nargs="*", default=["scalar_rgb", "llvm_ad_rgb"])
    ap.add_argument("--repeat", type=int, default=3,
                    help="runs per configuration; the fastest is reported (the machine is noisy)")
    args = ap.parse_args(argv)
    try:
        import mitsuba as mi
    except ImportError:
        print("mitsuba is not installed (pip install mitsuba); skipping bench_mitsuba")
        return 0
    import compileall
    import tempfile

    compileall.compile_dir(str(ROOT / "vrlab"), quiet=1)   # like an installed package (see above)
    w, h, spp = args.width, args.height, args.spp
    samples = w * h * spp
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.scenes:
            ref, _ = mitsuba_render("scalar_rgb", name, w, h, args.ref_spp, seed=12345)
            # every configuration of the scene once per round, round after round: the
            # machine's speed drifts over minutes, so each keeps its fastest whole process
            configs = [(f"mitsuba {v}", (lambda v=v: mitsuba_subprocess(v, name, w, h, spp, tmp)))
                       for v in args.variants]
            for strategy, selection, m in VRLAB_RUNS.get(name, [("mis-power", "uniform", 8)]):
                label = strategy + (f"/{selection}" if strategy in ("light", "ris") else "") + \
                    (f" M={m}" if strategy == "ris" else "")
                configs += [(f"vrlab {label} w={k}",
                             (lambda s=strategy, sel=selection, m=m, k=k:
                              vrlab_subprocess(name, w, h, spp, s, sel, m, k, tmp)))
                            for k in args.workers]
            best, failed = {}, {}
            for _ in range(max(1, args.repeat)):
                for label, run in configs:
                    if label in failed:
                        continue
                    r = run()
                    if r[0] is None:
                        failed[label] = r[1]
                    elif label not in best or r[2] < best[label][2]:
                        best[label] = r
            base = None
            for label, _ in configs:
                if label in failed:
                    rows.append((name, label, None, None, None, failed[label]))
                    continue
                img, dt, wall = best[label]
                rows.append((name, label, dt, samples / dt, relmse(img, ref), wall))
                if label == "mitsuba scalar_rgb":
                    base = rows[-1]
            rows.append((name, "--ratios vs scalar", base))
    print(f"mitsuba {mi.__version__}; {w}x{h}, {spp} spp; reference: mitsuba scalar_rgb {args.ref_spp} spp")
    print("render s: the render call (Mitsuba after a 1-spp warm-up); process s: the whole child process "
          "(Python start-up, imports, scene load, render).  Ratios are vrlab / Mitsuba scalar_rgb: "
          "speed = samples/s ratio (>1: vrlab faster), process = Mitsuba process s / vrlab process s "
          "(>1: vrlab faster), relMSE = vrlab / Mitsuba at equal spp (<1: vrlab better), "
          "eq-time = (relMSE x process s) ratio (<1: vrlab better at equal whole-process time)")
    print(f"{'scene':<12} {'renderer':<30} {'render s':>8} {'samples/s':>10} {'relMSE':>9} {'process s':>9}"
          f" {'speed':>6} {'process':>7} {'relMSE':>6} {'eq-time':>7}")
    base = {}
    for r in rows:
        if r[1] == "--ratios vs scalar":
            continue
        if r[2] is None:
            print(f"{r[0]:<12} {r[1]:<30} {'failed':>8}  ({r[5]})")
            continue
        if r[1] == "mitsuba scalar_rgb":
            base[r[0]] = r
        b = base.get(r[0])
        ratios = ""
        if b is not None and r[1].startswith("vrlab"):
            ratios = (f" {r[3] / b[3]:6.2f} {b[5] / r[5]:7.2f} {r[4] / b[4]:6.2f} "
                      f"{(r[4] * r[5]) / (b[4] * b[5]):7.2f}")
        print(f"{r[0]:<12} {r[1]:<30} {r[2]:8.2f} {r[3]:10.3g} {r[4]:9.3g} {r[5]:9.2f}{ratios}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
