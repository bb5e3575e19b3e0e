"""Common random numbers: Var_CRN = Var_a + Var_b - 2 Cov (closed form on e^x vs e^0.9x),
common < independent for correlated integrands, both unbiased and calibrated on every catalogue
integrand, batched differences (image gradients), and a stderr that ignores the covariance fails."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

import vrlab.integrands as I
from vrlab.estimators import MonteCarlo
from vrlab.estimators.antithetic import Antithetic
from vrlab.estimators.control import ControlVariate
from vrlab.estimators.crn import CRNDifference, crn_difference
from vrlab.integrands import Integrand
from vrlab.testing.stats import u_nodes

from conftest import CAL_N as N  # evaluations per estimate
from conftest import check_calibrated, replicate

ALPHA = 1e-3
E = np.e


def partner(it: Integrand) -> Integrand:
    """A second integrand correlated with ``it``: 0.8 f + h, h = sum of coordinates / z^2."""
    if it.bounds is not None:
        h_int = it.volume * float(np.sum(it.bounds.mean(1)))
        h = lambda x: np.sum(x, -1)  # noqa: E731
    else:
        h_int, h = 2 * np.pi / 3, (lambda w: w[..., 2] ** 2)
    return Integrand(lambda x: 0.8 * it(x) + h(x), it.domain, 0.8 * it.exact + h_int, it.name + "-b")


def crn_theory(a, b):
    """(Var_a, Var_b, Cov) of the plain unit values f/p under shared uniforms, by quadrature."""
    mc = MonteCarlo()
    u, w = u_nodes(mc.dim_u(a))
    ya, yb = mc.unit_values(a, u), mc.unit_values(b, u)
    ma, mb = w @ ya, w @ yb
    return float(w @ (ya - ma) ** 2), float(w @ (yb - mb) ** 2), float(w @ ((ya - ma) * (yb - mb)))


def test_closed_form_exp_pair():
    """f_a = e^x, f_b = e^{0.9x}: Var_a = 0.242036, Var_b, Cov in closed form; Var_CRN = Var_a + Var_b - 2 Cov."""
    a = I.get("exp")
    b = Integrand(lambda x: np.exp(0.9 * x[..., 0]), [(0, 1)], (np.exp(0.9) - 1) / 0.9, "exp09")
    var_a = (E**2 - 1) / 2 - (E - 1) ** 2
    var_b = (np.exp(1.8) - 1) / 1.8 - b.exact**2
    cov = (np.exp(1.9) - 1) / 1.9 - a.exact * b.exact
    assert var_a == pytest.approx(0.242036, abs=1e-6)
    np.testing.assert_allclose(crn_theory(a, b), (var_a, var_b, cov), rtol=1e-9)
    var_crn = var_a + var_b - 2 * cov
    assert var_crn < 0.015 * (var_a + var_b)         # corr = 0.9999: CRN removes > 98.5 %
    e = crn_difference(a, b, 1_000_000, rng=1)
    assert e.n == 500_000 and e.n_evals == 1_000_000
    assert abs(e.value - (a.exact - b.exact)) < 4 * e.stderr
    assert e.extra["var_a"] == pytest.approx(var_a, rel=0.02)
    assert e.extra["var_b"] == pytest.approx(var_b, rel=0.02)
    assert e.extra["cov"] == pytest.approx(cov, rel=0.02)
    assert e.variance == pytest.approx(var_crn, rel=0.02)
    assert e.variance == pytest.approx(e.extra["var_a"] + e.extra["var_b"] - 2 * e.extra["cov"], rel=1e-9)
    ind = crn_difference(a, b, 1_000_000, rng=1, common=False)
    assert ind.variance == pytest.approx(var_a + var_b, rel=0.02)
    assert abs(ind.extra["corr"]) < 0.01
    assert ind.stderr > 8 * e.stderr                 # sqrt(0.4172 / 0.00542) = 8.8
    # replicated: both unbiased and calibrated, with the predicted variances
    check_calibrated(CRNDifference(), (a, b), var_crn, exact=a.exact - b.exact, seed=2)
    check_calibrated(CRNDifference(common=False), (a, b), var_a + var_b, exact=a.exact - b.exact, seed=3)


@pytest.mark.parametrize("name", I.names(atoms=False))
def test_catalogue_common_and_independent(name):
    a = I.get(name)
    b = partner(a)
    va, vb, cov = crn_theory(a, b)
    exact = a.exact - b.exact
    n = 8000 if name.startswith("glossy-light") else N
    crn = check_calibrated(CRNDifference(), (a, b), va + vb - 2 * cov, exact=exact, n=n, seed=4)
    ind = check_calibrated(CRNDifference(common=False), (a, b), va + vb, exact=exact, n=n, seed=5)
    assert cov > 0 and np.var(crn.value) < np.var(ind.value)
    single = crn_difference(a, b, 20_000, rng=6)
    assert abs(single.value - exact) < 4 * single.stderr


def test_antithetic_base_and_cost():
    a, b = I.get("exp"), Integrand(lambda x: np.exp(0.9 * x[..., 0]), [(0, 1)], (np.exp(0.9) - 1) / 0.9)
    est = CRNDifference(Antithetic())
    assert est.evals_per_unit == 4
    e = est.estimate((a, b), 4003, rng=0)
    assert e.n == 1000 and e.n_evals == 4000
    check_calibrated(est, (a, b), exact=a.exact - b.exact, seed=7)
    assert "Antithetic" in est.label and "common" in est.label


def test_batched_image_gradient():
    """Per-pixel differences I(x + 1) - I(x) of a batched 'image' integrand: the stderr map is per pixel."""
    k = np.arange(1, 9, dtype=float)                      # 8 "pixels": f_k(x) = exp(k x / 8)
    img = Integrand(lambda x: np.exp(k[:, None] * x[..., 0] / 8), [(0, 1)], (np.exp(k / 8) - 1) / (k / 8))
    k2 = k + 0.5
    img2 = Integrand(lambda x: np.exp(k2[:, None] * x[..., 0] / 8), [(0, 1)], (np.exp(k2 / 8) - 1) / (k2 / 8))
    e = crn_difference(img2, img, 100_000, rng=3)
    ind = crn_difference(img2, img, 100_000, rng=3, common=False)
    assert e.value.shape == (8,) and e.stderr.shape == (8,)
    exact = img2.exact - img.exact
    assert np.all(np.abs(e.value - exact) < 4 * e.stderr)
    assert np.all(np.abs(ind.value - exact) < 4 * ind.stderr)
    assert np.all(e.stderr < 0.5 * ind.stderr) and np.mean(e.stderr / ind.stderr) < 0.2
    assert np.all(e.extra["corr"] > 0.99)


def test_same_seed_same_number_and_chunks():
    a, b = I.get("smooth-2d"), partner(I.get("smooth-2d"))
    e1 = crn_difference(a, b, 10_000, rng=5)
    e2 = CRNDifference().estimate((a, b), 10_000, rng=5, chunk=777)
    assert e1.value == pytest.approx(e2.value, rel=1e-12)
    assert e1.stderr == pytest.approx(e2.stderr, rel=1e-9)


def test_ci_coverage():
    a, b = I.get("exp"), partner(I.get("exp"))
    e = replicate(CRNDifference(), (a, b), n=1000, r=400, seed=8)
    lo, hi = e.ci(0.95)
    exact = a.exact - b.exact
    covered = np.mean((lo <= exact) & (exact <= hi))
    band = stats.binom.ppf([ALPHA / 2, 1 - ALPHA / 2], 400, 0.95) / 400
    assert band[0] <= covered <= band[1]


class IgnoresCovariance(CRNDifference):
    """The classic mistake: the stderr of a CRN difference as if the two means were independent."""

    def estimate(self, integrand, n, *, rng=None, points=None, chunk=1 << 18):
        e = super().estimate(integrand, n, rng=rng, points=points, chunk=chunk)
        e.stderr = np.sqrt((np.asarray(e.extra["var_a"]) + e.extra["var_b"]) / e.n)
        return e


class SwappedSign(CRNDifference):
    def unit_values(self, integrand, u):
        return -super().unit_values(integrand, u)


def test_checks_can_fail():
    a, b = I.get("exp"), partner(I.get("exp"))
    exact = a.exact - b.exact
    with pytest.raises(AssertionError):
        check_calibrated(IgnoresCovariance(), (a, b), exact=exact, seed=9)
    # a wrong predicted variance (the independent one) is rejected for the common estimator
    va, vb, cov = crn_theory(a, b)
    with pytest.raises(AssertionError):
        check_calibrated(CRNDifference(), (a, b), va + vb, exact=exact, seed=10)
    # b's integrand with the wrong exact value gives a detected bias
    wrong = Integrand(b.f, b.domain, b.exact * 1.01)
    with pytest.raises(AssertionError):
        check_calibrated(CRNDifference(), (a, wrong), exact=a.exact - wrong.exact, seed=11)


def test_bad_inputs():
    a = I.get("exp")
    with pytest.raises(TypeError, match="estimator"):
        CRNDifference(estimator="mc")
    with pytest.raises(TypeError, match="estimator"):
        CRNDifference(ControlVariate(lambda x: x[..., 0], 0.5))
    with pytest.raises(TypeError, match="common"):
        CRNDifference(common="yes")
    with pytest.raises(TypeError, match="integrand"):
        CRNDifference().estimate(a, 100, rng=0)
    with pytest.raises(TypeError, match="integrand"):
        CRNDifference().estimate((a, a, a), 100, rng=0)
    with pytest.raises(ValueError, match="integrand"):
        crn_difference(a, I.get("smooth-2d"), 100, rng=0)
    # independent uniforms work across dimensions
    e = crn_difference(a, I.get("smooth-2d"), 20_000, rng=0, common=False)
    assert abs(e.value - (a.exact - I.get("smooth-2d").exact)) < 4 * e.stderr
    with pytest.raises(ValueError, match="n"):
        crn_difference(a, a, 3, rng=0)
