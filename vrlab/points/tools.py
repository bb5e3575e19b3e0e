"""Point-set factory, independent replicates and discrepancy."""
from __future__ import annotations

import copy
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .. import checks
from .._rng import RNGLike, spawn
from .base import MAX_REPLICATES, PointSet, check_dim, check_int, check_workers
from .catalog import ENGINES
from .names import ALIASES, canonical
from .rotation import CranleyPatterson

#: canonical name -> class, and accepted aliases
POINT_SETS: dict[str, type] = {**ENGINES, "cranley-patterson": CranleyPatterson}
_ALIASES = ALIASES             # the one table, in vrlab.points.names


def make_points(name: str, d: int, *, rng: RNGLike = None, **kwargs: Any) -> PointSet:
    """Build a point set by name: ``make_points("halton", 2, rng=1, scramble=True)``.

    Names (case-insensitive): ``independent`` (``iid``, ``mc``), ``stratified``
    (``jittered``), ``lhs`` (``latin-hypercube``), ``halton``, ``hammersley``, ``sobol``,
    ``cranley-patterson`` (``cp``; ``points=`` names the shifted set, default unscrambled
    Halton).  ``kwargs`` go to the class (which checks them).  Unknown names raise
    ``ValueError``, a non-string name ``TypeError``.
    """
    return POINT_SETS[canonical(name, "name")](d, rng=rng, **kwargs)


def replicates(points: Any, R: int, *, rng: RNGLike = None, d: int | None = None,
               **kwargs: Any) -> list[Any]:
    """``R`` independent randomised replicates of one point set (for randomised QMC).

    ``points`` may be
    * a vrlab engine instance: ``points.replicate(R, rng)`` (same class and settings);
    * a name (see :func:`make_points`) or a point-set class (vrlab or
      ``scipy.stats.qmc``): built as ``cls(d, rng=child, **kwargs)``;
    * a factory ``f(rng) -> engine``: called as ``f(child)``.

    The children are ``vrlab._rng.spawn(rng, R)``, i.e. ``SeedSequence(rng).spawn(R)``:
    replicates are independent of each other and reproducible from ``rng`` (never make
    replicates by re-creating an engine with the same seed, or by sharing one engine).
    A deterministic set (``Halton(d, scramble=False)``, unscrambled Sobol, ...) would give
    ``R`` identical copies, so it raises ``ValueError``: scramble it or wrap it in
    :class:`CranleyPatterson`.
    """
    R = check_int("R", R, 0, MAX_REPLICATES)
    if isinstance(points, PointSet):
        if kwargs:
            raise TypeError(f"{', '.join(kwargs)}: keyword settings are only used when points is a name or a class")
        if d is not None and check_dim(d, 0) != points.d:
            raise ValueError(f"d: points is an engine of dimension {points.d}, but d = {d} was given")
        return points.replicate(R, rng=rng)
    from scipy.stats import qmc

    if isinstance(points, qmc.QMCEngine):
        raise TypeError(
            "points: cannot re-randomise a scipy.stats.qmc engine instance; pass its class "
            "(with d=... and settings) or a factory rng -> engine"
        )
    if isinstance(points, (str, type)):
        if d is None:
            raise TypeError("d is required when points is a name or a class")
        d = check_dim(d, 0)
        if isinstance(points, str):
            def factory(g):
                return make_points(points, d, rng=g.bit_generator.seed_seq, **kwargs)
        elif issubclass(points, PointSet):
            def factory(g):
                return points(d, rng=g.bit_generator.seed_seq, **kwargs)
        else:
            def factory(g):
                return points(d, rng=g, **kwargs)
    elif callable(points):
        if d is not None or kwargs:
            raise TypeError("d, " + ", ".join(kwargs) + ": d= and keyword settings are not used with a "
                            "factory function")
        factory = points
    else:
        raise TypeError(f"points must be a point set, a name, a class or a factory, got {type(points).__name__}")
    reps = [factory(child) for child in spawn(rng, R)]
    _check_not_identical(reps)
    return reps


def _check_not_identical(reps: list[Any]) -> None:
    if not reps:
        return
    flag = getattr(reps[0], "randomized", None)
    if flag is None and len(reps) >= 2:
        # a foreign engine: compare the first points of copies of two replicates
        a = copy.deepcopy(reps[0]).random(4)
        b = copy.deepcopy(reps[1]).random(4)
        flag = not np.array_equal(a, b)
    if flag is False:
        raise ValueError(
            f"points: {reps[0]!r} is deterministic, so its replicates would be identical copies "
            "(zero spread, no error estimate); use scramble=True or wrap it in CranleyPatterson(...)"
        )


_DISCREPANCY_METHODS = ("CD", "WD", "MD", "L2-star")


def discrepancy(points: ArrayLike, method: str = "CD", *, workers: int = 1) -> float:
    """Discrepancy of points in ``[0, 1]^d`` by ``scipy.stats.qmc.discrepancy``.

    ``method``: ``"CD"`` centered L2 (Hickernell 1998, default), ``"WD"`` wrap-around,
    ``"MD"`` mixture, ``"L2-star"`` (Warnock 1972).  Lower is more uniform; the cost is
    O(n^2 d).  Checked: ``points`` a finite ``(n, d)`` array, ``n, d >= 1``, values in
    ``[0, 1]``; ``method`` one of the four; ``workers`` -1 or > 0 (``ValueError``,
    ``TypeError`` for a non-numeric array or a non-string method).
    """
    checks.choice(method, "method", _DISCREPANCY_METHODS)
    check_workers(workers)
    x = checks.finite_array(points, "points", ndim=2)
    if x.shape[0] < 1 or x.shape[1] < 1:
        raise ValueError(f"points must have shape (n, d) with n, d >= 1, got {x.shape}")
    if (x.min() < 0) or (x.max() > 1):
        raise ValueError("points must lie in [0, 1]^d")
    from scipy.stats import qmc

    return float(qmc.discrepancy(x, method=method, workers=workers))
