"""``vrlab render SCENE --compare S1,S2,...``: the strategies side by side
(:func:`vrlab.render.compare.compare`), with relMSE against a reference.

Every compared render takes the sampling flags a single render takes: ``--spp``,
``--seed``, ``--pixel-sampler``, ``--light-selection``, ``--emitter-samples``,
``--bsdf-samples``, ``--ris-candidates``, ``--spp-batch``, ``--workers``,
``--width``/``--height`` (checked by :func:`vrlab.cli_render_settings.settings_from_args`), and shows a
progress bar as a single render does (``--progress``; default: when stderr is a
terminal).  The reference is ``--reference FILE`` if given; else the command says on
stderr, before it starts, that it renders one: ``mis-power`` at ``--reference-spp``
(default 256), i.i.d. points, its own seed.  ``--equal-time`` sets each strategy's spp
from the deterministic cost model of :mod:`vrlab.render.compare` (no pilot timing): the
last strategy keeps ``--spp``.  The output gives, per strategy, the relMSE, the spp used
and the measured seconds, and which reference was used.  ``--equal-cost`` adds each render's
counted cost (:mod:`vrlab.render.cost`) and ranks the strategies by relMSE x counted cost per
pixel, next to relMSE x seconds (:func:`vrlab.render.compare.equal_cost_table`);
``--cost-weights NAME=W,...`` sets the weights (counter names or the groups ``rays``,
``evals``, ``samples``; default 1 per ray, 0.1 per BSDF / emitter sample or evaluation, 0.25
per light-BVH walk).  ``--json`` always holds every strategy's counts (``counted_cost``).

Usage errors (exit status 2), before any work: ``--compare`` an empty, repeated or
unknown name; ``--strategy``, ``--stderr-out``, ``--checkpoint``, ``--scheduler`` with
``--compare``; ``--equal-time``, ``--equal-cost``, ``--cost-weights`` or ``--reference-spp``
without it; ``--cost-weights`` without ``--equal-cost``, or with an item that is not
NAME=number, an unknown name, a repeated name, a negative or non-finite weight, or every
weight 0; ``--reference-spp``
(1 .. 2**24, vrlab.limits.MAX_SPP) with ``--reference``.
"""
from __future__ import annotations

import argparse
import json
import sys

from .cli_render_settings import (NEED_COMPARE, NOT_WITH_COMPARE, REF_SPP, REF_STRATEGY,  # noqa: F401
                                  RenderSettings, progress_callback)


def add_arguments(rend: argparse.ArgumentParser) -> None:
    """The ``--compare`` flags of ``vrlab render``."""
    rend.add_argument("--compare", metavar="S1,S2,...", nargs="?", const="bsdf,light,mis-power",
                      help="render a grid of strategies, each with the sampling flags given (--spp, --seed, "
                           "--pixel-sampler, --light-selection, --emitter-samples, --bsdf-samples, --ris-candidates, "
                           "--spp-batch, --workers), relMSE against --reference (or a render of its own) under each "
                           "panel (default: the Veach figure bsdf,light,mis-power); -o names the figure (.png, .pdf "
                           "or .svg)")
    rend.add_argument("--equal-time", action="store_true",
                      help="with --compare: give each strategy the spp whose modelled cost (traced rays per "
                           "pixel sample, vrlab.render.compare; no clock, the same spp every run) equals the "
                           "last strategy's at --spp")
    rend.add_argument("--equal-cost", action="store_true",
                      help="with --compare: count each render's rays (camera, closest-hit, shadow), BSDF and emitter "
                           "samples and evaluations and light-BVH walks (vrlab.render.cost), and rank the strategies "
                           "by relMSE x counted cost per pixel (error at equal counted cost, the same on any machine), "
                           "shown next to relMSE x seconds")
    rend.add_argument("--cost-weights", metavar="NAME=W,...",
                      help="with --equal-cost: the weight of each count, by name (camera_rays, closest_rays, "
                           "shadow_rays, bsdf_samples, bsdf_evals, emitter_samples, emitter_evals, light_walks) or "
                           "group (rays, evals, samples; a group first, then names), finite numbers >= 0; default "
                           "1 per ray, 0.1 per sample or evaluation, 0.25 per light-BVH walk (e.g. rays=1,evals=0)")
    rend.add_argument("--reference-spp", metavar="N",
                      help=f"with --compare and no --reference: spp of the reference it renders ({REF_STRATEGY}, "
                           f"i.i.d. points, its own seed), 1 .. 2**24 (default: {REF_SPP})")


def run_compare(p: RenderSettings) -> int:
    """Render the strategies (and the reference, if none is given) and report them."""
    from .render.compare import compare, compare_figure
    from .render.film import SPP_BATCH

    scene = p.scene
    workers = p.resolved_workers()
    if p.reference is None:
        print(f"vrlab render: note: no --reference: rendering one first, {REF_STRATEGY} at {p.reference_spp} "
              f"spp (i.i.d. points, seed [{p.seed}, 1]); --reference FILE uses yours, --reference-spp N sets "
              "the spp",
              file=sys.stderr, flush=True)
    show = p.show_progress
    bars: dict = {}

    def progress(name, done, total):
        if name not in bars:
            bars[name] = progress_callback(True, name)
        bars[name](done, total)

    res = compare(scene, p.compare, p.spp, rng=p.seed, reference=p.reference, ref_spp=p.reference_spp,
                  ref_strategy=REF_STRATEGY, equal_time=p.equal_time, workers=workers,
                  progress=progress if show else None, kernels=p.kernels, equal_cost=p.equal_cost,
                  cost_weights=p.cost_weights, **p.sampling())
    spp = res["spp"] if isinstance(res["spp"], dict) else {s: res["spp"] for s in res["images"]}
    ref = res["reference_render"]
    reference = {"source": "file", "file": str(p.reference_path)} if ref is None else {"source": "rendered", **ref}
    integ = scene.integrator
    settings = {"pixel_sampler": p.pixel_sampler, "light_selection": p.light_selection,
                "emitter_samples": integ.emitter_samples if p.emitter_samples is None else p.emitter_samples,
                "bsdf_samples": integ.bsdf_samples if p.bsdf_samples is None else p.bsdf_samples,
                "ris_candidates": p.ris_candidates, "seed": p.seed, "workers": workers,
                "spp_batch": p.spp_batch or SPP_BATCH}
    out = {"scene": str(p.path), "width": scene.sensor.width, "height": scene.sensor.height,
           "equal_time": p.equal_time, "spp": spp,
           "rel_mse": res["rel_mse"], "seconds": res["seconds"], "cost_per_sample": res["cost"],
           "counted_cost": res["counted"], "reference": reference, "settings": settings}
    if p.equal_cost:
        out["equal_cost"] = res["equal_cost"]
    if p.output is not None:
        out["figure"] = str(compare_figure(res, p.output, exposure="auto" if p.exposure_auto else p.exposure))
    if p.json:
        print(json.dumps(out, indent=2))
        return 0
    if ref is None:
        lines = [f"reference: {reference['file']}"]
    else:
        lines = [f"reference: rendered, {ref['strategy']} at {ref['spp']} spp, seed [{p.seed}, 1], "
                 f"{ref['seconds']:.2f} s"]
    if out["equal_time"]:
        last = list(spp)[-1]
        lines.append(f"equal time (modelled, no clock): spp x rays per sample as near as can be to {last}'s "
                     f"{spp[last]} x {res['cost'][last]:g} (vrlab.render.compare)")
    if p.equal_cost:
        table = res["equal_cost"]
        w = ", ".join(f"{k} {v:g}" for k, v in table["weights"].items())
        lines.append(f"equal counted cost: relMSE x cost per pixel (weights: {w}), next to relMSE x seconds; "
                     "x: ratio to the best")
        lines += [f"{s:12s} relMSE {res['rel_mse'][s]:.4g}  {spp[s]} spp  {res['seconds'][s]:.2f} s  "
                  f"cost/sample {res['counted'][s]['weighted_per_sample']:.3g}  "
                  f"relMSE x cost {table['rel_mse_x_cost'][s]:.4g} (x{table['cost_ratio'][s]:.2f})  "
                  f"relMSE x time {table['rel_mse_x_time'][s]:.4g} (x{table['time_ratio'][s]:.2f})"
                  for s in res["rel_mse"]]
        lines.append(f"ranking at equal counted cost: {' < '.join(table['ranking'])}")
    else:
        lines += [f"{s:12s} relMSE {v:.4g}  {spp[s]} spp  {res['seconds'][s]:.2f} s  ({res['cost'][s]:g} rays/sample)"
                  for s, v in res["rel_mse"].items()]
    if "figure" in out:
        lines.append(f"figure: {out['figure']}")
    print("\n".join(lines))
    return 0
