"""Predicted variances by quadrature, for integrands/distributions without a closed form.

For importance sampling with density p, one term f(X)/p(X) has
Var = int f^2 / p dmu - I^2 (Veach 1997, eq. 2.8 ff.).  ``mc_variance`` evaluates
that integral with composite Gauss–Legendre on the domain's chart (the same
quadrature the chi-square harness uses).  Where p = 0 but f != 0 the estimator is
biased and the variance is reported as ``inf``.
"""
from __future__ import annotations

import numpy as np

from .base import Integrand


def chart_for(integrand: Integrand):
    """The chart that parameterises the integrand's domain."""
    from ..testing.charts import BoxChart, DiskChart, HemisphereChart, SphereChart  # scipy.stats: lazy

    if integrand.bounds is not None:
        if integrand.dim > 2:
            raise ValueError("quadrature of predicted variances is available for 1D and 2D boxes only")
        return BoxChart(integrand.bounds)
    return {"sphere": SphereChart, "hemisphere": HemisphereChart, "disk": DiskChart}[integrand.domain]()


def mc_variance(integrand: Integrand, distribution=None, *, bins: int | None = None, quad: int = 8,
                sub: int = 2) -> float:
    """Var of f(X)/p(X) for X ~ ``distribution`` (default uniform), by quadrature."""
    from ..testing.chisquare import cell_integrals  # scipy.stats: imported on use

    dist = integrand.uniform() if distribution is None else distribution
    chart = chart_for(integrand)
    nb = bins or (400 if chart.p == 1 else 96)

    def g(x):
        f = integrand(x)
        p = np.asarray(dist.pdf(x), float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(f != 0, np.where(p > 0, f * f / p, np.inf), 0.0)

    second = float(cell_integrals(g, chart, (nb,) * chart.p, quad, sub).sum())
    exact = integrand.exact
    if exact is None:
        exact = float(cell_integrals(integrand, chart, (nb,) * chart.p, quad, sub).sum())
    return second - exact**2
