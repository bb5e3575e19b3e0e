"""What every estimator shares: settings as keyword arguments, uniforms in, ``Estimate`` out.

An estimator turns blocks of uniforms ``u (*batch, m, d)`` into ``m`` independent,
unbiased *unit values* (one per sample point, pair, or group) with
``unit_values(integrand, u)``; ``estimate`` draws the uniforms from a point set in
chunks, folds the unit values into mergeable moments (``vrlab.estimate.Moments``)
and reports the mean and its standard error.  ``n`` always counts integrand
evaluations, so estimators compare at equal cost.
"""
from __future__ import annotations

import inspect
import time
import warnings
from typing import Any, Iterator

import numpy as np

from .. import checks
from .._rng import RNGLike, as_generator
from ..estimate import Estimate, Moments
from ..integrands.base import as_integrand

DEFAULT_CHUNK = 1 << 18  # sample units per chunk: bounded memory for any n


class BiasWarning(UserWarning):
    """The sampling density is zero where the integrand is not: the estimate is biased."""


def point_engine(points: Any, d: int, rng: RNGLike):
    """A point-set engine of dimension ``d`` from ``points`` (None, a class, a name or an engine).

    A vrlab engine built here from a ``Generator`` draws from that generator itself
    (``SharedGenerator``), not from a spawned child as a public ``Independent(d, rng=gen)``
    would: an estimator's engines share its stream, as the fast path of :func:`uniform_blocks`
    does, so an estimate's numbers for a seed are those of the estimator's generator.
    """
    from ..points import Independent, PointSet, make_points
    from ..points.base import SharedGenerator

    own = SharedGenerator(rng) if isinstance(rng, np.random.Generator) else rng
    if points is None:
        return Independent(d, rng=own)
    if isinstance(points, str):
        return make_points(points, d, rng=own)
    if isinstance(points, type):
        return points(d, rng=own if issubclass(points, PointSet) else rng)
    if callable(getattr(points, "random", None)):
        if getattr(points, "d", d) != d:
            raise ValueError(f"points: the engine has d = {points.d}, but this estimator needs d = {d} "
                             "uniforms per sample unit")
        return points
    raise TypeError("points: expected None, a point-set class or name, an engine with random(n), "
                    f"or an array of uniforms; got {type(points).__name__}")


def uniform_blocks(points: Any, d: int, m: int, rng: RNGLike, chunk: int = DEFAULT_CHUNK) -> Iterator[np.ndarray]:
    """Yield uniforms for ``m`` sample units of dimension ``d`` in blocks of at most ``chunk``.

    An array ``points`` of shape ``(*batch, m, d)`` is used as-is (one block).  Point
    sets whose size is part of their design (``extensible = False``: stratified, Latin
    hypercube, Hammersley) are drawn in one call so their structure is kept.
    """
    chunk = check_chunk(chunk)
    if isinstance(points, np.ndarray):
        if points.ndim < 2 or points.shape[-1] != d or points.shape[-2] != m:
            raise ValueError(f"points: an array of uniforms must have shape (*batch, {m}, {d}), got {points.shape}")
        yield checks.uniforms_array(points, "points", d=d)
        return
    if points is None and isinstance(rng, np.random.Generator):
        # fast path: draws from the caller's generator itself, the same numbers as the engine
        # point_engine(None, d, rng) would give (it shares rng too), without building it (its
        # private copy of the generator state costs ~0.5 ms per estimate).  A public
        # Independent(d, rng=rng) would spawn a child of rng instead (SciPy's convention).
        done = 0
        while done < m:
            k = min(chunk, m - done)
            yield rng.random((k, d))
            done += k
        return
    engine = point_engine(points, d, rng)
    if not getattr(engine, "extensible", True):
        chunk = m
    done = 0
    while done < m:
        k = min(chunk, m - done)
        yield np.asarray(engine.random(k), dtype=float)
        done += k


STDERR_NOTE = ("stderr uses the i.i.d. formula but the points are not independent (stratified/QMC): "
               "it is not a valid error bar (usually far too large); use RQMC replicates for one")


def independent_points(points: Any) -> bool:
    """True when ``points`` gives i.i.d. uniforms (None, "independent", or an Independent engine)."""
    from ..points import Independent

    if points is None or isinstance(points, np.ndarray):
        return True  # arrays are the caller's uniforms: assumed independent, as documented
    if isinstance(points, str):
        return points.lower() in ("independent", "iid", "random")
    return points is Independent or isinstance(points, Independent)


class Estimator:
    """Base class, and the extension hook for a user's own estimator.

    A subclass sets ``evals_per_unit`` (integrand evaluations per sample unit) and
    implements ``dim_u(integrand)`` (uniforms per unit) and ``unit_values(integrand, u)``:
    uniforms ``u (*batch, m, dim_u)`` to ``m`` independent unbiased unit values
    ``(*batch, m)``.  That is all ``estimate`` and the renderer need (the renderer calls
    it once per shading point, batched).  Estimators whose estimate is not a mean of unit
    values (regression control variates) also override ``unit_outputs`` (columns per
    unit) and ``fold`` (the estimate from a set of columns); estimators that are neither
    (stratified, RQMC, Metropolis chains) override ``estimate`` only.

    Distributions may be given by name (``"light"``): the integrand's technique of that
    name (:meth:`vrlab.Integrand.technique`), resolved at every call.
    """

    evals_per_unit: int = 1
    #: True when ``estimate`` is the fold of independent sample units, so the estimator can
    #: run one unit at a time (the renderer does, at each shading point); False for
    #: estimators that need the whole sample set (strata, replicates, chains, pairs of integrands)
    per_unit: bool = True

    # -- scikit-learn style settings ----------------------------------------------------
    def get_params(self) -> dict:
        """The constructor settings, by name."""
        sig = inspect.signature(type(self).__init__)
        return {k: getattr(self, k) for k in sig.parameters if k != "self" and hasattr(self, k)}

    def __repr__(self) -> str:
        params = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({params})"

    @property
    def label(self) -> str:
        return type(self).__name__

    # -- the work ------------------------------------------------------------------------
    def dim_u(self, integrand) -> int:  # pragma: no cover - interface
        raise NotImplementedError  # abstract

    def unit_values(self, integrand, u: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError  # abstract

    def check(self, integrand) -> None:
        """Hook: validate settings against the integrand (warn about bias, shapes...)."""

    def unit_dim(self, integrand) -> int:
        """Uniforms of one sample unit, as ``unit_values`` takes them (``dim_u`` unless a
        unit holds several samples of different techniques, as in MIS)."""
        return int(self.dim_u(integrand))

    def unit_outputs(self, integrand, u: np.ndarray) -> np.ndarray:
        """What :meth:`fold` combines, per unit: ``(*batch, m, c)``, column 0 the unit's
        value (terms common to every technique, like a pixel's emitted light, are added
        there).  Default: the unit values as one column."""
        return self.unit_values(integrand, u)[..., None]

    def accumulate(self, outputs: np.ndarray):
        """Mergeable statistics of the unit outputs ``(*batch, m, c)`` of m units (``merge``
        combines those of disjoint sets of units, Chan et al.'s update): for averaging
        estimators the :class:`~vrlab.estimate.Moments` of column 0."""
        return Moments().add(np.asarray(outputs)[..., 0])

    def summarize(self, stats) -> tuple[np.ndarray, np.ndarray]:
        """``(estimate, standard error)`` from :meth:`accumulate`'s statistics (merged or not):
        the mean and sqrt(s^2 / m)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.asarray(stats.mean), np.sqrt(stats.variance / stats.count)

    def fold(self, outputs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(estimate, standard error)`` from the unit outputs ``(*batch, m, c)`` of m units."""
        return self.summarize(self.accumulate(outputs))

    def units_for(self, n: int) -> int:
        n = check_n(n)
        m = n // self.evals_per_unit
        if m < 2:
            raise ValueError(f"n: {type(self).__name__} needs n >= {2 * self.evals_per_unit} evaluations "
                             f"(2 sample units) for a standard error, got {n}")
        return m

    def estimate(self, integrand, n: int, *, rng: RNGLike = None, points: Any = None,
                 chunk: int = DEFAULT_CHUNK) -> Estimate:
        """Estimate ``integrand``'s integral with ``n`` evaluations.

        ``points``: the uniforms' point set (class, name or engine; default
        independent) or an array of uniforms ``(*batch, m, d)``; ``rng`` seeds it.
        """
        integrand, chunk = as_integrand(integrand), check_chunk(chunk)
        self.check(integrand)
        m = self.units_for(n)
        gen = as_generator(rng) if not isinstance(rng, np.random.Generator) else rng
        t0 = time.perf_counter()
        mom = Moments()
        for u in uniform_blocks(points, self.dim_u(integrand), m, gen, chunk):
            mom.add(self.unit_values(integrand, u))
        extra = {} if independent_points(points) else {"stderr_note": STDERR_NOTE}
        return Estimate.from_moments(mom, mom.count * self.evals_per_unit, time.perf_counter() - t0, self.label,
                                     **extra)


def ratio(num: Any, den: Any) -> np.ndarray:
    """``num / den`` broadcast, 0 where ``den <= 0`` or ``den`` is NaN: the importance weight
    f / p at points where the density vanishes is 0 (samples never land there; this guards
    rounding).  float32 operands (the renderer's) stay float32, anything else is float64."""
    dtype = np.result_type(num, den)          # Python numbers are weak: float32 stays float32
    dtype = dtype if dtype in (np.float32, np.float64) else np.dtype(np.float64)
    num, den = np.asarray(num, dtype=dtype), np.asarray(den, dtype=dtype)
    return np.divide(num, den, out=np.zeros(np.broadcast_shapes(num.shape, den.shape), dtype), where=den > 0)


def check_chunk(chunk: Any) -> int:
    """``chunk`` (sample units per block of uniforms): an integer >= 1."""
    return checks.integer(chunk, "chunk", low=1)


def check_n(n: Any) -> int:
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)):
        raise TypeError(f"n must be an integer number of evaluations, got {n!r}")
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    return int(n)


def check_technique(value: Any, name: str = "distribution"):
    """A distribution (``dim_u``, ``sample``, ``pdf``) or the name of an integrand's
    technique (a non-empty str, resolved per integrand by :func:`resolve_distribution`)."""
    if isinstance(value, str):
        if not value:
            raise ValueError(f"{name}: a technique name must not be empty")
        return value
    return checks.distribution(value, name)


def technique_label(value: Any) -> str:
    """A short name of a distribution or technique name, for estimator labels."""
    return value if isinstance(value, str) else type(value).__name__


def resolve_distribution(distribution, integrand, name: str = "distribution"):
    """``distribution``; a name: the integrand's technique of that name; None: the uniform
    distribution on the integrand's domain."""
    if distribution is None:
        dist = integrand.uniform()
    elif isinstance(distribution, str):
        dist = integrand.technique(distribution, name)
    else:
        dist = distribution
    for attr in ("dim_u", "sample", "pdf"):
        if not hasattr(dist, attr):
            raise TypeError(f"distribution: {dist!r} has no {attr!r} (needs dim_u, sample, pdf)")
    return dist


def support_probe(integrand, distributions, n: int = 4096, label: str = "distribution") -> None:
    """Warn (``BiasWarning``) if every density is zero somewhere the integrand is not.

    Probes a fixed scrambled-Sobol sample of the integrand's domain; a cheap check
    that catches the common mistake (e.g. sampling a hemisphere for a sphere
    integrand, or an interval that misses part of the support), not a proof.
    """
    from ..points import Sobol

    probe = integrand.uniform()
    x = probe.sample(Sobol(probe.dim_u, rng=12345).random(n))
    f = np.asarray(integrand(x))
    if f.ndim > 1:  # batched integrand: probe where any batch element is non-zero
        f = np.abs(f).reshape(-1, f.shape[-1]).max(0)
    covered = np.zeros(x.shape[:-1], bool)
    for d in distributions:
        p = np.asarray(d.pdf(x))
        covered |= (p.reshape(-1, p.shape[-1]).max(0) if p.ndim > 1 else p) > 0
    missed = (f != 0) & ~covered
    if missed.any():
        share = float(np.abs(f[missed]).sum() / np.abs(f).sum())
        warnings.warn(
            f"{label} has zero density on {missed.mean():.1%} of the probed domain where the integrand "
            f"is non-zero (about {share:.1%} of |f|): the estimate is biased (it misses that part of "
            "the integral)", BiasWarning, stacklevel=3)
