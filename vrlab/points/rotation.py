"""Cranley--Patterson rotation: a random toroidal shift of any point set.

``x_i = (u_i + v) mod 1`` with one shift ``v ~ U[0,1)^d`` per engine (Cranley &
Patterson 1976).  Each ``x_i`` is uniform, so the QMC estimator becomes unbiased,
and independent shifts give independent replicates whose spread estimates the
error.  The shift is an isometry of the torus: toroidal distances between points,
hence lattice/net structure "modulo 1", are preserved (axis-aligned stratification
is not: a shifted elementary interval wraps around).
"""
from __future__ import annotations

import copy
from typing import Any

import numpy as np

from .._rng import RNGLike, spawn
from .base import PointSet, check_int


class CranleyPatterson(PointSet):
    """Random toroidal shift ``(u + v) mod 1`` of another point set.

    Parameters
    ----------
    base : a point-set engine (vrlab or ``scipy.stats.qmc``) to shift, *or* the
        dimension ``d`` (an int), in which case ``points`` says which set to build.
    points : when ``base`` is an int: a name accepted by :func:`make_points`, a
        point-set class, or ``None`` for unscrambled Halton; built with ``d`` and a
        child of ``rng`` (and ``**kwargs``).
    rng : seed or generator for the shift (drawn once, in the constructor).

    ``random``, ``reset`` and ``fast_forward`` act on the wrapped engine; the shift
    stays.  The wrapped engine is used (advanced) in place, not copied.
    """

    def __init__(self, base: Any, *, points: Any = None, rng: RNGLike = None, **kwargs: Any) -> None:
        if isinstance(base, (int, np.integer)) and not isinstance(base, bool):
            d = check_int("d", base, 1)
            super().__init__(d, rng=rng)
            child = spawn(self.rng, 1)[0]
            self.base = _build(points, d, child, kwargs)
        else:
            if not all(hasattr(base, a) for a in ("random", "reset", "d")):
                raise TypeError(
                    "base must be a point-set engine (with random, reset, d) or an int dimension, "
                    f"got {type(base).__name__}"
                )
            if points is not None or kwargs:
                raise TypeError("points=/keyword settings are only used when base is an int dimension")
            super().__init__(int(base.d), rng=rng)
            self.base = base
        self.shift = self.rng.random(self.d)
        self._points, self._kwargs = points, kwargs

    @property
    def extensible(self) -> bool:  # type: ignore[override]
        return getattr(self.base, "extensible", True)

    def _random(self, n: int) -> np.ndarray:
        x = np.asarray(self.base.random(n), dtype=np.float64) + self.shift
        x -= x >= 1.0          # both terms are in [0, 1): one wrap is enough
        return x

    def _fast_forward(self, n: int) -> None:
        self.base.fast_forward(n)

    def _reset(self) -> None:
        self.base.reset()

    def replicate(self, R: int, rng: RNGLike = None) -> list[CranleyPatterson]:
        """``R`` independently shifted copies.  The wrapped set is replicated too when it is
        randomised (a vrlab engine with ``randomized``); otherwise each copy shifts a
        fresh copy of it (``copy.deepcopy`` + ``reset``)."""
        R = check_int("R", R, 0)
        out = []
        for child in spawn(rng, R):
            c_base, c_shift = spawn(child, 2)
            if getattr(self.base, "randomized", False) and hasattr(self.base, "replicate"):
                base = self.base.replicate(1, rng=c_base)[0]
            else:
                base = copy.deepcopy(self.base)
                base.reset()
            out.append(CranleyPatterson(base, rng=c_shift))
        return out

    def __repr__(self) -> str:
        return f"CranleyPatterson({self.base!r})"


def _build(points: Any, d: int, rng: np.random.Generator, kwargs: dict) -> Any:
    from .tools import make_points  # late import: tools imports this module

    if points is None:
        return make_points("halton", d, rng=rng, scramble=False, **kwargs)
    if isinstance(points, str):
        return make_points(points, d, rng=rng, **kwargs)
    if isinstance(points, type):
        return points(d, rng=rng, **kwargs)
    raise TypeError(f"points must be None, a name or a point-set class, got {type(points).__name__}")
