"""Randomized quasi-Monte Carlo: R independent randomizations of one point set (Owen, ch. 17).

A QMC point set has low discrepancy but no error estimate, and a deterministic set gives
a biased (if very accurate) answer.  Randomizing it so that every point is uniform while
the set keeps its structure -- a Cranley--Patterson rotation (u + v) mod 1 (Cranley &
Patterson 1976), random digit permutations of Halton/Hammersley, scrambled Sobol' nets
(Owen 1995, 1997; Matousek 1998) -- makes each replicate estimate

    I_hat_r = base estimator on the r-th randomized set of n/R points

unbiased, and R independent randomizations give

    I_hat = mean_r I_hat_r,   stderr = s_R / sqrt(R),   s_R^2 = sample variance of the I_hat_r.

Only the spread between replicates is used (the base estimator's own within-set standard
error is meaningless for QMC points).  With few replicates use Student's t with R - 1
degrees of freedom (:func:`t_interval`); R = 10..30 is a good compromise between the
error estimate and the accuracy of each replicate (a replicate's error falls faster than
1/sqrt(n) for smooth integrands, e.g. about n^{-3/2} for scrambled nets, Owen 1997).

Deterministic sets (``Halton(d)``, ``Hammersley(d)``, ``Sobol(d, scramble=False)``) are
**wrapped in a Cranley--Patterson rotation automatically**; ``Estimate.extra``
``["randomization"]`` says so.  Seeds of the replicates come from ``SeedSequence.spawn``
(:meth:`vrlab.points.PointSet.replicate` / :func:`vrlab.points.replicates`).  For Sobol'
use n/R a power of two (SciPy warns otherwise).
"""
from __future__ import annotations

import time
from typing import Any

import numpy as np

from .._rng import RNGLike
from ..estimate import Estimate, Moments
from ..points.base import check_int
from .base import DEFAULT_CHUNK, Estimator, as_integrand, check_chunk, check_n


def _qmc_engine_type() -> type:
    """``scipy.stats.qmc.QMCEngine`` (imported on use: scipy.stats costs ~0.8 s to import)."""
    from scipy.stats import qmc

    return qmc.QMCEngine


def t_interval(estimate: Estimate, level: float = 0.95) -> tuple:
    """Student-t interval ``(lo, hi)`` with ``estimate.n - 1`` degrees of freedom (few replicates)."""
    if not 0 < level < 1:
        raise ValueError(f"level must be in (0, 1), got {level}")
    from scipy import stats

    q = stats.t.ppf(0.5 + level / 2, max(int(estimate.n) - 1, 1))
    v, s = np.asarray(estimate.value), np.asarray(estimate.stderr)
    return v - q * s, v + q * s


class RQMC(Estimator):
    """Randomized QMC: the base estimator on ``replicates`` independently randomized point sets.

    Parameters
    ----------
    base : the estimator run on each replicate (default :class:`~vrlab.estimators.MonteCarlo`).
    replicates : R >= 2 independent randomizations; each gets ``n // R`` evaluations.

    ``estimate(integrand, n, rng=..., points=...)``: ``points`` is the point set to
    randomize -- ``None`` (scrambled :class:`~vrlab.points.Sobol`), a name, a vrlab
    point-set class or instance (e.g. ``Halton(d, scramble=True)``), a
    ``scipy.stats.qmc`` engine class, or a factory ``rng -> engine``.  Deterministic vrlab
    sets get a Cranley--Patterson rotation.  ``Estimate.n`` is R (the independent units).
    """

    per_unit = False

    def __init__(self, base: Estimator | None = None, replicates: int = 16):
        if base is not None and not isinstance(base, Estimator):
            raise TypeError(f"base: expected a vrlab Estimator, got {type(base).__name__}")
        self.base = base
        self.replicates = check_int("replicates", replicates, 2)

    def _base(self) -> Estimator:
        if self.base is None:
            from .importance import MonteCarlo
            return MonteCarlo()
        return self.base

    @property
    def label(self) -> str:
        return f"RQMC[{self._base().label}, R={self.replicates}]"

    def dim_u(self, integrand) -> int:
        return self._base().dim_u(integrand)

    def unit_dim(self, integrand) -> int:
        """The base estimator's uniforms per unit: the dimension of the randomized point sets."""
        return self._base().unit_dim(integrand)

    def check(self, integrand) -> None:
        self._base().check(integrand)

    def engines(self, points: Any, d: int, rng: RNGLike = None) -> tuple[list, str]:
        """R independent randomized engines of dimension ``d`` and how they were randomized."""
        from ..points import CranleyPatterson, PointSet, Sobol, make_points, replicates

        R = self.replicates
        if points is None:
            template = Sobol(d, scramble=True, rng=0)
        elif isinstance(points, PointSet):
            if points.d != d:
                raise ValueError(f"points: the engine has d = {points.d}, but this estimator needs d = {d}")
            template = points
        elif isinstance(points, str):
            template = make_points(points, d, rng=0)
        elif isinstance(points, type) and issubclass(points, PointSet):
            template = points(d, rng=0)
        elif isinstance(points, type) and issubclass(points, _qmc_engine_type()):
            return replicates(points, R, rng=rng, d=d), "scipy"
        elif isinstance(points, _qmc_engine_type()):
            raise TypeError("points: a scipy.stats.qmc engine instance cannot be re-randomized; pass its class "
                            "or a factory rng -> engine")
        elif isinstance(points, np.ndarray):
            raise TypeError("points: RQMC needs a point set to randomize, not an array of uniforms")
        elif callable(points):
            engines = replicates(points, R, rng=rng)
            if engines and getattr(engines[0], "d", d) != d:
                raise ValueError(f"points: the factory makes engines with d = {engines[0].d}, need d = {d}")
            return engines, "factory"
        else:
            raise TypeError("points: expected None, a point-set name, class or instance, a scipy.stats.qmc class, "
                            f"or a factory rng -> engine; got {type(points).__name__}")
        how = "randomized" if template.randomized else "cranley-patterson"
        if not template.randomized:
            template = CranleyPatterson(template, rng=0)
        return template.replicate(R, rng=rng), how

    def unit_values(self, integrand, u):  # pragma: no cover - not an average of i.i.d. units
        raise TypeError("RQMC has no i.i.d. unit values; call estimate()")

    def estimate(self, integrand, n: int, *, rng: RNGLike = None, points: Any = None,
                 chunk: int = DEFAULT_CHUNK) -> Estimate:
        """Mean over R randomized replicates of ``n // R`` evaluations each; stderr across replicates."""
        integrand, chunk = as_integrand(integrand), check_chunk(chunk)
        n = check_n(n)
        base = self._base()
        R = self.replicates
        per = n // R
        least = 2 * base.evals_per_unit
        if per < least:
            raise ValueError(f"n: RQMC with replicates={R} needs n >= {R * least} ({least} evaluations "
                             f"per replicate), got {n}")
        self.check(integrand)
        t0 = time.perf_counter()
        engines, how = self.engines(points, self.unit_dim(integrand), rng)
        values, evals = [], 0
        for engine in engines:
            est = base.estimate(integrand, per, points=engine, chunk=chunk)
            values.append(np.asarray(est.value, float))
            evals += est.n_evals
        mom = Moments().add(np.stack(values, -1))
        return Estimate.from_moments(mom, evals, time.perf_counter() - t0, self.label,
                                     replicates=R, randomization=how, points=repr(engines[0]), dof=R - 1)
