"""Cranley--Patterson rotation: a random toroidal shift of any point set.

``x_i = (u_i + v) mod 1`` with one shift ``v ~ U[0,1)^d`` per engine (Cranley &
Patterson 1976).  Each ``x_i`` is uniform, so the QMC estimator becomes unbiased,
and independent shifts give independent replicates whose spread estimates the
error.  The shift is an isometry of the torus: toroidal distances between points,
hence lattice/net structure "modulo 1", are preserved (axis-aligned stratification
is not: a shifted elementary interval wraps around).

:func:`toroidal_shift` (the wrap) and :func:`engine_points` (a wrapped engine's checked
block) are shared with :class:`vrlab.points.pixel_sets.ShiftedCopies`.
"""
from __future__ import annotations

import copy
from typing import Any

import numpy as np

from .._rng import RNGLike, spawn
from .base import _NO_SEED, MAX_REPLICATES, PointSet, check_dim, check_int, child_seeds, clamp_open


class CranleyPatterson(PointSet):
    """Random toroidal shift ``(u + v) mod 1`` of another point set.

    Parameters
    ----------
    base : a point-set engine (vrlab or ``scipy.stats.qmc``) to shift, *or* the
        dimension ``d`` (an int), in which case ``points`` says which set to build.
    points : when ``base`` is an int: a name accepted by :func:`make_points`, a
        point-set class, or ``None`` for unscrambled Halton; built with ``d`` and a
        child of ``rng`` (and ``**kwargs``).
    rng : seed or generator for the shift (drawn once, in the constructor; legacy name
        ``seed``).

    ``random``, ``reset`` and ``fast_forward`` act on the wrapped engine; the shift
    stays.  The wrapped engine is used (advanced) in place, not copied.  Checked: ``base``
    (``TypeError`` unless an engine or an int; ``ValueError`` for a negative ``d``),
    ``points``, and every block the wrapped engine returns (``ValueError`` naming ``base``
    unless it is ``(n, d)`` with values in [0, 1]).
    """

    def __init__(self, base: Any, *, points: Any = None, rng: RNGLike = None, seed: Any = _NO_SEED,
                 **kwargs: Any) -> None:
        if isinstance(base, (int, np.integer)) and not isinstance(base, (bool, np.bool_)):
            d = check_dim(base, 0)
            super().__init__(d, rng=rng, seed=seed)
            child = spawn(self.rng, 1)[0].bit_generator.seed_seq
            self.base = _build(points, d, child, kwargs)
        else:
            if not all(hasattr(base, a) for a in ("random", "reset", "d")) or isinstance(base, type):
                raise TypeError(
                    "base must be a point-set engine (with random, reset, d) or an int dimension, "
                    f"got {type(base).__name__}"
                )
            if points is not None or kwargs:
                raise TypeError("points, " + ", ".join(kwargs) + ": points= and keyword settings are only "
                                "used when base is an int dimension")
            super().__init__(check_dim(base.d, 0, "base.d"), rng=rng, seed=seed)
            self.base = base
        self.shift = self.rng.random(self.d)
        self._points, self._kwargs = points, kwargs

    @property
    def extensible(self) -> bool:  # type: ignore[override]
        return getattr(self.base, "extensible", True)

    def _random(self, n: int) -> np.ndarray:
        return toroidal_shift(engine_points(self.base, n, self.d), self.shift)

    def _fast_forward(self, n: int) -> None:
        if callable(getattr(self.base, "fast_forward", None)):
            self.base.fast_forward(n)
            return
        if n * max(self.d, 1) > 1 << 36:
            raise ValueError(f"n: the wrapped engine has no fast_forward, and drawing and discarding {n} "
                             "points would not end")
        for start in range(0, n, 1 << 16):       # an engine without fast_forward: draw and discard
            self.base.random(min(1 << 16, n - start))

    def _reset(self) -> None:
        self.base.reset()

    def replicate(self, R: int, rng: RNGLike = None) -> list[CranleyPatterson]:
        """``R`` independently shifted copies.  The wrapped set is replicated too when it is
        randomised (a vrlab engine with ``randomized``); otherwise each copy shifts a
        fresh copy of it (``copy.deepcopy`` + ``reset``)."""
        R = check_int("R", R, 0, MAX_REPLICATES)
        out = []
        for child in spawn(rng, R):
            c_base, c_shift = child_seeds(child, 2)
            if getattr(self.base, "randomized", False) and hasattr(self.base, "replicate"):
                base = self.base.replicate(1, rng=c_base)[0]
            else:
                base = copy.deepcopy(self.base)
                base.reset()
            out.append(CranleyPatterson(base, rng=c_shift))
        return out

    def __repr__(self) -> str:
        return f"CranleyPatterson({self.base!r})"


def engine_points(engine: Any, n: int, d: int) -> np.ndarray:
    """``engine.random(n)`` as a new float64 array, checked: ``ValueError`` naming ``base``
    unless it has shape ``(n, d)`` and every value in [0, 1] (NaN refused)."""
    x = np.array(engine.random(n), dtype=np.float64)
    if x.shape != (n, d):
        raise ValueError(f"base: the wrapped engine returned shape {x.shape} for random({n}), "
                         f"expected {(n, d)}")
    if x.size and not ((x.min() >= 0.0) & (x.max() <= 1.0)):   # NaN fails both
        raise ValueError("base: the wrapped engine returned values outside [0, 1] (or NaN)")
    return x


def toroidal_shift(x: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """``(x + shift) mod 1`` (broadcast, a new array) for points ``x`` in [0, 1] and shifts in
    [0, 1): the sum is below 2, so one subtraction of 1 wraps it (exactly, Sterbenz); the
    result is clamped to [0, 1) (a point at 1.0 plus a shift within an ulp of 1 rounds to 2)."""
    y = np.add(x, shift, dtype=np.float64)
    y -= y >= 1.0
    return clamp_open(y)


def _build(points: Any, d: int, rng: np.random.SeedSequence, kwargs: dict) -> Any:
    from .catalog import ENGINES     # the engines by name (not vrlab.points.tools, which imports this module)
    from .names import canonical

    if points is None:
        return ENGINES["halton"](d, rng=rng, scramble=False, **kwargs)
    if isinstance(points, str):
        key = canonical(points, "points")
        return (CranleyPatterson if key == "cranley-patterson" else ENGINES[key])(d, rng=rng, **kwargs)
    if isinstance(points, type):
        # vrlab engines take the seed; other classes (SciPy's) the Generator, as before
        return points(d, rng=rng if issubclass(points, PointSet) else np.random.default_rng(rng), **kwargs)
    raise TypeError(f"points must be None, a name or a point-set class, got {type(points).__name__}")
