"""Bias and error bars of every render preset over independent seeds (issue: every number true).

For each battery scene (vrlab.testing.battery.battery_scenes) and preset, at the preset's
minimum spp, 4 and 16: the image mean over S seeds against a high-spp reference (z, M / mu)
and, at 16 spp, the reported per-pixel variance over the spread across seeds (1 = honest
error bars).  Prints a markdown table for BENCHMARKS.md.

    python benchmarks/bench_error_bars.py [--seeds 24] [--scenes cornell_box,veach_mis,...]
    python benchmarks/bench_error_bars.py --optimal-gain     # mis-optimal's variance against balance
"""
from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np

from vrlab.estimators import MIS, recipes
from vrlab.render import PRESETS
from vrlab.testing.battery import battery_scenes, reference_mean, seed_battery


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=24)
    ap.add_argument("--scenes", default="cornell_box,veach_mis,delta_lights,envmap")
    ap.add_argument("--presets", default=",".join(PRESETS))
    ap.add_argument("--optimal-gain", action="store_true",
                    help="per-pixel variance of mis-optimal (ridge 1) and of the unridged fit, over mis-balance's")
    args = ap.parse_args()
    if args.optimal_gain:
        return optimal_gain(args)
    with tempfile.TemporaryDirectory() as tmp:
        scenes = battery_scenes(tmp)
        print("| scene | preset | bias | z at 1 spp | z at 4 | z at 16 | mean/ref at 4 | error-bar ratio at 16 |")
        print("|---|---|---|---:|---:|---:|---:|---:|")
        for name in args.scenes.split(","):
            sc = scenes[name]
            ref = reference_mean(sc)
            for p in args.presets.split(","):
                t0 = time.perf_counter()
                try:
                    rows = {spp: seed_battery(sc, p, spp, ref, seeds=args.seeds) for spp in (1, 4, 16)}
                except ValueError as exc:
                    print(f"| {name} | {p} | {recipes()[p].bias} | refused: {str(exc)[:60]}... | | | | |")
                    continue
                print(f"| {name} | {p} | {recipes()[p].bias} | {rows[1]['z']:+.1f} | {rows[4]['z']:+.1f} | "
                      f"{rows[16]['z']:+.1f} | {rows[4]['mean_ratio']:.3f} | {rows[16]['bar_ratio']:.2f} |"
                      f"  <!-- {time.perf_counter() - t0:.1f} s -->", flush=True)


def optimal_gain(args, spps=(16, 64, 256), seeds=12) -> None:
    """Per-pixel variance over ``seeds`` seeds on a 24 x 18 film, relative to mis-balance's."""
    from vrlab.render import render

    with tempfile.TemporaryDirectory() as tmp:
        scenes = battery_scenes(tmp, 24, 18)
        print("| scene | spp | `mis-optimal` (ridge 1) | no ridge |")
        print("|---|---:|---:|---:|")
        for name in args.scenes.split(","):
            for spp in spps:
                var = {}
                for key, est in (("balance", "mis-balance"), ("preset", "mis-optimal"),
                                 ("plain", MIS(["light", "bsdf"], heuristic="optimal"))):
                    var[key] = np.stack([render(scenes[name], spp, est, rng=s).value for s in range(seeds)]).var(0).mean()
                print(f"| {name} | {spp} | {var['preset'] / var['balance']:.2f} | {var['plain'] / var['balance']:.2f} |",
                      flush=True)


if __name__ == "__main__":
    main()
