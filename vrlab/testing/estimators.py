"""``check_estimator``: the common checks every estimator must pass (as scikit-learn's).

``check_estimator(estimator)`` runs, in order, and raises ``AssertionError`` whose message
starts with ``check_estimator[<check>]`` naming the first check that failed:

``protocol``    what the estimator overrides keeps the documented protocol (the core and the
                renderer's hooks, :mod:`vrlab.estimators.hooks`): methods their signatures,
                counts integers, flags bools, a spatial estimator its three ``spatial_*``;
``params``      settings only in ``__init__``: every constructor argument is stored under its
                name, ``get_params()`` round-trips through ``clone()`` (same ``repr``, same
                estimate for the same seed), and ``estimate`` changes no setting;
``pickle``      the estimator pickles and, unpickled in a process started with the *spawn*
                method (as the renderer's and the lab's workers may be), gives the same estimate;
``unbiased``    on closed-form integrands (``integrand`` if given, else the catalogue's
                ``sin``, ``smooth-2d`` and ``cos-hemisphere`` where the estimator applies), scalar
                and batched (two integrals at once, f and 2 f), |estimate - exact| / stderr < ``z``
                (default 5: a Bonferroni bound at about 1e-5 per check for a calibrated
                estimator; a weight off by a factor 2 or a dropped pdf is off by tens);
``fold``        for estimators with per-unit values: ``estimate()`` on an array of uniforms
                equals ``summarize(accumulate(unit_outputs(u)))`` of the same uniforms (the
                lab and the renderer run the same code);
``render``      where the estimator applies to the renderer's shading integrand: the
                closed-form scene (a Lambertian floor under a rectangular light, exact by
                Lambert's polygon formula) renders its exact radiance (image mean per
                channel, |z| < ``z``);
``dimension``   a distribution of the wrong dimension (a 3-D ``UniformSphere`` for a 1-D
                integrand) put in place of the estimator's distribution is refused with a
                ``ValueError``/``TypeError``, not silently used.

Checks that do not apply (no closed-form integrand fits, no distribution setting, no
per-unit values) are skipped; ``check_estimator`` returns ``{check: "ok" | "skipped: why"}``.
"""
from __future__ import annotations

import inspect
import multiprocessing as mp
import pickle
import re
import sys
import warnings
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any

import numpy as np

from .closed_form import CLOSED_FORM_RADIANCE, FOOTPRINT_TOL, closed_form_scene
from .main_guard import main_guard_advice, unguarded_main_script

__all__ = ["check_estimator", "closed_form_scene", "CLOSED_FORM_RADIANCE"]

DEFAULT_INTEGRANDS = ("sin", "smooth-2d", "cos-hemisphere")
N_UNITS = 1 << 14            # sample units per unbiasedness check

# -- helpers ----------------------------------------------------------------------------------------
def _fail(check: str, message: str) -> AssertionError:
    return AssertionError(f"check_estimator[{check}]: {message}")


def _plain_repr(text: str) -> str:
    """A repr without memory addresses (functions print theirs)."""
    return re.sub(r" at 0x[0-9a-fA-F]+", "", text)


def _same(a: Any, b: Any) -> bool:
    return bool(np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True))


def _batched(integrand):
    """Two integrals at once: f and 2 f (batch axis first), exact (I, 2 I), same techniques."""
    from ..integrands import Integrand

    f = integrand

    def pair(x):
        v = f(x)
        return np.stack([v, 2.0 * v])
    return Integrand(pair, integrand.domain, [integrand.exact, 2.0 * integrand.exact], f"{integrand.name} x (1, 2)",
                     techniques=integrand.techniques, controls=integrand.controls, targets=integrand.targets)


def _applies(estimator, integrand) -> str | None:
    """None if the estimator can run on the integrand, else why not."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            estimator.check(integrand)
            estimator.dim_u(integrand)
    except (ValueError, TypeError) as exc:
        return str(exc)
    return None


def _n_for(estimator) -> int:
    return N_UNITS * max(1, int(estimator.evals_per_unit))


def _estimate(estimator, integrand, seed: int, points: Any = None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return estimator.estimate(integrand, _n_for(estimator), rng=seed, points=points)


def _spawn_estimate(payload: bytes, name: str | None, n: int, seed: int, points: Any):
    """In a spawned process: unpickle the estimator and estimate catalogue integrand ``name``."""
    est = pickle.loads(payload)
    if name is None:
        return repr(est), None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        e = est.estimate(name, n, rng=seed, points=points)
    return repr(est), (e.value, e.stderr)


_POOL: ProcessPoolExecutor | None = None


def _spawn_pool() -> ProcessPoolExecutor:
    """One spawned worker process, started once and reused by every check (it dies with this process)."""
    global _POOL
    if _POOL is None:
        import os

        from ..execution import worker_init      # it ends with this process, however this one ends
        _POOL = ProcessPoolExecutor(1, mp_context=mp.get_context("spawn"), initializer=worker_init,
                                    initargs=(os.getpid(),))
    return _POOL


def _drop_pool() -> None:
    """Forget a broken pool (its worker died), so that the next check starts a new one."""
    global _POOL
    if _POOL is not None:
        _POOL.shutdown(wait=False, cancel_futures=True)
    _POOL = None


# -- the checks --------------------------------------------------------------------------------------
def _check_protocol(est) -> str:
    from ..estimators.hooks import protocol_problems

    if bad := protocol_problems(est):
        raise _fail("protocol", f"{type(est).__name__} breaks the estimator protocol: {'; '.join(bad)}")
    return "ok"


def _check_params(est, integrand, points) -> str:
    sig = inspect.signature(type(est).__init__)
    names = [k for k, p in sig.parameters.items()
             if k != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
    params = est.get_params()
    missing = [k for k in names if k not in params]
    if missing:
        raise _fail("params", f"{type(est).__name__}.__init__ arguments {missing} are not stored under their "
                              "names (get_params cannot see them; store each setting as self.<name>)")
    try:
        twin = est.clone()
    except Exception as exc:  # noqa: BLE001 - any failure is the finding
        raise _fail("params", f"clone() failed: {type(exc).__name__}: {exc}") from None
    if repr(twin) != repr(est):
        raise _fail("params", f"clone() gives {twin!r}, not {est!r}")
    before = repr(est)
    if integrand is not None:
        a, b = _estimate(est, integrand, 7, points), _estimate(twin, integrand, 7, points)
        if not (_same(a.value, b.value) and _same(a.stderr, b.stderr)):
            raise _fail("params", f"a clone gives another estimate for the same seed ({a.value} vs {b.value}): "
                                  "state outside the settings")
    if repr(est) != before:
        raise _fail("params", f"estimate() changed the settings: {before} became {est!r}")
    return "ok"


def _check_pickle(est, integrand, points, spawn: bool) -> str:
    try:
        payload = pickle.dumps(est)
        back = pickle.loads(payload)
    except Exception as exc:  # noqa: BLE001
        raise _fail("pickle", f"{est!r} does not pickle ({type(exc).__name__}: {exc}); define the functions "
                              "it holds at module level, not as lambdas or closures") from None
    if _plain_repr(repr(back)) != _plain_repr(repr(est)):
        raise _fail("pickle", f"unpickled as {back!r}, not {est!r}")
    if not spawn:
        return "ok (in process)"
    from ..integrands import CATALOGUE

    script = unguarded_main_script(type(est))
    if script is not None:
        raise _fail("pickle", main_guard_advice(type(est), script))
    name = integrand.name if integrand is not None and integrand.name in CATALOGUE else None
    try:
        text, got = _spawn_pool().submit(_spawn_estimate, payload, name, _n_for(est), 11, points).result(timeout=120)
    except BrokenProcessPool as exc:
        _drop_pool()
        main = sys.modules.get("__main__")
        path = getattr(main, "__file__", None)
        if type(est).__module__ == "__main__" and path:
            raise _fail("pickle", f"the spawned process died ({exc}), most likely while running the main script "
                                  f"again to find {type(est).__name__}: " + main_guard_advice(type(est), path)) from None
        raise _fail("pickle", f"the spawned process checking {est!r} died ({exc})") from None
    except Exception as exc:  # noqa: BLE001
        where = ("it is defined in an interactive session or notebook cell, which a spawned process cannot "
                 "import: define it in a module" if type(est).__module__ == "__main__"
                 else "its class must be importable by module path")
        raise _fail("pickle", f"{est!r} cannot be used in a process started with the spawn method "
                              f"({type(exc).__name__}: {exc}); {where}") from None
    if _plain_repr(text) != _plain_repr(repr(est)):
        raise _fail("pickle", f"a spawned process sees {text}, not {est!r}")
    if got is not None:
        mine = _estimate(est, integrand, 11, points)
        if not (_same(got[0], mine.value) and _same(got[1], mine.stderr)):
            raise _fail("pickle", f"a spawned process estimates {got[0]}, this one {mine.value}, for the same seed")
    return "ok"


def _check_unbiased(est, integrands: list, points, z: float) -> str:
    for integrand in integrands:
        for case in (integrand, _batched(integrand)):
            e = _estimate(est, case, 3, points)
            exact = np.asarray(case.exact, float)
            value, stderr = np.asarray(e.value, float), np.asarray(e.stderr, float)
            if value.shape != exact.shape:
                raise _fail("unbiased", f"on {case.name!r} the estimate has shape {value.shape}, the integral "
                                        f"{exact.shape}")
            if not (np.all(np.isfinite(value)) and np.all(np.isfinite(stderr)) and np.all(stderr >= 0)):
                raise _fail("unbiased", f"on {case.name!r}: estimate {value}, stderr {stderr} (not finite)")
            with np.errstate(divide="ignore", invalid="ignore"):
                scores = np.abs(value - exact) / np.maximum(stderr, 1e-12 * np.maximum(np.abs(exact), 1.0))
            if np.any(scores > z):
                raise _fail("unbiased", f"on {case.name!r} the estimate {value} is {float(np.max(scores)):.1f} "
                                        f"standard errors from the exact {exact} (allowed {z})")
    return "ok"


def _check_fold(est, integrand) -> str:
    from ..estimators.base import Estimator

    if not est.per_unit or type(est).unit_outputs is Estimator.unit_outputs and \
            type(est).unit_values is Estimator.unit_values:
        return "skipped: no per-unit values (the estimator overrides estimate only)"
    m = max(N_UNITS // 4, 2 * int(est.min_units))
    u = np.random.default_rng(5).random((m, int(est.unit_dim(integrand))))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        e = est.estimate(integrand, m * int(est.evals_per_unit), points=u)
        value, stderr = est.summarize(est.accumulate(est.unit_outputs(integrand, u)))
    if not (np.allclose(e.value, value, rtol=1e-10, atol=0) and np.allclose(e.stderr, stderr, rtol=1e-10, atol=0)):
        raise _fail("fold", f"estimate() gives {e.value} ± {e.stderr}, summarize(accumulate(unit_outputs)) of the "
                            f"same uniforms {value} ± {stderr}: estimate must fold through accumulate/summarize")
    return "ok"


def _check_render(est, z: float) -> str:
    from ..estimators.base import Estimator

    if not est.per_unit or type(est).unit_values is Estimator.unit_values:
        return "skipped: no per-unit values (the renderer runs one unit per shading point)"
    from ..render import render

    scene = closed_form_scene()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            render(scene, max(1, int(est.min_units)), est, rng=0, width=2, height=2)
    except (ValueError, TypeError) as exc:
        return f"skipped: does not apply to the shading integrand ({exc})"
    spp = max(64, 256 // max(1, int(est.evals_per_unit)), int(est.min_units))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        img = render(scene, spp, est, rng=1)
    value = np.asarray(img.value, float).reshape(-1, 3)
    se = np.asarray(img.stderr, float).reshape(-1, 3)
    mean = value.mean(0)
    # a spatial estimator's pixels are correlated (samples reused between neighbours): the
    # image mean's standard error is then bounded by the pixels' mean one (Minkowski), not pooled
    se_mean = se.mean(0) if est.spatial else np.sqrt(np.sum(se**2, 0)) / len(value)
    tol = np.sqrt(se_mean**2 + (FOOTPRINT_TOL * CLOSED_FORM_RADIANCE) ** 2)
    scores = np.abs(mean - CLOSED_FORM_RADIANCE) / tol
    if not np.all(np.isfinite(scores)) or np.any(scores > z):
        raise _fail("render", f"the closed-form scene renders {np.round(mean, 5).tolist()} where the exact radiance "
                              f"is {np.round(CLOSED_FORM_RADIANCE, 5).tolist()} ({float(np.max(scores)):.1f} "
                              f"standard errors, allowed {z})")
    return "ok"


_DIST_PARAMS = ("distribution", "distributions", "source", "nominal")


def _check_dimension(est) -> str:
    from ..distributions import UniformSphere
    from ..integrands import get

    params = est.get_params()
    wrong = {}
    for k, v in params.items():
        is_dist = all(hasattr(v, a) for a in ("dim_u", "sample", "pdf"))
        many = isinstance(v, (list, tuple)) and v and all(
            isinstance(d, str) or all(hasattr(d, a) for a in ("dim_u", "sample", "pdf")) for d in v)
        if is_dist or (k in _DIST_PARAMS and (v is None or isinstance(v, str))):
            wrong[k] = UniformSphere()
        elif many:
            wrong[k] = [UniformSphere() for _ in v]
    if not wrong:
        return "skipped: no distribution setting"
    try:
        bad = type(est)(**{**params, **wrong})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            bad.estimate(get("sin"), _n_for(est) // 16, rng=0)
    except (ValueError, TypeError):
        return "ok"
    except Exception as exc:  # noqa: BLE001
        raise _fail("dimension", f"a 3-D distribution for a 1-D integrand raised {type(exc).__name__}: {exc} "
                                 "instead of a ValueError/TypeError naming the argument") from None
    raise _fail("dimension", f"{type(est).__name__} with {', '.join(wrong)} = UniformSphere() (3-D points) ran on "
                             "a 1-D integrand without an error")


def check_estimator(estimator, integrand=None, *, points: Any = None, z: float = 5.0, spawn: bool = True,
                    render: bool = True) -> dict[str, str]:
    """Run the common checks (module docstring) on ``estimator``; ``AssertionError`` naming the
    first failed check, else ``{check: "ok" | "skipped: why"}``.

    ``integrand``: the closed-form integrand the estimator was built for (an ``Integrand``
    with ``exact``, or a catalogue name); default: the catalogue integrands it applies to.
    ``points``: the point set its estimates use (a recipe's); ``z``: the allowed |z-score|;
    ``spawn=False`` checks pickling in this process only; ``render=False`` skips the scene.
    """
    from ..estimators.base import Estimator
    from ..integrands import as_integrand

    if not isinstance(estimator, Estimator):
        raise TypeError(f"estimator: expected a vrlab.estimators.Estimator, got {type(estimator).__name__}")
    if integrand is not None:
        integrands = [as_integrand(integrand)]
        why = _applies(estimator, integrands[0])
        if why is not None:
            raise _fail("unbiased", f"does not apply to the given integrand {integrands[0].name!r}: {why}")
    else:
        integrands = [as_integrand(n) for n in DEFAULT_INTEGRANDS]
        integrands = [i for i in integrands if _applies(estimator, i) is None]
    integrands = [i for i in integrands if i.exact is not None]
    first = integrands[0] if integrands else None
    out = {"protocol": _check_protocol(estimator), "params": _check_params(estimator, first, points),
           "pickle": _check_pickle(estimator, first, points, spawn)}
    out["unbiased"] = (_check_unbiased(estimator, integrands, points, z) if integrands
                       else "skipped: applies to no closed-form integrand")
    out["fold"] = _check_fold(estimator, first) if first is not None and points is None else \
        "skipped: no integrand" if first is None else "skipped: the recipe's own point set"
    out["render"] = _check_render(estimator, z) if render else "skipped: render=False"
    if all(v.startswith("skipped") for k, v in out.items() if k in ("unbiased", "render")):
        raise _fail("unbiased", f"{estimator!r} applies to none of the closed-form integrands "
                                f"({', '.join(DEFAULT_INTEGRANDS)}) nor to the closed-form scene: pass the "
                                "integrand it is built for")
    out["dimension"] = _check_dimension(estimator)
    return out
