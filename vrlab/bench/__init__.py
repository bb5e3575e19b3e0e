"""Benchmarks that time vrlab side by side with its peers in one run, reported as ratios.

``run("sampling")`` = ``qmc`` (Halton/Hammersley vs ``scipy.stats.qmc``) and
``discrete`` (alias table vs ``numpy`` ``choice``, ``scipy.stats.sampling.DiscreteAliasUrn``,
``searchsorted``).  ``run("estimators")``: estimator overhead against bare NumPy and
peak memory of a 10^8-sample run (:mod:`vrlab.bench.estimators`).  No test asserts
timings; BENCHMARKS.md records measured runs.  ``suite`` must be one of those names and
``quick`` a bool (``ValueError``/``TypeError`` naming them).
"""
from __future__ import annotations

import numpy as np

from .. import checks

SUITES = ("sampling", "qmc", "discrete", "estimators")


def _quick(quick) -> bool:
    if not isinstance(quick, (bool, np.bool_)):
        raise TypeError(f"quick must be True or False, got {checks.describe(quick)}")
    return bool(quick)


def run(suite: str, quick: bool = False) -> list[dict]:
    """Rows of timings for ``suite`` in {"sampling", "qmc", "discrete", "estimators"}."""
    rows: list[dict] = []
    suite = checks.choice(suite, "suite", SUITES)
    quick = _quick(quick)
    if suite == "estimators":
        from .estimators import bench_estimators
        return [{"suite": "estimators", **r} for r in bench_estimators(quick=quick)]
    if suite in ("sampling", "qmc"):
        from .qmc import bench_qmc
        rows += [{"suite": "qmc", **r} for r in bench_qmc(quick=quick)]
    if suite in ("sampling", "discrete"):
        from .discrete import bench_discrete
        rows += [{"suite": "discrete", **r} for r in bench_discrete(quick=quick)]
    return rows
