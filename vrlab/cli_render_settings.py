"""The settings of one ``vrlab render`` command, built once from its arguments.

:func:`settings_from_args` checks every flag (see :mod:`vrlab.cli_render`), loads and sizes
the scene, reads the reference and returns a :class:`RenderSettings`; the plain render
(:mod:`vrlab.cli_render`), ``--compare`` (:mod:`vrlab.cli_compare`) and
``--gradient-domain`` (:mod:`vrlab.cli_gradient`) all read that one object, and all depend on
this module rather than on each other (no import circle).  Also here: the flags' tables
(pixel samplers, limits from :mod:`vrlab.limits`, the ``--compare`` flags' rules), the
progress bar callback the three share and :class:`Phase`, the lines that say what a slow step
before the first sample (loading the scene, setting up the render) is doing.
"""
from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import os
import re
import sys
import threading
import time
import warnings
from pathlib import Path
from typing import Any, Callable

from . import cli_args as A
from . import limits

SPP_MAX = limits.MAX_SPP          # the one table of limits, shared with the library
SIDE_MAX = limits.MAX_SIDE
SAMPLES_MAX = limits.MAX_SAMPLES
RIS_MAX = limits.MAX_CANDIDATES
IMAGE_SUFFIXES = (".npy", ".png", ".exr")
FIGURE_SUFFIXES = (".png", ".pdf", ".svg")
#: the --pixel-sampler names, passed to render's ``points=`` as they are (vrlab.points.names)
PIXEL_SAMPLERS = ("independent", "stratified", "sobol", "halton")
PIXEL_SAMPLER_HELP = {
    "independent": "i.i.d. uniforms", "stratified": "padded jittered strata per pair of dimensions",
    "sobol": "one scrambled Sobol' set for all pixels, shifted per pixel",
    "halton": "the same with a scrambled Halton set"}
DEFAULTS = {"strategy": "mis-power", "pixel_sampler": "independent", "light_selection": "uniform",
            "ris_candidates": "8"}

# -- the --compare flags' rules ------------------------------------------------------------------
REF_STRATEGY, REF_SPP = "mis-power", 256
#: single-render flags (dest -> flag) that do not go with --compare, and why
NOT_WITH_COMPARE = {"strategy": ("--strategy", "--compare lists the strategies"),
                    "stderr_out": ("--stderr-out", "it writes one figure, not an image per strategy"),
                    "checkpoint": ("--checkpoint", "the compared renders are not checkpointed"),
                    "scheduler": ("--scheduler", "the compared renders run in local processes, see --workers")}
#: flags that only mean something with --compare (dest -> flag)
NEED_COMPARE = {"equal_time": "--equal-time", "equal_cost": "--equal-cost", "cost_weights": "--cost-weights",
                "reference_spp": "--reference-spp"}


@dataclasses.dataclass
class RenderSettings:
    """Every flag of one ``vrlab render`` command as a checked value, the scene loaded and
    sized, the reference read.  ``None`` for what was not given (the scene's or the
    renderer's default applies); the ``--gradient-domain`` fields are filled in by
    :func:`vrlab.cli_gradient.check_gradient`."""

    path: Path
    scene: Any
    strategy: str
    pixel_sampler: str
    light_selection: str
    spp: int
    seed: int
    emitter_samples: int | None
    bsdf_samples: int | None
    ris_candidates: int
    workers: int | None
    spp_batch: int | None
    exposure: float
    exposure_auto: bool
    output: Path | None
    stderr_out: Path | None
    checkpoint: Path | None
    scheduler: str | None
    reference_path: Path | None
    reference: Any
    show_progress: bool
    json: bool
    kernels: str = "auto"
    compare: list[str] | None = None
    equal_time: bool = False
    equal_cost: bool = False
    cost_weights: dict | None = None
    reference_spp: int | None = None
    # --gradient-domain
    alpha: float | None = None
    norm: str | None = None
    common: bool = True
    files: dict = dataclasses.field(default_factory=dict)

    def sampling(self) -> dict:
        """The keyword arguments every render of this command shares (``render``, ``compare``,
        ``render_gradient_domain``)."""
        return {"points": self.pixel_sampler, "light_selection": self.light_selection,
                "emitter_samples": self.emitter_samples, "bsdf_samples": self.bsdf_samples,
                "ris_candidates": self.ris_candidates, "spp_batch": self.spp_batch}

    def plan(self, strategy: str | None = None, spp: int | None = None, workers: int | None = None):
        """The :class:`vrlab.render.RenderPlan` of this command (``strategy``, ``spp``: another
        strategy or spp than the command's, for ``--compare``; ``workers``: default
        :meth:`resolved_workers`): every render setting resolved and checked once."""
        from .render import plan

        return plan(self.scene, self.spp if spp is None else spp, strategy or self.strategy,
                    workers=self.resolved_workers() if workers is None else workers, kernels=self.kernels,
                    **self.sampling())

    def resolved_workers(self) -> int:
        """``workers``, or the CPUs available when none was given."""
        if self.workers is None:
            from .render.film import default_workers
            return default_workers()
        return self.workers


class Phase:
    """A step that may be slow, said on stderr when ``show`` and only once it has taken ``after``
    seconds: ``vrlab render: <label> ...``, then at :meth:`stop` ``vrlab render: <label>: done
    after X.X s`` (a quicker step prints nothing).  A timer thread prints the first line;
    :meth:`stop` cancels it and may be called more than once.  Also a context manager."""

    def __init__(self, show: bool, label: str, after: float = 1.0, prefix: str = "vrlab render"):
        self.show, self.label, self.after, self.prefix = bool(show), label, float(after), prefix
        self._lock = threading.Lock()
        self._timer: threading.Timer | None = None
        self._said = self._stopped = False
        self._t0 = 0.0

    def start(self) -> "Phase":
        if self.show:
            self._t0 = time.perf_counter()
            self._timer = threading.Timer(self.after, self._say)
            self._timer.daemon = True
            self._timer.start()
        return self

    @property
    def said(self) -> bool:
        """Whether the first line was printed (the step took longer than ``after``)."""
        return self._said

    def _say(self) -> None:
        with self._lock:
            if not self._stopped:
                print(f"{self.prefix}: {self.label} ...", file=sys.stderr, flush=True)
                self._said = True

    def stop(self) -> None:
        with self._lock:
            first, self._stopped = not self._stopped, True
            said = self._said
        if self._timer is not None:
            self._timer.cancel()
        if first and said:
            print(f"{self.prefix}: {self.label}: done after {time.perf_counter() - self._t0:.1f} s", file=sys.stderr,
                  flush=True)

    def __enter__(self) -> "Phase":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


def progress_callback(show: bool, label: str, first: Callable[[], None] | None = None
                      ) -> Callable[[int, int], None] | None:
    """``progress(done, total)`` for a render (pixel samples done of the total), drawing a
    progress bar on stderr labelled ``label`` that counts samples, in samples/s (made on the
    first report, which knows the total, after calling ``first()``, e.g. a :class:`Phase`'s
    ``stop``); None if not ``show``."""
    if not show:
        return None

    bar: list = []
    start = time.time()          # the render starts now; the bar is made at its first report

    def progress(done, total):
        if not bar:
            if first is not None:
                first()
            from .lab.progress import ProgressBar
            bar.append(ProgressBar(total, label=label, unit="samples", start=start))
        bar[0].update(done - bar[0].done)
    return progress


def _compare_flags(args: argparse.Namespace, strategies) -> dict:
    """``{"compare": names or None, "equal_time", "equal_cost", "cost_weights", "reference_spp"}``;
    usage errors (see
    :mod:`vrlab.cli_compare`) before the defaults of the single-render flags are filled in."""
    def given(key):
        return getattr(args, key, None) not in (None, False)

    if args.compare is None:
        for key, flag in NEED_COMPARE.items():
            if given(key):
                raise A.UsageError(f"{flag} needs --compare")
        return {"compare": None, "equal_time": False, "equal_cost": False, "cost_weights": None,
                "reference_spp": None}
    for key, (flag, why) in NOT_WITH_COMPARE.items():
        if given(key):
            raise A.UsageError(f"{flag} does not apply with --compare ({why})")
    if given("reference") and given("reference_spp"):
        raise A.UsageError("--reference-spp does not apply with --reference (the reference is the file given)")
    weights = None
    if given("cost_weights"):
        if not args.equal_cost:
            raise A.UsageError("--cost-weights needs --equal-cost (the weights rank the strategies at equal cost)")
        from .render.cost import parse_cost_weights
        try:
            weights = parse_cost_weights(args.cost_weights, "--cost-weights")
        except ValueError as exc:
            raise A.UsageError(str(exc)) from None
    return {"compare": A.names(args.compare, "--compare", strategies), "equal_time": args.equal_time,
            "equal_cost": args.equal_cost, "cost_weights": weights,
            "reference_spp": A.integer(args.reference_spp, "--reference-spp", low=1, high=SPP_MAX) or REF_SPP}


def scene_path(text: str | None) -> Path:
    """The scene argument as a path: a file, or a built-in scene's XML."""
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


def defines(items: list[str] | None) -> dict[str, str]:
    """The ``-D NAME=VALUE`` flags as ``{NAME: VALUE}`` (Mitsuba's ``-D``; the value is the
    text after the first ``=``, substituted for ``$NAME`` as it is).  A flag without ``=``,
    with a name that is not letters, digits and _ (not starting with a digit), or a name
    given twice is a usage error naming -D."""
    out: dict[str, str] = {}
    for item in items or ():
        name, eq, value = item.partition("=")
        name = name.strip()
        if not eq:
            raise A.UsageError(f"-D: expected NAME=VALUE (e.g. -D spp=64), got {item!r}")
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
            raise A.UsageError(f"-D: {name!r} in {item!r} is not a parameter name (letters, digits and _, "
                               "not starting with a digit)" if name else f"-D: empty parameter name in {item!r}")
        if name in out:
            raise A.UsageError(f"-D: the parameter {name!r} is given twice ({out[name]!r} and {value!r})")
        out[name] = value
    return out


def _load(path: Path, params: dict[str, str] | None = None):
    from .render import SceneError, load_scene

    try:
        return load_scene(path, params=params or None)
    except SceneError as exc:
        text = str(exc).replace(": params: ", ": -D: ", 1).replace("(from params)", "(from -D)")
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


def _unused_flags(given: set, strategies: list) -> None:
    """Warn (on stderr, "vrlab render: warning: ...") about a sampling flag that none of
    ``strategies`` reads (the registry's ``Recipe.uses``): ``--ris-candidates`` without ``ris``..."""
    from .estimators.registry import recipes

    table = recipes("render")
    for key in sorted(given):
        if not any(key in table[s].uses for s in strategies if s in table):
            flag = "--" + key.replace("_", "-")
            users = [n for n, r in table.items() if key in r.uses]
            warnings.warn(f"{flag} does not apply to {', '.join(strategies)} (it is read by {', '.join(users)}); "
                          "ignored", UserWarning, stacklevel=3)


def settings_from_args(args: argparse.Namespace) -> RenderSettings:
    """Every flag of ``vrlab render`` as a value, the scene loaded and sized, the reference
    read (see :mod:`vrlab.cli_render`); raises :class:`~vrlab.cli_args.UsageError` or
    :class:`~vrlab.cli_args.Failure` before any work."""
    from .render.presets import PRESETS

    cmp = _compare_flags(args, tuple(PRESETS))
    compare = cmp["compare"] is not None
    given_flags = {key for key in ("emitter_samples", "bsdf_samples", "ris_candidates", "light_selection")
                   if getattr(args, key) is not None}
    for key, value in DEFAULTS.items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    spp = A.integer(args.spp, "--spp", low=1, high=SPP_MAX)
    width = A.integer(args.width, "--width", low=1, high=SIDE_MAX)
    height = A.integer(args.height, "--height", low=1, high=SIDE_MAX)
    seed = A.seed(args.seed)
    emitter_samples = A.integer(args.emitter_samples, "--emitter-samples", low=0, high=SAMPLES_MAX)
    bsdf_samples = A.integer(args.bsdf_samples, "--bsdf-samples", low=0, high=SAMPLES_MAX)
    ris_candidates = A.integer(args.ris_candidates, "--ris-candidates", low=1, high=RIS_MAX)
    workers = A.workers(args.workers)
    exposure_auto = str(args.exposure).strip().lower() == "auto"
    # a number for the figures of --compare / --gradient-domain (auto: 1.0 there)
    try:
        exposure = 1.0 if exposure_auto else A.real(args.exposure, "--exposure", low=0, low_open=True)
    except A.UsageError:
        raise A.UsageError(f"--exposure must be auto or a finite number > 0, got {args.exposure!r}") from None
    output = A.output_file(args.output, "-o/--output", FIGURE_SUFFIXES if compare else IMAGE_SUFFIXES)
    stderr_out = A.output_file(args.stderr_out, "--stderr-out", IMAGE_SUFFIXES)
    checkpoint = A.output_file(args.checkpoint, "--checkpoint", (".npz",))
    spp_batch = A.integer(args.spp_batch, "--spp-batch", low=1, high=SPP_MAX)
    A.distinct({"-o/--output": output, "--stderr-out": stderr_out, "--checkpoint": checkpoint})
    scheduler = A.scheduler_address(args.scheduler)
    if scheduler is not None and workers not in (None, 1):
        raise A.UsageError("--scheduler and --workers do not go together: the scheduler's workers render the "
                           "units (leave out --workers)")
    if (args.reference or "").lower().endswith(".exr") and importlib.util.find_spec("OpenEXR") is None:
        raise A.UsageError("--reference: reading .exr needs the OpenEXR package (pip install OpenEXR); use a .npy")
    ref_path = A.input_file(args.reference, "--reference", (".npy", ".exr"))
    params = defines(getattr(args, "defines", None))
    path = scene_path(args.scene)
    show = args.progress if args.progress is not None else sys.stderr.isatty()
    with Phase(show, f"loading {path.name}"):
        scene = _load(path, params)
    if width is not None or height is not None:
        scene = scene.with_size(width or scene.sensor.width, height or scene.sensor.height)
    spp = spp or scene.sensor.spp
    if stderr_out is not None and spp < 2:
        raise A.UsageError(f"--stderr-out needs --spp >= 2 (one sample has no standard error), got spp {spp}")
    given = {"--emitter-samples": emitter_samples is not None, "--bsdf-samples": bsdf_samples is not None}
    n_l = scene.integrator.emitter_samples if emitter_samples is None else emitter_samples
    n_b = scene.integrator.bsdf_samples if bsdf_samples is None else bsdf_samples
    for strategy in cmp["compare"] or [args.strategy]:
        _samples_for(strategy, n_l, n_b, given, "--compare" if compare else "--strategy")
    _unused_flags(given_flags, cmp["compare"] or [args.strategy])
    if not exposure_auto and not compare and not getattr(args, "gradient_domain", False) and (
            output is None or output.suffix.lower() != ".png"):
        warnings.warn("--exposure only scales .png images and the --compare / --gradient-domain figures; "
                      f"{'no image is saved' if output is None else output.suffix + ' is saved linear'}, unscaled",
                      UserWarning, stacklevel=2)
    reference = _reference(ref_path, (scene.sensor.height, scene.sensor.width, 3))
    return RenderSettings(path=path, scene=scene, strategy=args.strategy, pixel_sampler=args.pixel_sampler,
                          light_selection=args.light_selection, spp=spp, seed=seed, emitter_samples=emitter_samples,
                          bsdf_samples=bsdf_samples, ris_candidates=ris_candidates, workers=workers,
                          spp_batch=spp_batch, exposure=exposure, exposure_auto=exposure_auto, output=output,
                          stderr_out=stderr_out, checkpoint=checkpoint, scheduler=scheduler, reference_path=ref_path,
                          reference=reference, show_progress=bool(show), json=bool(args.json),
                          kernels=getattr(args, "kernels", "auto"), **cmp)
