"""Sobol' points: a thin wrapper around ``scipy.stats.qmc.Sobol`` (not re-implemented).

Sobol' (1967) sequences are base-2 digital nets: for ``n = 2^m`` every elementary
box of volume ``2^{t-m}`` holds exactly ``2^t`` points.  ``scramble=True`` (default,
as in SciPy) applies SciPy's randomisation: a random linear matrix scramble plus a
random digital shift (Matousek 1998; Owen 1995 for why scrambling keeps the net
property and makes the estimator unbiased).

The balance properties hold for ``n`` a power of 2 (and start indices multiple of
it): SciPy warns (``UserWarning``) when ``random(n)`` breaks that, and this wrapper
keeps SciPy's behaviour unchanged.  Use :meth:`Sobol.random_base2` to ask for
``2^m`` points.
"""
from __future__ import annotations

import numpy as np

from .._rng import RNGLike
from .base import PointSet, check_int

_MAX_DIM = 21201  # the direction numbers SciPy ships (Joe & Kuo 2008)


class Sobol(PointSet):
    """Sobol' sequence of ``scipy.stats.qmc.Sobol(d, scramble=..., bits=..., rng=...)``.

    Parameters
    ----------
    d : dimension, ``1 <= d <= 21201``.
    scramble : SciPy's LMS + digital shift scrambling (default ``True``).
    bits : number of bits of the generator (SciPy's ``bits``, at most 64).  vrlab's default
        is 52 when scrambled (SciPy's is 30): scrambled points on a 2^-30 grid carry a
        bias of order 2^-31 per coordinate, which for smooth integrands exceeds the RQMC
        error itself at a few thousand points, so replicate-based standard errors come
        out far too small (measured: z-score spread 37 instead of 1 for e^x, 8 x 2048
        points).  With 52 bits the z-scores have spread 1.02.  Unscrambled: 30.
    rng : seed or generator for the scrambling.

    A sequence: successive calls continue it, ``fast_forward(k)`` skips ``k``
    indices, ``reset()`` returns to index 0 with the same scrambling.
    """

    def __init__(self, d: int, *, scramble: bool = True, bits: int | None = None, rng: RNGLike = None) -> None:
        super().__init__(d, rng=rng)
        if self.d > _MAX_DIM:
            raise ValueError(f"d must be <= {_MAX_DIM} for Sobol (SciPy's direction numbers), got {self.d}")
        if not isinstance(scramble, (bool, np.bool_)):
            raise TypeError(f"scramble must be a bool for Sobol, got {scramble!r}")
        if bits is not None:
            bits = check_int("bits", bits, 1)
        elif scramble:
            bits = 52
        self.scramble = bool(scramble)
        self.bits = bits
        self.randomized = self.scramble
        from scipy.stats import qmc  # imported here: scipy.stats costs ~0.8 s to import

        self.engine = qmc.Sobol(self.d, scramble=self.scramble, bits=bits, rng=self.rng)
        self._params = {"scramble": self.scramble, "bits": bits}

    def _random(self, n: int) -> np.ndarray:
        return self.engine.random(n)

    def random_base2(self, m: int) -> np.ndarray:
        """The next ``2^m`` points (SciPy's ``random_base2``: checks the balance properties)."""
        m = check_int("m", m, 0)
        x = self.engine.random_base2(m)
        self.num_generated += 1 << m
        return x

    def _fast_forward(self, n: int) -> None:
        if not n:  # scipy 1.17's Sobol.fast_forward(0) raises OverflowError
            return
        if self.engine.bits <= 32:
            self.engine.fast_forward(n)
            return
        # scipy 1.17's fast_forward fails for bits > 32 (uint32 buffer); draw and discard
        for start in range(0, n, 1 << 16):
            self.engine.random(min(1 << 16, n - start))

    def _reset(self) -> None:
        self.engine.reset()
