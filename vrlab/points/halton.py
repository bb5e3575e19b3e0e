r"""Halton and Hammersley point sets.

* Halton (1960): point ``i`` is ``(phi_2(i), phi_3(i), phi_5(i), ...)``, the
  radical inverses in the first ``d`` primes, ``i = 0, 1, 2, ...`` (an extensible
  sequence; star discrepancy ``O(log^d n / n)``).
* Hammersley (1964): the ``n``-point set ``(i/n, phi_2(i), ..., phi_{p_{d-1}}(i))``,
  ``i = 0..n-1`` (discrepancy ``O(log^{d-1} n / n)``, but ``n`` is fixed in advance).

Scrambles (``scramble=True`` random digit permutations, ``"owen"`` nested) are
described in :mod:`vrlab.points.scrambles`; digit tables in :mod:`vrlab.points.radical`.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .._rng import RNGLike
from .base import _NO_SEED, PointSet, check_dim, check_int, clamp_open
from .radical import MAX_PRIMES, first_primes, radical_inverse  # noqa: F401  (re-exported)
from .scrambles import ScrambleArg, _make_dims, _scramble_mode

_INDEX_LIMIT = 1 << 62  # point indices (int64 arithmetic)


def _check_index(engine: PointSet, n: int, action: str) -> None:
    if engine.num_generated + n > _INDEX_LIMIT:
        raise ValueError(f"n: {action} {n} points after point {engine.num_generated} goes past index 2**62, "
                         "the largest point index supported")


def _fill(groups: list, s: int, n: int, out: np.ndarray, j: int = 0) -> None:
    for g in groups:
        g.fill(s, n, out[:, j:j + g.width])
        j += g.width


# ---------------------------------------------------------------------------------------
# engines
# ---------------------------------------------------------------------------------------
class Halton(PointSet):
    """Halton sequence (Halton 1960): point ``i`` is ``(phi_2(i), phi_3(i), ..., phi_{p_d}(i))``.

    Parameters
    ----------
    d : dimension (bases: the first ``d`` primes).
    scramble : ``False`` (default) -- the plain, deterministic sequence, index 0 first
        (``(0, ..., 0)``): the same points as ``scipy.stats.qmc.Halton(d,
        scramble=False)``.  Note that SciPy's default is ``scramble=True``; here
        randomisation is asked for explicitly.  ``True`` / ``"permutation"`` -- random
        digit permutations per dimension and digit position (SciPy's scrambling);
        ``"owen"`` -- nested (Owen 1995) scrambling.  See the module docstring.
        For bases above ``2**12`` (``d > 564``) the permutations are random affine digit
        maps (same pairwise laws, no tables; see :mod:`vrlab.points.scrambles`).
    optimization : None, ``"random-cd"`` or ``"lloyd"`` (SciPy's optimisers, applied to
        each ``random`` call).
    rng : seed or generator for the scrambling (drawn once, in the constructor; legacy
        name ``seed``).

    A sequence: successive calls continue it, ``fast_forward(k)`` skips ``k`` indices,
    ``reset()`` returns to index 0 with the same scrambling.  ``0 <= d <= 2**23``; memory
    and time grow linearly in ``d`` (``d = 10^4`` is fine).
    """

    MAXDIM = MAX_PRIMES

    def __init__(self, d: int, *, scramble: ScrambleArg = False, optimization: str | None = None,
                 rng: RNGLike = None, seed: Any = _NO_SEED) -> None:
        super().__init__(d, optimization=optimization, rng=rng, seed=seed)
        mode = _scramble_mode(scramble)
        self.scramble: ScrambleArg = {None: False, "permutation": True, "owen": "owen"}[mode]
        self.randomized = mode is not None
        self.base = [int(b) for b in first_primes(self.d)]
        self._dims = _make_dims(self.base, mode, self.rng)
        self._params = {"scramble": self.scramble, "optimization": self.optimization}

    def _random(self, n: int) -> np.ndarray:
        _check_index(self, n, "drawing")
        out = np.empty((n, self.d), order="F")
        _fill(self._dims, self.num_generated, n, out)
        return out

    def _fast_forward(self, n: int) -> None:
        _check_index(self, n, "skipping")  # points are a function of their index


class Hammersley(PointSet):
    """Hammersley point set (Hammersley 1964): ``x_i = (i/N, phi_2(i), ..., phi_{p_{d-1}}(i))``.

    Parameters
    ----------
    d : dimension; coordinates ``1..d-1`` are the first ``d-1`` Halton coordinates.
    n : the set size ``N``.  If given, the engine walks through the rows of the
        ``N``-point set: ``random(m)`` returns the next ``m`` rows, ``fast_forward(k)``
        skips ``k`` rows, and asking for rows past ``N`` raises ``ValueError``.  If
        ``None`` (default), ``N`` is fixed by the first draw: after ``fast_forward(k)``
        (or none, ``k = 0``), ``random(m)`` returns rows ``k .. k+m`` of the
        ``(k+m)``-point set, so a fresh engine's ``random(n)`` is the whole ``n``-point
        set.  A Hammersley set cannot be extended: a further ``random`` call raises
        (instead of silently repeating points); call ``reset()`` (same
        randomisation) to draw a set again, possibly of another size.
    scramble : as for :class:`Halton` (default ``False``) for coordinates ``1..d-1``;
        when randomised, the first coordinate becomes ``(i + v)/N`` with one random
        ``v ~ U[0,1)`` per engine (a Cranley--Patterson shift within the strata
        ``[i/N, (i+1)/N)``), so every point is uniform.
    rng : seed or generator for the scrambling (drawn once, in the constructor; legacy
        name ``seed``).
    """

    extensible = False
    MAXDIM = MAX_PRIMES + 1

    def __init__(self, d: int, *, n: int | None = None, scramble: ScrambleArg = False,
                 rng: RNGLike = None, seed: Any = _NO_SEED) -> None:
        check_dim(d, 1)  # the i/N coordinate: d >= 1
        super().__init__(d, rng=rng, seed=seed)
        self.n = None if n is None else check_int("n", n, 1, _INDEX_LIMIT)
        mode = _scramble_mode(scramble)
        self.scramble: ScrambleArg = {None: False, "permutation": True, "owen": "owen"}[mode]
        self.randomized = mode is not None
        self.base = [int(b) for b in first_primes(self.d - 1)]
        self._shift = float(self.rng.random()) if self.randomized else 0.0
        self._dims = _make_dims(self.base, mode, self.rng)
        self._size = self.n
        self._params = {"n": self.n, "scramble": self.scramble}

    def _check_rows(self, m: int, action: str) -> int:
        size = self._size
        if size is None:
            size = self.num_generated + m
        if self.num_generated + m > size:
            raise ValueError(
                f"n: Hammersley: {action} {m} rows after row {self.num_generated} goes past the end "
                f"of the {size}-point set (a Hammersley set has a fixed size n); call reset(), "
                "create the engine with a larger n=..., or use Halton for an extensible sequence"
            )
        return size

    def _random(self, n: int) -> np.ndarray:
        if n == 0:
            return np.empty((0, self.d), order="F")
        _check_index(self, n, "drawing")
        size = self._size = self._check_rows(n, "drawing")
        s = self.num_generated
        out = np.empty((n, self.d), order="F")
        col = out[:, 0]
        col[:] = np.arange(s, s + n, dtype=np.float64)
        if self.randomized:
            col += self._shift
        col /= size
        clamp_open(col)
        _fill(self._dims, s, n, out, 1)
        return out

    def _fast_forward(self, n: int) -> None:
        if self._size is not None:
            self._check_rows(n, "skipping")
        _check_index(self, n, "skipping")

    def _reset(self) -> None:
        self._size = self.n


__all__ = ["Halton", "Hammersley", "first_primes", "radical_inverse"]

