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
from ..distributions.base import checked_pdf
from ..estimate import Estimate, Moments
from ..integrands.lookup import as_integrand
from .hooks import CORE, RENDER_HOOKS, RenderHooks

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
        # fast path: draws from the caller's generator itself, the numbers point_engine(None, d,
        # rng) would give, without building it (its private copy of the generator state costs
        # ~0.5 ms); a public Independent(d, rng=rng) would spawn a child of rng (SciPy's habit).
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
    """True when ``points`` gives i.i.d. uniforms: :func:`vrlab.points.names.is_independent`,
    the one resolver (None, an array, a name or alias of ``independent``, ``Independent``)."""
    from ..points.names import is_independent

    return is_independent(points)


class Estimator(RenderHooks):
    """Base class, the estimator protocol, and the extension hook for a user's own estimator.

    Everything the lab, the renderer, checkpoints and ``--compare`` ask of an estimator is
    here, with a default (``docs/design.md``, "The estimator protocol"), in two parts.  The
    **core** (``Estimator.CORE``), which the lab and the renderer share:

    =========================  ===============================================================
    ``dim_u(integrand)``       uniforms per sample unit (abstract)
    ``unit_values(f, u)``      ``u (*batch, m, dim_u)`` -> m independent unbiased unit values
                               ``(*batch, m)`` (abstract for averaging estimators)
    ``check``, ``unit_dim``    validation against an integrand; a unit's uniforms (``dim_u``)
    ``unit_outputs(f, u)``     columns per unit ``(*batch, m, c)``, column 0 the value
                               (default: the unit values as one column)
    ``accumulate(outputs)``    mergeable statistics of m units (default :class:`Moments` of
                               column 0); statistics have ``count``, ``merge``, ``state()``,
                               ``from_state``, ``concat``
    ``summarize(stats)``       ``(estimate, standard error)`` (default: mean, sqrt(s^2 / m))
    ``details(stats)``         extra fields of an ``Estimate`` (per-unit ``variance``, fitted
                               coefficients...)
    ``statistics_from_state``  the statistics of a saved ``state()`` (checkpoints)
    ``fold``, ``units_for``,   the fold of unit outputs, units for n evaluations, the whole
    ``estimate``,              estimate and its ``Estimate``
    ``to_estimate``
    ``evals_per_unit``         integrand evaluations per unit: the cost ``n`` counts
    ``min_units``              units one fold needs (a pixel's spp at least this)
    ``per_unit``               True when the estimate is the fold of independent units, so
                               it can run one unit at a time (the renderer's shading points)
    ``get_params``/``clone``   settings (scikit-learn's convention); ``label``: the name
    =========================  ===============================================================

    and the **renderer's hooks** (``Estimator.RENDER_HOOKS``, inherited from
    :class:`~vrlab.estimators.hooks.RenderHooks`, which documents them): ``add_emitted``,
    ``traced_per_unit()``, ``candidates_per_unit``, ``closed_form_per_unit`` (the renderer's
    cost model) and ``spatial`` with ``spatial_check``/``spatial_dim``/``spatial_outputs``
    (reuse across the pixels of a block, ReSTIR).  The lab asks for no hook.

    ``estimate`` goes through ``unit_outputs`` -> ``accumulate`` -> ``merge`` ->
    ``summarize``, the same code the renderer runs per pixel.  Estimators that are not a fold
    of independent units (stratified, RQMC, Metropolis chains, pairs of integrands) set
    ``per_unit = False`` and override ``estimate``.  Settings are keyword arguments of
    ``__init__`` stored under their own names (``get_params``/``clone``, as scikit-learn);
    :func:`vrlab.testing.check_estimator` checks a new estimator against this protocol.

    Distributions may be given by name (``"light"``): the integrand's technique of that
    name (:meth:`vrlab.Integrand.technique`), resolved at every call.
    """

    evals_per_unit: int = 1
    #: True when ``estimate`` is the fold of independent sample units, so the estimator can
    #: run one unit at a time (the renderer does, at each shading point); False for
    #: estimators that need the whole sample set (strata, replicates, chains, pairs of integrands)
    per_unit: bool = True
    #: sample units one fold needs (fitted coefficients need more than one)
    min_units: int = 1
    #: the two parts of the protocol, by name (:mod:`vrlab.estimators.hooks`)
    CORE, RENDER_HOOKS = CORE, RENDER_HOOKS

    # -- scikit-learn style settings ----------------------------------------------------
    def get_params(self) -> dict:
        """The constructor settings, by name."""
        sig = inspect.signature(type(self).__init__)
        return {k: getattr(self, k) for k in sig.parameters
                if k != "self" and sig.parameters[k].kind not in (inspect.Parameter.VAR_POSITIONAL,
                                                                  inspect.Parameter.VAR_KEYWORD)
                and hasattr(self, k)}

    def clone(self) -> "Estimator":
        """A new estimator of the same class with the same settings (``type(self)(**get_params())``)."""
        return type(self)(**self.get_params())

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
        """What :meth:`accumulate` combines, per unit: ``(*batch, m, c)``, column 0 the unit's
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

    def details(self, stats) -> dict:
        """Extra fields of the ``Estimate`` from the statistics: ``"variance"`` (per unit,
        so stderr^2 = variance / n) and anything technique-specific (``Estimate.extra``)."""
        return {"variance": stats.variance}

    def statistics_from_state(self, state: dict):
        """The statistics object of :meth:`accumulate` saved as ``stats.state()`` (checkpoints)."""
        return Moments.from_state(state)

    def fold(self, outputs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(estimate, standard error)`` from the unit outputs ``(*batch, m, c)`` of m units."""
        return self.summarize(self.accumulate(outputs))

    def units_for(self, n: int) -> int:
        n = check_n(n)
        m = n // self.evals_per_unit
        need = max(2, int(self.min_units))
        if m < need:
            raise ValueError(f"n: {self.label} needs n >= {need * self.evals_per_unit} evaluations "
                             f"({need} sample units) for a standard error, got {n}")
        return m

    def estimate(self, integrand, n: int, *, rng: RNGLike = None, points: Any = None,
                 chunk: int = DEFAULT_CHUNK) -> Estimate:
        """Estimate ``integrand``'s integral with ``n`` evaluations.

        ``points``: the uniforms' point set (class, name or engine; default
        independent) or an array of uniforms ``(*batch, m, d)``; ``rng`` seeds it.
        The units' outputs go through :meth:`accumulate`, merged chunk after chunk, and
        :meth:`summarize`: the code the renderer runs per pixel.
        """
        integrand, chunk = as_integrand(integrand), check_chunk(chunk)
        self.check(integrand)
        m = self.units_for(n)
        gen = as_generator(rng) if not isinstance(rng, np.random.Generator) else rng
        t0 = time.perf_counter()
        stats = None
        for u in uniform_blocks(points, self.unit_dim(integrand), m, gen, chunk):
            block = self.accumulate(self.unit_outputs(integrand, u))
            stats = block if stats is None else stats.merge(block)
        return self.to_estimate(stats, time.perf_counter() - t0, points)

    def to_estimate(self, stats, seconds: float = 0.0, points: Any = None) -> Estimate:
        """The :class:`~vrlab.estimate.Estimate` of merged statistics (``summarize`` + ``details``)."""
        value, stderr = self.summarize(stats)
        extra = dict(self.details(stats))
        variance = extra.pop("variance", None)
        if variance is None:
            variance = np.asarray(stderr, float) ** 2 * stats.count
        if not independent_points(points):
            extra["stderr_note"] = STDERR_NOTE
        return Estimate(_plain(value), _plain(stderr), int(stats.count), int(stats.count) * self.evals_per_unit,
                        seconds, _plain(variance), self.label, extra)


def _plain(a):
    """A float for a 0-d result, else a float array (``Estimate``'s convention)."""
    a = np.asarray(a, dtype=float)
    return float(a) if a.ndim == 0 else a


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
    check_dimension(dist, integrand, name)
    return dist


def check_dimension(dist, integrand, name: str = "distribution") -> None:
    """``ValueError`` naming ``name`` when ``dist`` produces points of another dimension than
    the integrand's domain (``dist.dim_x``, or the last axis of one sample when it has none)."""
    want = getattr(integrand, "dim", None)
    if want is None:
        return
    got = getattr(dist, "dim_x", None)
    if got is None:
        try:
            got = np.shape(dist.sample(np.full((1, int(dist.dim_u)), 0.5)))[-1]
        except Exception:           # a sampler that cannot run on one point: leave it to the estimate
            return
    if int(got) != int(want):
        raise ValueError(f"{name}: {type(dist).__name__} produces {got}-dimensional points but integrand "
                         f"{getattr(integrand, 'name', '')!r} is {want}-dimensional; use a distribution on the "
                         "integrand's domain")


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
    for k, d in enumerate(distributions):
        p = checked_pdf(d, x, label if len(distributions) == 1 else f"{label}[{k}]")
        covered |= (p.reshape(-1, p.shape[-1]).max(0) if p.ndim > 1 else p) > 0
    missed = (f != 0) & ~covered
    if missed.any():
        share = float(np.abs(f[missed]).sum() / np.abs(f).sum())
        warnings.warn(
            f"{label} has zero density on {missed.mean():.1%} of the probed domain where the integrand "
            f"is non-zero (about {share:.1%} of |f|): the estimate is biased (it misses that part of "
            "the integral)", BiasWarning, stacklevel=3)
