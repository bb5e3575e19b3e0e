"""Independent randomised copies of one ``n``-point set: the samples of many pixels at once.

A pixel value is an integral over primary sample space [0, 1)^d, estimated from ``n``
samples.  Every pixel needs its own randomised copy of an ``n``-point set, unbiased on
its own and independent of the other pixels, and a renderer draws them in blocks:
``random_sets(count, n, rng) -> (count, n, d)``.

* :class:`PaddedStratified` - "padded" jittered sampling (Pharr, Jakob & Humphreys,
  *Physically Based Rendering*, 3rd ed., 2016, sec. 7.3).  The dimensions are split into
  groups (default: pairs ``(0, 1), (2, 3), ...``; an odd last dimension alone).  A group of
  ``k`` dimensions gets its own jittered grid of ``n`` cells with per-axis counts
  ``m = balanced_strata(n, k)``: sample ``i`` of cell ``c_i`` is ``u = (c_i + xi_i) / m``,
  ``xi_i ~ U[0, 1)^k``.  The ``n`` samples of each group are then permuted by an
  independent uniform permutation, so the cell of group A tells nothing about the cell
  of group B: every sample is uniform on [0, 1)^d (unbiased), each group keeps exactly
  one sample per cell of its grid.
* :class:`ShiftedCopies` - one shared ``n``-point set ``x_i`` (any engine's first ``n``
  points) with an independent Cranley-Patterson shift per copy, ``(x_i + v) mod 1``,
  ``v ~ U[0, 1)^d`` (Cranley & Patterson 1976; randomised QMC, e.g. L'Ecuyer & Lemieux
  2002): each copy's estimate is unbiased, copies are independent.
* :class:`SetSampler` - the renderer's entry point: a point set given by name, class or
  instance, ``draw(count, gen)`` from the caller's ``Generator``.

Every call draws all its randomness with one ``rng.random`` call laid out set after set,
so the sets drawn do not depend on how a block of ``count`` sets is split into calls.
The per-copy standard error from the i.i.d. formula ``s / sqrt(n)`` is valid only for
independent samples (:attr:`SetSampler.iid`); within a stratified or shifted QMC copy the
samples are dependent and the formula overestimates the error.
"""
from __future__ import annotations

import copy
import functools
import inspect
from typing import Any

import numpy as np

from .. import checks
from .._rng import RNGLike, as_generator
from .base import _NO_SEED, MAX_POINTS, MAX_REPLICATES, PointSet, check_dim, check_int, child_seeds, clamp_open
from .iid import Independent
from .rotation import engine_points, toroidal_shift
from .stratified import balanced_strata


def _generator(gen: Any, name: str) -> np.random.Generator:
    if not isinstance(gen, np.random.Generator):
        raise TypeError(f"{name} must be a numpy.random.Generator, got {checks.describe(gen)}")
    return gen


def _all_groups(groups: Any, d: int) -> tuple[tuple[tuple[int, ...], ...], tuple[tuple[int, ...], ...]]:
    """(the groups given or the default pairs, those followed by every other dimension alone)."""
    if groups is None:
        given = [(k, k + 1) for k in range(0, d - 1, 2)]
    else:
        bad = TypeError(f"groups must be a sequence of tuples of dimension indices, got {checks.describe(groups)}")
        if isinstance(groups, (str, bytes)) or not hasattr(groups, "__iter__"):
            raise bad
        given = []
        for g in groups:
            if isinstance(g, (str, bytes)) or not hasattr(g, "__iter__"):
                raise bad
            given.append(tuple(checks.integer(k, "groups", low=0, high=d - 1) for k in g))
        flat = [k for g in given for k in g]
        if any(len(g) == 0 for g in given) or len(flat) != len(set(flat)):
            raise ValueError(f"groups must be non-empty, disjoint tuples of distinct dimensions, got {groups!r}")
    covered = {k for g in given for k in g}
    return tuple(given), tuple(given) + tuple((k,) for k in range(d) if k not in covered)


@functools.lru_cache(maxsize=16)
def _grid(n: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Cell multi-indices ``(n, k)`` (row-major) and per-axis counts of the ``n``-cell grid."""
    counts = balanced_strata(n, k)
    cells = np.stack(np.unravel_index(np.arange(n), counts), -1)
    cells.setflags(write=False)
    return cells, np.asarray(counts, dtype=np.float64)


class PaddedStratified(PointSet):
    """Padded jittered sampling: a jittered ``n``-cell grid per dimension group, shuffled.

    Parameters
    ----------
    d : dimension (an integer >= 0).
    groups : tuples of distinct dimensions in [0, d) stratified jointly (disjoint); default
        ``(0, 1), (2, 3), ...``.  Dimensions in no group are single 1D groups.
    rng : seed or generator (legacy name ``seed``), as for every engine.

    ``random(n)`` returns one new padded set; :meth:`random_sets` many at once.  The
    set's size is part of the design (``extensible = False``).  Randomness per set: one
    ``(n, d + G)`` block of uniforms (``G`` groups, singles included): column ``k`` jitters
    dimension ``k``, column ``d + j`` holds the sort keys of group ``j``'s permutation.
    :attr:`groups` lists every group, the singles last.
    """

    extensible = False

    def __init__(self, d: int, groups: Any = None, *, rng: RNGLike = None, seed: Any = _NO_SEED) -> None:
        super().__init__(d, rng=rng, seed=seed)
        given, self.groups = _all_groups(groups, self.d)
        self._params = {"groups": None if groups is None else given}

    def random_sets(self, count: int, n: int, rng: np.random.Generator | None = None) -> np.ndarray:
        """``count`` independent padded ``n``-point sets, ``(count, n, d)`` in [0, 1), drawn
        from ``rng`` (a ``Generator``; default: the engine's own)."""
        count = check_int("count", count, 0)
        n = check_int("n", n, 0, MAX_POINTS)
        gen = self.rng if rng is None else _generator(rng, "rng")
        d = self.d
        r = gen.random((count, n, d + len(self.groups)))
        u = np.empty((count, n, d))
        if n == 0:
            return u
        for j, g in enumerate(self.groups):
            cells, counts = _grid(n, len(g))
            cols = list(g)
            strata = (cells + r[..., cols]) / counts                      # (count, n, len(g))
            order = np.argsort(r[..., d + j], axis=1)                     # a uniform permutation per set
            u[..., cols] = np.take_along_axis(strata, order[..., None], axis=1)
        return clamp_open(u)

    def _random(self, n: int) -> np.ndarray:
        return self.random_sets(1, n)[0]


class ShiftedCopies(PointSet):
    """A shared ``n``-point set with an independent Cranley-Patterson shift per copy.

    Parameters
    ----------
    base : a point-set engine instance (vrlab or ``scipy.stats.qmc``) of dimension ``d``.
        A private copy is kept: the engine given is not advanced.  The shared set for
        ``n`` is the first ``n`` points of that copy (``random(n)`` of a fresh copy of it),
        drawn once per ``n`` and cached (:meth:`points`).
    rng : seed or generator of the shifts (legacy name ``seed``), as for every engine.

    ``random_sets(count, n, rng)`` gives ``count`` copies ``(x_i + v_c) mod 1`` with
    ``v_c ~ U[0, 1)^d`` from one ``rng.random((count, 1, d))`` call; ``random(n)`` one copy
    with a new shift from the engine's generator.  ``extensible = False``.  Checked: ``base``
    (``TypeError`` unless an engine instance; ``ValueError`` naming ``base`` if it returns
    anything but ``(n, d)`` values in [0, 1]).
    """

    extensible = False

    def __init__(self, base: Any, *, rng: RNGLike = None, seed: Any = _NO_SEED) -> None:
        if isinstance(base, type) or not callable(getattr(base, "random", None)) or not hasattr(base, "d"):
            raise TypeError("base must be a point-set engine instance (vrlab or scipy.stats.qmc, with "
                            f"random(n) and d), got {checks.describe(base)}")
        super().__init__(check_dim(base.d, 0, "base.d"), rng=rng, seed=seed)
        self.base = copy.deepcopy(base)
        self._sets: dict[int, np.ndarray] = {}

    def points(self, n: int) -> np.ndarray:
        """The shared ``n``-point set ``(n, d)`` (read-only), drawn on the first request."""
        n = check_int("n", n, 0, MAX_POINTS)
        if n not in self._sets:
            x = engine_points(copy.deepcopy(self.base), n, self.d)
            x.setflags(write=False)
            self._sets[n] = x
        return self._sets[n]

    def random_sets(self, count: int, n: int, rng: np.random.Generator | None = None) -> np.ndarray:
        """``count`` independently shifted copies ``(count, n, d)`` in [0, 1), the shifts drawn
        from ``rng`` (a ``Generator``; default: the engine's own)."""
        count = check_int("count", count, 0)
        gen = self.rng if rng is None else _generator(rng, "rng")
        x = self.points(n)
        return toroidal_shift(x, gen.random((count, 1, self.d)))

    def _random(self, n: int) -> np.ndarray:
        return self.random_sets(1, n)[0]

    def replicate(self, R: int, rng: RNGLike = None) -> list[ShiftedCopies]:
        """``R`` copies with independent shift streams (children of ``rng``), same shared set."""
        R = check_int("R", R, 0, MAX_REPLICATES)
        return [ShiftedCopies(self.base, rng=child) for child in child_seeds(rng, R)]

    def __repr__(self) -> str:
        return f"ShiftedCopies({self.base!r})"


def _scipy_engine_type() -> type:
    from scipy.stats import qmc  # imported here: scipy.stats costs ~0.8 s to import

    return qmc.QMCEngine


def _label(cls: type) -> str:
    if issubclass(cls, Independent):
        return "independent"
    if issubclass(cls, PaddedStratified):
        return "stratified"
    return cls.__name__ if issubclass(cls, PointSet) else f"scipy {cls.__name__}"


def _named(name: str) -> tuple[str, type]:
    """(canonical name, class) of a :func:`make_points` name; ``"stratified"`` is padded here."""
    from .names import canonical
    from .tools import POINT_SETS  # late import: tools imports every engine module

    key = canonical(name, "points")
    return key, PaddedStratified if key == "stratified" else POINT_SETS[key]


class SetSampler:
    """Independent randomised copies of an ``n``-point set in ``d`` dimensions, in batches.

    ``SetSampler(points, d, n, rng=...)`` then ``draw(count, gen) -> (count, n, d)`` float64
    in [0, 1), all randomness of a call from the caller's ``Generator`` ``gen`` (one
    ``gen.random`` call, set after set, so blocks can be split freely).  ``points``:

    * ``None``, ``"independent"`` (or an alias of :func:`make_points`), the class
      ``Independent`` or an instance: i.i.d., exactly ``gen.random((count, n, d))``;
    * ``"stratified"`` (or ``"jittered"``), the class :class:`PaddedStratified` (built as
      ``PaddedStratified(d, groups, rng=rng)``) or an instance: its ``random_sets``;
    * any other name of :func:`make_points`, vrlab point-set class or ``scipy.stats.qmc``
      engine class: built once as ``cls(d, rng=rng)``, with ``scramble=True`` where the
      class takes ``scramble`` (Sobol, Halton, ...), used as :class:`ShiftedCopies`;
    * an engine instance (vrlab or SciPy) of dimension ``d``: :class:`ShiftedCopies` of its
      first ``n`` points (a :class:`ShiftedCopies` instance is used as it is).

    The shared set is drawn here, so a pickled sampler (sent to worker processes) draws
    the same values.  ``rng`` seeds the built engine only (an int seeds a vrlab engine
    directly, ``default_rng(rng)``).  ``groups`` goes to :class:`PaddedStratified`.
    Checked: ``d``, ``n`` integers >= 1; ``points`` (``TypeError``; ``ValueError`` for an
    unknown name or an instance of another dimension); ``groups`` only with the padded
    set; in :meth:`draw` ``count`` an integer >= 0 and ``gen`` a ``Generator``.
    """

    def __init__(self, points: Any, d: int, n: int, *, rng: RNGLike = None, groups: Any = None) -> None:
        self.d = checks.integer(d, "d", low=1, high=PointSet.MAXDIM)
        self.n = checks.integer(n, "n", low=1, high=MAX_POINTS)
        as_generator(rng)                                  # checks rng (names it)
        self.label, self.engine = self._resolve(points, rng, groups)
        if isinstance(self.engine, ShiftedCopies):
            try:
                self.engine.points(self.n)                 # drawn now, not lazily in a worker
            except ValueError as exc:
                raise ValueError(f"points: {exc}") from None

    @property
    def iid(self) -> bool:
        """True for i.i.d. samples, where the standard error ``s / sqrt(n)`` is valid."""
        return self.engine is None

    def _resolve(self, points: Any, rng: RNGLike, groups: Any) -> tuple[str, Any]:
        given, label = points, None
        if isinstance(points, str):
            label, points = _named(points)
        if groups is not None and not (isinstance(points, type) and issubclass(points, PaddedStratified)):
            raise TypeError("groups: only used when points is \"stratified\" or the class PaddedStratified, "
                            f"got points={checks.describe(given)}")
        if points is None:
            return "independent", None
        if isinstance(points, type):
            usable = issubclass(points, PointSet) or issubclass(points, _scipy_engine_type())
            if not usable or inspect.isabstract(points) or points is PointSet or issubclass(points, ShiftedCopies):
                raise TypeError(f"points: {points.__name__} is not a point-set class that can be built "
                                "as cls(d, rng=...)")
            label = label or _label(points)
            if issubclass(points, Independent):
                return label, None
            if issubclass(points, PaddedStratified):
                return label, points(self.d, groups, rng=rng)
            scramble = {"scramble": True} if "scramble" in inspect.signature(points).parameters else {}
            # the copies' shifts come from draw's gen, so ShiftedCopies' own generator is unused
            return label, ShiftedCopies(points(self.d, rng=rng, **scramble), rng=0)
        if isinstance(points, PointSet) or isinstance(points, _scipy_engine_type()):
            if points.d != self.d:
                raise ValueError(f"points: the engine has dimension {points.d}, but d = {self.d}")
            if isinstance(points, Independent):
                return "independent", None
            engine = points if isinstance(points, (PaddedStratified, ShiftedCopies)) else ShiftedCopies(points, rng=0)
            return _label(type(points)), engine
        raise TypeError("points must be None, a point-set name, a point-set class (vrlab or scipy.stats.qmc) "
                        f"or an engine instance, got {checks.describe(points)}")

    def draw(self, count: int, gen: np.random.Generator) -> np.ndarray:
        """The next ``count`` independent copies ``(count, n, d)`` from ``gen``."""
        count = checks.integer(count, "count", low=0)
        gen = _generator(gen, "gen")
        if self.engine is None:
            return gen.random((count, self.n, self.d))
        return self.engine.random_sets(count, self.n, gen)

    def __repr__(self) -> str:
        return f"SetSampler({self.label!r}, d={self.d}, n={self.n})"
