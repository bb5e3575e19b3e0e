"""Latin hypercube sampling (McKay, Beckman & Conover 1979), strength 1 and 2.

Strength 1: for each axis ``j`` an independent random permutation ``pi_j`` of
``0..n-1``; point ``i`` is ``u_ij = (pi_j(i) + xi_ij) / n`` with ``xi ~ U[0,1)`` (or
``1/2`` with ``scramble=False``, i.e. centred).  Every one-dimensional projection has
exactly one point in each of the ``n`` strata ``[k/n, (k+1)/n)``; the estimator is
unbiased, its variance is never more than ``Var f / (n - 1)`` (Owen 1997) and it
removes the additive (main-effect) part of ``f`` asymptotically (Stein 1987).

Strength 2 (orthogonal-array LHS, Tang 1993; implemented here): ``n = p^2`` for a
prime ``p`` and ``d <= p + 1``.  Bose's orthogonal array OA(p^2, p+1, p, 2) has rows
``(a, b)``, ``a, b in Z_p``, and columns ``a``, ``b``, ``a + c b mod p``
(``c = 1..p-1``); every pair of columns takes each of the ``p^2`` level pairs once.
Each column's levels are relabelled by a random permutation, then the ``p`` rows at
level ``k`` get the ``p`` sub-strata ``k p .. k p + p - 1`` in random order, so the
points form a Latin hypercube whose two-dimensional projections are also balanced
on the ``p x p`` grid.
"""
from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

from .._rng import RNGLike
from .base import _NO_SEED, PointSet, clamp_open

_MAX_OA_P = 1 << 20  # strength 2: n = p**2 <= 2**40


def _is_prime(p: int) -> bool:
    return p >= 2 and all(p % q for q in range(2, math.isqrt(p) + 1))


class LatinHypercube(PointSet):
    """Latin hypercube points: one point per row stratum ``[k/n, (k+1)/n)`` on every axis.

    Parameters (as ``scipy.stats.qmc.LatinHypercube``)
    ----------
    d : dimension (``>= 0``).
    scramble : ``True`` (default): each point uniform inside its cell; ``False``: at the
        centre of its cell (still a random permutation per axis).
    strength : 1 (default) or 2 (orthogonal-array LHS: ``n = p**2``, ``p`` prime, ``d <= p + 1``;
        other ``n`` raise ``ValueError`` in ``random``).
    optimization : None, ``"random-cd"`` or ``"lloyd"`` (SciPy's optimisers, see
        :class:`~vrlab.points.base.PointSet`).
    centered : vrlab's older name: ``centered=True`` is ``scramble=False`` (give one, or
        both consistently).
    rng : seed or generator for the permutations and the jitter (legacy name ``seed``).

    Each ``random(n)`` call returns a new, independent ``n``-point Latin hypercube.
    An LHS has a size, so ``fast_forward(k)`` follows SciPy's convention: it draws
    and discards one ``k``-point set.  ``reset()`` rewinds the random stream.
    """

    extensible = False

    def __init__(self, d: int, *, scramble: bool | None = None, strength: int = 1,
                 optimization: str | None = None, centered: bool | None = None,
                 rng: RNGLike = None, seed: Any = _NO_SEED) -> None:
        super().__init__(d, optimization=optimization, rng=rng, seed=seed)
        for name, flag in (("scramble", scramble), ("centered", centered)):
            if flag is not None and not isinstance(flag, (bool, np.bool_)):
                raise TypeError(f"{name} must be a bool, got {flag!r} ({type(flag).__name__})")
        if scramble is not None and centered is not None and bool(scramble) == bool(centered):
            raise ValueError(f"scramble, centered: centered=True means scramble=False; got scramble={scramble} "
                             f"and centered={centered}")
        self.scramble = bool(scramble) if scramble is not None else not centered
        self.centered = not self.scramble
        if isinstance(strength, (bool, np.bool_)) or not isinstance(strength, numbers.Real) or strength not in (1, 2):
            raise ValueError(f"strength: {strength!r} is not a valid strength. It must be one of {{1, 2}}")
        self.strength = int(strength)
        self._params = {"scramble": self.scramble, "strength": self.strength, "optimization": self.optimization}

    def _random(self, n: int) -> np.ndarray:
        if self.strength == 2:
            return self._random_oa(n)
        # one random permutation of 0..n-1 per axis (column), independent across axes
        perm = self.rng.permuted(np.broadcast_to(np.arange(n, dtype=np.float64), (self.d, n)), axis=1).T
        jitter = 0.5 if self.centered else self.rng.random((n, self.d))
        x = (perm + jitter) / n
        return clamp_open(x)

    def _random_oa(self, n: int) -> np.ndarray:
        p = math.isqrt(n)
        if p > _MAX_OA_P:
            raise ValueError(f"n must be <= {_MAX_OA_P ** 2} for strength=2 (n points of d coordinates), got {n}")
        if p * p != n or not _is_prime(p):
            lo = next((q for q in range(p, 1, -1) if _is_prime(q)), 2)
            hi = next(q for q in range(max(p + 1, 2), 2 * p + 3) if _is_prime(q))
            raise ValueError(f"n is not the square of a prime number (strength=2 needs n = p**2 for a prime p), "
                             f"got n = {n}. Close values are {sorted({lo * lo, hi * hi})}")
        if self.d > p + 1:
            raise ValueError(f"n is too small for d. Must be n > (d-1)**2: strength=2 needs d <= p + 1 for "
                             f"n = p**2; got n = {n} (p = {p}) and d = {self.d}")
        a, b = np.divmod(np.arange(n, dtype=np.int64), p)
        x = np.empty((n, self.d))
        for j in range(self.d):
            level = a if j == 0 else b if j == 1 else (a + (j - 1) * b) % p     # Bose's OA column
            level = self.rng.permutation(p)[level]                              # relabel the levels
            order = np.argsort(level, kind="stable")                            # p rows per level
            sub = self.rng.permuted(np.broadcast_to(np.arange(p), (p, p)), axis=1).ravel()
            jitter = 0.5 if self.centered else self.rng.random(n)
            x[order, j] = (level[order] * p + sub + jitter) / n
        return clamp_open(x)
