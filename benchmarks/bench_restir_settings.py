"""ReSTIR's settings at equal time on the triangle field: can any (candidates, neighbours,
radius, passes) beat ``mis-power`` with the light BVH by 2x?

    python benchmarks/bench_restir_settings.py [--width 64 --height 48 --seeds 3 --set grid]
    python benchmarks/bench_restir_settings.py --set top --seeds 30
    python benchmarks/bench_restir_settings.py --set top --seeds 10 --width 128 --height 96

Scene, reference and error as ``bench_many_lights.py`` (the triangle field of
:mod:`vrlab.testing.triangle_field`, Mitsuba ``direct`` at ``--ref-spp``, relMSE over the pixels
that see no emitter, 16 spp, CPU time the fastest of ``--rounds`` renders with ``workers=1``,
rounds taking turns).  Reported per setting: relMSE, microseconds per sample and relMSE x time
relative to ``mis-power`` with ``light_selection="bvh"`` (the best preset without reuse; below 0.5
meets issue 24's target).  Sets: ``grid`` (pairwise, candidates 2..32 x neighbours 2/5/10 x
radius 3/10/30 x passes 1/2: 90 settings, about 40 minutes), ``top`` (the best settings of the
grid, the no-reuse rows and balance weights; for more seeds and larger images).  ``--cache DIR``
keeps the references between runs.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "experiments"))

from bench_many_lights import reference  # noqa: E402
from vrlab.metrics import rel_mse  # noqa: E402

SPP = 16
BASE = "mis-power bvh"


def restir(mis: str, c: int, k: int, r: float, p: int) -> str:
    return f"restir {mis} c={c} k={k} r={r:g} p={p}"


SETS = {
    "grid": [restir("pairwise", c, k, r, p) for p in (1, 2) for r in (3, 10, 30) for c in (2, 4, 8, 16, 32)
             for k in (2, 5, 10)],
    "top": ["ris bvh k=4", "ris bvh k=8", restir("pairwise", 4, 5, 2, 1), restir("pairwise", 4, 5, 3, 1),
            restir("pairwise", 8, 5, 3, 2), restir("pairwise", 4, 2, 3, 2), restir("pairwise", 4, 2, 2, 1),
            restir("pairwise", 16, 10, 3, 1), restir("pairwise", 8, 0, 3, 1), restir("balance", 4, 5, 3, 1)],
}


def method(label: str):
    """``(estimator, light_selection, options)`` of a label: 'mis-power bvh', 'ris bvh k=8',
    'restir pairwise c=8 k=5 r=3 p=1'."""
    from vrlab.estimators import ReSTIR

    parts = label.split()
    if parts[0] == "mis-power":
        return "mis-power", parts[1], {}
    if parts[0] == "ris":
        return "ris", parts[1], {"ris_candidates": int(parts[2][2:])}
    kv = dict(p.split("=") for p in parts[2:])
    return (ReSTIR(candidates=int(kv["c"]), neighbours=int(kv["k"]), radius=float(kv["r"]), passes=int(kv["p"]),
                   mis=parts[1]), "bvh", {})


def scene_and_reference(w: int, h: int, ref_spp: int, cache: Path):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    from vrlab.render import load_scene
    from vrlab.render.direct import DirectLighting
    from vrlab.testing.triangle_field import write_triangle_field

    xml = write_triangle_field(cache / f"scene_{w}x{h}", width=w, height=h)
    scene = load_scene(xml)
    path = cache / f"ref_{w}x{h}_{ref_spp}.npz"
    if path.exists():
        ref = np.load(path)["mean"]
    else:
        ref, err = reference(mi, mi.load_file(str(xml)), ref_spp)
        np.savez(path, mean=ref, stderr=err)
    lit = DirectLighting(scene)
    mask = ~np.isin(lit.pixel_hits(64), np.flatnonzero(lit.is_emitter)).any(1).reshape(h, w)
    return scene, ref, mask


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--width", type=int, default=64)
    ap.add_argument("--height", type=int, default=48)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--set", choices=sorted(SETS), default="top")
    ap.add_argument("--labels", nargs="*", default=[], help="extra settings, e.g. 'restir pairwise c=4 k=5 r=2 p=1'")
    ap.add_argument("--cache", type=Path, default=None)
    args = ap.parse_args(argv)
    from vrlab.render import render

    cache = args.cache or Path(tempfile.mkdtemp(prefix="bench_restir_"))
    cache.mkdir(parents=True, exist_ok=True)
    w, h = args.width, args.height
    scene, ref, mask = scene_and_reference(w, h, args.ref_spp, cache)
    labels = [BASE] + SETS[args.set] + args.labels
    runs = {label: method(label) for label in labels}
    err = {label: [] for label in labels}
    cpu = {label: np.inf for label in labels}
    for r in range(max(args.seeds, args.rounds)):
        for label, (est, sel, opts) in runs.items():
            t = time.process_time()
            img = render(scene, SPP, est, rng=1000 * r + 7, light_selection=sel, workers=1, **opts).value
            if r < args.rounds:
                cpu[label] = min(cpu[label], time.process_time() - t)
            if r < args.seeds:
                err[label].append(rel_mse(np.asarray(img, np.float64), ref, mask=mask))
    base = np.mean(err[BASE]) * cpu[BASE]
    print(f"## triangle field {w} x {h}, {SPP} spp, {args.seeds} seeds, {int(mask.sum())} lit pixels")
    print("| setting | relMSE lit | us / sample | relMSE x time vs mis-power bvh |")
    print("|---|---:|---:|---:|")
    for label in sorted(labels, key=lambda k: np.mean(err[k]) * cpu[k]):
        e = float(np.mean(err[label]))
        print(f"| {label} | {e:.4g} | {1e6 * cpu[label] / (w * h * SPP):.2f} | {e * cpu[label] / base:.2f} |")


if __name__ == "__main__":
    main()
