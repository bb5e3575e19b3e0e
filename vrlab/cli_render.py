"""``vrlab render``: direct lighting of a Mitsuba 3 XML scene (see :mod:`vrlab.render`).

Checked before rendering (usage errors, exit status 2, unless noted): ``--spp``
(1 .. 2**24), ``--width``/``--height`` (1 .. 65536; :mod:`vrlab.limits`, as the library), ``--seed`` (0 .. 2**128-1),
``--emitter-samples``/``--bsdf-samples`` (0 .. 1024, and what the strategy needs),
``--ris-candidates`` (1 .. 4096), ``--workers`` (1 .. 256), ``--exposure`` (``auto``
or finite > 0), the ``--compare`` flags (:mod:`vrlab.cli_compare`), flags that do not apply
together; ``-o``/``--stderr-out``: suffix, a folder that exists and is writable (else
exit status 1); the scene (a file: read and parsed, else exit status 1; or a built-in
name); ``--reference``: a readable ``.npy`` (or ``.exr`` with OpenEXR) of finite values
whose shape matches the image (else exit status 1).
``--export NAME [--to FOLDER]`` takes no other render flag and no scene; NAME must be a
built-in scene; FOLDER (default ``.``) a folder or creatable, writable, without a file
of that name already (else exit status 1).
"""
from __future__ import annotations

import argparse
import contextlib
import json
import sys

from . import cli_args as A
from . import cli_compare as C
from . import limits
from .cli_render_settings import (DEFAULTS, FIGURE_SUFFIXES, IMAGE_SUFFIXES, PIXEL_SAMPLER_HELP,  # noqa: F401
                                  PIXEL_SAMPLERS, RIS_MAX, SAMPLES_MAX, SIDE_MAX, SPP_MAX, Phase, RenderSettings,
                                  progress_callback, settings_from_args)


def _menu(table: dict, names) -> str:
    """'name: what it does; ...' for every name the renderer accepts (tests/test_cli_help.py checks
    that the table covers them all)."""
    return "; ".join(f"{name}: {table[name]}" if name in table else name for name in names)


def _with_bias(table: dict) -> dict:
    """``table``'s help texts followed by each strategy's bias status from the registry
    (``Recipe.bias``: unbiased / consistent / biased)."""
    from .estimators import recipes

    bias = {name: r.bias for name, r in recipes("render").items()}
    return {name: f"{text} [{bias[name]}]" if name in bias else text for name, text in table.items()}


def add_parser(sub, **kw) -> argparse.ArgumentParser:
    from .render.presets import PRESETS, preset_help

    rend = sub.add_parser("render", help="render a Mitsuba 3 XML scene (or a built-in one) with direct lighting",
                          description="Direct lighting with a choice of sampling strategy; writes .npy (linear),\n"
                                      ".png (tonemapped sRGB) or .exr.  Built-in scenes: --list describes them,\n"
                                      "--export NAME copies one into a folder for editing.", **kw)
    rend.add_argument("scene", nargs="?", help="a scene XML file (Mitsuba 3 subset) or a built-in scene name "
                                               "(see --list)")
    rend.add_argument("-D", dest="defines", action="append", metavar="NAME=VALUE",
                      help="set the scene parameter $NAME (overrides its <default>), as Mitsuba's -D; repeatable: "
                           "-D max_depth=2 -D spp=64 (or -Dspp=64)")
    rend.add_argument("--list", action="store_true", help="list the built-in scenes, one line each (with --json: "
                                                          "name -> summary, full description and file)")
    rend.add_argument("--export", metavar="NAME", help="copy the built-in scene NAME (its XML and any mesh files "
                      "it uses) into --to FOLDER for editing, then render the copy: vrlab render FOLDER/NAME.xml")
    rend.add_argument("--to", metavar="FOLDER", help="with --export: the folder to write into, created if missing; "
                                                     "existing files are not replaced (default: the current folder)")
    rend.add_argument("--spp", help=f"samples per pixel, 1 .. {SPP_MAX} (default: the scene's)")
    rend.add_argument("--strategy", choices=list(PRESETS), metavar="NAME",
                      help=f"how each shading point samples its direct light, [its bias status]. "
                           f"{_menu(_with_bias(preset_help()), PRESETS)} (default: mis-power)")
    rend.add_argument("--pixel-sampler", choices=list(PIXEL_SAMPLERS), metavar="NAME",
                      help=f"how each pixel's uniforms are drawn. {_menu(PIXEL_SAMPLER_HELP, PIXEL_SAMPLERS)}. "
                           "The standard errors assume independent (default: independent)")
    rend.add_argument("--light-selection", choices=list(limits.LIGHT_SELECTIONS), metavar="NAME",
                      help="how strategies that sample a light pick it. uniform: each light alike; power: by "
                           "emitted power (pi x mean radiance x area; a point light 4 pi I), from an alias table; "
                           "bvh: pbrt-v4's light BVH, by power, distance and orientation from each shading point "
                           "(default: uniform)")
    rend.add_argument("--seed", default="0", help="root seed of every random number, 0 .. 2**128-1: the same seed "
                                                  "gives the same image for any --workers (default: %(default)s)")
    rend.add_argument("--emitter-samples", help=f"light samples per shading point, 0 .. {SAMPLES_MAX} "
                                                "(default: the scene integrator's)")
    rend.add_argument("--bsdf-samples", help=f"BSDF samples per shading point, 0 .. {SAMPLES_MAX} "
                                             "(default: the scene integrator's)")
    rend.add_argument("--ris-candidates", help=f"light candidates per RIS sample (ris), 1 .. {RIS_MAX} (default: 8)")
    rend.add_argument("--workers", help=f"worker processes, 1 .. {A.WORKERS_MAX} (default: the CPUs available; "
                                        "tiles are seeded per tile, so the image is the same for any count)")
    rend.add_argument("--progress", dest="progress", action="store_true", default=None,
                      help="progress bar on stderr (default: when stderr is a terminal)")
    rend.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    rend.add_argument("--width", help=f"override the film width, 1 .. {SIDE_MAX}")
    rend.add_argument("--height", help=f"override the film height, 1 .. {SIDE_MAX}")
    rend.add_argument("-o", "--output", help="image file: .npy, .png or .exr (with --compare: the figure, "
                                             ".png, .pdf or .svg)")
    rend.add_argument("--stderr-out", help="per-pixel standard error image (.npy, .png or .exr; needs spp >= 2)")
    rend.add_argument("--reference", help="reference .npy (or .exr) of the same size: print relMSE = "
                                          "mean((img-ref)^2/(ref^2+0.01)); with --compare: the reference "
                                          "of every panel")
    rend.add_argument("--exposure", default="auto",
                      help="exposure scale of a .png and of the --compare / --gradient-domain figures: auto "
                           "(mid-grey key 0.18 on the log-average luminance, at most 3%% of the pixels white; "
                           "vrlab.render.image.auto_exposure; the figures share one scale, from the reference, else "
                           "the image or primal) or a number > 0; .npy and .exr are saved linear, unscaled "
                           "(default: auto)")
    C.add_arguments(rend)
    rend.add_argument("--gradient-domain", action="store_true",
                      help="render the image and its pixel differences with common random numbers and "
                           "reconstruct it (screened Poisson); -o OUT.EXT also writes OUT_primal, OUT_dx, OUT_dy "
                           "(|differences|) and the figure OUT_panels.png (primal, |dx| + |dy|, the --reconstruct "
                           "reconstruction); spp >= 2 (vrlab.cli_gradient)")
    rend.add_argument("--reconstruct", choices=["l2", "l1"], metavar="NORM",
                      help="with --gradient-domain: the one reconstruction solved, written to -o and shown in "
                           "the figure. l2: least squares, "
                           "exact DCT solve; l1: gradient terms in the 1-norm (IRLS), robust to outlying gradients "
                           "(default: l2)")
    rend.add_argument("--alpha", help="with --gradient-domain: weight of the primal image in the reconstruction, "
                                      "finite and > 0 (default: 0.2)")
    rend.add_argument("--independent", action="store_true",
                      help="with --gradient-domain: the neighbour pixels get their own uniforms (no common "
                           "random numbers; the baseline)")
    rend.add_argument("--checkpoint", metavar="FILE.npz",
                      help="save the per-pixel statistics after each spp batch; rerunning the same command "
                           "resumes an interrupted render, a larger --spp extends a finished one (same bytes as "
                           "one uninterrupted render)")
    rend.add_argument("--spp-batch", help=f"samples per pixel of one work unit, 1 .. {SPP_MAX}: the image depends "
                                          "on it, not on how units run (default: 64)")
    rend.add_argument("--kernels", choices=["auto", "numba", "numpy"], default="auto",
                      help="kernels of the per-sample path: auto (default: the compiled ones where numba imports and "
                           "they gain: the light BVH, RIS, ReSTIR, and rays in scenes with many spheres or "
                           "without Embree), numba, or numpy (the reference implementation); --json reports "
                           "which ran")
    rend.add_argument("--scheduler", metavar="ADDRESS",
                      help="render the units on a running Dask scheduler, e.g. tcp://127.0.0.1:8786 (needs "
                           "vrlab[distributed]; same image as a local render; not with --workers; an address that "
                           f"does not answer as a scheduler within {A.SCHEDULER_TIMEOUT:g} s: exit 1; no workers: "
                           f"waits up to {A.WORKER_WAIT:g} s)")
    rend.add_argument("--json", action="store_true", help="print time, samples/s and errors as JSON (with "
                                                          "--list or --export: what they print)")
    rend.set_defaults(parser=rend, func=run_render)
    return rend


def _emit(args, out: dict, text: str) -> None:
    print(json.dumps(out, indent=2) if args.json else text)


def _given(args: argparse.Namespace, keep: set[str]) -> list[str]:
    """The flags given on the command line (value not the default) whose dest is not in ``keep``."""
    parser = args.parser
    defaults = parser.parse_known_args([])[0]
    out = []
    for action in parser._actions:
        value = getattr(args, action.dest, None)
        if not action.option_strings or action.dest in keep or value == getattr(defaults, action.dest, None):
            continue
        if isinstance(value, bool) and action.const is not None and value != action.const:
            continue                        # --progress / --no-progress share one dest
        out.append(action.option_strings[-1])
    return out


def _list(args: argparse.Namespace) -> int:
    import textwrap

    from .render.builtin import builtin_scene_path, describe_builtin_scene, list_builtin_scenes

    names = list_builtin_scenes()
    if args.json:
        print(json.dumps({n: {"summary": describe_builtin_scene(n), "description": describe_builtin_scene(n, full=True),
                              "file": str(builtin_scene_path(n))} for n in names}, indent=2))
        return 0
    width = max(map(len, names)) + 2
    for n in names:
        print(textwrap.fill(describe_builtin_scene(n), 100, initial_indent=n.ljust(width), break_on_hyphens=False,
                            subsequent_indent=" " * width))
    print("\nvrlab render NAME renders one; vrlab render --export NAME [--to FOLDER] copies its XML for editing.")
    return 0


def _export(args: argparse.Namespace) -> int:
    """``--export NAME [--to FOLDER]``: checks (usage errors: other render flags, a scene, an
    unknown NAME; failures: --to not a writable folder, a file there already), then copies."""
    from .render.builtin import describe_builtin_scene, export_builtin_scene, list_builtin_scenes

    if args.export is None:
        raise A.UsageError("--to needs --export NAME (it names the folder the scene is copied into)")
    if args.scene is not None:
        raise A.UsageError(f"--export takes no scene argument (got {args.scene!r}): vrlab render --export NAME "
                           "[--to FOLDER]")
    others = _given(args, {"export", "to", "json", "debug"})
    if others:
        raise A.UsageError(f"{others[0]} does not apply with --export (it only copies a built-in scene: "
                           "vrlab render --export NAME [--to FOLDER])")
    name = A.names(args.export.strip().removesuffix(".xml"), "--export", list_builtin_scenes())
    if len(name) > 1:
        raise A.UsageError(f"--export takes one built-in scene name, got {args.export!r}")
    folder = A.output_folder("." if args.to is None else args.to, "--to")
    try:
        files = export_builtin_scene(name[0], folder)
    except FileExistsError as exc:
        taken = str(exc).removeprefix("folder: ").split(";")[0]
        raise A.Failure(f"--to: {taken}; files are not replaced: remove it or choose another folder") from None
    out = {"scene": name[0], "description": describe_builtin_scene(name[0], full=True),
           "files": [str(f) for f in files]}
    _emit(args, out, f"wrote {', '.join(out['files'])}\nedit it, then render it: vrlab render {out['files'][0]}")
    return 0


def run_render(args: argparse.Namespace) -> int:
    if args.list:
        if args.export is not None or args.to is not None:
            raise A.UsageError("--list and --export do not go together (give one)")
        return _list(args)
    if args.export is not None or args.to is not None:
        return _export(args)
    if args.gradient_domain or args.reconstruct is not None or args.alpha is not None or args.independent:
        from .cli_gradient import run_gradient      # (its flags without --gradient-domain: a usage error there)
        return run_gradient(args)
    p = settings_from_args(args)
    from ._alloc import keep_freed_memory

    keep_freed_memory()     # this process is vrlab's own: reuse freed ray temporaries (vrlab._alloc)
    if p.compare:
        return C.run_compare(p)
    return _run_one(args, p)


def _run_one(args: argparse.Namespace, p: RenderSettings) -> int:
    """One render with the settings ``p``: render, save, report."""
    import time

    import numpy as np

    from .render import render
    from .render.image import auto_exposure, rel_mse, save_image

    scene = p.scene
    t0 = time.perf_counter()
    workers = p.resolved_workers()
    with contextlib.ExitStack() as stack:
        client = None
        if p.scheduler is not None:
            client = stack.enter_context(A.connect_scheduler(p.scheduler))
        # geometry, acceleration structure and lights, up to the first finished samples (the bar's first report)
        setup = stack.enter_context(Phase(p.show_progress, "setting up the render (geometry, acceleration "
                                                           "structure, lights)"))
        plan = p.plan(workers=2 if client is not None else workers)      # resolved and checked once
        try:
            est = render(plan, rng=p.seed, executor=client, checkpoint=p.checkpoint,
                         progress=progress_callback(p.show_progress, "render", first=setup.stop))
        except ValueError as exc:
            if str(exc).startswith("checkpoint"):      # another render's file: choose another name
                raise A.UsageError("--" + str(exc)) from None
            raise
    img, err = est.value, est.stderr
    seconds = time.perf_counter() - t0
    resumed = int(est.extra.get("spp_resumed", 0))
    bad = int(np.count_nonzero(~np.isfinite(img)))
    if bad:
        import warnings
        warnings.warn(f"the image has {bad} non-finite values (NaN or inf)", RuntimeWarning, stacklevel=1)
    finite_err = err[np.isfinite(err)]
    out = {"scene": str(p.path), "strategy": p.strategy, "spp": p.spp, "workers": workers,
           "width": scene.sensor.width, "height": scene.sensor.height, "seconds": seconds,
           # samples rendered by this run: a resumed --checkpoint's stored samples are not counted
           "samples_per_second": scene.sensor.width * scene.sensor.height * (p.spp - resumed) / seconds,
           # spp = 1 has no standard error: null in JSON rather than NaN
           "mean_stderr": float(finite_err.mean()) if finite_err.size else None,
           "kernels": est.extra["kernels"], "plan": repr(plan), "cost": est.extra["cost"]}
    if p.checkpoint is not None:
        out["spp_resumed"] = resumed
        if resumed:
            print(f"vrlab render: note: {resumed} of {p.spp} spp were read from {p.checkpoint}; "
                  f"samples_per_second counts the {p.spp - resumed} rendered now", file=sys.stderr, flush=True)
    if p.output is not None:
        if p.output.suffix.lower() == ".png":         # the exposure used, in the report
            out["exposure"] = auto_exposure(img) if p.exposure_auto else p.exposure
        out["output"] = str(save_image(p.output, img, out.get("exposure", 1.0)))
    else:                                             # say so: nothing was saved
        out["output"] = None
        print("vrlab render: note: no -o/--output: the image was not saved (give -o FILE.npy, .png or .exr)",
              file=sys.stderr, flush=True)
    if p.stderr_out is not None:
        out["stderr_output"] = str(save_image(p.stderr_out, err))
    if p.reference is not None:
        out["rel_mse"] = rel_mse(img, p.reference)
    # the text line: the counted cost as its weighted figure per sample (--json: every count)
    flat = {**{k: v for k, v in out.items() if k != "cost"}, "cost_per_sample": est.extra["cost"]["weighted_per_sample"]}
    _emit(args, out, "  ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in flat.items()))
    return 0

