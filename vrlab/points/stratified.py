"""Stratified (jittered) sampling: one uniform point in every cell of a grid.

The unit cube is cut into ``M = m_1 * ... * m_d`` equal cells; cell ``c`` with
multi-index ``(c_1, ..., c_d)`` receives ``u_j = (c_j + xi_j) / m_j`` with
``xi ~ U[0,1)^d`` independent.  Every point is uniform on the cube in
distribution (a random cell equally likely), so the estimator is unbiased, and its
variance is ``(1/n^2) sum_cells Var_cell f <= Var f / n``; for smooth ``f`` it is
``O(n^{-1-2/d})`` (jittered sampling; see e.g. Owen, *Monte Carlo theory,
methods and examples*, ch. 10; Cook 1986 for jittered sampling in rendering).

Choice of grid
--------------
* ``n = m^d``: the full ``m x ... x m`` grid, exactly one point per cell.
* other ``n``: per-axis counts with ``m_1 * ... * m_d = n`` as balanced as
  possible, found by handing out the prime factors of ``n`` (largest first) to
  the axis whose count is currently smallest; the larger counts go to the first
  axes.  Balanced counts make the leading variance term of smooth integrands,
  proportional to ``sum_j 1/m_j^2``, small.  Still one point per cell.  When
  ``n`` has a large prime factor the grid is unbalanced; for prime ``n`` it is
  ``n x 1 x ... x 1``: only the first coordinate is stratified (never worse than
  independent sampling, but pick ``n = m^d`` or a highly composite ``n`` for
  the full benefit).
* ``strata=(m_1, ..., m_d)`` fixes the grid; ``n`` must then be a multiple of
  ``M`` and every cell receives ``n / M`` points.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .._rng import RNGLike
from .base import _NO_SEED, MAX_POINTS, PointSet, check_int, clamp_open

_MAX_FACTOR_N = 1 << 40  # balanced_strata factors n by trial division (sqrt(n) steps)


def _prime_factors(n: int) -> list[int]:
    out, p = [], 2
    while p * p <= n:
        while n % p == 0:
            out.append(p)
            n //= p
        p += 1 if p == 2 else 2
    if n > 1:
        out.append(n)
    return out


def balanced_strata(n: int, d: int) -> tuple[int, ...]:
    """Per-axis counts ``(m_1 >= ... >= m_d)`` with product ``n``, as balanced as the
    prime factorisation of ``n`` allows (greedy: largest prime factor first, to the
    axis with the smallest count).  ``n = m^d`` gives ``(m, ..., m)``.  ``1 <= n <= 2**40``,
    ``1 <= d <= 2**24`` (integers; ``TypeError``/``ValueError`` naming the argument otherwise)."""
    n = check_int("n", n, 1, _MAX_FACTOR_N)
    d = check_int("d", d, 1, PointSet.MAXDIM)
    m = round(n ** (1.0 / d))
    for c in (m - 1, m, m + 1):  # exact d-th power: the full grid
        if c >= 1 and c ** d == n:
            return (c,) * d
    counts = [1] * d
    for p in sorted(_prime_factors(n), reverse=True):
        j = min(range(d), key=lambda k: counts[k])
        counts[j] *= p
    return tuple(sorted(counts, reverse=True))


class Stratified(PointSet):
    """Jittered stratified points: one (or ``n / M``) uniform point per grid cell.

    Parameters
    ----------
    d : dimension.
    strata : optional per-axis counts ``(m_1, ..., m_d)`` (positive integers); default:
        chosen from ``n`` at each ``random(n)`` call by :func:`balanced_strata` (see
        module docstring).
    rng : seed or generator for the jitter (legacy name ``seed``).

    Each ``random(n)`` call returns a new, independently jittered ``n``-point
    stratified set (cells in row-major order, first axis slowest).  A stratified set
    has a size, so ``fast_forward(k)`` follows SciPy's convention for such engines: it
    draws and discards one ``k``-point set.  ``reset()`` rewinds the jitter stream.
    """

    extensible = False

    def __init__(self, d: int, *, strata: Sequence[int] | None = None, rng: RNGLike = None,
                 seed: Any = _NO_SEED) -> None:
        super().__init__(d, rng=rng, seed=seed)
        if strata is not None:
            try:
                ok = not isinstance(strata, (str, bytes)) and np.ndim(strata) == 1 and len(strata) == self.d
            except (TypeError, ValueError):   # ragged sequences
                ok = False
            if not ok:
                raise ValueError(f"strata must be a sequence of d={self.d} positive integers, got {strata!r}")
            strata = tuple(check_int("strata", s, 1, MAX_POINTS) for s in strata)
        self.strata = strata
        self._params = {"strata": strata}

    def grid(self, n: int) -> tuple[int, ...]:
        """The per-axis counts used for an ``n``-point set."""
        n = check_int("n", n, 0)
        if self.strata is not None:
            cells = math.prod(self.strata)
            if n % cells:
                raise ValueError(f"n must be a multiple of prod(strata) = {cells} for strata={self.strata}, got {n}")
            return self.strata
        if self.d == 0:
            return ()
        return balanced_strata(max(n, 1), self.d)

    def _random(self, n: int) -> np.ndarray:
        if self.d == 0:
            self.grid(n)
            return np.empty((n, 0))
        counts = np.asarray(self.grid(n), dtype=np.int64)
        cells = math.prod(int(c) for c in counts)
        cell = np.arange(n, dtype=np.int64) // (n // cells) if n else np.zeros(0, np.int64)
        # multi-index of each point's cell (row-major), then jitter inside the cell
        idx = np.stack(np.unravel_index(cell, tuple(counts)), axis=-1)
        x = (idx + self.rng.random((n, self.d))) / counts
        return clamp_open(x)
