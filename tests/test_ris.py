"""Resampled importance sampling and weighted reservoirs: unbiasedness, the target = k f
variance, streaming = sequential, merge = one big reservoir, the selected samples'
distribution, batching, and checks that broken weights are caught."""
import numpy as np
import pytest
from scipy import stats

from vrlab import distributions as D
from vrlab.distributions.frames import Oriented
from vrlab.estimators import BiasWarning
from vrlab.estimators.ris import RIS, Reservoir
from vrlab.integrands import Integrand, get, mc_variance
from vrlab.testing import IntervalChart, chi2_discrete, chi2_gof

HALF_PI = np.pi / 2
UNIFORM = D.UniformInterval(0, HALF_PI)


def sin_target(x):
    return np.sin(x[..., 0])


def rough_bump(x):  # a rough approximation of gauss-bump: wider, off-centre, with a floor
    return np.exp(-0.5 * ((x[..., 0] - 0.47) / 0.08) ** 2) + 0.02


def assert_unbiased(est, exact, label=""):
    err = np.asarray(est.value) - exact
    assert np.all(np.abs(err) <= 4 * np.asarray(est.stderr)), f"{label}: z = {est.zscore(exact)}"


def variance_band_ok(sample_var, R, var_theory, alpha=1e-3):
    stat = (R - 1) * sample_var / var_theory
    return stats.chi2.ppf(alpha / 2, R - 1) < stat < stats.chi2.ppf(1 - alpha / 2, R - 1)


# ---------------------------------------------------------------------------------------
# unbiasedness
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("m", [1, 4, 32])
def test_unbiased_sin(m):
    integrand = get("sin")
    est = RIS(UNIFORM, lambda x: x[..., 0], m).estimate(integrand, 20_000, rng=1)
    assert_unbiased(est, integrand.exact, f"m={m}")


@pytest.mark.parametrize("m", [4, 32])
def test_unbiased_gauss_bump(m):
    integrand = get("gauss-bump")
    est = RIS(D.UniformInterval(0, 1), rough_bump, m).estimate(integrand, 20_000, rng=2)
    assert_unbiased(est, integrand.exact, f"m={m}")
    plain = integrand.uniform_variance
    assert est.variance < plain / 3  # resampling towards a rough shape of f already helps a lot


def test_unbiased_glossy_light_brdf_target():
    integrand = get("glossy-light")
    est = RIS(D.UniformBox([(0, 1), (0, 1)]), integrand.f.rho, 16).estimate(integrand, 20_000, rng=3)
    assert_unbiased(est, integrand.exact)


def test_broken_contribution_weight_is_detected():
    """Dropping the 1/M in W = w_sum / (M p̂(Y)) multiplies the estimate by m."""
    integrand, m = get("sin"), 4
    ris = RIS(UNIFORM, lambda x: x[..., 0], m)
    u = np.random.default_rng(4).random((20_000, ris.dim_u()))
    res = ris.reservoirs(u)
    good = integrand(res.y) * res.W
    bad = integrand(res.y) * res.w_sum / res.target
    for vals, ok in ((good, True), (bad, False)):
        z = (vals.mean() - integrand.exact) / (vals.std(ddof=1) / np.sqrt(len(vals)))
        assert (abs(z) < 4) == ok, z


# ---------------------------------------------------------------------------------------
# the target = k f case: RIS is IS with m samples
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("m", [1, 4, 16])
def test_target_proportional_to_f_is_importance_sampling_with_m_samples(m):
    integrand = get("sin")
    ris = RIS(UNIFORM, lambda x: 3.0 * np.sin(x[..., 0]), m)
    # sample by sample: f(Y) W = (1/m) sum_j f(Y_j) / p(Y_j)
    u = np.random.default_rng(5).random((5000, ris.dim_u()))
    cand = UNIFORM.sample(u[:, :m].reshape(-1, m, 1))
    direct = np.mean(integrand(cand) / UNIFORM.pdf(cand), -1)
    np.testing.assert_allclose(ris.unit_values(integrand, u), direct, rtol=1e-12)
    # variance over replicates: Var_p[f/p] / m per output sample
    R, n = 400, 50
    theory = mc_variance(integrand, UNIFORM) / m / n
    est = ris.estimate(integrand, n, points=np.random.default_rng(6).random((R, n, ris.dim_u())))
    assert est.value.shape == (R,)
    assert variance_band_ok(np.var(est.value, ddof=1), R, theory), (np.var(est.value, ddof=1), theory)
    # a wrong variance law (no 1/m) is rejected for m > 1
    if m > 1:
        assert not variance_band_ok(np.var(est.value, ddof=1), R, theory * m)


# ---------------------------------------------------------------------------------------
# reservoirs
# ---------------------------------------------------------------------------------------
def test_streaming_update_equals_sequential():
    rng = np.random.default_rng(7)
    T, m = 1000, 16
    x = rng.random((T, m, 2))
    w = rng.random((T, m)) * (rng.random((T, m)) > 0.2)  # some zero weights
    t = rng.random((T, m)) + 0.1
    u = rng.random((T, m))
    batch = Reservoir.empty((T,), 2).update(x, w, u, t)
    seq = Reservoir.empty((T,), 2)
    for j in range(m):
        seq = seq.update(x[:, j:j + 1], w[:, j:j + 1], u[:, j:j + 1], t[:, j:j + 1])
    for attr in ("y", "w_sum", "M", "target"):
        np.testing.assert_array_equal(getattr(batch, attr), getattr(seq, attr))
    # two batches in a row = one batch
    two = Reservoir.empty((T,), 2).update(x[:, :5], w[:, :5], u[:, :5], t[:, :5])
    two = two.update(x[:, 5:], w[:, 5:], u[:, 5:], t[:, 5:])
    np.testing.assert_array_equal(two.y, batch.y)
    assert np.all(batch.M == m)


def test_selection_probabilities_and_merge():
    """Given fixed candidates, one reservoir over all m and the merge of two reservoirs over
    m/2 each select candidate j with probability w_j / sum w (chi-square), with the same
    w_sum and M: merged reservoirs are distributed like one of m."""
    T, m = 200_000, 8
    w = np.array([0.5, 0.0, 2.0, 1.0, 0.25, 3.0, 0.75, 1.5])
    x = np.arange(m, dtype=float)[:, None] * np.ones((T, 1, 1))  # the candidate's index as its point
    t = w + 1.0
    u = np.random.default_rng(8).random((T, m + 1))
    single = Reservoir.empty((T,), 1).update(x, w, u[:, :m], t)
    a = Reservoir.empty((T,), 1).update(x[:, :4], w[:4], u[:, :4], t[:4])
    b = Reservoir.empty((T,), 1).update(x[:, 4:], w[4:], u[:, 4:m], t[4:])
    merged = a.merge(b, u[:, m])
    pmf = w / w.sum()
    for res in (single, merged):
        assert res.w_sum == pytest.approx(w.sum()) and np.all(res.M == m)
        idx = res.y[:, 0].astype(int)
        assert chi2_discrete(idx, pmf).pvalue > 1e-3
        np.testing.assert_allclose(res.target, t[idx])
    # a merge that ignores the weights (picks either side with probability 1/2) is caught
    naive = Reservoir(np.where((u[:, m] < 0.5)[:, None], b.y, a.y), a.w_sum + b.w_sum, a.M + b.M, a.target)
    assert chi2_discrete(naive.y[:, 0].astype(int), pmf).pvalue < 1e-6


def test_merged_reservoirs_give_unbiased_ris():
    integrand, m = get("sin"), 8
    ris_half = RIS(UNIFORM, lambda x: x[..., 0], m // 2)
    rng = np.random.default_rng(9)
    n = 50_000
    a = ris_half.reservoirs(rng.random((n, ris_half.dim_u())))
    b = ris_half.reservoirs(rng.random((n, ris_half.dim_u())))
    merged = a.merge(b, rng.random(n))
    vals = integrand(merged.y) * merged.W
    full = RIS(UNIFORM, lambda x: x[..., 0], m).estimate(integrand, n, rng=10)
    z = (vals.mean() - integrand.exact) / (vals.std(ddof=1) / np.sqrt(n))
    assert abs(z) < 4
    assert vals.var(ddof=1) == pytest.approx(full.variance, rel=0.05)


def test_merge_with_other_target():
    """ReSTIR-style reuse: with target_at_other = this target at other's sample and equal
    targets, merging equals the plain merge."""
    ris = RIS(UNIFORM, lambda x: x[..., 0], 4)
    rng = np.random.default_rng(11)
    a = ris.reservoirs(rng.random((100, ris.dim_u())))
    b = ris.reservoirs(rng.random((100, ris.dim_u())))
    u = rng.random(100)
    plain = a.merge(b, u)
    again = a.merge(b, u, target_at_other=b.y[..., 0])
    np.testing.assert_allclose(again.w_sum, plain.w_sum, rtol=1e-12)
    np.testing.assert_array_equal(again.y, plain.y)


def test_empty_reservoir():
    r = Reservoir.empty((3,), 2)
    assert r.shape == (3,) and r.y.shape == (3, 2)
    np.testing.assert_array_equal(r.W, 0)
    r = r.update(np.ones((3, 2, 2)), np.zeros((3, 2)), np.full((3, 2), 0.5), np.zeros((3, 2)))
    np.testing.assert_array_equal(r.W, 0)  # only zero weights: nothing selected, W = 0
    np.testing.assert_array_equal(r.M, 2)


# ---------------------------------------------------------------------------------------
# the selected samples approach target / int target as m grows
# ---------------------------------------------------------------------------------------
class Selected:
    """The RIS selection as a distribution: sample(u) -> Y, pdf = normalised target."""

    def __init__(self, ris, target, norm):
        self.ris, self.target, self.norm = ris, target, norm
        self.dim_u = ris.dim_u()

    def sample(self, u):
        return self.ris.reservoirs(u).y

    def pdf(self, x):
        return self.target(x) / self.norm


def test_selected_samples_follow_target_at_large_m():
    chart = IntervalChart(0, HALF_PI)  # target sin x on [0, pi/2]: int = 1
    big = chi2_gof(Selected(RIS(UNIFORM, sin_target, 64), sin_target, 1.0), chart, (40,), n=40_000, rng=12)
    assert big.pvalue > 1e-3, big.message()
    one = chi2_gof(Selected(RIS(UNIFORM, sin_target, 1), sin_target, 1.0), chart, (40,), n=40_000, rng=12)
    assert one.pvalue < 1e-6  # m = 1 selects the source's samples: uniform, not sin


# ---------------------------------------------------------------------------------------
# batching, settings, cost accounting
# ---------------------------------------------------------------------------------------
def test_batched_integrand():
    base = get("sin")
    scales = np.array([0.5, 2.0, 7.0])
    batched = Integrand(lambda x: scales[:, None] * np.sin(x[..., 0]), base.domain, scales)
    ris = RIS(UNIFORM, lambda x: x[..., 0], 8)
    est = ris.estimate(batched, 3000, rng=13)
    ref = ris.estimate(base, 3000, rng=13)
    assert np.shape(est.value) == (3,)
    np.testing.assert_allclose(est.value, scales * ref.value, rtol=1e-12)
    np.testing.assert_allclose(est.stderr, scales * ref.stderr, rtol=1e-9)


def test_batched_frames():
    """Per-pixel frames: cosine source and cos^8 target about a per-pixel axis; rotation
    invariance makes every pixel's estimate equal the unrotated one (same uniforms)."""
    rng = np.random.default_rng(14)
    axes = rng.normal(size=(5, 3))
    axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
    cos8 = get("cos8-hemisphere")
    f = Integrand(lambda w: np.clip(np.sum(w * axes[:, None, :], -1), 0, None) ** 8, "sphere", 2 * np.pi / 9)
    source = Oriented(D.CosineHemisphere(), axes[:, None, :])
    target = lambda w: np.clip(np.sum(w * axes[:, None, :], -1), 0, None) ** 6  # noqa: E731
    est = RIS(source, target, 8, probe=False).estimate(f, 2000, rng=15)
    ref = RIS(D.CosineHemisphere(), lambda w: np.clip(w[..., 2], 0, None) ** 6, 8).estimate(cos8, 2000, rng=15)
    np.testing.assert_allclose(est.value, ref.value, rtol=1e-9)
    assert_unbiased(ref, cos8.exact)


def test_cost_accounting_and_chunks():
    integrand = get("sin")
    ris = RIS(UNIFORM, lambda x: x[..., 0], 16)
    assert ris.dim_u() == 16 * (1 + 1)
    a = ris.estimate(integrand, 5000, rng=16)
    assert a.n_evals == 5000 and a.extra["target_evals"] == 5000 * 16 and a.extra["candidates"] == 16
    b = ris.estimate(integrand, 5000, rng=16, chunk=16 * 700)
    assert a.value == pytest.approx(b.value, rel=1e-12)


def test_settings_and_warnings():
    integrand = get("sin")
    with pytest.raises(ValueError, match="m"):
        RIS(UNIFORM, sin_target, 0)
    with pytest.raises(TypeError, match="m"):           # not an integer: a TypeError, as everywhere
        RIS(UNIFORM, sin_target, 2.5)
    with pytest.raises(TypeError, match="target"):
        RIS(UNIFORM, 3.0, 4)
    with pytest.raises(TypeError, match="source"):
        RIS(object(), sin_target, 4)
    with pytest.raises(ValueError, match="target"):
        RIS(UNIFORM, lambda x: -np.ones(x.shape[:-1]), 4, probe=False).estimate(integrand, 100, rng=0)
    with pytest.warns(BiasWarning):  # the target is zero on (1, pi/2] where f is not
        RIS(UNIFORM, lambda x: (x[..., 0] < 1).astype(float), 4).estimate(integrand, 100, rng=0)
    with pytest.warns(BiasWarning):  # the source misses (1, pi/2]
        RIS(D.UniformInterval(0, 1), sin_target, 4).estimate(integrand, 100, rng=0)
    with pytest.raises(ValueError, match="dimension"):
        RIS(UNIFORM, sin_target, 4).estimate(get("smooth-2d"), 100, rng=0)
