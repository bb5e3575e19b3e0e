"""Latin hypercube sampling (McKay, Beckman & Conover 1979).

For each axis ``j`` an independent random permutation ``pi_j`` of ``0..n-1``;
point ``i`` is ``u_ij = (pi_j(i) + xi_ij) / n`` with ``xi ~ U[0,1)`` (or ``1/2``
with ``centered=True``).  Every one-dimensional projection has exactly one point
in each of the ``n`` strata ``[k/n, (k+1)/n)``; the estimator is unbiased and its
variance is never more than ``Var f / (n - 1)`` (Owen 1997) and removes the additive
(main-effect) part of ``f`` asymptotically (Stein 1987).
"""
from __future__ import annotations

import numpy as np

from .._rng import RNGLike
from .base import PointSet, clamp_open


class LatinHypercube(PointSet):
    """Latin hypercube points: one point per row stratum ``[k/n, (k+1)/n)`` on every axis.

    Parameters
    ----------
    d : dimension.
    centered : put each point at the centre of its stratum (still a random
        permutation per axis) instead of uniformly inside it.
    rng : seed or generator for the permutations and the jitter.

    Each ``random(n)`` call returns a new, independent ``n``-point Latin hypercube.
    An LHS has a size, so ``fast_forward(k)`` follows SciPy's convention: it draws
    and discards one ``k``-point set.  ``reset()`` rewinds the random stream.
    """

    extensible = False

    def __init__(self, d: int, *, centered: bool = False, rng: RNGLike = None) -> None:
        super().__init__(d, rng=rng)
        if not isinstance(centered, (bool, np.bool_)):
            raise TypeError(f"centered must be a bool, got {centered!r}")
        self.centered = bool(centered)
        self._params = {"centered": self.centered}

    def _random(self, n: int) -> np.ndarray:
        # one random permutation of 0..n-1 per axis (column), independent across axes
        perm = self.rng.permuted(np.broadcast_to(np.arange(n, dtype=np.float64), (self.d, n)), axis=1).T
        jitter = 0.5 if self.centered else self.rng.random((n, self.d))
        x = (perm + jitter) / n
        return clamp_open(x)
