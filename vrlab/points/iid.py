"""Independent uniform points: plain Monte Carlo.

``u_i ~ U[0, 1)^d`` independently; the estimator ``(1/n) sum f(u_i)`` has variance
``Var f / n`` (the baseline every other point set is compared against).
"""
from __future__ import annotations

import numpy as np

from .._rng import RNGLike
from .base import PointSet


class Independent(PointSet):
    """Independent uniforms drawn from ``rng`` (``Generator.random``), row by row.

    The engine is a stream: successive ``random`` calls continue it, and
    ``fast_forward(k)`` followed by ``random(m)`` gives rows ``k .. k+m`` of a fresh
    engine's ``random(k + m)``.  ``reset()`` rewinds the stream.
    """

    _CHUNK = 1 << 22  # values discarded per step in fast_forward (bounded memory)

    def __init__(self, d: int, *, rng: RNGLike = None) -> None:
        super().__init__(d, rng=rng)

    def _random(self, n: int) -> np.ndarray:
        return self.rng.random((n, self.d))

    def _fast_forward(self, n: int) -> None:
        left = n * self.d
        while left > 0:
            step = min(left, self._CHUNK)
            self.rng.random(step)
            left -= step
