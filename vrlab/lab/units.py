"""The lab's work units: one (estimator, integrand) job, the repetitions of one block, and
the per-job metadata of the result table (split from :mod:`vrlab.lab.runner`).

A unit runs repetitions ``reps`` of one (job, n), each from its own seed, the child
``(e, i, n, rep)`` of the run's root (see :mod:`vrlab.lab.runner`); it runs the same in this
process and in a worker, which rebuilds the job from its specs (received once per worker
process with the run's other specs, :func:`vrlab.execution.run_units`; recipe and catalogue
names are built once per worker process: :func:`_build_named`).
"""
from __future__ import annotations

import copy
import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._rng import unit_seed
from . import registry
from ._args import lab_integrand

__all__ = ["CORE_COLUMNS"]

CORE_COLUMNS = ["estimator", "integrand", "n", "rep", "value", "stderr", "exact", "error", "seconds",
                "n_evals", "n_units", "points", "class", "dim_u", "smooth"]


def _integrand(spec):
    return lab_integrand(spec, "integrands")


@dataclass
class _Job:
    """One (estimator, integrand) pair: specs to rebuild it in a worker, objects to run it here."""

    label: str
    est_spec: Any      # recipe name (str) or (estimator, points)
    int_spec: Any      # catalogue name (str) or Integrand
    estimator: Any
    points: Any
    integrand: Any


def _instantiate(est_spec, integrand):
    if isinstance(est_spec, str):
        return registry.build(est_spec, integrand)
    return est_spec


# -- the work ------------------------------------------------------------------------------------
def _unit_points(points, seed: np.random.SeedSequence):
    """The points of one unit: a randomised vrlab point set is re-randomised from the unit's
    seed (same class and settings: ``replicate``), so repetitions are independent and the
    numbers reproducible; any other engine instance is copied as it is (a deterministic set,
    or a SciPy engine, whose randomisation is fixed by the seed it was built with)."""
    from ..points import PointSet

    if isinstance(points, PointSet) and points.randomized:
        return points.replicate(1, rng=seed.spawn(1)[0])[0]
    return copy.deepcopy(points) if hasattr(points, "random") else points


def _one(estimator, integrand, points, n: int, seed: np.random.SeedSequence, chunk: int | None,
         label: str = "?"):
    pts = _unit_points(points, seed)
    kw = {} if chunk is None else {"chunk": chunk}
    try:
        est = estimator.estimate(integrand, n, rng=np.random.default_rng(seed), points=pts, **kw)
    except (TypeError, ValueError) as exc:     # say which unit failed, keep the kind of error
        kind = TypeError if isinstance(exc, TypeError) else ValueError
        raise kind(f"estimators: {label!r} on integrand {integrand.name!r} at n = {n}: {exc}") from exc
    value, stderr = est.value, est.stderr
    if np.ndim(value) != 0:
        raise ValueError(f"integrands: the lab runs scalar integrals; {integrand.name!r} gave a value of shape "
                         f"{np.shape(value)}")
    if not np.isfinite(value):
        raise ValueError(f"estimators: {label!r} on integrand {integrand.name!r} at n = {n} gave the non-finite "
                         f"estimate {float(value)}")
    return float(value), float(stderr), float(est.seconds), int(est.n_evals), int(est.n)


def _build(est_spec, int_spec) -> tuple:
    """(estimator, points, integrand) built from a recipe and an integrand spec."""
    integrand = _integrand(int_spec)
    return (*_instantiate(est_spec, integrand), integrand)


@functools.lru_cache(maxsize=64)
def _build_named(est_spec: str, int_spec: str) -> tuple:
    """:func:`_build` for recipe and catalogue names, memoised (a pure function of the names):
    a worker builds each pair once, not once per block."""
    return _build(est_spec, int_spec)


def _run_block(jobs: dict, task) -> list[tuple]:
    """Run repetitions ``reps`` of one (job, n): used both in-process and in workers.  ``jobs``:
    the run's jobs by key (a worker's: their specs, received once per worker process)."""
    ij, (entropy, spawn_key, pool_size), key, n, reps, chunk = task
    job = jobs[ij]
    if isinstance(job, tuple):        # in a worker: rebuild from specs
        label, est_spec, int_spec = job
        named = isinstance(est_spec, str) and isinstance(int_spec, str)
        estimator, points, integrand = (_build_named if named else _build)(est_spec, int_spec)
    else:
        label = job.label
        estimator, points, integrand = job.estimator, job.points, job.integrand
    root = np.random.SeedSequence(entropy, spawn_key=spawn_key, pool_size=pool_size)
    return [_one(estimator, integrand, points, n, unit_seed(root, *key, r), chunk, label) for r in reps]


def _points_name(points) -> str:
    if points is None:
        return "independent"
    if isinstance(points, str):
        return points
    if isinstance(points, type):
        return points.__name__.lower()
    return type(points).__name__.lower()


def _meta(job: _Job) -> dict:
    est, integrand = job.estimator, job.integrand
    exact = integrand.exact
    exact = float(exact) if exact is not None and np.ndim(exact) == 0 else float("nan")
    try:
        dim_u = int(est.dim_u(integrand))
    except (AttributeError, TypeError, ValueError, NotImplementedError):  # no fixed uniform dimension
        dim_u = -1
    meta = {"exact": exact, "points": _points_name(job.points), "class": type(est).__name__,
            "dim_u": dim_u, "smooth": registry.is_smooth(integrand)}
    try:
        params = est.get_params()
    except (AttributeError, TypeError):  # user objects without get_params
        params = {}
    for k, v in params.items():
        if isinstance(v, (bool, int, float, str, np.bool_, np.integer, np.floating)):
            col = k if k not in CORE_COLUMNS else f"param_{k}"
            meta[col] = v.item() if isinstance(v, np.generic) else v
    return meta
