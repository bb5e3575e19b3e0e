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
import importlib.util
import json
import os
import sys
from pathlib import Path

from . import cli_args as A
from . import limits
from . import cli_compare as C

SPP_MAX = limits.MAX_SPP          # the one table of limits, shared with the library
SIDE_MAX = limits.MAX_SIDE
SAMPLES_MAX = limits.MAX_SAMPLES
RIS_MAX = limits.MAX_CANDIDATES
IMAGE_SUFFIXES = (".npy", ".png", ".exr")
#: the --pixel-sampler names; each maps to render's ``points=`` (``independent`` -> None, i.i.d.)
PIXEL_SAMPLERS = ("independent", "stratified", "sobol", "halton")
FIGURE_SUFFIXES = (".png", ".pdf", ".svg")
DEFAULTS = {"strategy": "mis-power", "pixel_sampler": "independent", "light_selection": "uniform",
            "ris_candidates": "8"}


PIXEL_SAMPLER_HELP = {
    "independent": "i.i.d. uniforms", "stratified": "padded jittered strata per pair of dimensions",
    "sobol": "one scrambled Sobol' set for all pixels, shifted per pixel",
    "halton": "the same with a scrambled Halton set"}


def _menu(table: dict, names) -> str:
    """'name: what it does; ...' for every name the renderer accepts (tests/test_cli_help.py checks
    that the table covers them all)."""
    return "; ".join(f"{name}: {table[name]}" if name in table else name for name in names)


def _points(name: str) -> str | None:
    """render's ``points=`` for a --pixel-sampler name: None (i.i.d.) for ``independent``."""
    return None if name == "independent" else name


def add_parser(sub, **kw) -> argparse.ArgumentParser:
    from .render.presets import PRESETS, preset_help

    rend = sub.add_parser("render", help="render a Mitsuba 3 XML scene (or a built-in one) with direct lighting",
                          description="Direct lighting with a choice of sampling strategy; writes .npy (linear),\n"
                                      ".png (tonemapped sRGB) or .exr.  Built-in scenes: --list describes them,\n"
                                      "--export NAME copies one into a folder for editing.", **kw)
    rend.add_argument("scene", nargs="?", help="a scene XML file (Mitsuba 3 subset) or a built-in scene name "
                                               "(see --list)")
    rend.add_argument("--list", action="store_true", help="list the built-in scenes, one line each (with --json: "
                                                          "name -> summary, full description and file)")
    rend.add_argument("--export", metavar="NAME", help="copy the built-in scene NAME (its XML and any mesh files "
                      "it uses) into --to FOLDER for editing, then render the copy: vrlab render FOLDER/NAME.xml")
    rend.add_argument("--to", metavar="FOLDER", help="with --export: the folder to write into, created if missing; "
                                                     "existing files are not replaced (default: the current folder)")
    rend.add_argument("--spp", help=f"samples per pixel, 1 .. {SPP_MAX} (default: the scene's)")
    rend.add_argument("--strategy", choices=list(PRESETS), metavar="NAME",
                      help=f"how each shading point samples its direct light. {_menu(preset_help(), PRESETS)} "
                           "(default: mis-power)")
    rend.add_argument("--pixel-sampler", choices=list(PIXEL_SAMPLERS), metavar="NAME",
                      help=f"how each pixel's uniforms are drawn. {_menu(PIXEL_SAMPLER_HELP, PIXEL_SAMPLERS)}. "
                           "The standard errors assume independent (default: independent)")
    rend.add_argument("--light-selection", choices=["uniform", "power"], metavar="NAME",
                      help="how strategies that sample a light pick it. uniform: each light alike; power: by "
                           "emitted power (mean radiance x area), from an alias table (default: uniform)")
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
                      help="exposure scale of a .png: auto (mid-grey key 0.18 on the log-average luminance, at "
                           "most 3%% of the pixels white; vrlab.render.image.auto_exposure) or a number > 0; "
                           "--compare and --gradient-domain figures take 1.0 for auto (default: auto)")
    C.add_arguments(rend)
    rend.add_argument("--gradient-domain", action="store_true",
                      help="render the image and its pixel differences with common random numbers and "
                           "reconstruct it (screened Poisson); -o OUT.EXT also writes OUT_primal, OUT_dx, OUT_dy "
                           "(|differences|) and the figure OUT_panels.png; spp >= 2 (vrlab.cli_gradient)")
    rend.add_argument("--reconstruct", choices=["l2", "l1"], metavar="NORM",
                      help="with --gradient-domain: the reconstruction written to -o. l2: least squares, "
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
    rend.add_argument("--scheduler", metavar="ADDRESS",
                      help="render the units on a running Dask scheduler, e.g. tcp://127.0.0.1:8786 (needs "
                           "vrlab[distributed]; same image as a local render; not with --workers; an address that "
                           f"does not answer as a scheduler within {A.SCHEDULER_TIMEOUT:g} s: exit 1; no workers: "
                           f"waits up to {A.WORKER_WAIT:g} s)")
    rend.add_argument("--json", action="store_true", help="print time, samples/s and errors as JSON (with "
                                                          "--list or --export: what they print)")
    rend.set_defaults(parser=rend, func=run_render)
    return rend


def _scene_path(text: str | None) -> Path:
    from .render import builtin_scene_path, list_builtin_scenes

    if text is None:
        raise A.UsageError("give a scene: an XML path or a built-in name (--list shows them)")
    if not text.strip():
        raise A.UsageError("scene must not be empty: give an XML path or a built-in name (--list shows them)")
    if os.path.exists(text):
        return Path(text)
    if text.lower().endswith(".xml") and ("/" in text or os.sep in text or text[:-4] not in list_builtin_scenes()):
        raise A.Failure(f"scene: no such file {text!r}")
    try:
        return builtin_scene_path(text)
    except ValueError:
        raise A.UsageError(f"scene: {text!r} is neither a file nor a built-in scene; built-in: "
                           f"{', '.join(list_builtin_scenes())}") from None


def _load(path: Path):
    from .render import SceneError, load_scene

    try:
        return load_scene(path)
    except SceneError as exc:
        text = str(exc)
        raise A.Failure(text if str(path) in text else f"scene {str(path)!r}: {text}") from exc


def _samples_for(strategy: str, n_l: int, n_b: int, given: dict, flag: str = "--strategy") -> None:
    """The renderer's rules for light/BSDF sample counts (``check_sample_counts``), checked
    up front; the message names the flags, or the scene's settings where no flag was given."""
    from .render.presets import check_sample_counts

    try:
        check_sample_counts(strategy, n_l, n_b)
    except ValueError as exc:
        text = f"{flag} {strategy}: {exc}"
        for name in ("emitter", "bsdf"):
            arg = f"--{name}-samples" if given[f"--{name}-samples"] else f"the scene integrator's {name}_samples"
            text = text.replace(f"{name}_samples", arg)
        raise A.UsageError(text) from None


def _reference(path: Path | None, shape: tuple):
    if path is None:
        return None
    from .render.image import load_image

    try:                                    # a linear image (H, W, 3) of finite values
        ref = load_image(path, "--reference")
    except (TypeError, ValueError) as exc:
        raise A.Failure(str(exc)) from exc
    if ref.shape != shape:
        raise A.Failure(f"--reference: shape {ref.shape} differs from the image's {shape} "
                        "(set --width/--height to the reference's size)")
    return ref


def check_render(args: argparse.Namespace) -> dict:
    """Every flag of ``vrlab render`` as a value, the scene loaded and sized, the reference
    read (see the module docstring); raises :class:`~vrlab.cli_args.UsageError` or
    :class:`~vrlab.cli_args.Failure`."""
    import dataclasses

    from .render.presets import PRESETS

    p = C.check_flags(args, PRESETS, SPP_MAX)
    compare = p["compare"] is not None
    for key, value in DEFAULTS.items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    p.update(spp=A.integer(args.spp, "--spp", low=1, high=SPP_MAX),
             width=A.integer(args.width, "--width", low=1, high=SIDE_MAX),
             height=A.integer(args.height, "--height", low=1, high=SIDE_MAX),
             seed=A.seed(args.seed),
             emitter_samples=A.integer(args.emitter_samples, "--emitter-samples", low=0, high=SAMPLES_MAX),
             bsdf_samples=A.integer(args.bsdf_samples, "--bsdf-samples", low=0, high=SAMPLES_MAX),
             ris_candidates=A.integer(args.ris_candidates, "--ris-candidates", low=1, high=RIS_MAX),
             workers=A.workers(args.workers),
             exposure_auto=str(args.exposure).strip().lower() == "auto")
    # a number for the figures of --compare / --gradient-domain (auto: 1.0 there)
    try:
        p["exposure"] = 1.0 if p["exposure_auto"] else A.real(args.exposure, "--exposure", low=0, low_open=True)
    except A.UsageError:
        raise A.UsageError(f"--exposure must be auto or a finite number > 0, got {args.exposure!r}") from None
    p["output"] = A.output_file(args.output, "-o/--output", FIGURE_SUFFIXES if compare else IMAGE_SUFFIXES)
    p["stderr_out"] = A.output_file(args.stderr_out, "--stderr-out", IMAGE_SUFFIXES)
    p["checkpoint"] = A.output_file(args.checkpoint, "--checkpoint", (".npz",))
    p["spp_batch"] = A.integer(args.spp_batch, "--spp-batch", low=1, high=SPP_MAX)
    A.distinct({"-o/--output": p["output"], "--stderr-out": p["stderr_out"], "--checkpoint": p["checkpoint"]})
    p["scheduler"] = A.scheduler_address(args.scheduler)
    if p["scheduler"] is not None and p["workers"] not in (None, 1):
        raise A.UsageError("--scheduler and --workers do not go together: the scheduler's workers render the "
                           "units (leave out --workers)")
    if (args.reference or "").lower().endswith(".exr") and importlib.util.find_spec("OpenEXR") is None:
        raise A.UsageError("--reference: reading .exr needs the OpenEXR package (pip install OpenEXR); use a .npy")
    p["reference_path"] = ref_path = A.input_file(args.reference, "--reference", (".npy", ".exr"))
    p["path"] = _scene_path(args.scene)
    scene = _load(p["path"])
    if p["width"] is not None or p["height"] is not None:
        scene.sensor = dataclasses.replace(scene.sensor, width=p["width"] or scene.sensor.width,
                                           height=p["height"] or scene.sensor.height)
    p["scene"], p["spp"] = scene, p["spp"] or scene.sensor.spp
    if p["stderr_out"] is not None and p["spp"] < 2:
        raise A.UsageError(f"--stderr-out needs --spp >= 2 (one sample has no standard error), got spp {p['spp']}")
    given = {"--emitter-samples": p["emitter_samples"] is not None, "--bsdf-samples": p["bsdf_samples"] is not None}
    n_l = scene.integrator.emitter_samples if p["emitter_samples"] is None else p["emitter_samples"]
    n_b = scene.integrator.bsdf_samples if p["bsdf_samples"] is None else p["bsdf_samples"]
    for strategy in p["compare"] or [args.strategy]:
        _samples_for(strategy, n_l, n_b, given, "--compare" if compare else "--strategy")
    p["reference"] = _reference(ref_path, (scene.sensor.height, scene.sensor.width, 3))
    return p


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
    p = check_render(args)
    from ._alloc import keep_freed_memory

    keep_freed_memory()     # this process is vrlab's own: reuse freed ray temporaries (vrlab._alloc)
    if p["compare"]:
        return C.run_compare(args, p)
    import time

    import numpy as np

    from .render import render
    from .render.image import auto_exposure, rel_mse, save_image

    scene = p["scene"]
    t0 = time.perf_counter()
    if p["workers"] is None:
        from .render.film import default_workers
        p["workers"] = default_workers()
    show = args.progress if args.progress is not None else sys.stderr.isatty()
    with contextlib.ExitStack() as stack:
        client = None
        if p["scheduler"] is not None:
            client = stack.enter_context(A.connect_scheduler(p["scheduler"]))
        try:
            est = render(scene, p["spp"], args.strategy, rng=p["seed"], points=_points(args.pixel_sampler),
                         light_selection=args.light_selection, emitter_samples=p["emitter_samples"],
                         bsdf_samples=p["bsdf_samples"], ris_candidates=p["ris_candidates"],
                         workers=2 if client is not None else p["workers"], executor=client,
                         progress=C.progress_callback(show, "render"), spp_batch=p["spp_batch"],
                         checkpoint=p["checkpoint"])
        except ValueError as exc:
            if str(exc).startswith("checkpoint"):      # another render's file: choose another name
                raise A.UsageError("--" + str(exc)) from None
            raise
    img, err = est.value, est.stderr
    seconds = time.perf_counter() - t0
    bad = int(np.count_nonzero(~np.isfinite(img)))
    if bad:
        import warnings
        warnings.warn(f"the image has {bad} non-finite values (NaN or inf)", RuntimeWarning, stacklevel=1)
    finite_err = err[np.isfinite(err)]
    out = {"scene": str(p["path"]), "strategy": args.strategy, "spp": p["spp"], "workers": p["workers"],
           "width": scene.sensor.width, "height": scene.sensor.height, "seconds": seconds,
           "samples_per_second": scene.sensor.width * scene.sensor.height * p["spp"] / seconds,
           # spp = 1 has no standard error: null in JSON rather than NaN
           "mean_stderr": float(finite_err.mean()) if finite_err.size else None}
    if p["output"] is not None:
        if p["output"].suffix.lower() == ".png":         # the exposure used, in the report
            out["exposure"] = auto_exposure(img) if p["exposure_auto"] else p["exposure"]
        out["output"] = str(save_image(p["output"], img, out.get("exposure", 1.0)))
    if p["stderr_out"] is not None:
        out["stderr_output"] = str(save_image(p["stderr_out"], err))
    if p["reference"] is not None:
        out["rel_mse"] = rel_mse(img, p["reference"])
    _emit(args, out, "  ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in out.items()))
    return 0

