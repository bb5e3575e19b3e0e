"""Common random numbers: estimate a difference int f_a - int f_b with shared uniforms (lecture 000, "CRN").

With the same uniforms for both integrands (``common=True``) each unit value is
D = Y_a(u) - Y_b(u), Y = the wrapped estimator's unit value (f/p for Monte Carlo), and

    Var[D] = Var[Y_a] + Var[Y_b] - 2 Cov[Y_a, Y_b],

which is small when f_a and f_b move together (image gradients in gradient-domain
rendering, two nearby pixels, a scene before and after an edit).  With independent
uniforms (``common=False``: the unit uses 2d uniforms, the first d for f_a, the rest for
f_b) the covariance term is zero.  Both are unbiased; the standard error comes from the
unit differences, so it is valid either way (Owen, *Monte Carlo theory, methods and
examples*, ch. 8, common random numbers).

``n`` counts evaluations of *both* integrands: one unit costs 2 x the wrapped estimator's
``evals_per_unit``.  ``Estimate.extra`` reports each integral with its standard error and
the sample covariance/correlation of the unit values.
"""
from __future__ import annotations

import time
from typing import Any

import numpy as np

from .._rng import RNGLike, as_generator
from ..estimate import Estimate
from .base import DEFAULT_CHUNK, Estimator, as_integrand, check_chunk, uniform_blocks
from .regression import CoMoments


def _scalar(a):
    a = np.asarray(a, dtype=float)
    return float(a) if a.ndim == 0 else a


def _pair(integrands) -> tuple:
    if not isinstance(integrands, (tuple, list)) or len(integrands) != 2:
        raise TypeError("integrand: CRNDifference estimates int f_a - int f_b and takes a pair "
                        f"(integrand_a, integrand_b), got {type(integrands).__name__}")
    return tuple(as_integrand(f, f"integrand[{i}]") for i, f in enumerate(integrands))


class CRNDifference(Estimator):
    """Difference of two integrals with common (or independent) random numbers.

    Parameters
    ----------
    estimator : the estimator applied to each integrand (default
        :class:`~vrlab.estimators.MonteCarlo`); it must be an average of i.i.d. unit
        values (``MonteCarlo``, ``Antithetic``, ...), not one that overrides ``estimate``.
    common : ``True`` (default) feeds the same uniforms to both integrands;
        ``False`` uses independent uniforms (the baseline).

    ``estimate((integrand_a, integrand_b), n, ...)``: ``n`` counts evaluations of both.
    """

    per_unit = False

    def __init__(self, estimator: Estimator | None = None, common: bool = True):
        if estimator is not None:
            if not isinstance(estimator, Estimator):
                raise TypeError(f"estimator: expected a vrlab Estimator, got {type(estimator).__name__}")
            if (not estimator.per_unit or int(estimator.min_units) > 1
                    or type(estimator).unit_values is Estimator.unit_values):
                raise TypeError(f"estimator: {type(estimator).__name__} is not an average of i.i.d. unit values "
                                "(per_unit, unit_values, min_units 1 in the estimator protocol); use MonteCarlo, "
                                "Antithetic or another unit-value estimator")
        if not isinstance(common, (bool, np.bool_)):
            raise TypeError(f"common: expected a bool, got {common!r}")
        self.estimator = estimator
        self.common = bool(common)

    @property
    def base(self) -> Estimator:
        if self.estimator is None:
            from .importance import MonteCarlo
            return MonteCarlo()
        return self.estimator

    @property
    def evals_per_unit(self) -> int:  # type: ignore[override]
        return 2 * self.base.evals_per_unit

    @property
    def label(self) -> str:
        return f"CRNDifference[{self.base.label}, {'common' if self.common else 'independent'}]"

    def check(self, integrand) -> None:
        a, b = _pair(integrand)
        self.base.check(a)
        self.base.check(b)
        if self.common and self.base.dim_u(a) != self.base.dim_u(b):
            raise ValueError(f"integrand: common random numbers need the same number of uniforms per sample "
                             f"for both integrands, got {self.base.dim_u(a)} and {self.base.dim_u(b)}")

    def dim_u(self, integrand) -> int:
        a, b = _pair(integrand)
        da, db = self.base.dim_u(a), self.base.dim_u(b)
        return da if self.common else da + db

    def _both(self, integrand, u) -> tuple[np.ndarray, np.ndarray]:
        a, b = _pair(integrand)
        base = self.base
        if self.common:
            return base.unit_values(a, u), base.unit_values(b, u)
        da = base.dim_u(a)
        return base.unit_values(a, u[..., :da]), base.unit_values(b, u[..., da:])

    def unit_values(self, integrand, u: np.ndarray) -> np.ndarray:
        ya, yb = self._both(integrand, u)
        return ya - yb

    def estimate(self, integrand, n: int, *, rng: RNGLike = None, points: Any = None,
                 chunk: int = DEFAULT_CHUNK) -> Estimate:
        """Estimate int f_a - int f_b for ``integrand = (f_a, f_b)`` with ``n`` evaluations in all."""
        integrand, chunk = _pair(integrand), check_chunk(chunk)
        self.check(integrand)
        m = self.units_for(n)
        gen = as_generator(rng)
        t0 = time.perf_counter()
        mom = CoMoments()
        for u in uniform_blocks(points, self.dim_u(integrand), m, gen, chunk):
            ya, yb = self._both(integrand, u)
            ya, yb = np.broadcast_arrays(ya, yb)
            mom.add(np.stack([ya, yb], -1))
        cov = mom.covariance
        va, vb, cab = cov[..., 0, 0], cov[..., 1, 1], cov[..., 0, 1]
        var = np.maximum(va + vb - 2 * cab, 0.0)          # = sample variance of the differences
        k = mom.count
        with np.errstate(divide="ignore", invalid="ignore"):
            corr = np.where((va > 0) & (vb > 0), cab / np.sqrt(va * vb), 0.0)
        extra = {"common": self.common, "value_a": _scalar(mom.mean[..., 0]), "value_b": _scalar(mom.mean[..., 1]),
                 "stderr_a": _scalar(np.sqrt(va / k)), "stderr_b": _scalar(np.sqrt(vb / k)),
                 "var_a": _scalar(va), "var_b": _scalar(vb), "cov": _scalar(cab), "corr": _scalar(corr)}
        return Estimate(_scalar(mom.mean[..., 0] - mom.mean[..., 1]), _scalar(np.sqrt(var / k)), k,
                        k * self.evals_per_unit, time.perf_counter() - t0, _scalar(var), self.label, extra)


def crn_difference(integrand_a, integrand_b, n: int, *, estimator: Estimator | None = None,
                   rng: RNGLike = None, points: Any = None, common: bool = True) -> Estimate:
    """Estimate ``int f_a - int f_b`` with ``n`` evaluations in all (``n/2`` of each integrand).

    ``common=True`` shares the uniforms (CRN), ``False`` draws them independently.
    See :class:`CRNDifference`.
    """
    return CRNDifference(estimator, common=common).estimate((integrand_a, integrand_b), n, rng=rng, points=points)
