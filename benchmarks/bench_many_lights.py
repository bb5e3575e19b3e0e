"""Many lights: uniform, power and light-BVH selection on thousands of emissive triangles and on
many_lights' 128 spheres, against Mitsuba 3.

    python benchmarks/bench_many_lights.py [--width 64 --height 48 --spp 16 --ref-spp 4096 --rounds 2]

Scenes: **triangle_field** (:mod:`vrlab.testing.triangle_field`: 1200 small emissive
triangles in 4 OBJ meshes of different radiance above a floor with three boxes and two
spheres; written to a temporary folder) and the built-in **many_lights** (128 sphere
lights).  Methods: vrlab's ``light`` and ``mis-power`` with ``light_selection`` uniform,
power and bvh (with bvh every triangle is a leaf of pbrt-v4's light BVH,
:mod:`vrlab.render.light_tree`), and RIS (the ``ris`` preset, ``--ris-candidates``
candidates) with each selection; Mitsuba 3 ``scalar_rgb`` ``direct`` (one emitter and one
BSDF sample, power heuristic; its emitter choice is uniform over emitters, triangles by area
within a mesh) for comparison.

Reported per method: relMSE = mean((img - ref)^2 / (ref^2 + 0.01)) (``vrlab.metrics.rel_mse``)
at ``--spp``, mean over ``--seeds`` seeds, over all pixels and over the pixels that see no
emitter (*lit*: none of 64 x 64 camera rays meets an emitter; directly seen small lights add
camera-sampling noise that is the same for every estimator, and a 4 x 4 grid missed 67 pixels of
many_lights that see a tiny bright sphere, whose directly seen light then dominated the
column); the CPU time (``time.process_time``, the
fastest of ``--rounds`` rounds that take turns, vrlab ``workers=1``, Mitsuba one thread) per
sample (pixels x spp) in microseconds; and the work-normalised error relMSE x time relative
to uniform ``light`` (below 1: better at equal time; at equal time relMSE scales as
1 / time, so this ratio is the equal-time relMSE ratio).  Everything runs in this process.
References: Mitsuba ``direct`` at ``--ref-spp`` (batches of 256 spp summed in float64, 2
threads; for many_lights at 64 x 48 the stored 16384-spp reference,
``vrlab.render.mitsuba_reference``); *ref floor* is the relMSE a perfect image would score.
"""
from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from vrlab.metrics import rel_mse  # noqa: E402

REF_BATCH = 256
SELECTIONS = ("uniform", "power", "bvh")


def methods(m: int, meshes: bool = False):
    """(label, strategy, light_selection, options) of every vrlab run: light, mis-power and RIS
    with each selection, and ReSTIR (M candidates, 5 neighbours within 3 pixels, one pass) with
    each of its reuse weights on bvh candidates, pairwise on power candidates, and the best
    setting of ``bench_restir_settings.py`` (4 candidates, 5 neighbours within 2 pixels)."""
    from vrlab.estimators import ReSTIR

    out = []
    for strategy in ("light", "mis-power", "ris"):
        for sel in SELECTIONS:
            opts = {"ris_candidates": m} if strategy == "ris" else {}
            out.append((f"{strategy} {sel}" + (f" M={m}" if strategy == "ris" else ""), strategy, sel, opts))
    restir = [("pairwise", "bvh"), ("balance", "bvh"), ("1/M", "bvh")] + ([] if meshes else [("pairwise", "power")])
    for mis, sel in restir:     # mesh lights give their sampled point only triangle by triangle (bvh)
        out.append((f"restir {mis} {sel} M={m}", ReSTIR(candidates=m, neighbours=5, radius=3, mis=mis), sel, {}))
    # the best setting of bench_restir_settings.py's sweep on the triangle field
    out.append(("restir pairwise bvh M=4 k=5 r=2", ReSTIR(candidates=4, neighbours=5, radius=2), "bvh", {}))
    return out


def mitsuba_scene(mi, name, xml_path, w, h):
    if name == "many_lights":
        from mitsuba_references import load
        return load(mi, name, w, h)
    return mi.load_file(str(xml_path))


def llvm_runner(mi, name, xml, w, h, spp):
    """A render function of Mitsuba's ``llvm_ad_rgb`` variant (one thread; its first, compiling
    render done here), or None without a libLLVM (see ``bench_bsdfs.py``)."""
    import drjit as dr
    try:
        mi.set_variant("llvm_ad_rgb")
        dr.set_thread_count(1)
        scene = mitsuba_scene(mi, name, xml, w, h)
        mi.render(scene, spp=spp, seed=0)
    except Exception as exc:  # noqa: BLE001 - no LLVM: the row is left out
        print(f"(no llvm_ad_rgb rows: {exc})")
        mi.set_variant("scalar_rgb")
        return None
    mi.set_variant("scalar_rgb")

    def run(seed):
        mi.set_variant("llvm_ad_rgb")
        dr.set_thread_count(1)
        img = mi.render(scene, spp=spp, seed=seed)
        out = np.array(img, np.float64)[..., :3]
        mi.set_variant("scalar_rgb")
        return out
    return run


def reference(mi, scene, ref_spp):
    """(mean, stderr) of Mitsuba batches of REF_BATCH spp (2 threads)."""
    import drjit as dr
    dr.set_thread_count(2)
    k = max(2, ref_spp // REF_BATCH)
    imgs = np.stack([np.array(mi.render(scene, spp=REF_BATCH, seed=10_000 + i), np.float64)[..., :3]
                     for i in range(k)])
    return imgs.mean(0), imgs.std(0, ddof=1) / np.sqrt(k)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--width", type=int, default=64)
    ap.add_argument("--height", type=int, default=48)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--ris-candidates", type=int, default=8)
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--scenes", nargs="*", default=["triangle_field", "many_lights"])
    args = ap.parse_args(argv)

    import drjit as dr
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    from vrlab.render import builtin_scene_path, load_scene, mitsuba_reference, render
    from vrlab.testing.triangle_field import write_triangle_field

    w, h, spp = args.width, args.height, args.spp
    tmp = Path(tempfile.mkdtemp(prefix="bench_many_lights_"))
    for name in args.scenes:
        if name == "triangle_field":
            xml = write_triangle_field(tmp, width=w, height=h)
            scene = load_scene(xml)
        else:
            xml = builtin_scene_path(name)
            scene = load_scene(xml).with_size(w, h)
        ms = mitsuba_scene(mi, name, xml, w, h)
        t0 = time.perf_counter()
        if name == "many_lights" and (w, h) == (64, 48):
            ref, ref_err = (np.asarray(a, np.float64) for a in mitsuba_reference(name))
        else:
            ref, ref_err = reference(mi, ms, args.ref_spp)
        from vrlab.render.direct import DirectLighting
        lit = DirectLighting(scene)
        lit_mask = ~np.isin(lit.pixel_hits(64), np.flatnonzero(lit.is_emitter)).any(1).reshape(h, w)
        floor = rel_mse(ref + ref_err * np.random.default_rng(0).standard_normal(ref.shape), ref)
        print(f"\n## {name}: {w} x {h}, {spp} spp, relMSE over {args.seeds} seeds; reference "
              f"{time.perf_counter() - t0:.0f} s, ref floor {floor:.2e}")
        runs = {label: (lambda seed, s=s, sel=sel, o=o: render(scene, spp, s, rng=seed, light_selection=sel,
                                                                 workers=1, **o).value)
                for label, s, sel, o in methods(args.ris_candidates, name == "triangle_field")}

        def mitsuba_run(seed):
            dr.set_thread_count(1)
            return np.array(mi.render(ms, spp=spp, seed=seed), np.float64)[..., :3]
        runs["mitsuba direct"] = mitsuba_run
        llvm = llvm_runner(mi, name, xml, w, h, spp)
        if llvm is not None:
            runs["mitsuba llvm_ad_rgb direct"] = llvm
        err = {k: [] for k in runs}
        err_lit = {k: [] for k in runs}
        cpu = {k: np.inf for k in runs}
        for r in range(max(args.rounds, args.seeds)):
            for label, fn in runs.items():
                t = time.process_time()
                img = np.asarray(fn(1000 * r + 7), np.float64)
                cpu[label] = min(cpu[label], time.process_time() - t)
                if r < args.seeds:
                    err[label].append(rel_mse(img, ref))
                    err_lit[label].append(rel_mse(img, ref, mask=lit_mask))
        base = np.mean(err["light uniform"]) * cpu["light uniform"]
        base_lit = np.mean(err_lit["light uniform"]) * cpu["light uniform"]
        print(f"lit pixels: {int(lit_mask.sum())} of {w * h}")
        print("| method | relMSE | relMSE lit | CPU s | us / sample | relMSE x time vs light uniform | lit |")
        print("|---|---:|---:|---:|---:|---:|---:|")
        for label in runs:
            e, el = float(np.mean(err[label])), float(np.mean(err_lit[label]))
            print(f"| {label} | {e:.4g} | {el:.4g} | {cpu[label]:.2f} | {1e6 * cpu[label] / (w * h * spp):.2f} | "
                  f"{e * cpu[label] / base:.3f} | {el * cpu[label] / base_lit:.3f} |")
        sys.stdout.flush()
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
