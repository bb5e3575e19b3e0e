"""Predicted variances by quadrature, for integrands/distributions without a closed form.

For importance sampling with density p, one term f(X)/p(X) has
Var = int f^2 / p dmu - I^2 (Veach 1997, eq. 2.8 ff.).  ``mc_variance`` evaluates
that integral with composite Gauss–Legendre on the domain's chart
(:mod:`vrlab.distributions.charts`, :mod:`vrlab.distributions.quadrature`: the same quadrature the
chi-square harness uses).  Where p = 0 but f != 0 the estimator is
biased and the variance is reported as ``inf``.

With point masses (``integrand.atoms``, weights c_k at a_k) the integral is over the mixed
measure mu = length + counting on the atoms and every density is w.r.t. mu
(:mod:`vrlab.distributions.point_masses`): Var = int_{off atoms} f^2 / p dx + sum_k c_k^2 / m_k
- I^2, m_k the probability that the distribution produces a_k (``inf`` if some m_k = 0 with
c_k != 0).  A distribution whose pdf at an atom is not m_k (a plain continuous density: its
density w.r.t. length) is refused with ``ValueError``, as the estimators refuse it.
"""
from __future__ import annotations

import numpy as np

from ..distributions.charts import BoxChart, DiskChart, HemisphereChart, SphereChart
from ..distributions.quadrature import cell_integrals
from .base import Integrand


def chart_for(integrand: Integrand):
    """The chart that parameterises the integrand's domain."""
    if integrand.bounds is not None:
        if integrand.dim > 2:
            raise ValueError("quadrature of predicted variances is available for 1D and 2D boxes only")
        return BoxChart(integrand.bounds)
    return {"sphere": SphereChart, "hemisphere": HemisphereChart, "disk": DiskChart}[integrand.domain]()


def mc_variance(integrand: Integrand, distribution=None, *, bins: int | None = None, quad: int = 8,
                sub: int = 2) -> float:
    """Var of f(X)/p(X) for X ~ ``distribution`` (default uniform), by quadrature."""
    dist = integrand.uniform() if distribution is None else distribution
    chart = chart_for(integrand)
    nb = bins or (400 if chart.p == 1 else 96)

    atoms = integrand.atoms

    def g(x):
        f = integrand.continuous(x) if atoms else integrand(x)
        p = np.asarray(dist.pdf(x), float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(f != 0, np.where(p > 0, f * f / p, np.inf), 0.0)

    second = float(cell_integrals(g, chart, (nb,) * chart.p, quad, sub).sum())
    if atoms:
        from ..distributions.point_masses import check_atom_densities

        mass = check_atom_densities(dist, integrand.atom_points, "distribution", "mc_variance")
        c = integrand.atom_weights
        with np.errstate(divide="ignore"):
            second += float(np.sum(np.where(c != 0, np.where(mass > 0, c * c / mass, np.inf), 0.0)))
    exact = integrand.exact
    if exact is None:
        fn = integrand.continuous if atoms else integrand
        exact = float(cell_integrals(fn, chart, (nb,) * chart.p, quad, sub).sum())
        exact += float(np.sum(integrand.atom_weights)) if atoms else 0.0
    return second - exact**2
