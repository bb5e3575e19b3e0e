"""Independent uniform points: plain Monte Carlo.

``u_i ~ U[0, 1)^d`` independently; the estimator ``(1/n) sum f(u_i)`` has variance
``Var f / n`` (the baseline every other point set is compared against).
"""
from __future__ import annotations

import numpy as np

from typing import Any

from .._rng import RNGLike
from .base import _NO_SEED, PointSet


_DISCARD_LIMIT = 1 << 36  # values drawn and discarded by fast_forward without advance()


class Independent(PointSet):
    """Independent uniforms drawn from ``rng`` (``Generator.random``), row by row.

    The engine is a stream: successive ``random`` calls continue it, and
    ``fast_forward(k)`` followed by ``random(m)`` gives rows ``k .. k+m`` of a fresh
    engine's ``random(k + m)``.  ``reset()`` rewinds the stream.  ``d >= 0``; ``rng`` (or
    its legacy name ``seed``) as for every engine (:mod:`vrlab.points.base`).
    """

    _CHUNK = 1 << 22  # values discarded per step in fast_forward (bounded memory)

    def __init__(self, d: int, *, rng: RNGLike = None, seed: Any = _NO_SEED) -> None:
        super().__init__(d, rng=rng, seed=seed)

    def _random(self, n: int) -> np.ndarray:
        return self.rng.random((n, self.d))

    def _fast_forward(self, n: int) -> None:
        left = n * self.d                     # one 64-bit draw per float64 value
        bg = self.rng.bit_generator
        if isinstance(bg, (np.random.PCG64, np.random.PCG64DXSM)) and not bg.state.get("has_uint32"):
            bg.advance(left)                  # jump ahead: O(log n), same state as drawing
            return
        if left > _DISCARD_LIMIT:
            raise ValueError(f"n: fast_forward({n}) would draw and discard {left} values with a "
                             f"{type(bg).__name__} generator (only PCG64 can jump ahead); at most "
                             f"{_DISCARD_LIMIT} values")
        while left > 0:
            step = min(left, self._CHUNK)
            self.rng.random(step)
            left -= step
