"""Run estimators x integrands x sample counts x repetitions into one tidy DataFrame.

Seeds.  One root ``SeedSequence(rng)``; the work unit (estimator, integrand, n, rep) draws
from ``SeedSequence(root.entropy, spawn_key=root.spawn_key + (e, i, n, rep))``, the child of
the spawn tree ``root -> e -> i -> n -> rep`` (NumPy ``SeedSequence``, "spawn_key"), where
``e`` and ``i`` are stable indices of the estimator label and the integrand name (CRC-32 of
the text), ``n`` the sample count and ``rep`` the repetition.  A unit's numbers therefore
depend only on the root seed and on what the unit is -- not on the order of execution,
on which worker runs it, or on which other estimators, integrands, counts or repetitions
are in the same run: ``workers=k`` gives bit-identical values to ``workers=1``, and
``run(["mc", "cv"], ...)`` gives "mc" the same numbers as ``run(["mc"], ...)``.  With
``crn=True`` the estimator index is left out (e = 0), so all estimators see the same seed
in the same (integrand, n, rep): common random numbers across estimators.
"""
from __future__ import annotations

import copy
import pickle
import sys
import time
import zlib
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from .._rng import unit_seed
from . import registry

CORE_COLUMNS = ["estimator", "integrand", "n", "rep", "value", "stderr", "exact", "error", "seconds",
                "n_evals", "n_units", "points", "class", "dim_u", "smooth"]


@dataclass
class _Job:
    """One (estimator, integrand) pair: specs to rebuild it in a worker, objects to run it here."""

    label: str
    est_spec: Any      # recipe name (str) or (estimator, points)
    int_spec: Any      # catalogue name (str) or Integrand
    estimator: Any
    points: Any
    integrand: Any


# -- inputs -------------------------------------------------------------------------------------
def _integrand(spec):
    if isinstance(spec, str):
        from ..integrands import get
        return get(spec)
    if not callable(spec) or not hasattr(spec, "dim"):
        raise TypeError(f"integrands: expected catalogue names or vrlab Integrand objects, got {spec!r}")
    return spec


def _estimator_specs(estimators) -> list[tuple[str, Any]]:
    """Normalise ``estimators`` to ``[(label, spec)]`` with spec a recipe name or (estimator, points)."""
    if isinstance(estimators, str) or (isinstance(estimators, tuple) and len(estimators) in (2, 3)
                                       and hasattr(estimators[1], "estimate")):
        estimators = [estimators]
    out = []
    for e in estimators:
        if isinstance(e, str):
            registry.get_recipe(e)          # unknown names fail here, before any work
            out.append((e.strip(), e.strip()))
        elif isinstance(e, tuple) and len(e) in (2, 3) and isinstance(e[0], str):
            est = e[1]
            if not callable(getattr(est, "estimate", None)):
                raise TypeError(f"estimators: {e[0]!r}: {est!r} has no estimate(integrand, n, ...)")
            out.append((e[0], (est, e[2] if len(e) == 3 else None)))
        else:
            raise TypeError("estimators: each item must be a recipe name or a tuple (label, estimator[, points]); "
                            f"got {e!r}")
    labels = [lab for lab, _ in out]
    dup = sorted({lab for lab in labels if labels.count(lab) > 1})
    if dup:
        raise ValueError(f"estimators: duplicate labels {dup}")
    return out


def _instantiate(est_spec, integrand):
    if isinstance(est_spec, str):
        return registry.build(est_spec, integrand)
    return est_spec


def _root(rng) -> np.random.SeedSequence:
    if isinstance(rng, np.random.SeedSequence):
        return rng
    if rng is None or isinstance(rng, (int, np.integer)):
        if rng is not None and rng < 0:
            raise ValueError(f"rng: a seed must be non-negative, got {rng}")
        return np.random.SeedSequence(rng)
    raise TypeError("rng: the lab needs a reproducible root: an int seed, a SeedSequence or None "
                    f"(fresh entropy, recorded in df.attrs['entropy']); got {type(rng).__name__}")


def stable_index(text: str) -> int:
    """A stable spawn-key index for a label or name: CRC-32 of its UTF-8 bytes."""
    return zlib.crc32(str(text).encode("utf-8"))


# -- the work ------------------------------------------------------------------------------------
def _one(estimator, integrand, points, n: int, seed: np.random.SeedSequence, chunk: int | None):
    pts = copy.deepcopy(points) if hasattr(points, "random") else points
    kw = {} if chunk is None else {"chunk": chunk}
    est = estimator.estimate(integrand, n, rng=np.random.default_rng(seed), points=pts, **kw)
    value, stderr = est.value, est.stderr
    if np.ndim(value) != 0:
        raise ValueError(f"the lab runs scalar integrals; {integrand.name!r} gave a value of shape {np.shape(value)}")
    return float(value), float(stderr), float(est.seconds), int(est.n_evals), int(est.n)


_WORKER_CACHE: dict = {}


def _run_block(task) -> list[tuple]:
    """Run repetitions ``reps`` of one (job, n): used both in-process and in workers."""
    job, (entropy, spawn_key, pool_size), key, n, reps, chunk = task
    if isinstance(job, tuple):        # in a worker: rebuild from specs (cached per process)
        label, est_spec, int_spec = job
        ck = (label, est_spec, int_spec) if isinstance(est_spec, str) and isinstance(int_spec, str) else None
        if ck is not None and ck in _WORKER_CACHE:
            estimator, points, integrand = _WORKER_CACHE[ck]
        else:
            integrand = _integrand(int_spec)
            estimator, points = _instantiate(est_spec, integrand)
            if ck is not None:
                _WORKER_CACHE[ck] = (estimator, points, integrand)
    else:
        estimator, points, integrand = job.estimator, job.points, job.integrand
    root = np.random.SeedSequence(entropy, spawn_key=spawn_key, pool_size=pool_size)
    return [_one(estimator, integrand, points, n, unit_seed(root, *key, r), chunk) for r in reps]


class ProgressBar:
    """A one-line text progress bar on ``stream`` (default stderr), redrawn at most 10 times a second."""

    def __init__(self, total: int, stream=None, width: int = 30, label: str = "lab"):
        self.total, self.width, self.label = max(int(total), 1), width, label
        self.stream = stream if stream is not None else sys.stderr
        self.done, self.t0, self._last = 0, time.perf_counter(), 0.0

    def update(self, k: int = 1) -> None:
        self.done += k
        now = time.perf_counter()
        if now - self._last >= 0.1 or self.done >= self.total:
            self._last = now
            frac = self.done / self.total
            fill = round(frac * self.width)
            elapsed = now - self.t0
            eta = elapsed / frac - elapsed if frac > 0 else float("nan")
            self.stream.write(f"\r{self.label} [{'#' * fill}{'.' * (self.width - fill)}] "
                              f"{self.done}/{self.total} {elapsed:5.1f} s, ~{eta:4.0f} s left ")
            if self.done >= self.total:
                self.stream.write("\n")
            self.stream.flush()


def run(estimators: Sequence, integrands: Iterable, ns: Iterable[int], reps: int, *, rng: Any = 0,
        progress: bool | Callable[[int, int], None] = False, workers: int = 1, skip: bool = False,
        crn: bool = False, chunk: int | None = None) -> pd.DataFrame:
    """Run every estimator on every integrand at every ``n`` (integrand evaluations), ``reps`` times.

    ``estimators``: recipe names (see :mod:`vrlab.lab.registry`) or tuples
    ``(label, estimator[, points])``.  ``integrands``: catalogue names or ``Integrand``
    objects.  ``rng``: root seed (int, ``SeedSequence`` or None).  ``workers``: processes
    (``concurrent.futures.ProcessPoolExecutor``); objects other than names must then be
    picklable.  ``skip``: leave out estimator x integrand pairs whose recipe does not
    apply (listed in ``df.attrs["skipped"]``) instead of raising.  ``progress``: a text
    bar on stderr, or a callback ``(done, total)``.

    Returns one row per estimator x integrand x n x rep with columns ``estimator,
    integrand, n, rep, value, stderr, exact, error (= value - exact), seconds, n_evals,
    n_units, points, class, dim_u, smooth`` and the estimator's scalar ``get_params()``.
    """
    specs = _estimator_specs(estimators)
    if isinstance(integrands, str) or hasattr(integrands, "dim"):
        integrands = [integrands]
    int_specs = list(integrands)
    ns = [int(n) for n in ([ns] if np.ndim(ns) == 0 else ns)]
    if not ns or min(ns) < 1:
        raise ValueError(f"ns: need positive sample counts, got {ns}")
    if isinstance(reps, bool) or not isinstance(reps, (int, np.integer)) or reps < 1:
        raise ValueError(f"reps must be a positive integer, got {reps!r}")
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    root = _root(rng)

    jobs: dict[tuple[int, int], _Job] = {}
    skipped: list[dict] = []
    seen: dict[str, int] = {}
    for jj, ispec in enumerate(int_specs):
        integrand = _integrand(ispec)
        if integrand.name in seen:
            raise ValueError(f"integrands: the name {integrand.name!r} occurs twice (names label rows and seeds)")
        seen[integrand.name] = jj
        for ii, (label, espec) in enumerate(specs):
            try:
                est, pts = _instantiate(espec, integrand)
            except ValueError as exc:
                if not skip:
                    raise
                skipped.append({"estimator": label, "integrand": integrand.name, "reason": str(exc)})
                continue
            jobs[ii, jj] = _Job(label, espec, ispec, est, pts, integrand)

    # blocks of repetitions: enough tasks to balance the workers, few enough to keep overhead low
    per = reps if workers == 1 else max(1, -(-reps // 4))
    seed_state = (root.entropy, tuple(root.spawn_key), root.pool_size)
    tasks = []
    keys = [stable_index(label) for label, _ in specs]
    if len(set(keys)) < len(keys):   # pragma: no cover - a CRC-32 collision between two labels
        raise ValueError("estimators: two labels share a seed index; rename one")
    if len(set(ns)) < len(ns):
        raise ValueError(f"ns: repeated sample counts {ns}")
    for (ii, jj), job in jobs.items():
        for kk, n in enumerate(ns):
            for lo in range(0, reps, per):
                key = (0 if crn else keys[ii], stable_index(job.integrand.name), n)
                tasks.append(((ii, jj, kk, lo), job, key, n, range(lo, min(lo + per, reps))))

    total = len(jobs) * len(ns) * reps
    bar = ProgressBar(total) if progress is True else None

    def tick(k):
        if bar is not None:
            bar.update(k)
        elif callable(progress):
            tick.done += k
            progress(tick.done, total)
    tick.done = 0

    results: dict[tuple, list] = {}
    if workers == 1 or len(tasks) <= 1:
        for tid, job, key, n, rr in tasks:
            results[tid] = _run_block((job, seed_state, key, n, rr, chunk))
            tick(len(rr))
    else:
        wire = {}
        for tid, job, *_ in tasks:
            if id(job) not in wire:
                wire[id(job)] = (job.label, job.est_spec, job.int_spec)
                try:
                    pickle.dumps(wire[id(job)])
                except (pickle.PicklingError, AttributeError, TypeError) as exc:
                    raise TypeError(f"workers > 1: cannot send {job.label!r} on {job.integrand.name!r} to a worker "
                                    f"process ({exc}); use recipe and catalogue names, picklable objects "
                                    "(module-level functions, no lambdas), or workers=1") from None
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = {pool.submit(_run_block, (wire[id(job)], seed_state, key, n, rr, chunk)): (tid, len(rr))
                       for tid, job, key, n, rr in tasks}
            for fut in as_completed(futures):
                tid, k = futures[fut]
                results[tid] = fut.result()
                tick(k)

    rows = []
    for tid, job, key, n, rr in tasks:
        meta = _meta(job)
        exact = meta.pop("exact")
        for r, (value, stderr, seconds, n_evals, n_units) in zip(rr, results[tid]):
            rows.append({"estimator": job.label, "integrand": job.integrand.name, "n": n, "rep": r,
                         "value": value, "stderr": stderr, "exact": exact, "error": value - exact,
                         "seconds": seconds, "n_evals": n_evals, "n_units": n_units, **meta})
    df = pd.DataFrame(rows, columns=None if rows else CORE_COLUMNS)
    df.attrs.update({"entropy": root.entropy, "spawn_key": tuple(root.spawn_key), "crn": crn,
                     "skipped": skipped})
    return df


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
