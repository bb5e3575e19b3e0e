"""Stratified sampling: unbiased and calibrated on every catalogue integrand, variance equal to
sum_h w_h^2 sigma_h^2 / n_h (closed form on sin), proportional never above plain MC, Neyman below
proportional on peaked/skewed integrands, jittered (points=Stratified) RMSE slope -3/2 in 1D,
the one-point-per-stratum error, and broken weights detected."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

import vrlab.integrands as I
import vrlab.points as P
from vrlab.estimators import MonteCarlo
from vrlab.estimators.stratified import Stratified, allocate, default_grid
from vrlab.integrands import Integrand

from conftest import assert_calibrated

R = 200
ALPHA = 1e-3


def strata_moments(integrand, grid, distribution=None, quad: int = 8, sub: int = 4):
    """Per-stratum mean and variance of Y = f/p over the u-grid ``grid``, by Gauss-Legendre
    inside each stratum (``sub`` sub-cells per axis): arrays of shape (H,)."""
    dist = integrand.uniform() if distribution is None else distribution
    g, w = np.polynomial.legendre.leggauss(quad)
    t = (((g + 1) / 2)[None, :] + np.arange(sub)[:, None]).ravel() / sub     # nodes in [0, 1]
    wt = np.tile(w / 2, sub) / sub
    axes = [(np.arange(m)[:, None] + t[None, :]) / m for m in grid]         # (m_j, q)
    if len(grid) == 1:
        u = axes[0][..., None]
        wq = wt
    else:
        u = np.stack(np.broadcast_arrays(axes[0][:, None, :, None], axes[1][None, :, None, :]), -1)
        u = u.transpose(0, 1, 2, 3, 4).reshape(grid[0] * grid[1], t.size, t.size, 2)
        wq = np.outer(wt, wt)
    x = dist.sample(u)
    p = dist.pdf(x)
    y = integrand(x) / p
    axes_sum = tuple(range(1, y.ndim))
    mu = np.sum(wq * y, axis=axes_sum)
    var = np.sum(wq * (y - mu.reshape((-1,) + (1,) * (y.ndim - 1))) ** 2, axis=axes_sum)
    return mu.ravel(), var.ravel()


def replicate(est, integrand, n, r=R, seed=0):
    """Loop: Stratified draws its own points (arrays of uniforms are refused)."""
    out = [est.estimate(integrand, n, rng=s) for s in np.random.SeedSequence(seed).spawn(r)]
    return np.array([e.value for e in out]), np.array([e.stderr for e in out]), out[0]


def check_calibrated(est, integrand, n, est_var=None, r=R, seed=0, exact=None):
    vals, se, first = replicate(est, integrand, n, r, seed)
    assert_calibrated(vals, se, integrand.exact if exact is None else exact, est_var)
    return vals, se, first


def test_sin_closed_form():
    """sin on [0, pi/2], H equal strata: sigma_h^2 in closed form; Var = (1/n) sum_h w_h sigma_h^2."""
    it = I.get("sin")
    H, n = 16, 64
    a = np.arange(H) * (np.pi / 2) / H
    b = a + (np.pi / 2) / H
    c = np.pi / 2                                           # Y = f/p = (pi/2) sin x
    mean = c * (np.cos(a) - np.cos(b)) / (b - a)
    second = c * c * (0.5 - (np.sin(2 * b) - np.sin(2 * a)) / (4 * (b - a)))
    sig2 = second - mean**2
    mu_q, var_q = strata_moments(it, (H,))
    np.testing.assert_allclose(mu_q, mean, rtol=1e-12)
    np.testing.assert_allclose(var_q, sig2, rtol=1e-8)
    v_strat = np.sum(sig2 / H) / n
    assert v_strat < it.theory["var:uniform"] / n / 50          # 64 points, 16 strata: > 50x better
    vals, se, first = check_calibrated(Stratified(strata=H), it, n, v_strat, seed=1)
    assert first.extra["strata"] == (H,) and list(first.extra["counts"]) == [4] * H
    assert first.n == n and first.n_evals == n


@pytest.mark.parametrize("name", I.names(atoms=False))
def test_catalogue_proportional(name):
    it = I.get(name)
    est = Stratified()
    n = 2048 if name.startswith("glossy-light") else 512
    grid = est.grid(n, est.dim_u(it))
    counts = allocate(n, np.ones(int(np.prod(grid))))
    mu, var = strata_moments(it, grid)
    # (the disk's edge cuts through quadrature cells: only 1e-3 there)
    assert np.mean(mu) == pytest.approx(it.exact, rel=1e-3 if name == "disk-indicator" else 1e-6)
    w = 1.0 / counts.size
    v_est = np.sum(w * w * var / counts)
    # never above plain Monte Carlo at the same n (proportional allocation)
    assert v_est <= I.mc_variance(it) / n * (1 + 1e-9)
    r = 150 if it.dim == 1 else 100
    check_calibrated(est, it, n, v_est, r=r, seed=2)


@pytest.mark.parametrize("name", ["step-x2", "gauss-bump", "disk-indicator", "exp", "cos8-hemisphere"])
def test_catalogue_neyman(name):
    it = I.get(name)
    est = Stratified(strata=16 if it.dim == 1 else 6, allocation="neyman")
    n = 1200
    vals, se, first = check_calibrated(est, it, n, r=100, seed=3)
    assert first.n_evals == n and first.n + first.extra["n_pilot"] == n


def test_neyman_beats_proportional_on_skewed():
    """gauss-bump (a narrow peak) and step-x2 (zero on half the domain), 16 strata, equal total n:
    Neyman's n_h ~ w_h sigma_h wins despite spending 4 x 16 evaluations on the pilot."""
    for name in ("gauss-bump", "step-x2"):
        it = I.get(name)
        n, H = 800, 16
        mu, var = strata_moments(it, (H,))
        sigma = np.sqrt(var)
        v_prop = np.sum(var / H) / n
        v_ney_ideal = np.sum(sigma / H) ** 2 / (n - 4 * H)
        assert v_ney_ideal < 0.7 * v_prop
        prop, _, _ = check_calibrated(Stratified(strata=H), it, n, v_prop, r=150, seed=4)
        ney, _, first = check_calibrated(Stratified(strata=H, allocation="neyman"), it, n, r=150, seed=5)
        assert np.var(ney) < np.var(prop)
        # the allocation follows sigma_h: the busiest stratum is where sigma_h is largest
        assert np.argmax(first.extra["counts"]) in np.argsort(sigma)[-4:]


def test_jittered_rmse_slope():
    """MonteCarlo with points=Stratified (one jittered point per stratum) on e^x: RMSE ~ n^{-3/2}."""
    it = I.get("exp")
    ns = 4 ** np.arange(2, 7)                          # 16 .. 4096
    rmse = []
    for n in ns:
        eng = P.Stratified(1, rng=int(n))
        u = np.stack([eng.random(int(n)) for _ in range(200)])          # (200, n, 1) jittered sets
        e = MonteCarlo().estimate(it, int(n), points=u)
        rmse.append(np.sqrt(np.mean((np.asarray(e.value) - it.exact) ** 2)))
    slope = np.polyfit(np.log(ns), np.log(rmse), 1)[0]
    assert -1.65 < slope < -1.35, slope
    # the stratified estimator with two points per stratum converges at the same rate
    rm2 = []
    for n in ns[1:]:
        vals, _, _ = replicate(Stratified(), it, int(n), r=60, seed=int(n))
        rm2.append(np.sqrt(np.mean((vals - it.exact) ** 2)))
    slope2 = np.polyfit(np.log(ns[1:]), np.log(rm2), 1)[0]
    assert -1.75 < slope2 < -1.3, slope2


def test_one_point_per_stratum_raises():
    it = I.get("exp")
    with pytest.raises(ValueError, match="RQMC|points=vrlab.points.Stratified"):
        Stratified(strata=64).estimate(it, 64, rng=0)
    with pytest.raises(ValueError, match="n"):
        Stratified(strata=64).estimate(it, 100, rng=0)
    with pytest.raises(ValueError, match="n"):
        Stratified(strata=8, allocation="neyman").estimate(it, 40, rng=0)


def test_grid_allocation_helpers():
    assert default_grid(1000, 1) == (1000,)
    assert default_grid(100, 2) == (10, 10)
    assert default_grid(120, 2) == (11, 10)
    g = default_grid(512, 10)
    assert int(np.prod(g)) <= 512 and max(g) - min(g) <= 1
    assert default_grid(0, 3) == (1, 1, 1)
    c = allocate(103, np.array([1.0, 0.0, 3.0]))
    assert c.sum() == 103 and c.min() >= 2 and c[2] > c[0] > c[1]
    assert list(allocate(10, np.zeros(5))) == [2] * 5
    assert Stratified(strata=(4, 3)).grid(100, 2) == (4, 3)
    assert Stratified(strata=5).grid(100, 2) == (5, 5)


def test_batched_and_importance():
    scales = np.array([1.0, 3.0, -2.0])
    it = Integrand(lambda x: scales[:, None] * np.exp(x[..., 0]), [(0, 1)], scales * (np.e - 1))
    for alloc in ("proportional", "neyman"):
        e = Stratified(strata=10, allocation=alloc).estimate(it, 2000, rng=1)
        assert e.value.shape == (3,) and np.all(np.abs(e.value - it.exact) < 4 * e.stderr)
    sin = I.get("sin")
    est = Stratified(strata=8, distribution=sin.techniques["linear"])
    mu, var = strata_moments(sin, (8,), sin.techniques["linear"])
    assert np.mean(mu) == pytest.approx(1.0, rel=1e-6)
    check_calibrated(est, sin, 256, np.sum(var / 8) / 256, r=100, seed=6)
    # chunked strata give the same numbers as one block
    a = Stratified(strata=40).estimate(sin, 4000, rng=3)
    b = Stratified(strata=40).estimate(sin, 4000, rng=3, chunk=333)
    assert a.value == pytest.approx(b.value, rel=1e-12) and a.stderr == pytest.approx(b.stderr, rel=1e-9)


def test_ci_coverage():
    it = I.get("exp")
    vals, se, _ = replicate(Stratified(strata=50), it, 200, r=300, seed=8)
    z = stats.norm.ppf(0.975)
    covered = np.mean(np.abs(vals - it.exact) <= z * se)
    band = stats.binom.ppf([ALPHA / 2, 1 - ALPHA / 2], 300, 0.95) / 300
    assert band[0] <= covered <= band[1]


class PooledMean(Stratified):
    """A classic bug: average all samples (weights n_h / n) instead of sum_h w_h mean_h."""

    def _stats(self, integrand, grid, counts, engine, chunk):
        mu, var = super()._stats(integrand, grid, counts, engine, chunk)
        return mu * counts * counts.size / counts.sum(), var


class PlainStderr(Stratified):
    """Another: the i.i.d. formula sigma / sqrt(n) for the stderr, ignoring the strata."""

    def estimate(self, integrand, n, **kw):
        e = super().estimate(integrand, n, **kw)
        e.stderr = np.sqrt(I.mc_variance(integrand) / n)
        return e


def test_checks_can_fail():
    it = I.get("gauss-bump")
    with pytest.raises(AssertionError):
        check_calibrated(PooledMean(strata=16, allocation="neyman"), it, 800, r=100, seed=9)
    with pytest.raises(AssertionError):
        check_calibrated(PlainStderr(strata=16), it, 800, r=100, seed=10)


def test_bad_inputs():
    with pytest.raises(ValueError, match="strata"):
        Stratified(strata=0)
    with pytest.raises(ValueError, match="strata"):
        Stratified(strata=(4, 0))
    with pytest.raises(TypeError, match="strata"):
        Stratified(strata=2.5)
    with pytest.raises(ValueError, match="strata"):
        Stratified(strata=[])
    with pytest.raises(ValueError, match="allocation"):
        Stratified(allocation="optimal")
    with pytest.raises(ValueError, match="pilot"):
        Stratified(pilot=1)
    it = I.get("smooth-2d")
    with pytest.raises(ValueError, match="strata"):
        Stratified(strata=(4, 4, 4)).estimate(it, 1000, rng=0)
    with pytest.raises(ValueError, match="points"):
        Stratified().estimate(it, 1000, rng=0, points=P.Halton)
    with pytest.raises(ValueError, match="points"):
        Stratified().estimate(it, 1000, points=np.random.default_rng(0).random((500, 2)))
    e = Stratified().estimate(it, 1000, rng=0, points="independent")
    assert abs(e.value - it.exact) < 4 * e.stderr
