"""vrlab vs Mitsuba 3 on veach_mis and cornell_box: speed and equal-spp error.

Renders each scene at the same resolution and spp with vrlab ("mis-power") and with
Mitsuba 3's ``direct`` integrator (``scalar_rgb``; ``llvm_ad_rgb`` too when it runs --
it is tried in a subprocess because drjit's LLVM backend aborts the process on systems
whose libLLVM is too old).  Reports wall time (render call and whole process), samples/s (pixels x spp / s), and the
relMSE = mean((img - ref)^2 / (ref^2 + 0.01)) of each image against a high-spp Mitsuba
``scalar_rgb`` reference.  The scene files get the same in-memory edits as in
``experiments/mitsuba_references.py`` (resolution; black BSDF on emitters).  Skips
gracefully without mitsuba.

    python benchmarks/bench_mitsuba.py [--width 128 --height 96 --spp 64 --ref-spp 4096]
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

SCENES = ("veach_mis", "cornell_box")


def relmse(img, ref):
    img, ref = np.asarray(img, np.float64), np.asarray(ref, np.float64)
    return float(np.mean((img - ref) ** 2 / (ref ** 2 + 0.01)))


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


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--width", type=int, default=128)
    ap.add_argument("--height", type=int, default=96)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--variants", nargs="*", default=["scalar_rgb", "llvm_ad_rgb"])
    args = ap.parse_args(argv)
    try:
        import mitsuba as mi
    except ImportError:
        print("mitsuba is not installed (pip install mitsuba); skipping bench_mitsuba")
        return 0
    import tempfile
    from vrlab.render import builtin_scene_path, load_scene, render

    w, h, spp = args.width, args.height, args.spp
    samples = w * h * spp
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in SCENES:
            ref, t_ref = mitsuba_render("scalar_rgb", name, w, h, args.ref_spp, seed=12345)
            t0 = time.perf_counter()
            scene = load_scene(builtin_scene_path(name))
            scene = dataclasses.replace(scene, sensor=dataclasses.replace(scene.sensor, width=w, height=h))
            t = time.perf_counter()
            img, _ = render(scene, spp, "mis-power", rng=1)
            dt = time.perf_counter() - t
            rows.append((name, "vrlab mis-power", dt, samples / dt, relmse(img, ref),
                         time.perf_counter() - t0))
            for v in args.variants:
                img, dt, wall = mitsuba_subprocess(v, name, w, h, spp, tmp)
                if img is None:
                    rows.append((name, f"mitsuba {v}", None, None, None, dt))
                else:
                    rows.append((name, f"mitsuba {v}", dt, samples / dt, relmse(img, ref), wall))
    print(f"mitsuba {mi.__version__}; {w}x{h}, {spp} spp; reference: mitsuba scalar_rgb {args.ref_spp} spp")
    print("render s: the render call (Mitsuba after a 1-spp warm-up); process s: vrlab scene "
          "load + render, Mitsuba the whole child process (import, load, warm-up, render)")
    print(f"{'scene':<12} {'renderer':<22} {'render s':>8} {'samples/s':>11} {'relMSE':>10} {'process s':>9}")
    for r in rows:
        if r[2] is None:
            print(f"{r[0]:<12} {r[1]:<22} {'failed':>8}  ({r[5]})")
        else:
            print(f"{r[0]:<12} {r[1]:<22} {r[2]:8.2f} {r[3]:11.3g} {r[4]:10.3g} {r[5]:9.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
