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

Execution.  The work units -- blocks of repetitions of one (estimator, integrand, n), at
most about ``UNIT_SAMPLES`` evaluations each -- go through :func:`vrlab.execution.run_units`:
in this process, in ``workers`` local processes, or on an ``executor`` (a process pool, a
Dask ``Client``); results are placed by their key, so the table is the same every way.
With ``store=`` each finished unit is written to SQLite at once (:mod:`vrlab.lab.store`)
and a rerun computes only the repetitions that are missing.

Arguments are checked before any work (errors name them): at least one estimator and one
integrand, known recipe and catalogue names, unique labels and names, sample counts
``ns`` integers in [1, ``MAX_N``] without repeats, ``reps`` in [2, ``MAX_REPS``],
``workers`` in [1, ``MAX_WORKERS``], flags ``True``/``False``.  An estimate that is NaN
or infinite stops the run with a ``ValueError`` naming the estimator and integrand.
"""
from __future__ import annotations

import numbers
import zlib
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np
import pandas as pd

from .. import checks, limits
from .._rng import unit_seed  # noqa: F401  (re-exported: tests, notebooks)
from ..execution import MAX_WORKERS, check_executor, check_picklable, parallelism, run_units
from . import registry
from ._args import flag, lab_integrand
from .progress import ProgressBar
from .units import CORE_COLUMNS, _instantiate, _Job, _meta, _points_name, _run_block  # noqa: F401
from .store import ResultStore, describe_estimator, describe_integrand, store_path

#: Largest sample count per estimate and repetitions of one ``run`` (worker processes:
#: ``vrlab.execution.MAX_WORKERS``).
MAX_N = limits.MAX_N          # vrlab.limits, shared with the CLI
MAX_REPS = limits.MAX_REPS
#: A work unit holds repetitions of one (estimator, integrand, n) up to about this many
#: evaluations, so that large-n sweeps balance over workers and resume unit by unit.
UNIT_SAMPLES = 2**22



# -- inputs -------------------------------------------------------------------------------------
def _integrand(spec):
    return lab_integrand(spec, "integrands")


def _items(value, name: str, what: str) -> list:
    """``value`` as a non-empty list (``TypeError`` unless it is iterable)."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise TypeError(f"{name} must be a list of {what}, got {checks.describe(value)}")
    items = list(value)
    if not items:
        raise ValueError(f"{name}: give at least one of {what} (got an empty list)")
    return items


def _estimator_specs(estimators) -> list[tuple[str, Any]]:
    """Normalise ``estimators`` to ``[(label, spec)]`` with spec a recipe name or (estimator, points)."""
    if isinstance(estimators, str) or (isinstance(estimators, tuple) and len(estimators) in (2, 3)
                                       and hasattr(estimators[1], "estimate")):
        estimators = [estimators]
    out = []
    for e in _items(estimators, "estimators", "recipe names or (label, estimator[, points]) tuples"):
        if isinstance(e, str):
            registry._split(e, "estimators")   # unknown names fail here, before any work
            out.append((e.strip(), e.strip()))
        elif isinstance(e, tuple) and len(e) in (2, 3) and isinstance(e[0], str):
            est = e[1]
            if not e[0].strip():
                raise ValueError(f"estimators: a label must be a non-empty string, got {e[0]!r}")
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


def _root(rng) -> np.random.SeedSequence:
    if isinstance(rng, np.random.SeedSequence):
        return rng
    if rng is None or (isinstance(rng, (int, np.integer)) and not isinstance(rng, (bool, np.bool_))):
        if rng is not None and rng < 0:
            raise ValueError(f"rng: a seed must be non-negative, got {rng}")
        return np.random.SeedSequence(rng)
    raise TypeError("rng: the lab needs a reproducible root: an int seed, a SeedSequence or None "
                    f"(fresh entropy, recorded in df.attrs['entropy']); got {type(rng).__name__}")


def stable_index(text: str) -> int:
    """A stable spawn-key index for a label or name: CRC-32 of its UTF-8 bytes."""
    return zlib.crc32(str(text).encode("utf-8"))


def run(estimators: Sequence, integrands: Iterable, ns: Iterable[int], reps: int, *, rng: Any = 0,
        progress: bool | Callable[[int, int], None] = False, workers: int = 1, skip: bool = False,
        crn: bool = False, chunk: int | None = None, executor: Any = None, store: Any = None,
        resumed: Callable[[int, int], None] | None = None) -> pd.DataFrame:
    """Run every estimator on every integrand at every ``n`` (integrand evaluations), ``reps`` times.

    ``estimators``: recipe names (see :mod:`vrlab.lab.registry`) or tuples
    ``(label, estimator[, points])``.  ``integrands``: catalogue names or ``Integrand``
    objects.  ``rng``: root seed (int, ``SeedSequence`` or None).  ``workers``: local
    processes (:func:`vrlab.execution.run_units`); ``executor``: run the units on a
    ``concurrent.futures.Executor`` or a ``dask.distributed.Client`` instead (``workers``
    is then unused); objects other than names must then be picklable (Dask: by cloudpickle).
    The numbers are the same for every choice.  ``store``: a ``.sqlite`` file
    (:mod:`vrlab.lab.store`) that keeps each finished unit; a rerun with the same store runs
    only what is missing and returns the same table (it needs a fixed ``rng``; a store of
    another sweep is refused with a ``ValueError`` naming ``store``).  ``skip``: leave out
    estimator x integrand pairs whose recipe does not apply (listed in
    ``df.attrs["skipped"]``) instead of raising.  ``progress``: True for a tqdm bar on
    stderr (shown when stderr is a terminal), or a callback ``(done, total)``.  ``resumed``:
    a callback ``(stored, total)``, called once before any unit runs when ``store`` already
    holds ``stored`` of the sweep's ``total`` units (estimator x integrand x n x rep).

    Returns one row per estimator x integrand x n x rep with columns ``estimator,
    integrand, n, rep, value, stderr, exact, error (= value - exact), seconds, n_evals,
    n_units, points, class, dim_u, smooth`` and the estimator's scalar ``get_params()``.
    """
    specs = _estimator_specs(estimators)
    if isinstance(integrands, str) or hasattr(integrands, "dim"):
        integrands = [integrands]
    int_specs = _items(integrands, "integrands", "catalogue names or Integrand objects")
    ns = _sample_counts(ns)
    reps = checks.integer(reps, "reps", low=2, high=MAX_REPS)
    workers = checks.integer(workers, "workers", low=1, high=MAX_WORKERS)
    skip, crn = flag(skip, "skip"), flag(crn, "crn")
    if not isinstance(progress, (bool, np.bool_)) and not callable(progress):
        raise TypeError(f"progress must be True, False or a callback (done, total), got {type(progress).__name__}")
    progress = bool(progress) if isinstance(progress, (bool, np.bool_)) else progress
    chunk = None if chunk is None else checks.integer(chunk, "chunk", low=1)
    if resumed is not None and not callable(resumed):
        raise TypeError(f"resumed must be a callback (stored, total) or None, got {type(resumed).__name__}")
    pool = check_executor(executor)
    if store is not None:
        store_path(store)
        if rng is None:
            raise ValueError("store: a resumable sweep needs a fixed seed; rng=None draws fresh entropy, "
                             "so a rerun could not continue it (give rng=<int>)")
    root = _root(rng)

    jobs: dict[tuple[int, int], _Job] = {}
    skipped: list[dict] = []
    seen: dict[str, int] = {}
    described = []
    for jj, ispec in enumerate(int_specs):
        integrand = _integrand(ispec)
        if integrand.name in seen:
            raise ValueError(f"integrands: the name {integrand.name!r} occurs twice (names label rows and seeds)")
        seen[integrand.name] = jj
        described.append(describe_integrand(ispec, integrand))
        for ii, (label, espec) in enumerate(specs):
            try:
                est, pts = _instantiate(espec, integrand)
            except ValueError as exc:
                if not skip:
                    raise ValueError(f"estimators: {label!r} does not apply to integrand {integrand.name!r}: {exc} "
                                     "(skip=True leaves such pairs out)") from None
                skipped.append({"estimator": label, "integrand": integrand.name, "reason": str(exc)})
                continue
            jobs[ii, jj] = _Job(label, espec, ispec, est, pts, integrand)

    keys = [stable_index(label) for label, _ in specs]
    if len(set(keys)) < len(keys):   # pragma: no cover - a CRC-32 collision between two labels
        raise ValueError("estimators: two labels share a seed index; rename one")
    if not jobs:
        raise ValueError("estimators, integrands: no estimator applies to any integrand; skipped: "
                         + "; ".join(f"{s['estimator']} on {s['integrand']}: {s['reason']}" for s in skipped))
    parallel = workers if pool is None else parallelism(pool)
    serial = pool is None and workers == 1
    wire = {} if serial else _wire_specs(jobs, pool)
    seed_state = (root.entropy, tuple(root.spawn_key), root.pool_size)
    est_ids = [describe_estimator(label, spec, "" if isinstance(spec, str) else _points_name(spec[1]))
               for label, spec in specs]
    settings = {"estimators": est_ids, "integrands": described, "ns": ns, "reps": reps, "crn": crn, "chunk": chunk,
                "skip": skip,
                "seed": {"entropy": root.entropy, "spawn_key": list(root.spawn_key), "pool_size": root.pool_size}}
    db = None if store is None else ResultStore(store, settings)
    bar = None
    try:
        results: dict[tuple, tuple] = {}
        if db is not None:
            stored = db.done()
            for (ii, jj), job in jobs.items():
                for n in ns:
                    for r in range(reps):
                        got = stored.get((job.label, job.integrand.name, n, r))
                        if got is not None:
                            results[ii, jj, n, r] = got
        # units: blocks of repetitions -- enough to balance the workers, small enough to resume
        # finely, few enough to keep the per-unit overhead low; the numbers do not depend on them
        tasks = []
        for (ii, jj), job in jobs.items():
            for n in ns:
                todo = [r for r in range(reps) if (ii, jj, n, r) not in results]
                per = max(1, min(reps if parallel == 1 else -(-reps // (4 * parallel)), UNIT_SAMPLES // n))
                for lo in range(0, len(todo), per):
                    key = (0 if crn else keys[ii], stable_index(job.integrand.name), n)
                    tasks.append(((ii, jj), key, n, tuple(todo[lo:lo + per])))

        total = len(jobs) * len(ns) * reps
        if results and resumed is not None:
            resumed(len(results), total)
        # the bar counts integrand evaluations (samples, in samples/s); a callable gets repetitions
        evals = len(jobs) * sum(ns) * reps
        bar = ProgressBar(evals, disable=None, unit="samples") if progress is True else None   # quiet off a terminal

        def tick(k, samples):
            if bar is not None:
                bar.update(samples)
            elif callable(progress):
                tick.done += k
                progress(tick.done, total)
        tick.done = 0
        if results:
            tick(len(results), sum(key[2] for key in results))

        fn = _run_block          # a local pool's processes tune their allocator (vrlab.execution.worker_init)
        # a unit carries the key of its job; the jobs (objects here, their specs for workers: a
        # user's integrand may hold large tables) reach each worker once, as run_units' shared input
        # units in flight: a few per worker; more on an executor, to hide its round trip (~ms)
        for i, out in run_units(fn, [((ij, seed_state, key, n, rr, chunk),) for ij, key, n, rr in tasks],
                                workers=workers, executor=pool, shared=jobs if serial else wire,
                                window=max(8, 4 * parallel) if pool is None else max(32, 8 * parallel)):
            (ii, jj), _, n, rr = tasks[i]
            for r, res in zip(rr, out):
                results[ii, jj, n, r] = res
            if db is not None:
                job = jobs[ii, jj]
                db.add([(job.label, job.integrand.name, n, r, res) for r, res in zip(rr, out)])
            tick(len(rr), len(rr) * n)
    finally:
        if bar is not None:
            bar.close()
        if db is not None:
            db.close()

    rows = []
    for (ii, jj), job in jobs.items():
        meta = _meta(job)
        exact = meta.pop("exact")
        for n in ns:
            for r in range(reps):
                value, stderr, seconds, n_evals, n_units = results[ii, jj, n, r]
                rows.append({"estimator": job.label, "integrand": job.integrand.name, "n": n, "rep": r,
                             "value": value, "stderr": stderr, "exact": exact, "error": value - exact,
                             "seconds": seconds, "n_evals": n_evals, "n_units": n_units, **meta})
    df = pd.DataFrame(rows, columns=None if rows else CORE_COLUMNS)
    df.attrs.update({"entropy": root.entropy, "spawn_key": tuple(root.spawn_key), "crn": crn,
                     "skipped": skipped})
    return df


def _wire_specs(jobs: dict, executor) -> dict:
    """What a unit sends of its job: (label, estimator spec, integrand spec), checked to travel
    to a worker (:func:`vrlab.execution.check_picklable`)."""
    wire = {}
    for ij, job in jobs.items():
        wire[ij] = (job.label, job.est_spec, job.int_spec)
        check_picklable(wire[ij], executor, f"workers > 1: cannot send {job.label!r} on {job.integrand.name!r} to "
                        "a worker process", "use recipe and catalogue names, picklable objects (module-level "
                        "functions, no lambdas), or workers=1")
    return wire


def _sample_counts(ns) -> list[int]:
    """``ns`` (one count or a list) as distinct integers in [1, MAX_N]."""
    if ns is None or isinstance(ns, (str, bytes, numbers.Number, np.generic)) or \
            (isinstance(ns, np.ndarray) and ns.ndim == 0):
        return [checks.integer(ns, "ns", low=1, high=MAX_N)]
    items = _items(ns, "ns", "sample counts (integers >= 1)")
    out = [checks.integer(n, f"ns[{k}]", low=1, high=MAX_N) for k, n in enumerate(items)]
    if len(set(out)) < len(out):
        raise ValueError(f"ns: repeated sample counts {out}")
    return out


