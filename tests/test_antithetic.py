"""Antithetic variates: unbiasedness, calibrated stderr and predicted variance on every catalogue
integrand, the e^x golden factor 1 + rho = 0.03233, the even-symmetric failure case (variance
doubles), and a broken estimator (forgets the 1/2) caught by the same checks."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

import vrlab.integrands as I
from vrlab.distributions import UniformBox
from vrlab.estimators import MonteCarlo
from vrlab.estimators.antithetic import Antithetic, reflect
from vrlab.integrands import Integrand
from vrlab.testing.stats import std_band, u_nodes

from conftest import CAL_N as N  # evaluations per estimate
from conftest import CAL_R as R  # replicates for calibration
from conftest import check_calibrated, replicate

ALPHA = 1e-3                 # per-check false-alarm rate (several checks per integrand)


def u_moments(fn, d: int) -> tuple[float, float]:
    """(E[Y], Var[Y]) of Y = fn(u), u uniform on [0,1]^d, by composite Gauss-Legendre."""
    u, w = u_nodes(d)
    y = fn(u)
    m1 = float(w @ y)
    return m1, float(w @ (y - m1) ** 2)


def antithetic_theory(integrand) -> tuple[float, float]:
    """sigma^2 of plain MC and the variance of one antithetic pair mean, from the plain
    unit values g(u) = f/p (independent of the Antithetic code): (sigma^2 + Cov(g(u), g(1-u))) / 2."""
    mc = MonteCarlo()
    u, w = u_nodes(mc.dim_u(integrand))
    g, g_ref = mc.unit_values(integrand, u), mc.unit_values(integrand, 1 - u)
    mean = w @ g
    var = w @ (g - mean) ** 2
    cov = w @ ((g - mean) * (g_ref - mean))
    return float(var), float(0.5 * (var + cov))


@pytest.mark.parametrize("name", I.names(atoms=False))
def test_catalogue_unbiased_calibrated_and_predicted(name):
    integrand = I.get(name)
    sigma2, pair_var = antithetic_theory(integrand)
    est = Antithetic()
    # quadrature of the antithetic unit itself: its mean is the integral (no sampling noise)
    mean_q, var_q = u_moments(lambda u: est.unit_values(integrand, u), est.dim_u(integrand))
    assert mean_q == pytest.approx(integrand.exact, rel=2e-4)
    assert var_q == pytest.approx(pair_var, rel=2e-3, abs=1e-10)
    n = 8_000 if name.startswith("glossy-light") else N   # heavy tail (small bright light): more pairs
    check_calibrated(est, integrand, pair_var, n=n)
    # single estimate at a fixed seed
    single = est.estimate(integrand, 20_000, rng=11)
    if pair_var > 0:
        assert abs(single.value - integrand.exact) < 4 * single.stderr


def test_exp_golden_factor():
    """e^x on [0, 1]: plain variance 0.242036, antithetic factor 1 + rho = 0.03233 at equal evaluations."""
    it = I.get("exp")
    assert it.theory["var:uniform"] == pytest.approx(0.242036, abs=1e-6)
    assert it.theory["antithetic_factor"] == pytest.approx(0.03233, abs=1e-5)
    sigma2, pair_var = antithetic_theory(it)
    assert sigma2 == pytest.approx(0.242036, abs=1e-6)
    assert 2 * pair_var / sigma2 == pytest.approx(0.03233, abs=1e-5)
    # measured: per-pair variance x 2 / sigma^2 from one long run (2.5e5 pairs: rel. error ~ 0.3 %)
    e = Antithetic().estimate(it, 500_000, rng=5)
    factor = 2 * e.variance / it.theory["var:uniform"]
    assert factor == pytest.approx(it.theory["antithetic_factor"], rel=0.02)
    # and the variance of replicated estimates at equal evaluations
    anti = replicate(Antithetic(), it, seed=1)
    plain = replicate(MonteCarlo(), it, seed=2)
    ratio = np.var(anti.value, ddof=1) / np.var(plain.value, ddof=1)
    lo, hi = std_band(R)
    assert (lo / hi) ** 2 * 0.03233 < ratio < (hi / lo) ** 2 * 0.03233


def test_even_symmetric_doubles_variance():
    """sin(pi x) on [0, 1] is even about 1/2: pairs are identical, rho = +1, variance x 2 at equal cost."""
    it = Integrand(lambda x: np.sin(np.pi * x[..., 0]), [(0, 1)], 2 / np.pi, "sin-pi")
    u = np.random.default_rng(3).random((50, 1))
    pair = Antithetic().unit_values(it, u)
    np.testing.assert_allclose(pair, np.sin(np.pi * u[:, 0]), rtol=1e-12)   # both members equal
    sigma2 = 0.5 - 4 / np.pi**2
    _, pair_var = antithetic_theory(it)
    assert pair_var == pytest.approx(sigma2, rel=1e-6)          # factor 1 + rho = 2
    anti = check_calibrated(Antithetic(), it, pair_var)
    plain = replicate(MonteCarlo(), it, seed=9)
    ratio = np.var(anti.value, ddof=1) / np.var(plain.value, ddof=1)
    lo, hi = std_band(R)
    assert (lo / hi) ** 2 * 2 < ratio < (hi / lo) ** 2 * 2


@pytest.mark.parametrize("f", [lambda x: x**3, np.exp, lambda x: np.log1p(5 * x), np.sqrt])
def test_monotone_beats_plain(f):
    it = Integrand(lambda x: f(x[..., 0]), [(0, 1)], None, "monotone")
    mc = MonteCarlo()
    s2 = u_moments(lambda u: mc.unit_values(it, u), 1)[1]
    _, pair_var = antithetic_theory(it)
    assert 2 * pair_var < s2                      # 1 + rho < 1 at equal evaluations
    a = Antithetic().estimate(it, 200_000, rng=1)
    p = MonteCarlo().estimate(it, 200_000, rng=1)
    assert a.stderr < p.stderr


def test_linear_is_exact_and_hemisphere_reflection():
    it = Integrand(lambda x: 3 * x[..., 0] + 1, [(0, 2)], 8.0)
    e = Antithetic().estimate(it, 100, rng=0)
    assert e.value == pytest.approx(8.0, rel=1e-12) and e.stderr < 1e-12
    # cos over the uniform hemisphere: z and its reflection sum to 1 -> zero variance
    cos = I.get("cos-hemisphere")
    e = Antithetic().estimate(cos, 1000, rng=0)
    assert e.value == pytest.approx(np.pi, rel=1e-12)


def test_cost_accounting_reflection_and_batches():
    it = I.get("exp")
    e = Antithetic().estimate(it, 1001, rng=0)
    assert e.n == 500 and e.n_evals == 1000
    assert Antithetic.evals_per_unit == 2
    u = np.array([[0.0], [0.25], [0.9]])
    r = reflect(u)
    assert np.all(r < 1.0) and r[1, 0] == 0.75 and r[0, 0] == np.nextafter(1.0, 0.0)
    # batched integrand (*batch, n): value per batch element
    scales = np.array([1.0, 2.0, -3.0])
    batched = Integrand(lambda x: scales[:, None] * np.exp(x[..., 0]), [(0, 1)], scales * (np.e - 1))
    eb = Antithetic().estimate(batched, 20_000, rng=4)
    assert eb.value.shape == (3,) and eb.stderr.shape == (3,)
    assert np.all(np.abs(eb.value - batched.exact) < 4 * eb.stderr)
    np.testing.assert_allclose(eb.stderr, np.abs(scales) * eb.stderr[0], rtol=1e-10)
    # same seed, same number
    assert Antithetic().estimate(it, 1000, rng=7).value == Antithetic().estimate(it, 1000, rng=7).value


def test_importance_distribution_pairs():
    it = I.get("sin")
    est = Antithetic(it.techniques["linear"])
    single = est.estimate(it, 200_000, rng=2)
    assert abs(single.value - 1.0) < 4 * single.stderr
    check_calibrated(est, it, None)


def test_ci_coverage():
    it = I.get("exp")
    e = replicate(Antithetic(), it, n=2000, r=400, seed=21)
    lo, hi = e.ci(0.95)
    covered = np.mean((lo <= it.exact) & (it.exact <= hi))
    band = stats.binom.ppf([ALPHA / 2, 1 - ALPHA / 2], 400, 0.95) / 400
    assert band[0] <= covered <= band[1]


class ForgetsHalf(Antithetic):
    """A broken antithetic estimator: sums the pair instead of averaging it."""

    def unit_values(self, integrand, u):
        return 2.0 * super().unit_values(integrand, u)


class WrongPdf(Antithetic):
    """Uses p = 1 instead of 1 / |domain| on a box that is not the unit interval."""

    def unit_values(self, integrand, u):
        return super().unit_values(integrand, u) / (np.pi / 2)


@pytest.mark.parametrize("bad", [ForgetsHalf(), WrongPdf()])
def test_checks_can_fail(bad):
    it = I.get("sin")
    with pytest.raises(AssertionError):
        check_calibrated(bad, it, antithetic_theory(it)[1])
    e = bad.estimate(it, 20_000, rng=11)
    assert abs(e.value - it.exact) > 4 * e.stderr


def test_distribution_validation():
    it = I.get("exp")
    with pytest.raises(TypeError, match="distribution"):
        Antithetic(distribution=object()).estimate(it, 100, rng=0)
    with pytest.raises(ValueError, match="n"):
        Antithetic().estimate(it, 3, rng=0)
    assert repr(Antithetic(UniformBox([(0, 1)]))).startswith("Antithetic(")
