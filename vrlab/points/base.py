"""Shared machinery of the point sets: the engine base class and argument checks.

Every point set is a small engine with the interface of ``scipy.stats.qmc``
engines (so SciPy engines and vrlab engines can be used interchangeably)::

    eng = Cls(d, *, rng=None, **settings)
    u = eng.random(n)        # ndarray (n, d), float64, every value in [0, 1)
    eng.reset()              # back to the initial state -> same points again
    eng.fast_forward(k)      # skip k points (see each class for what a "point" is)
    eng.d, eng.num_generated

``rng`` is anything ``vrlab._rng.as_generator`` accepts (None, int seed,
``SeedSequence``, ``BitGenerator``, ``Generator``).  All randomisation of a
randomised QMC set (scrambles, shifts) is drawn once, in the constructor, so
``reset()`` gives back exactly the same points.  Independent randomised copies
of one set come from :meth:`PointSet.replicate` / :func:`vrlab.points.replicates`,
never from re-using a seed.
"""
from __future__ import annotations

import copy
import numbers
from typing import Any

import numpy as np

from .._rng import RNGLike, as_generator, spawn

#: The largest float64 below 1; values are clamped to it so that every point is in [0, 1).
ONE_MINUS_EPS = float(np.nextafter(1.0, 0.0))


def check_int(name: str, value: Any, minimum: int | None = None) -> int:
    """Return ``value`` as a Python int; ``TypeError`` if it is not an integer,
    ``ValueError`` if it is below ``minimum``.  The messages name the argument."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral, np.integer)):
        raise TypeError(f"{name} must be an integer, got {value!r} ({type(value).__name__})")
    value = int(value)
    if minimum is not None and value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    return value


def clamp_open(x: np.ndarray) -> np.ndarray:
    """Clamp in place to ``[0, 1)`` (guards against rounding up to exactly 1.0)."""
    np.minimum(x, ONE_MINUS_EPS, out=x)
    return x


class PointSet:
    """Base class of vrlab point sets (engine API of ``scipy.stats.qmc``).

    Subclasses implement ``_random(n) -> (n, d)`` (called with the engine's
    position in ``self.num_generated``), and may override ``_fast_forward`` and
    ``_reset``.  ``randomized`` says whether the points depend on ``rng``
    (``False`` for unscrambled Halton/Hammersley/Sobol: replicating them gives
    identical copies).  ``_params`` holds the constructor settings other than
    ``d`` and ``rng``, so that :meth:`replicate` can rebuild the engine.
    """

    randomized: bool = True
    #: False for point sets whose n is part of the design (stratified, Latin hypercube,
    #: Hammersley): estimators then draw all n points in one call instead of chunks.
    extensible: bool = True

    def __init__(self, d: int, *, rng: RNGLike = None) -> None:
        self.d = check_int("d", d, 1)
        self.rng = as_generator(rng)
        # A private copy of the initial generator state: reset() restores it.
        self._rng_initial = copy.deepcopy(self.rng)
        self.num_generated = 0
        self._params: dict[str, Any] = {}

    # -- engine API -------------------------------------------------------------------
    def random(self, n: int = 1) -> np.ndarray:
        """Return the next ``n`` points as a float64 array of shape ``(n, d)`` in [0, 1)."""
        n = check_int("n", n, 0)
        x = self._random(n)
        self.num_generated += n
        return x

    def reset(self) -> PointSet:
        """Restore the initial state (same points, same randomisation); returns ``self``."""
        self.rng = copy.deepcopy(self._rng_initial)
        self.num_generated = 0
        self._reset()
        return self

    def fast_forward(self, n: int) -> PointSet:
        """Skip ``n`` points; returns ``self``."""
        n = check_int("n", n, 0)
        self._fast_forward(n)
        self.num_generated += n
        return self

    def replicate(self, R: int, rng: RNGLike = None) -> list[PointSet]:
        """``R`` independent randomised copies of this point set (same class and settings).

        Replicate ``r`` is built with the ``r``-th child of ``SeedSequence(rng).spawn(R)``
        (``vrlab._rng.spawn``), so replicates are independent of each other and
        reproducible from ``rng``.  The copies start at index 0.  Raises
        ``ValueError`` for a deterministic set (e.g. ``Halton(d, scramble=False)``),
        whose "replicates" would all be identical: scramble it or wrap it in
        :class:`~vrlab.points.CranleyPatterson`.
        """
        R = check_int("R", R, 0)
        if not self.randomized:
            raise ValueError(
                f"replicate: {self!r} is deterministic, so its replicates would be {R} identical "
                "copies (zero spread, no error estimate); use scramble=True or wrap it in "
                "CranleyPatterson(...)"
            )
        return [type(self)(self.d, rng=child, **self._params) for child in spawn(rng, R)]

    # -- hooks ------------------------------------------------------------------------
    def _random(self, n: int) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError  # abstract: subclasses draw the points

    def _reset(self) -> None:
        pass

    def _fast_forward(self, n: int) -> None:
        # Default: draw and discard (the SciPy convention for sets without an index).
        self._random(n)

    def __repr__(self) -> str:
        args = "".join(f", {k}={v!r}" for k, v in self._params.items())
        return f"{type(self).__name__}({self.d}{args})"
