"""Strategy comparisons: the Veach figure (BSDF sampling | light sampling | MIS).

``compare(scene, strategies, spp)`` renders the scene once per strategy, all with the
same seed and the same sampling settings (``points``, ``light_selection``,
``emitter_samples``, ``bsdf_samples``, ``ris_candidates``, ``spp_batch``, ``workers``:
those of :func:`vrlab.render.render`), and reports each image's relMSE against a
reference: the ``reference`` image if one is given, else a ``ref_strategy`` render at
``ref_spp`` (i.i.d. points, the scene's sample counts, the given light selection, its
own seed ``[rng, 1]``: independent of the compared images).  ``compare_figure`` draws
the panels with the relMSE under each.

Equal spp by default.  With ``equal_time=True`` each strategy s gets
spp_s = max(1, round(spp x c_last / c_s)), at most ``MAX_SPP``, where c is a fixed cost
model of one pixel sample in traced-ray units (:func:`sample_cost`), so the *last*
strategy (MIS in the Veach order) keeps ``spp`` and the others get its modelled cost:
the comparison that counts, error at equal cost (Veach 1997, ch. 9).  No clock is read,
so the same call gives the same spp and images every time::

    c = CAMERA_COST + units x (rays + CANDIDATE_COST x m) + [control] (CONTROL_COST + CONTROL_COST_PER_LIGHT x lights)

with ``units`` the estimator's units per shading point, ``rays`` its traced rays per
unit (``evals_per_unit``; a one-sample mixture traces its direction once per technique
to weigh it), m its RIS candidates (unshadowed: no ray) and, for a control variate, the
closed-form integral over the scene's lights at each shading point.  The constants were
fitted once to single-process timings of every preset on the built-in scenes; what the
model leaves out (scene-dependent ray and light-sampling costs) shows in the measured
seconds, which ``compare`` reports next to the spp.

Equal counted cost (``equal_cost=True``): the renders report what they did
(``Estimate.extra["cost"]``, :mod:`vrlab.render.cost`: rays by kind, BSDF and emitter
samples and evaluations, light-BVH walks), weighted by ``cost_weights`` (default
:data:`~vrlab.render.cost.DEFAULT_WEIGHTS`: 1 per ray, 0.1 per sample or evaluation, 0.25
per light-BVH walk) into a cost per pixel C_s = spp_s x (weighted cost per sample).  For an
unbiased estimator relMSE falls as 1 / spp, so relMSE x C_s does not depend on spp: the
strategy with the smallest relMSE x C_s has the smallest error at equal counted cost,
whatever machine or kernels ran it.  It is reported next to relMSE x seconds (the same
efficiency at equal measured time), with each strategy's ratio to the best and the ranking::

    efficiency_s = relMSE_s x spp_s x sum_k w_k n_k,s / samples_s

``progress(name, done, total)``, if given, is called as each render advances (``name``:
the strategy, or ``"reference"``).  Checked before any rendering: ``strategies`` a
non-empty list of distinct strategy names (the presets, :data:`vrlab.render.PRESETS`),
``spp``/``ref_spp`` integers >= 1, ``rng`` an integer >= 0, ``reference`` a finite image
of the scene's shape, ``equal_time`` a bool, ``progress`` callable, and every render's
settings (as :func:`vrlab.render.render` checks them); ``compare_figure`` checks the
result dict, the path (suffix and folder) and ``exposure``.
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from .. import checks
from .film import MAX_SPP, _as_scene, render
from .planning import default_workers, plan
from .image import _image, auto_exposure, rel_mse, srgb_encode
from .cost import Cost, cost_weights as _cost_weights
from .pixels import PixelIntegrand
from .presets import PRESETS
from .scene import Scene

__all__ = ["VEACH_STRATEGIES", "bias_status", "compare", "compare_figure", "equal_cost_table", "panels_figure",
           "sample_cost"]

VEACH_STRATEGIES = ("bsdf", "light", "mis-power")
#: the cost model of ``equal_time`` (see the module docstring), in traced rays per pixel sample
CAMERA_COST = 1.0              # the camera ray and the pixel's bookkeeping
CANDIDATE_COST = 0.5           # one RIS candidate: a light sample and its unshadowed target, no ray
CONTROL_COST = 2.0             # a control variate's closed form at a shading point ...
CONTROL_COST_PER_LIGHT = 1 / 16  # ... and per light of the scene


def _cost(integrand: PixelIntegrand) -> float:
    est = integrand.estimator        # the estimator protocol (vrlab.estimators.Estimator) gives the costs
    cost = CAMERA_COST + integrand.units * (est.traced_per_unit() + CANDIDATE_COST * est.candidates_per_unit)
    if est.closed_form_per_unit:
        lights = integrand.lighting.lights
        cost += CONTROL_COST + CONTROL_COST_PER_LIGHT * (0 if lights is None else len(lights.lights))
    return float(cost)


def sample_cost(scene: Scene | str, strategy: str = "mis-power", **settings: Any) -> float:
    """The modelled cost of one pixel sample of ``strategy`` in traced rays (the module
    docstring's formula); ``settings``: ``light_selection``, ``emitter_samples``,
    ``bsdf_samples``, ``ris_candidates`` as for :func:`vrlab.render.render`."""
    strategy = checks.choice(strategy, "strategy", PRESETS)
    return _cost(PixelIntegrand(_as_scene(scene), strategy, **settings))


def _strategies(strategies: Any) -> list[str]:
    if isinstance(strategies, str) or not isinstance(strategies, Sequence):
        raise TypeError(f"strategies must be a list of strategy names, got {type(strategies).__name__}")
    strategies = [checks.choice(s, f"strategies[{k}]", PRESETS) for k, s in enumerate(strategies)]
    if not strategies:
        raise ValueError(f"strategies: need at least one of {', '.join(PRESETS)}")
    if len(set(strategies)) != len(strategies):
        raise ValueError(f"strategies: each strategy at most once, got {strategies}")
    return strategies


def compare(scene: Scene, strategies: Sequence[str] = VEACH_STRATEGIES, spp: int = 16, *, rng: int = 0,
            reference: np.ndarray | None = None, ref_spp: int = 256, ref_strategy: str = "mis-power",
            equal_time: bool = False, points: Any = None, light_selection: str = "uniform",
            emitter_samples: int | None = None, bsdf_samples: int | None = None, ris_candidates: int = 8,
            workers: int | None = 1, spp_batch: int | None = None,
            progress: Callable[[str, int, int], None] | None = None, kernels: str = "auto",
            equal_cost: bool = False, cost_weights: dict | None = None) -> dict:
    """Render ``scene`` with each strategy; ``{"images", "seconds", "rel_mse", "reference",
    "spp", "cost", "counted", "reference_render", "settings"}``: ``spp`` an int (equal spp) or
    a dict per strategy (equal time), ``cost`` the modelled cost per pixel sample of each
    strategy (:func:`sample_cost`), ``counted`` each render's counted cost
    (``Estimate.extra["cost"]`` with ``cost_weights``), ``reference_render`` None
    (``reference`` given) or the strategy, spp, seed and seconds of the reference render,
    ``settings`` the sampling settings used.  With ``equal_cost``, also ``"equal_cost"``:
    :func:`equal_cost_table` (the module docstring).  ``cost_weights``: weights by counter
    name or group (:func:`vrlab.render.cost.cost_weights`; None: the defaults).  ``scene``
    may be a path or a built-in name (as for ``render``); ``workers=None``: the CPUs
    available."""
    scene = _as_scene(scene)
    strategies = _strategies(strategies)
    spp = checks.integer(spp, "spp", low=1, high=MAX_SPP)
    ref_spp = checks.integer(ref_spp, "ref_spp", low=1, high=MAX_SPP)
    ref_strategy = checks.choice(ref_strategy, "ref_strategy", PRESETS)
    rng = checks.integer(rng, "rng", low=0)
    equal_time = checks.flag(equal_time, "equal_time")
    equal_cost = checks.flag(equal_cost, "equal_cost")
    weights = _cost_weights(cost_weights, "cost_weights")
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be a callable progress(name, done, total) or None, "
                        f"got {type(progress).__name__}")
    if reference is not None:
        reference = _image(reference, "reference", True)
        want = (scene.sensor.height, scene.sensor.width, 3)
        if reference.shape != want:
            raise ValueError(f"reference: shape {reference.shape} differs from the scene's image {want}")
    workers = default_workers() if workers is None else workers
    sampling = dict(light_selection=light_selection, emitter_samples=emitter_samples, bsdf_samples=bsdf_samples,
                    ris_candidates=ris_candidates)
    common = dict(points=points, workers=workers, spp_batch=spp_batch, kernels=kernels)
    # every render's plan is built, and so checked, before the first one runs
    plans = {s: plan(scene, spp, s, **common, **sampling) for s in strategies}
    cost = {s: _cost(p.integrand) for s, p in plans.items()}
    counts = {s: spp for s in strategies}
    if equal_time:
        counts = {s: int(min(MAX_SPP, max(1, round(spp * cost[strategies[-1]] / cost[s])))) for s in strategies}
        plans = {s: p if counts[s] == spp else plan(scene, counts[s], s, **common, **sampling) for s, p in plans.items()}
    ref_seed = np.random.SeedSequence([rng, 1])
    ref_plan = None if reference is not None else plan(scene, ref_spp, ref_strategy, light_selection=light_selection,
                                                       workers=workers, spp_batch=spp_batch, kernels=kernels)

    def report(name):
        return None if progress is None else (lambda done, total: progress(name, done, total))

    images, seconds, errors, counted, ref_info = {}, {}, {}, {}, None
    if reference is None:
        t0 = time.perf_counter()
        reference = render(ref_plan, rng=ref_seed, progress=report("reference")).value
        ref_info = {"strategy": ref_strategy, "spp": ref_spp, "seed": [rng, 1],
                    "seconds": time.perf_counter() - t0}
    for s in strategies:
        t0 = time.perf_counter()
        est = render(plans[s], rng=np.random.SeedSequence([rng, 0]), progress=report(s))
        images[s] = est.value
        seconds[s] = time.perf_counter() - t0
        errors[s] = rel_mse(images[s], reference)
        counted[s] = Cost(est.extra["cost"]["samples"], **est.extra["cost"]["totals"]).report(weights)
    settings = dict(points=points, workers=workers, spp_batch=spp_batch, seed=rng, kernels=kernels, **sampling)
    out = {"images": images, "seconds": seconds, "rel_mse": errors, "reference": reference,
           "spp": counts if equal_time else spp, "cost": cost, "counted": counted, "reference_render": ref_info,
           "settings": settings}
    if equal_cost:
        out["equal_cost"] = equal_cost_table(errors, seconds, counts, counted)
    return out


def equal_cost_table(rel_mse: dict, seconds: dict, spp: dict, counted: dict) -> dict:
    """Per strategy s (dicts keyed by strategy; ``counted[s]``: a cost report,
    :meth:`vrlab.render.cost.Cost.report`, whose ``weighted_per_sample`` is c_s):
    ``{"weights", "cost_per_pixel": spp_s c_s, "rel_mse_x_cost": relMSE_s spp_s c_s,
    "rel_mse_x_time": relMSE_s seconds_s, "cost_ratio" / "time_ratio": each over the
    smallest, "ranking": the strategies by relMSE x cost, best first}`` (module docstring)."""
    names = list(rel_mse)
    per_pixel = {s: spp[s] * counted[s]["weighted_per_sample"] for s in names}
    by_cost = {s: rel_mse[s] * per_pixel[s] for s in names}
    by_time = {s: rel_mse[s] * seconds[s] for s in names}

    def ratios(v: dict) -> dict:
        best = min(v.values())
        return {s: (x / best if best > 0 else float("nan")) for s, x in v.items()}

    return {"weights": dict(counted[names[0]]["weights"]), "cost_per_pixel": per_pixel, "rel_mse_x_cost": by_cost,
            "rel_mse_x_time": by_time, "cost_ratio": ratios(by_cost), "time_ratio": ratios(by_time),
            "ranking": sorted(names, key=lambda s: by_cost[s])}


def bias_status(strategy: str) -> str:
    """The bias status the registry states for render strategy ``strategy`` (``Recipe.bias``:
    "unbiased", "consistent" or "biased"); "bias unknown" for a name it does not know."""
    from ..estimators.registry import recipes

    recipe = recipes("render").get(strategy)
    return recipe.bias if recipe is not None else "bias unknown"


def compare_figure(result: dict, path: str | Path, *, title: str = "", exposure: float | str = "auto") -> Path:
    """Panels side by side, each labelled with its strategy, the strategy's bias status
    (:func:`bias_status`), relMSE and time (matplotlib, Agg); ``path``'s
    suffix picks the format (.png, .pdf, .svg, ...).  ``exposure``: one scale for every
    panel, ``"auto"`` (default): :func:`~vrlab.render.image.auto_exposure` of the reference."""
    keys = ("images", "seconds", "rel_mse", "reference", "spp")
    if not isinstance(result, dict) or any(k not in result for k in keys) or not result["images"]:
        raise ValueError(f"result must be the dict returned by compare() (keys {', '.join(keys)})")
    if not isinstance(path, (str, Path)):
        raise TypeError(f"path must be a file path, got {type(path).__name__}")
    path = Path(path)
    if path.suffix.lower().lstrip(".") not in ("png", "pdf", "svg", "jpg", "jpeg", "eps", "ps", "tif", "tiff", "webp"):
        raise ValueError(f"path: unknown figure format {path.suffix!r}; use .png, .pdf or .svg")
    if not path.parent.is_dir():
        raise ValueError(f"path: the folder {str(path.parent)!r} does not exist")
    auto = isinstance(exposure, str) and exposure == "auto"
    exposure = auto_exposure(result["reference"]) if auto else checks.real(exposure, "exposure", low=0, low_open=True)
    if not isinstance(title, str):
        raise TypeError(f"title must be a string, got {type(title).__name__}")
    names = list(result["images"])
    panels = []
    table = result.get("equal_cost")
    for name in names:
        each = f", {result['spp'][name]} spp" if isinstance(result["spp"], dict) else ""
        by_cost = "" if table is None else f"\nrelMSE x cost = {table['rel_mse_x_cost'][name]:.3g}"
        panels.append((f"{name} ({bias_status(name)})\nrelMSE = {result['rel_mse'][name]:.3g}, "
                       f"{result['seconds'][name]:.1f} s{each}{by_cost}",
                       result["images"][name]))
    equal = "equal modelled cost" if isinstance(result["spp"], dict) else f"{result['spp']} spp per strategy"
    shared = f"exposure: {'auto, ' if auto else ''}shared, x{exposure:.3g}"
    return panels_figure(panels, path, title=f"{title or equal} ({shared})", exposure=exposure)


def panels_figure(panels: Sequence[tuple[str, np.ndarray]], path: str | Path, *, title: str,
                  exposure: float) -> Path:
    """Linear images ``(label, (H, W, 3))`` side by side, each tone mapped with the one
    ``exposure`` (NaN shows black) and labelled below; written to ``path`` (matplotlib, Agg)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    h, w, _ = np.shape(panels[0][1])
    fig = Figure(figsize=(3.2 * len(panels), 3.2 * h / w + 1.2))
    FigureCanvasAgg(fig)
    for k, (label, img) in enumerate(panels):
        ax = fig.add_subplot(1, len(panels), k + 1)
        ax.imshow(srgb_encode(np.nan_to_num(np.asarray(img, float)) * exposure))
        ax.set_xticks([]), ax.set_yticks([])
        ax.set_xlabel(label, fontsize=9)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return Path(path)
