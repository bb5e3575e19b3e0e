"""Control variates and the Owen--Zhou defensive mixture.

Golden numbers on e^x (h = x: beta* = 1.6903, factor 1 - rho^2 = 0.01628), every
catalogue integrand (unbiased, calibrated stderr, variance = quadrature prediction),
alpha = 1 vs optimal, several controls, batched alpha, the mixture's guarantee
Var <= min_k sigma_k^2 / c_k, and broken inputs (a wrong control integral is caught).
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

import vrlab.integrands as I
from vrlab.distributions import TruncatedNormal
from vrlab.estimators import MonteCarlo
from vrlab.estimators.control import CoMoments, ControlVariate, DefensiveMixture
from vrlab.integrands import Integrand
from vrlab.testing.stats import std_band, u_nodes

from conftest import CAL_N as N  # evaluations per estimate
from conftest import CAL_R as R  # replicates for calibration
from conftest import check_calibrated, replicate

ALPHA = 1e-3


def control_for(integrand):
    """A generic control with a known integral: sum of coordinates on a box, z^2 on the hemisphere."""
    if integrand.bounds is not None:
        b = integrand.bounds
        return (lambda x: np.sum(x, -1)), integrand.volume * float(np.sum(b.mean(1)))
    return (lambda w: w[..., 2] ** 2), 2 * np.pi / 3


def cv_theory(integrand, h):
    """(Var Y, Var(Y - H), Var(Y - alpha* H), alpha*) of Y = f/p, H = h/p under the uniform
    distribution, by quadrature in u-space (independent of the estimator code)."""
    dist = integrand.uniform()
    u, w = u_nodes(dist.dim_u)
    x = dist.sample(u)
    p = dist.pdf(x)
    y, hh = integrand(x) / p, h(x) / p
    my, mh = w @ y, w @ hh
    vy, vh, c = w @ (y - my) ** 2, w @ (hh - mh) ** 2, w @ ((y - my) * (hh - mh))
    return float(vy), float(vy + vh - 2 * c), float(vy - c * c / vh), float(c / vh)


# -- golden numbers -------------------------------------------------------------------------
def test_exp_golden_alpha_and_factor():
    it = I.get("exp")
    th = it.theory
    assert th["cv_x:beta"] == pytest.approx(1.6903, abs=1e-4)
    assert th["cv_x:factor"] == pytest.approx(0.01628, abs=1e-5)
    vy, _, vopt, a_star = cv_theory(it, lambda x: x[..., 0])
    assert a_star == pytest.approx(1.6903, abs=1e-4) and vopt / vy == pytest.approx(0.01628, abs=1e-5)
    e = ControlVariate(lambda x: x[..., 0], 0.5).estimate(it, 1_000_000, rng=3)
    # se(alpha_hat) = sqrt(sigma^2 (1 - rho^2) / (n Var h)) = 2.2e-4
    assert e.extra["alpha"] == pytest.approx(th["cv_x:beta"], abs=1e-3)
    assert e.extra["variance_factor"] == pytest.approx(th["cv_x:factor"], rel=0.02)
    assert e.variance == pytest.approx(th["cv_x:factor"] * th["var:uniform"], rel=0.02)
    assert abs(e.value - it.exact) < 4 * e.stderr
    # replicated estimates at equal n: variance ratio to plain MC = 1 - rho^2
    cv = replicate(ControlVariate(lambda x: x[..., 0], 0.5), it, seed=1)
    plain = replicate(MonteCarlo(), it, seed=2)
    ratio = np.var(cv.value, ddof=1) / np.var(plain.value, ddof=1)
    lo, hi = std_band(R)
    assert (lo / hi) ** 2 * 0.01628 < ratio < (hi / lo) ** 2 * 0.01628
    assert np.all(np.abs(np.asarray(cv.extra["alpha"]) - 1.6903) < 0.1)


# -- every catalogue integrand ----------------------------------------------------------------
@pytest.mark.parametrize("name", I.names(atoms=False))
def test_catalogue_optimal_and_alpha_one(name):
    it = I.get(name)
    h, theta = control_for(it)
    vy, v1, vopt, _ = cv_theory(it, h)
    n = 8000 if name.startswith("glossy-light") else N
    check_calibrated(ControlVariate(h, theta), it, vopt, n=n, seed=1)
    check_calibrated(ControlVariate(h, theta, alpha=1), it, v1, n=n, seed=2)
    assert vopt <= min(v1, vy) + 1e-12
    e = ControlVariate(h, theta).estimate(it, 20_000, rng=5)
    assert abs(e.value - it.exact) < 4 * e.stderr


def test_alpha_one_vs_optimal():
    """Both unbiased; optimal never has more variance.  On exp with h = x the plain difference
    (alpha = 1) still helps (corr = 0.99 > sigma_h / (2 sigma_f)), but optimal is 11x better."""
    it = I.get("exp")
    h = lambda x: x[..., 0]  # noqa: E731
    vy, v1, vopt, _ = cv_theory(it, h)
    assert vopt < v1 < vy
    a = check_calibrated(ControlVariate(h, 0.5), it, vopt, seed=3)
    b = check_calibrated(ControlVariate(h, 0.5, alpha=1), it, v1, seed=3)
    assert np.var(a.value) < np.var(b.value)
    # a weakly correlated control: alpha = 1 makes things worse, optimal cannot
    wiggle = lambda x: np.sin(6 * np.pi * x[..., 0]) + 2 * x[..., 0]  # noqa: E731
    vy, v1, vopt, _ = cv_theory(it, wiggle)
    assert v1 > vy and vopt <= vy
    check_calibrated(ControlVariate(wiggle, 1.0, alpha=1), it, v1, seed=4)
    check_calibrated(ControlVariate(wiggle, 1.0), it, vopt, seed=5)


def test_several_controls_least_squares():
    it = I.get("exp")
    hs = [lambda x: x[..., 0], lambda x: x[..., 0] ** 2]
    est = ControlVariate(hs, [0.5, 1 / 3])
    e = est.estimate(it, 200_000, rng=1)
    assert abs(e.value - it.exact) < 4 * e.stderr
    # alpha = least squares of f on (x, x^2): solve the normal equations by quadrature
    u, w = u_nodes(1)
    X = np.stack([u[:, 0], u[:, 0] ** 2], -1)
    Xc = X - w @ X
    y = np.exp(u[:, 0])
    a_star = np.linalg.solve(Xc.T @ (w[:, None] * Xc), Xc.T @ (w * (y - w @ y)))
    np.testing.assert_allclose(e.extra["alpha"], a_star, rtol=0.02)
    resid = y - w @ y - Xc @ a_star
    assert e.variance == pytest.approx(w @ resid**2, rel=0.03)
    assert e.variance < ControlVariate(hs[0], 0.5).estimate(it, 200_000, rng=1).variance
    check_calibrated(est, it, float(w @ resid**2), seed=6)
    # fixed vector alpha
    e2 = ControlVariate(hs, [0.5, 1 / 3], alpha=list(a_star)).estimate(it, 200_000, rng=1)
    np.testing.assert_allclose(e2.extra["alpha"], a_star)
    assert e2.variance == pytest.approx(e.variance, rel=0.02)


def test_batched_alpha_per_element():
    scales = np.array([1.0, -2.0, 0.0, 5.0])
    it = Integrand(lambda x: scales[:, None] * np.exp(x[..., 0]), [(0, 1)], scales * (np.e - 1))
    e = ControlVariate(lambda x: x[..., 0], 0.5).estimate(it, 100_000, rng=2)
    assert e.value.shape == (4,) and np.shape(e.extra["alpha"]) == (4,)
    np.testing.assert_allclose(e.extra["alpha"], 1.6903 * scales, atol=0.02 * np.abs(scales).max())
    assert e.value[2] == 0.0 and e.stderr[2] == 0.0           # all-zero element: no NaN
    ok = scales != 0
    assert np.all(np.abs(e.value - it.exact)[ok] < 4 * e.stderr[ok])
    # batched control integral and a per-element fixed alpha
    e2 = ControlVariate(lambda x: x[..., 0], 0.5, alpha=1.6903 * scales).estimate(it, 100_000, rng=2)
    np.testing.assert_allclose(e2.value, e.value, atol=5 * e.stderr.max())
    # chunked accumulation gives the same answer as one block
    e3 = ControlVariate(lambda x: x[..., 0], 0.5).estimate(it, 100_000, rng=2, chunk=7_000)
    np.testing.assert_allclose(e3.value, e.value, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(e3.stderr, e.stderr, rtol=1e-8, atol=1e-14)


def test_comoments_merge_matches_numpy():
    v = np.random.default_rng(0).normal(size=(3, 1000, 4))
    mom = CoMoments()
    for block in np.split(v, [10, 11, 500], axis=1):
        mom.add(block)
    np.testing.assert_allclose(mom.mean, v.mean(1))
    np.testing.assert_allclose(mom.covariance, np.stack([np.cov(b.T) for b in v]), rtol=1e-10)


def test_ci_coverage():
    it = I.get("exp")
    e = replicate(ControlVariate(lambda x: x[..., 0], 0.5), it, n=500, r=400, seed=9)
    lo, hi = e.ci(0.95)
    covered = np.mean((lo <= it.exact) & (it.exact <= hi))
    band = stats.binom.ppf([ALPHA / 2, 1 - ALPHA / 2], 400, 0.95) / 400
    assert band[0] <= covered <= band[1]


# -- defensive mixture -----------------------------------------------------------------------
def x_nodes(integrand):
    u, w = u_nodes(integrand.dim)
    b = integrand.bounds
    return b[:, 0] + (b[:, 1] - b[:, 0]) * u, w * integrand.volume


def mixture_theory(est, integrand):
    """Residual variance of f/q on the controls p_k/q under q (x-space quadrature on a box)."""
    mix = est.mixture(integrand)
    x, w = x_nodes(integrand)
    pk = mix.component_pdfs(x)
    q = pk @ mix.probabilities
    wq = w * q
    y = np.divide(integrand(x), q, out=np.zeros_like(q), where=q > 0)
    cols = np.divide(pk[:, :-1], q[:, None], out=np.zeros_like(pk[:, :-1]), where=q[:, None] > 0)
    yc, hc = y - wq @ y, cols - wq @ cols
    beta = np.linalg.lstsq(hc.T @ (wq[:, None] * hc), hc.T @ (wq * yc), rcond=None)[0]
    return float(wq @ (yc - hc @ beta) ** 2), float(wq @ yc**2)


def mixture_for(integrand):
    dists = list(integrand.techniques.values()) or [integrand.uniform()]
    return DefensiveMixture(dists)


# f is a combination of the mixture components (cos = pi p_cosine, cos^8 = 2pi/9 p_phong;
# glossy-light-in-span up to the lobe's far tails, ~1e-9 relative): the components as controls
# remove (nearly) all variance.  glossy-light is not in the span (the light's edge cuts the lobe).
IN_SPAN = {"cos-hemisphere", "cos8-hemisphere", "glossy-light-in-span"}


@pytest.mark.parametrize("name", I.names(atoms=False))
def test_catalogue_defensive_mixture(name):
    it = I.get(name)
    est = mixture_for(it)
    check_calibrated(DefensiveMixture(list(est.distributions), controls=False), it, seed=8)
    if name in IN_SPAN:
        e = est.estimate(it, 20_000, rng=3)
        assert e.value == pytest.approx(it.exact, rel=1e-5) and e.stderr < 1e-5 * it.exact
        if it.bounds is not None:
            assert mixture_theory(est, it)[0] < 1e-6 * it.exact**2
        return
    unit_var = mixture_theory(est, it)[0] if it.bounds is not None else None
    check_calibrated(est, it, unit_var, seed=7)


def test_glossy_light_is_not_in_the_span_of_its_densities():
    """The glossy-light toy leaves a residual the controls cannot remove (the part of the lobe
    outside the big light counts in p_brdf but not in f); its in-span twin has none.  The
    residual is measured by x-space quadrature, against Var(f/q) of the mixture alone."""
    resid, plain = mixture_theory(mixture_for(I.get("glossy-light")), I.get("glossy-light"))
    assert 1e-3 * plain < resid < plain
    twin = I.get("glossy-light-in-span")
    resid_twin, plain_twin = mixture_theory(mixture_for(twin), twin)
    assert resid_twin < 1e-8 * plain_twin
    # the residual is what the lobe's unlit part adds: moving the lobe out of the light grows it
    toy = I.GlossyLight(center=(0.46, 0.5))
    farther = Integrand(toy, [(0, 1), (0, 1)], techniques={"brdf": toy.brdf, "light": toy.light})
    assert mixture_theory(mixture_for(farther), farther)[0] > resid


def test_mixture_never_much_worse_than_best_component():
    """Owen & Zhou (2000): Var <= min_k sigma_k^2 / c_k with the components as controls."""
    it = I.get("gauss-bump")
    good = it.techniques["normal"]
    bad = TruncatedNormal(0.2, 0.02, 0, 1)          # misses the bump: useless (infinite variance) alone
    est = DefensiveMixture([good, bad], defensive=0.1)
    c = est.mixture(it).probabilities               # (0.1 uniform, 0.45 good, 0.45 bad)
    sig_good, sig_unif = I.mc_variance(it, good), I.mc_variance(it)
    bound = min(sig_unif / c[0], sig_good / c[1])
    unit_var, plain_mix = mixture_theory(est, it)
    assert unit_var <= bound
    e = check_calibrated(est, it, unit_var, seed=10)
    assert np.var(e.value, ddof=1) * N < 1.15 * bound
    # without the controls the same mixture is several times worse than the bound
    nc = check_calibrated(DefensiveMixture([good, bad], defensive=0.1, controls=False), it, plain_mix, seed=11)
    assert np.var(nc.value, ddof=1) > 2 * np.var(e.value, ddof=1)
    one = est.estimate(it, 100_000, rng=4)
    assert one.variance < 1.1 * bound and abs(one.value - it.exact) < 4 * one.stderr


# -- failures are detected ---------------------------------------------------------------------
def test_wrong_control_integral_is_detected():
    it = I.get("exp")
    bad = ControlVariate(lambda x: x[..., 0], 0.45)       # true integral 0.5
    with pytest.raises(AssertionError):
        check_calibrated(bad, it, seed=12)
    e = bad.estimate(it, 20_000, rng=1)
    assert abs(e.value - it.exact) > 4 * e.stderr


def test_wrong_mixture_density_is_detected():
    class HalfPdf(DefensiveMixture):
        def _columns(self, integrand, u):
            cols = super()._columns(integrand, u)
            cols[..., 0] *= 0.5
            return cols
    it = I.get("gauss-bump")
    with pytest.raises(AssertionError):
        check_calibrated(HalfPdf([it.techniques["normal"]]), it, seed=13)


def test_bad_inputs():
    h = lambda x: x[..., 0]  # noqa: E731
    with pytest.raises(ValueError, match="alpha"):
        ControlVariate(h, 0.5, alpha="best")
    with pytest.raises(ValueError, match="alpha"):
        ControlVariate([h, h], [0.5, 0.5], alpha=[1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="alpha"):
        ControlVariate(h, 0.5, alpha=np.nan)
    with pytest.raises(TypeError, match="alpha"):
        ControlVariate(h, 0.5, alpha=True)
    with pytest.raises(TypeError, match="control"):
        ControlVariate(3.0, 0.5)
    with pytest.raises(TypeError, match="control"):
        ControlVariate([], [])
    with pytest.raises(ValueError, match="control_integral"):
        ControlVariate([h, h], [0.5])
    with pytest.raises(ValueError, match="control_integral"):
        ControlVariate(h, np.inf)
    it = I.get("exp")
    with pytest.raises(ValueError, match="alpha"):       # batch-shaped alpha of the wrong size
        ControlVariate(h, 0.5, alpha=[1.0, 2.0]).estimate(it, 100, rng=0)
    with pytest.raises(ValueError, match="n"):      # a standard error needs two units
        ControlVariate([h, lambda x: x[..., 0] ** 2], [0.5, 1 / 3]).estimate(it, 1, rng=0)
    with pytest.raises(ValueError, match="defensive"):
        DefensiveMixture([it.uniform()], defensive=1.5)
    with pytest.raises(ValueError, match="probabilities"):
        DefensiveMixture([it.uniform(), it.uniform()], [0.5])
    with pytest.raises(TypeError, match="distributions"):
        DefensiveMixture([object()])
    with pytest.raises(TypeError, match="distributions"):
        DefensiveMixture([])
