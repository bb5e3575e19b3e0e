"""Shared machinery of the point sets: the engine base class and argument checks.

Every point set is a small engine with the interface of ``scipy.stats.qmc``
engines (so SciPy engines and vrlab engines can be used interchangeably)::

    eng = Cls(d, *, rng=None, **settings)
    u = eng.random(n)        # ndarray (n, d), float64, every value in [0, 1)
    k = eng.integers(10, n=5)  # (n, d) int64 in [0, 10), as SciPy's QMCEngine.integers
    eng.reset()              # back to the initial state -> same points again
    eng.fast_forward(k)      # skip k points (see each class for what a "point" is)
    eng.d, eng.num_generated

``rng`` (legacy name ``seed``, as in SciPy; not both) is ``None``, an int seed (or a
list of them), a ``SeedSequence``, a ``BitGenerator`` or a ``Generator``.  A ``Generator``
or ``BitGenerator`` is not drawn from directly: the engine spawns a child of it, as
SciPy's ``QMCEngine`` does, so the caller's later draws do not change its points.
Seeds make a new generator directly (``default_rng(seed)``).  All randomisation of a
randomised QMC set (scrambles, shifts) is drawn once, in the constructor, so
``reset()`` gives back exactly the same points.  Independent randomised copies
of one set come from :meth:`PointSet.replicate` / :func:`vrlab.points.replicates`,
never from re-using a seed.

Checked here (messages name the argument): ``d`` (``ValueError`` unless an integer
>= 0, SciPy's type), ``rng``/``seed``, ``optimization``, ``n``, ``workers``, and the
bounds of :meth:`PointSet.integers`.
"""
from __future__ import annotations

import copy
import functools
from typing import Any

import numpy as np

from .. import checks
from .._rng import RNGLike, as_generator, spawn

#: The largest float64 below 1; values are clamped to it so that every point is in [0, 1).
ONE_MINUS_EPS = float(np.nextafter(1.0, 0.0))
#: Largest ``n`` of one ``random(n)`` call (the points are held in memory: 2 PiB per coordinate).
MAX_POINTS = 1 << 48
#: Largest ``R`` for ``replicate``/``replicates`` (each replicate is an engine object).
MAX_REPLICATES = 1 << 20
_NO_SEED: Any = object()  # sentinel: the legacy ``seed=`` keyword was not given
_OPTIMIZATIONS = ("random-cd", "lloyd")


_describe = checks.describe


def check_int(name: str, value: Any, minimum: int | None = None, maximum: int | None = None) -> int:
    """``checks.integer`` with the argument name first (the points package's older spelling):
    ``TypeError`` if ``value`` is not an integer, ``ValueError`` outside [minimum, maximum]."""
    return checks.integer(value, name, low=minimum, high=maximum)


def check_dim(d: Any, minimum: int = 0, name: str = "d") -> int:
    """The dimension ``d``: like SciPy's engines, ``ValueError`` for anything but an integer
    ``>= minimum`` (a float, string, bool or None included)."""
    try:
        return check_int(name, d, minimum)
    except (TypeError, ValueError):
        # SciPy's engine tests pin the start of this message: "d must be a non-negative integer"
        what = "a non-negative integer" if minimum == 0 else f"an integer >= {minimum}"
        raise ValueError(f"{name} must be {what}, got {d!r} ({type(d).__name__})") from None


def check_workers(workers: Any) -> int:
    """SciPy's ``workers``: -1 or a positive integer (``ValueError`` otherwise, as in SciPy)."""
    try:
        w = check_int("workers", workers, None, 2**31 - 1)
    except TypeError as exc:
        raise ValueError(str(exc)) from None
    if w != -1 and w <= 0:
        raise ValueError(f"workers must be -1 or > 0 (invalid number of workers), got {w}")
    return w


class SharedGenerator:
    """Internal: hands a ``Generator`` to a vrlab engine to be drawn from *directly*
    (no spawned child).  Used by vrlab's estimators, whose engines draw from the
    estimator's own generator, so an estimate's numbers for a seed stay as they were."""

    __slots__ = ("gen",)

    def __init__(self, gen: np.random.Generator) -> None:
        if not isinstance(gen, np.random.Generator):
            raise TypeError(f"rng: SharedGenerator needs a numpy Generator, got {_describe(gen)}")
        self.gen = gen


def resolve_rng(rng: RNGLike = None, seed: Any = _NO_SEED, *, spawn_child: bool = True) -> np.random.Generator:
    """The engine's own generator (see the module docstring); ``seed`` is SciPy's legacy name.
    With ``spawn_child=False`` a ``Generator`` is returned as is (a ``BitGenerator`` wrapped)."""
    name = "rng"
    if seed is not _NO_SEED:
        if rng is not None:
            raise TypeError("rng, seed: got multiple values for argument now known as `rng`; "
                            "give rng= or its legacy name seed=, not both")
        rng, name = seed, "seed"
    if isinstance(rng, SharedGenerator):
        return rng.gen
    if isinstance(rng, (bool, np.bool_)):
        raise TypeError(f"{name}: expected None, an int seed, a numpy SeedSequence, BitGenerator or "
                        f"Generator, got {_describe(rng)}")
    if not spawn_child and isinstance(rng, (np.random.Generator, np.random.BitGenerator)):
        return rng if isinstance(rng, np.random.Generator) else np.random.Generator(rng)
    if isinstance(rng, (np.random.Generator, np.random.BitGenerator)):
        bg = rng.bit_generator if isinstance(rng, np.random.Generator) else rng
        try:
            return np.random.Generator(bg.spawn(1)[0])  # == SciPy's _rng_spawn(rng, 1)[0]
        except (TypeError, AttributeError) as exc:
            raise TypeError(f"{name}: cannot spawn a child generator from {_describe(rng)} ({exc}); "
                            "pass a seed or a SeedSequence-based generator") from None
    try:
        return as_generator(rng)
    except (TypeError, ValueError) as exc:
        msg = str(exc)
        raise type(exc)(msg if msg.startswith(name) else f"{name}: {msg}") from None


def child_seeds(rng: RNGLike, R: int) -> list[np.random.SeedSequence]:
    """``R`` independent child seeds of ``rng`` (the seeds of ``vrlab._rng.spawn(rng, R)``)."""
    return [g.bit_generator.seed_seq for g in spawn(rng, R)]


def check_optimization(optimization: Any, d: int) -> str | None:
    """SciPy's ``optimization``: None, ``"random-cd"`` or ``"lloyd"`` (any case)."""
    if optimization is None:
        return None
    key = optimization.lower() if isinstance(optimization, str) else None
    if key not in _OPTIMIZATIONS:
        raise ValueError(f"optimization: {optimization!r} is not a valid optimization method. "
                         f"It must be one of {set(_OPTIMIZATIONS)!r} or None")
    if key == "lloyd" and d < 2:
        raise ValueError(f"optimization='lloyd' needs d >= 2 (a Voronoi tessellation), got d = {d}")
    return key


@functools.cache
def _given_sample_engine() -> type:
    """A ``scipy.stats.qmc.QMCEngine`` whose sample is given: SciPy's public engine
    interface then applies its own ``optimization`` post-processing to it."""
    from scipy.stats import qmc  # imported here: scipy.stats costs ~0.8 s to import

    class _GivenSample(qmc.QMCEngine):
        def __init__(self, sample: np.ndarray, optimization: str, rng: int) -> None:
            super().__init__(d=sample.shape[1], optimization=optimization, rng=rng)
            self.sample = sample

        def _random(self, n: int = 1, *, workers: int = 1) -> np.ndarray:
            return self.sample

    return _GivenSample


def optimize(sample: np.ndarray, method: str, rng: np.random.Generator) -> np.ndarray:
    """SciPy's optimisation ``method`` (``"random-cd"``, ``"lloyd"``) of ``sample`` (n, d)."""
    n, d = sample.shape
    if n == 0:
        return sample
    if method == "lloyd" and n < d + 1:
        raise ValueError(f"n: optimization='lloyd' needs n >= d + 1 = {d + 1} points per call, got {n}")
    seed = int(rng.integers(0, 2**63))
    out = np.array(_given_sample_engine()(sample, method, seed).random(n), dtype=np.float64)
    return clamp_open(out)


def clamp_open(x: np.ndarray) -> np.ndarray:
    """Clamp in place to ``[0, 1)`` (guards against rounding up to exactly 1.0)."""
    np.minimum(x, ONE_MINUS_EPS, out=x)
    return x


def _int_bounds(value: Any, name: str) -> np.ndarray:
    try:
        a = np.asarray(value) if not isinstance(value, (str, bytes)) else np.asarray(None)
    except (TypeError, ValueError):     # ragged lists and the like
        a = np.asarray(None)
    if a.dtype.kind not in "iu" or a.ndim > 1:
        raise ValueError(f"{name}: 'u_bounds' and 'l_bounds' must be integers or array-like of integers "
                         f"(at most 1-D), got {_describe(value)}")
    if a.size and (np.abs(a.astype(np.float64)).max() > 2.0**53):
        raise ValueError(f"{name} must lie within +-2**53 (exact in float64), got {_describe(value)}")
    return a.astype(np.int64)


class PointSet:
    """Base class of vrlab point sets (engine API of ``scipy.stats.qmc``).

    Subclasses implement ``_random(n) -> (n, d)`` (called with the engine's
    position in ``self.num_generated``), and may override ``_fast_forward`` and
    ``_reset``.  ``randomized`` says whether the points depend on ``rng``
    (``False`` for unscrambled Halton/Hammersley/Sobol: replicating them gives
    identical copies).  ``_params`` holds the constructor settings other than
    ``d`` and ``rng``, so that :meth:`replicate` can rebuild the engine.
    ``optimization`` (SciPy's ``None``, ``"random-cd"``, ``"lloyd"``) post-processes
    each ``random`` call with SciPy's own optimisers (through its public
    ``QMCEngine`` interface), its random choices drawn from the engine's ``rng``.
    """

    randomized: bool = True
    #: False for point sets whose n is part of the design (stratified, Latin hypercube,
    #: Hammersley): estimators then draw all n points in one call instead of chunks.
    extensible: bool = True
    #: largest dimension (a guard against absurd ``d``; Sobol and Halton have their own)
    MAXDIM: int = 1 << 24

    def __init__(self, d: int, *, optimization: str | None = None, rng: RNGLike = None,
                 seed: Any = _NO_SEED) -> None:
        self.d = check_dim(d, 0)
        if self.d > self.MAXDIM:
            raise ValueError(f"d must be <= {self.MAXDIM} for {type(self).__name__}: Maximum supported "
                             f"dimensionality is {self.MAXDIM}, got {self.d}")
        self.rng = self._own_rng(rng, seed)
        # A private copy of the initial generator state: reset() restores it.
        self._rng_initial = copy.deepcopy(self.rng)
        self.num_generated = 0
        self.optimization = check_optimization(optimization, self.d)
        self._params: dict[str, Any] = {}

    @staticmethod
    def _own_rng(rng: RNGLike, seed: Any) -> np.random.Generator:
        return resolve_rng(rng, seed)

    # -- engine API -------------------------------------------------------------------
    def random(self, n: int = 1, *, workers: int = 1) -> np.ndarray:
        """The next ``n`` points, float64 ``(n, d)`` in [0, 1).  ``0 <= n <= 2**48``; ``workers``
        (SciPy's: -1 or > 0) is checked and accepted; vrlab computes in one thread (same points)."""
        n = check_int("n", n, 0, MAX_POINTS)
        check_workers(workers)
        try:
            x = self._random(n)
        except MemoryError:
            raise ValueError(f"n: {n} points of dimension {self.d} do not fit in memory") from None
        if self.optimization is not None:
            x = optimize(x, self.optimization, self.rng)
        self.num_generated += n
        return x

    def integers(self, l_bounds: Any, *, u_bounds: Any = None, n: int = 1, endpoint: bool = False,
                 workers: int = 1) -> np.ndarray:
        """``n`` points as integers in ``[l_bounds, u_bounds)`` (``]`` with ``endpoint``):
        ``floor(u * (u_bounds - l_bounds) + l_bounds)``, as SciPy's ``QMCEngine.integers``
        (one bound given: it is ``u_bounds`` and ``l_bounds = 0``).  Bounds: integers,
        scalars or length-``d`` arrays, ``l_bounds < u_bounds`` (``ValueError`` otherwise)."""
        if u_bounds is None:
            l_bounds, u_bounds = 0, l_bounds
        lo, hi = _int_bounds(l_bounds, "l_bounds"), _int_bounds(u_bounds, "u_bounds")
        if not isinstance(endpoint, (bool, np.bool_)):
            raise TypeError(f"endpoint must be a bool, got {_describe(endpoint)}")
        if endpoint:
            hi = hi + 1
        try:
            lo, hi = np.broadcast_to(lo, (self.d,)), np.broadcast_to(hi, (self.d,))
        except ValueError:
            raise ValueError(f"l_bounds, u_bounds: 'l_bounds' and 'u_bounds' must be broadcastable and respect "
                             f"the sample dimension d = {self.d}; got shapes {lo.shape} and {hi.shape}") from None
        if np.any(lo >= hi):
            raise ValueError("l_bounds, u_bounds: Bounds are not consistent 'l_bounds' < 'u_bounds' "
                             f"(l_bounds={lo.tolist()}, u_bounds={hi.tolist()})")
        sample = self.random(n, workers=workers)
        return np.floor(sample * (hi - lo).astype(np.float64) + lo).astype(np.int64)

    def reset(self) -> PointSet:
        """Restore the initial state (same points, same randomisation); returns ``self``."""
        self.rng = copy.deepcopy(self._rng_initial)
        self.num_generated = 0
        self._reset()
        return self

    def fast_forward(self, n: int) -> PointSet:
        """Skip ``n`` points; returns ``self``."""
        n = check_int("n", n, 0)
        try:
            self._fast_forward(n)
        except MemoryError:
            raise ValueError(f"n: fast_forward({n}) draws and discards an {n}-point set of dimension "
                             f"{self.d}, which does not fit in memory") from None
        self.num_generated += n
        return self

    def replicate(self, R: int, rng: RNGLike = None) -> list[PointSet]:
        """``R`` independent randomised copies of this point set (same class and settings).

        Replicate ``r`` is built with the ``r``-th child of ``SeedSequence(rng).spawn(R)``
        (``vrlab._rng.spawn``), so replicates are independent of each other and
        reproducible from ``rng``.  The copies start at index 0.  Raises
        ``ValueError`` for a deterministic set (e.g. ``Halton(d, scramble=False)``),
        whose "replicates" would all be identical: scramble it or wrap it in
        :class:`~vrlab.points.CranleyPatterson`.  ``R <= 2**20``.
        """
        R = check_int("R", R, 0, MAX_REPLICATES)
        if not self.randomized:
            raise ValueError(
                f"replicate: {self!r} is deterministic, so its replicates would be {R} identical "
                "copies (zero spread, no error estimate); use scramble=True or wrap it in "
                "CranleyPatterson(...)"
            )
        return [type(self)(self.d, rng=child, **self._params) for child in child_seeds(rng, R)]

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
