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


#: the parts of each suite, in order ("sampling" is both races)
PARTS = {"sampling": ("qmc", "discrete"), "qmc": ("qmc",), "discrete": ("discrete",), "estimators": ("estimators",)}


def run(suite: str, quick: bool = False, progress=None) -> list[dict]:
    """Rows of timings for ``suite`` in {"sampling", "qmc", "discrete", "estimators"}, each with
    its part in column ``suite`` (one table per part: their columns differ).  ``progress(part,
    done, total)``, if given, is called before each part starts (done = parts finished) and
    after the last."""
    suite = checks.choice(suite, "suite", SUITES)
    quick = _quick(quick)
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be callable progress(part, done, total) or None, got {checks.describe(progress)}")
    parts = PARTS[suite]
    rows: list[dict] = []
    for k, part in enumerate(parts):
        if progress is not None:
            progress(part, k, len(parts))
        if part == "estimators":
            from .estimators import bench_estimators as bench
        elif part == "qmc":
            from .qmc import bench_qmc as bench
        else:
            from .discrete import bench_discrete as bench
        rows += [{"suite": part, **r} for r in bench(quick=quick)]
    if progress is not None:
        progress(parts[-1], len(parts), len(parts))
    return rows
