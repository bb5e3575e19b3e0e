"""RIS and ReSTIR with the compiled reservoir and reuse helpers (kernels "numba") against the
NumPy oracle (kernels "numpy"), and relMSE x time against ``mis-power`` with the light BVH.

    python benchmarks/bench_reuse_kernels.py [--width 64 --height 48 --spp 16 --rounds 2 --ref-spp 1024]

Scenes: the built-in **many_lights** (128 sphere lights) and the **triangle field**
(:mod:`vrlab.testing.triangle_field`: 1200 emissive triangles over occluders).  Per method and
kernels: CPU time per sample (``time.process_time``, the fastest of ``--rounds`` renders taking
turns, ``workers=1``; pixels x spp), and relMSE (``vrlab.metrics.rel_mse``, mean over the rounds'
seeds, over the pixels that see no emitter, as ``bench_many_lights.py``) against a vrlab
``mis-power`` + bvh render at ``--ref-spp`` (another seed); relMSE x time relative to
``mis-power`` bvh with the same kernels (below 1: better at equal time).  The last column
counts the pixels (over all rounds) where the two kernels' images differ (0: bit-identical).
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

from vrlab.metrics import rel_mse  # noqa: E402

METHODS = [("mis-power", "bvh"), ("ris", "bvh"), ("restir", "bvh"), ("restir", "uniform")]


def methods(scene) -> list:
    """METHODS without ReSTIR on uniform selection where mesh lights need "bvh" (sampled
    triangle by triangle) to give their sampled points."""
    meshes = any(s.emitter is not None and s.has_barycentrics for s in scene.shapes)
    return [(st, sel) for st, sel in METHODS if not (meshes and st == "restir" and sel != "bvh")]


def scenes(w: int, h: int, folder: Path) -> dict:
    from vrlab.render import load_scene
    from vrlab.render.builtin import builtin_scene_path
    from vrlab.testing.triangle_field import write_triangle_field

    return {"many_lights": load_scene(builtin_scene_path("many_lights")).with_size(w, h),
            "triangle_field": load_scene(write_triangle_field(folder, width=w, height=h))}


def lit_mask(scene) -> np.ndarray:
    from vrlab.render.direct import DirectLighting

    lit = DirectLighting(scene)
    w, h = scene.sensor.width, scene.sensor.height
    return ~np.isin(lit.pixel_hits(64), np.flatnonzero(lit.is_emitter)).any(1).reshape(h, w)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--width", type=int, default=64)
    ap.add_argument("--height", type=int, default=48)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--ref-spp", type=int, default=1024)
    ap.add_argument("--scenes", nargs="*", default=["many_lights", "triangle_field"])
    args = ap.parse_args(argv)
    from vrlab.render import render

    w, h, spp = args.width, args.height, args.spp
    print(f"load before: {os.getloadavg()[0]:.2f} (1-min average, {os.cpu_count()} CPUs)")
    for name, scene in scenes(w, h, Path(tempfile.mkdtemp(prefix="bench_reuse_"))).items():
        if name not in args.scenes:
            continue
        ref = render(scene, args.ref_spp, "mis-power", rng=99, light_selection="bvh", workers=1,
                     spp_batch=64).value.astype(np.float64)
        mask = lit_mask(scene)
        for kern in ("numpy", "numba"):        # compile / load the kernels outside the timings
            render(scene, 1, "restir", rng=0, light_selection="bvh", workers=1, kernels=kern)
        cpu, err, imgs, diff = {}, {}, {}, {}
        for r in range(args.rounds):
            for strategy, sel in methods(scene):
                for kern in ("numpy", "numba"):
                    key = (strategy, sel, kern)
                    t = time.process_time()
                    est = render(scene, spp, strategy, rng=1000 + r, light_selection=sel, workers=1, kernels=kern)
                    cpu[key] = min(cpu.get(key, np.inf), time.process_time() - t)
                    img = np.asarray(est.value, np.float64)
                    err.setdefault(key, []).append(rel_mse(img, ref, mask=mask))
                    other = imgs.setdefault((strategy, sel, r), img)
                    diff[(strategy, sel)] = diff.get((strategy, sel), 0) + int(np.any(other != img, -1).sum())
        n = w * h * spp
        print(f"\n## {name} {w} x {h}, {spp} spp, {args.rounds} seeds, workers=1, reference mis-power bvh "
              f"{args.ref_spp} spp, {int(mask.sum())} lit pixels")
        print("| method | us/sample numpy | us/sample numba | speed-up | relMSE lit | relMSE x time vs mis-power bvh "
              "(numpy / numba) | pixels numba != numpy |")
        print("|---|---:|---:|---:|---:|---:|---:|")
        for strategy, sel in methods(scene):
            k0, k1 = (strategy, sel, "numpy"), (strategy, sel, "numba")
            e = np.mean(err[k1])
            rel = [e * cpu[k] / (np.mean(err[("mis-power", "bvh", k[2])]) * cpu[("mis-power", "bvh", k[2])])
                   for k in (k0, k1)]
            print(f"| {strategy} {sel} | {cpu[k0] / n * 1e6:.2f} | {cpu[k1] / n * 1e6:.2f} | "
                  f"{cpu[k0] / cpu[k1]:.2f}x | {e:.4f} | {rel[0]:.2f} / {rel[1]:.2f} | {diff[(strategy, sel)]} |")
    print(f"\nload after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
