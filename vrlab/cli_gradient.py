"""``vrlab render SCENE --gradient-domain``: the primal image and its CRN gradients
(:func:`vrlab.render.render_gradient_domain`), then a screened Poisson reconstruction
(:func:`vrlab.render.screened_poisson`, ``--reconstruct l2|l1``, ``--alpha``).

The scene, ``--spp``, ``--strategy``, ``--pixel-sampler``, ``--seed``, ``--workers``,
``--light-selection``, ``--emitter-samples``/``--bsdf-samples``/``--ris-candidates``,
``--width``/``--height``, ``--exposure``, ``--reference`` and ``--stderr-out`` (the
primal's standard error) mean what they mean for a plain render and are checked by
:func:`vrlab.cli_render_settings.settings_from_args`.  ``--independent`` gives the neighbours their own
uniforms (``common=False``, the baseline without common random numbers).

With ``-o OUT.EXT`` (.npy, .png or .exr) the files are, next to ``OUT``:

* ``OUT.EXT``: the reconstruction chosen by ``--reconstruct`` (default l2);
* ``OUT_primal.EXT``: the primal image;
* ``OUT_dx.EXT``, ``OUT_dy.EXT``: ``|dx|`` and ``|dy|`` per channel, ``dx`` (H, W-1) padded
  with a zero last column and ``dy`` (H-1, W) with a zero last row to the image's (H, W);
* ``OUT_panels.png``: primal | ``|dx| + |dy|`` | the ``--reconstruct`` reconstruction (its
  label names the norm) | reference (with ``--reference``), each labelled, with
  ``relMSE = mean((img-ref)^2/(ref^2+0.01))`` under the images when a reference is given.

Only the ``--reconstruct`` norm is solved (the L1 solve, iteratively reweighted, takes about
100 times the L2's DCT solve; it prints a one-line note on stderr when it starts).
``reconstruct_seconds`` reports the time of the solve, by norm.

Checked before rendering, usage errors (exit status 2): ``--reconstruct`` (argparse
choice), ``--alpha`` a finite real > 0 whose square is finite and non-zero, the spp
(given or the scene's) >= 2, ``--compare``/``--equal-time`` (they do not apply), and
``--reconstruct``/``--alpha``/``--independent`` without ``--gradient-domain``; the
derived file names must not clash with ``--stderr-out``.  Failures (exit status 1):
a derived file that is a folder or not writable.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from . import cli_args as A
from .cli_render_settings import RenderSettings, progress_callback, settings_from_args

DEFAULTS = {"reconstruct": "l2", "alpha": "0.2"}
#: flags of vrlab render that do not go with --gradient-domain (dest -> flag)
NOT_WITH_GRADIENT = {"compare": "--compare", "equal_time": "--equal-time", "equal_cost": "--equal-cost",
                     "cost_weights": "--cost-weights"}
#: flags that only mean something with --gradient-domain (dest -> flag)
NEED_GRADIENT = {"reconstruct": "--reconstruct", "alpha": "--alpha", "independent": "--independent"}
#: the files written next to -o OUT.EXT: key in the JSON -> file name suffix
SIDE_FILES = {"primal_output": "_primal", "dx_output": "_dx", "dy_output": "_dy"}


def _side(path: Path, tag: str, suffix: str | None = None) -> Path:
    return path.with_name(f"{path.stem}{tag}{path.suffix if suffix is None else suffix}")


def check_gradient(args: argparse.Namespace) -> RenderSettings:
    """The settings of ``--gradient-domain`` (see the module docstring) on top of
    :func:`vrlab.cli_render_settings.settings_from_args`'s; raises UsageError / Failure before any work."""
    def given(key):
        return getattr(args, key) not in (None, False)

    if not args.gradient_domain:
        for key, flag in NEED_GRADIENT.items():
            if given(key):
                raise A.UsageError(f"{flag} needs --gradient-domain")
    for key, flag in NOT_WITH_GRADIENT.items():
        if given(key):
            raise A.UsageError(f"{flag} does not apply with --gradient-domain (it renders one image and "
                               "its gradients; the panels figure OUT_panels.png shows primal, gradients and the reconstruction)")
    if given("scheduler"):
        raise A.UsageError("--scheduler does not apply with --gradient-domain yet (use --workers; "
                           "vrlab.render.render_gradient_domain(executor=client) in Python)")
    for key, value in DEFAULTS.items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    alpha = A.real(args.alpha, "--alpha", low=0, low_open=True)
    if not 0.0 < alpha * alpha < float("inf"):
        raise A.UsageError(f"--alpha must have a finite, non-zero square, got {alpha:g}")
    p = settings_from_args(args)
    if p.spp < 2:
        given = "" if args.spp is not None else " (the scene's spp; give --spp 2 or more)"
        raise A.UsageError(f"--spp: --gradient-domain needs spp >= 2 (gradients need a standard error per "
                           f"pixel), got {p.spp}{given}")
    p.alpha, p.norm, p.common, p.files = alpha, args.reconstruct, not args.independent, {}
    out = p.output
    if out is not None:
        files = {key: _side(out, tag) for key, tag in SIDE_FILES.items()}
        files["figure"] = _side(out, "_panels", ".png")
        for key, path in files.items():
            A.output_file(str(path), "-o/--output", (path.suffix.lower(),))
        A.distinct({"-o/--output": out, **{f"-o/--output ({path.name})": path for path in files.values()},
                    "--stderr-out": p.stderr_out})
        p.files = files
    return p


def _magnitude(diff, shape: tuple):
    """``|diff|`` per channel, padded with zeros to ``shape`` (a last column or row)."""
    import numpy as np

    out = np.zeros(shape, np.float32)
    out[: diff.shape[0], : diff.shape[1]] = np.abs(diff)
    return out


def run_gradient(args: argparse.Namespace) -> int:
    """``vrlab render ... --gradient-domain``: check, render, reconstruct, write, report."""
    p = check_gradient(args)
    import numpy as np

    from .render import render_gradient_domain
    from .render.compare import panels_figure
    from .render.image import auto_exposure, rel_mse, save_image

    scene = p.scene
    workers = p.resolved_workers()
    t0 = time.perf_counter()
    gd = render_gradient_domain(p.plan(workers=workers), rng=p.seed, common=p.common,
                                progress=progress_callback(p.show_progress, "gradient-domain"),
                                checkpoint=p.checkpoint)
    seconds = time.perf_counter() - t0
    primal = gd.primal.value
    bad = int(np.count_nonzero(~np.isfinite(primal)))
    if bad:
        import warnings
        warnings.warn(f"the primal image has {bad} non-finite values (NaN or inf)", RuntimeWarning, stacklevel=1)
    # only the reconstruction asked for is solved; the figure shows that one
    if p.norm == "l1":
        import sys
        print(f"vrlab render: solving the L1 reconstruction of {scene.sensor.width}x{scene.sensor.height} pixels "
              "(iteratively reweighted least squares; about 100x the L2 solve) ...", file=sys.stderr, flush=True)
    t1 = time.perf_counter()
    recon = {p.norm: gd.reconstruct(p.alpha, p.norm)}
    timing = {p.norm: time.perf_counter() - t1}
    h, w = scene.sensor.height, scene.sensor.width
    out = {"scene": str(p.path), "strategy": p.strategy, "spp": p.spp, "workers": workers,
           "width": w, "height": h, "common": p.common, "alpha": p.alpha, "reconstruct": p.norm,
           "seconds": seconds, "reconstruct_seconds": timing, "cost": gd.primal.extra["cost"]}
    if p.reference is not None:
        out["rel_mse"] = {"primal": rel_mse(primal, p.reference),
                          **{norm: rel_mse(img, p.reference) for norm, img in recon.items()}}
    if p.output is not None:
        files, exposure = p.files, p.exposure
        if p.exposure_auto:          # one scale for every image: from the reference, else the primal
            exposure = auto_exposure(primal if p.reference is None else p.reference)
            out["exposure"] = exposure
        dx, dy = _magnitude(gd.dx.value, (h, w, 3)), _magnitude(gd.dy.value, (h, w, 3))
        out["output"] = str(save_image(p.output, recon[p.norm], exposure))
        for key, img in (("primal_output", primal), ("dx_output", dx), ("dy_output", dy)):
            out[key] = str(save_image(files[key], img, exposure))
        err = out.get("rel_mse", {})
        panels = [("primal", primal, err.get("primal")), ("|dx| + |dy|", dx + dy, None),
                  (f"{p.norm.upper()} reconstruction, alpha = {p.alpha:g}", recon[p.norm], err.get(p.norm))]
        if p.reference is not None:
            panels.append(("reference", p.reference, None))
        kind = "common random numbers" if p.common else "independent neighbours"
        title = (f"{p.path.stem}: gradient-domain, {p.strategy}, {p.spp} spp, {kind} "
                 f"(exposure: shared, x{exposure:.3g})")
        panels = [(label if err is None else f"{label}\nrelMSE = {err:.3g}", img) for label, img, err in panels]
        out["figure"] = str(panels_figure(panels, files["figure"], title=title, exposure=exposure))
    if p.stderr_out is not None:
        out["stderr_output"] = str(save_image(p.stderr_out, gd.primal.stderr))
    if p.json:
        print(json.dumps(out, indent=2))
    else:
        flat = {**{k: v for k, v in out.items() if k not in ("rel_mse", "reconstruct_seconds", "cost")},
                "cost_per_sample": out["cost"]["weighted_per_sample"],
                **{f"reconstruct_seconds_{k}": v for k, v in timing.items()},
                **{f"rel_mse_{k}": v for k, v in out.get("rel_mse", {}).items()}}
        print("  ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in flat.items()))
    return 0
