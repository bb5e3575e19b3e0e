"""Multi-sample and one-sample MIS: unbiasedness, closed-form variances, Veach's bound,
optimal MIS, stderr calibration, batching, and checks that broken weights are caught."""
import numpy as np
import pytest
from scipy import stats

from vrlab import distributions as D
from vrlab.distributions.frames import Oriented
from vrlab.estimators import BiasWarning, MonteCarlo
from vrlab.estimators.mis import HEURISTICS, MIS, mis_weights, split_counts
from vrlab.estimators.onesample import OneSampleMIS
from vrlab.integrands import Integrand, get, mc_variance
from vrlab.integrands.theory import chart_for

PAIRS = {
    "glossy-light": ("brdf", "light"),
    "sin": ("uniform", "linear"),
    "cos8-hemisphere": ("cosine", "phong"),
    "step-x2": ("uniform", "half"),
}
VARIANTS = {h: dict(heuristic=h) for h in HEURISTICS}
VARIANTS["power-3"] = dict(heuristic="power", beta=3.0)
VARIANTS["optimal-pilot"] = dict(heuristic="optimal", optimal_pilot=0.2)


def techniques(name):
    integrand = get(name)
    return integrand, [integrand.techniques[t] for t in PAIRS[name]]


class Quadrature:
    """Composite Gauss-Legendre nodes on the integrand's chart (as ``mc_variance`` uses), with
    f and every technique's pdf evaluated once: integrals are weighted sums."""

    def __init__(self, integrand, dists, cells=None, nodes=8):
        chart = chart_for(integrand)
        cells = cells or (400 if chart.p == 1 else 96)
        g, w = np.polynomial.legendre.leggauss(nodes)
        t = ((np.arange(cells)[:, None] + (g + 1) / 2) / cells).ravel()
        wt = np.tile(w / 2, cells) / cells
        if chart.p == 1:
            param, weight = t[:, None], wt
        else:
            param = np.stack(np.meshgrid(t, t, indexing="ij"), -1).reshape(-1, 2)
            weight = np.outer(wt, wt).ravel()
        x = chart.from_param(param)
        self.weight = weight * chart.jacobian(param)
        self.f = integrand(x)
        self.P = np.stack([np.asarray(d.pdf(x), float) for d in dists], -1)

    def integral(self, values):
        return float(np.sum(self.weight * values))

    def mixture(self, counts):
        """c = counts / N and q = sum_k c_k p_k at the nodes."""
        c = np.asarray(counts, float) / np.sum(counts)
        return c, self.P @ c

    def over(self, a, q):
        return np.divide(a, q, out=np.zeros(np.broadcast_shapes(np.shape(a), q.shape)), where=q > 0)


def balance_variance(integrand, dists, counts, *, wrong=False):
    """Var of the balance-heuristic F (Veach 1997, eq. 9.9 with w_i = c_i p_i / q):
    (1/N) [int f^2 / q - sum_i c_i m_i^2], q = sum_k c_k p_k, m_i = int f p_i / q = E_i[f/q].
    ``wrong=True``: the brief's (1/N)[int f^2/q - sum_i c_i mu_i^2] with mu_i = int w_i f = c_i m_i."""
    Q = integrand if isinstance(integrand, Quadrature) else Quadrature(integrand, dists)
    c, q = Q.mixture(counts)
    second = Q.integral(Q.over(Q.f**2, q))
    m = np.array([Q.integral(Q.over(Q.f * Q.P[:, i], q)) for i in range(len(c))])
    return (second - np.sum(c * (c * m if wrong else m) ** 2)) / np.sum(counts)


def optimal_variance(integrand, dists, counts):
    """Var of optimal MIS (Kondapaneni et al. 2019): (1/N) int (f - a.p)^2 / q with A a = b,
    A_ik = int p_i p_k / q, b_i = int f p_i / q."""
    Q = integrand if isinstance(integrand, Quadrature) else Quadrature(integrand, dists)
    c, q = Q.mixture(counts)
    K = len(c)
    A = np.array([[Q.integral(Q.over(Q.P[:, i] * Q.P[:, k], q)) for k in range(K)] for i in range(K)])
    b = np.array([Q.integral(Q.over(Q.f * Q.P[:, i], q)) for i in range(K)])
    a = np.linalg.lstsq(A, b, rcond=None)[0]
    return Q.integral(Q.over((Q.f - Q.P @ a) ** 2, q)) / np.sum(counts)


def variance_band_ok(sample_var, R, var_theory, alpha=1e-3):
    """(R - 1) s^2 / sigma^2 ~ chi2(R - 1) for (near-)normal replicates: two-sided test."""
    stat = (R - 1) * sample_var / var_theory
    return stats.chi2.ppf(alpha / 2, R - 1) < stat < stats.chi2.ppf(1 - alpha / 2, R - 1)


def assert_unbiased(est, exact, label=""):
    err = np.asarray(est.value) - exact
    assert np.all(np.abs(err) <= 4 * np.asarray(est.stderr) + 1e-10), f"{label}: z = {est.zscore(exact)}"


# ---------------------------------------------------------------------------------------
# unbiasedness
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("variant", list(VARIANTS))
@pytest.mark.parametrize("name", list(PAIRS))
def test_multi_sample_unbiased(name, variant):
    integrand, dists = techniques(name)
    est = MIS(dists, **VARIANTS[variant]).estimate(integrand, 20_000, rng=11)
    assert est.n_evals == 20_000
    assert_unbiased(est, integrand.exact, f"{name}/{variant}")


@pytest.mark.parametrize("heuristic", ["balance", "power", "maximum", "cutoff"])
@pytest.mark.parametrize("name", list(PAIRS))
def test_one_sample_unbiased(name, heuristic):
    integrand, dists = techniques(name)
    est = OneSampleMIS(dists, [0.4, 0.6], heuristic).estimate(integrand, 20_000, rng=12)
    assert_unbiased(est, integrand.exact, f"{name}/{heuristic}")


def test_unequal_fractions_unbiased():
    integrand, dists = techniques("glossy-light")
    for fr, counts in (([0.9, 0.1], [18000, 2000]), ([0.2, 0.8], [4000, 16000]),
                       ([0.123, 0.877], [2460, 17541])):   # not whole numbers: n_i of all n samples
        for h in ("balance", "optimal"):
            est = MIS(dists, fr, h).estimate(integrand, 20_001, rng=13)
            assert_unbiased(est, integrand.exact, f"{fr}/{h}")
            assert est.extra["counts"] == counts and est.n == est.n_evals == sum(counts)


def test_broken_weights_are_detected(raises_naming, monkeypatch):
    """w_i = 1 for every technique (weights summing to 2): refused up front, naming the
    heuristic; with that check switched off, the unbiasedness z-test catches it too."""
    integrand, dists = techniques("sin")

    def ones(q):
        return np.ones_like(q)

    with raises_naming(ValueError, "heuristic", "'ones'"):
        MIS(dists, heuristic=ones).estimate(integrand, 20_000, rng=11)
    with raises_naming(ValueError, "heuristic"):
        OneSampleMIS(dists, heuristic=ones).estimate(integrand, 20_000, rng=11)
    import vrlab.estimators.heuristics as heuristics_module

    monkeypatch.setattr(heuristics_module, "check_heuristic_weights", lambda h, q: np.asarray(h(q), float))
    est = MIS(dists, heuristic=ones).estimate(integrand, 20_000, rng=11)
    assert abs(est.zscore(integrand.exact)) > 4
    assert est.value == pytest.approx(2.0, rel=0.02)
    # one-sample without the weight (F = f / (c_I p_I)): also sums to 2 I
    est = OneSampleMIS(dists, heuristic=ones).estimate(integrand, 20_000, rng=11)
    assert abs(est.zscore(integrand.exact)) > 4


def test_heuristic_weights_checked_where_some_density_is_positive(raises_naming):
    """Weights may be anything where every q_k = 0, and a technique with q_k = 0 may get any
    weight (it never samples there), but the others must then sum to 1."""
    from vrlab.estimators.mis import check_heuristic_weights, mis_weights

    q = np.array([[1.0, 3.0], [0.0, 2.0], [0.0, 0.0]])
    balance = mis_weights(q, "balance")
    np.testing.assert_allclose(check_heuristic_weights(lambda q: balance, q), balance)
    odd = balance.copy()
    odd[1, 0], odd[2] = 0.7, 5.0                  # q_0 = 0 at row 1; nothing covers row 2
    check_heuristic_weights(lambda q: odd, q)
    odd[1, 1] = 0.5
    with raises_naming(ValueError, "heuristic"):
        check_heuristic_weights(lambda q: odd, q)
    with raises_naming(ValueError, "heuristic"):
        check_heuristic_weights(lambda q: np.full_like(q, np.nan), q)
    with raises_naming(ValueError, "heuristic"):
        check_heuristic_weights(lambda q: np.ones(5), q)


# ---------------------------------------------------------------------------------------
# closed-form variances
# ---------------------------------------------------------------------------------------
def test_single_technique_is_montecarlo():
    integrand, (uniform, linear) = techniques("sin")
    mis = MIS([linear]).estimate(integrand, 5000, rng=3)
    mc = MonteCarlo(linear).estimate(integrand, 5000, rng=3)
    assert mis.value == pytest.approx(mc.value, rel=1e-13)
    assert mis.stderr == pytest.approx(mc.stderr, rel=1e-10)


def test_identical_techniques_balance_is_montecarlo():
    """Two copies of p with the balance heuristic: every weight is n_i / N, F is plain IS."""
    integrand, (_, linear) = techniques("sin")
    u = np.random.default_rng(4).random((10_000, 1))
    # units of 3 + 7 samples: the same 10 000 uniforms, 10 per row
    mis = MIS([linear, D.LinearInterval(0, np.pi / 2, 0, 1)], [0.3, 0.7]).estimate(integrand, 10_000,
                                                                                    points=u.reshape(1000, 10))
    mc = MonteCarlo(linear).estimate(integrand, 10_000, points=u)
    assert mis.value == pytest.approx(mc.value, rel=1e-12)
    assert mis.stderr == pytest.approx(mc.stderr, rel=0.05)
    assert mis.variance == pytest.approx(mc_variance(integrand, linear), rel=0.05)


@pytest.mark.parametrize("name,fractions,n", [("sin", [0.3, 0.7], 200), ("cos8-hemisphere", [0.5, 0.5], 200),
                                             ("glossy-light", [0.4, 0.6], 1000)])
def test_balance_variance_matches_quadrature(name, fractions, n):
    """Var[F] over 400 replicates vs (1/N)[int f^2/q - sum_i c_i m_i^2] (chi-square band)."""
    integrand, dists = techniques(name)
    mis = MIS(dists, fractions)
    counts = mis.counts(n)
    Q = Quadrature(integrand, dists)
    theory = balance_variance(Q, dists, counts)
    R = 400
    u = np.random.default_rng(5).random((R, n // mis.evals_per_unit, mis.unit_dim()))
    est = mis.estimate(integrand, n, points=u)
    assert est.value.shape == (R,)
    assert variance_band_ok(np.var(est.value, ddof=1), R, theory), (np.var(est.value, ddof=1), theory)
    # the within-run stderr estimates the same variance
    assert np.mean(est.stderr**2) == pytest.approx(theory, rel=0.1)
    # a wrong formula (sum_i c_i mu_i^2 with mu_i = int w_i f) is rejected where it differs
    wrong = balance_variance(Q, dists, counts, wrong=True)
    if abs(wrong / theory - 1) > 0.5:
        assert not variance_band_ok(np.var(est.value, ddof=1), R, wrong)


def test_veach_bound_nearly_tight():
    """Veach (1997, Thm. 9.2): V[F_balance] - V[F*] <= (1/min n_i - 1/sum n_i) mu^2 for the best
    non-negative weights F*.

    Design: f = 1 on [0, 1] (mu = 1); technique 1 is piecewise constant with density 2 eps on
    [0, 1/2) and 2 (1 - eps) on [1/2, 1]; technique 2 is uniform on [1/2, 1] (perfect there);
    n_1 = n_2 = N/2.  On [1/2, 1] the weight w of technique 1 leaves technique 2's term at zero,
    and V(w) = (1/(4 n_1)) [1/eps + w^2/(1 - eps) - (1 + w)^2] decreases on [0, 1]: the best
    non-negative weights give technique 1 everything (w = 1, technique 2's samples are thrown
    away), because that puts the whole mu into a single technique's -mu_i^2/n_i term, while the
    balance heuristic splits mu across techniques.  As eps -> 0 the gap tends to exactly half
    the bound (a numerical search over 2-4-cell two-technique designs found nothing above 1/2);
    eps = 0.1 gives 0.48 of it with variances small enough to measure.  Optimal MIS with signed
    weights writes f = 5 p_1 - 4 p_2 and has zero variance: the bound is for w >= 0 only.
    """
    eps, N = 0.1, 200_000
    n1 = N // 2
    one = Integrand(lambda x: np.ones(x.shape[:-1]), [(0, 1)], 1.0, "one")
    p1, p2 = D.PiecewiseConstant1D([eps, 1 - eps], (0, 1)), D.UniformInterval(0.5, 1)
    bound = 1 / n1 - 1 / N

    def V(w):  # closed form of Var[F] for weight w of technique 1 on [1/2, 1]
        return (1 / eps + w**2 / (1 - eps) - (1 + w) ** 2) / (4 * n1)

    w_bal = (1 - eps) / (2 - eps)
    grid = np.linspace(0, 1, 1001)
    assert np.argmin(V(grid)) == len(grid) - 1
    v_bal, v_star = V(w_bal), V(1.0)
    assert v_bal == pytest.approx(balance_variance(one, [p1, p2], [n1, n1]), rel=1e-6)
    assert v_star == pytest.approx(mc_variance(one, p1) / n1, rel=1e-6)
    assert 0.45 * bound < v_bal - v_star <= bound

    bal = MIS([p1, p2]).estimate(one, N, rng=6)
    star = MIS([p1, p2], heuristic=lambda q: np.broadcast_to([1.0, 0.0], q.shape)).estimate(one, N, rng=6)
    assert bal.stderr**2 == pytest.approx(v_bal, rel=0.03)
    assert star.stderr**2 == pytest.approx(v_star, rel=0.03)
    gap = bal.stderr**2 - star.stderr**2
    assert 0.3 * bound < gap < 1.2 * bound
    # signed weights: optimal MIS beats the balance heuristic by more than the bound
    opt = MIS([p1, p2], heuristic="optimal").estimate(one, N, rng=6)
    assert opt.stderr < 1e-9 and abs(opt.value - 1) < 1e-9
    # f = a_1 p_1 + a_2 p_2 with a = (0.5 / eps, (1 - (1 - eps) / eps) / 2); the control H_1 - 1
    # gets beta_1 = a_1 - a_2 c_1 / c_2
    a1, a2 = 0.5 / eps, (1 - (1 - eps) / eps) / 2
    assert np.allclose(opt.extra["alpha"], [a1 - a2])
    assert bal.stderr**2 - opt.stderr**2 > 3 * bound


@pytest.mark.parametrize("name", list(PAIRS))
def test_optimal_never_worse_than_balance(name):
    integrand, dists = techniques(name)
    mis_b, mis_o = MIS(dists), MIS(dists, heuristic="optimal")
    n, R = 1000, 300
    Q = Quadrature(integrand, dists)
    theory_b = balance_variance(Q, dists, mis_b.counts(n))
    theory_o = optimal_variance(Q, dists, mis_o.counts(n))
    assert theory_o <= theory_b * (1 + 1e-9)
    u = np.random.default_rng(7).random((R, n // mis_b.evals_per_unit, mis_b.unit_dim()))  # common random numbers
    vb = np.var(mis_b.estimate(integrand, n, points=u).value, ddof=1)
    vo = np.var(mis_o.estimate(integrand, n, points=u).value, ddof=1)
    assert vo <= 1.15 * vb, (vo, vb)
    if theory_o > 1e-12 * theory_b:
        assert variance_band_ok(vo, R, theory_o), (vo, theory_o)
    else:
        assert vo < 1e-20


@pytest.mark.parametrize("fractions", [[1, 1], [2, 1]])
@pytest.mark.parametrize("name", list(PAIRS))
def test_optimal_per_unit_is_unbiased_with_the_optimal_variance(name, fractions):
    """The renderer's optimal MIS (``unit_outputs`` -> regression on the density controls
    H_k - 1): unbiased, and its variance over replicates is the optimal one,
    Var = (1/N) int (f - a.p)^2 / q with N = m sum_k c_k (Kondapaneni et al. 2019: at their a,
    E_k[(f - a.p)/q] = 0 for every technique, so the unit's variance is the same integral)."""
    integrand, dists = techniques(name)
    est = MIS(dists, fractions, "optimal")
    m, R = 400, 300
    u = np.random.default_rng(17).random((R, m, est.unit_dim(integrand)))
    out = est.unit_outputs(integrand, u)
    assert out.shape == (R, m, 2) and est.min_units == 2
    assert abs(out[..., 1].mean()) < 5 * out[..., 1].std() / np.sqrt(R * m)          # E[H_0] = 1
    value, stderr = est.fold(out)
    theory = optimal_variance(Quadrature(integrand, dists), dists, np.array(fractions) * m)
    v = np.var(value, ddof=1)
    if theory > 1e-12:
        assert variance_band_ok(v, R, theory * (1 + 3 / m)), (v, theory)    # + the fit's O(K/m)
        assert np.mean(stderr**2) == pytest.approx(theory, rel=0.1)
        pooled = np.mean(value)
        assert abs(pooled - integrand.exact) < 4 * np.sqrt(v / R), (pooled, integrand.exact)
    else:
        assert v < 1e-20 and np.allclose(value, integrand.exact)
    # the controls' known mean is 1: centring them at anything else biases the estimate
    wrong = out.copy()
    wrong[..., 1] += 0.2
    if theory > 1e-12 and np.any(np.abs(est.details(est.accumulate(out))["alpha"]) > 0.05):
        assert abs(np.mean(est.fold(wrong)[0]) - integrand.exact) > 8 * np.sqrt(v / R)


# ---------------------------------------------------------------------------------------
# one-sample MIS
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("name,probs", [("cos8-hemisphere", [0.5, 0.5]), ("glossy-light", [0.25, 0.75]),
                                        ("sin", [0.7, 0.3])])
def test_one_sample_balance_is_mixture_importance_sampling(name, probs):
    """The lecture's p(w) = 1/2 p_cos + 1/2 p_other: one-sample balance MIS = IS from the mixture."""
    integrand, dists = techniques(name)
    one = OneSampleMIS(dists, probs)
    u = np.random.default_rng(8).random((4096, one.dim_u()))
    a = one.unit_values(integrand, u)
    b = MonteCarlo(D.Mixture(dists, probs)).unit_values(integrand, u)
    np.testing.assert_array_equal(a, b)
    # the generic weighted path (w_I f / (c_I p_I)) agrees up to rounding
    generic = OneSampleMIS(dists, probs, heuristic=lambda q: q / q.sum(-1, keepdims=True))
    np.testing.assert_allclose(generic.unit_values(integrand, u), a, rtol=1e-12, atol=1e-300)


def test_one_sample_power_variance_differs_from_balance():
    integrand, dists = techniques("glossy-light")
    bal = OneSampleMIS(dists).estimate(integrand, 50_000, rng=9)
    pw = OneSampleMIS(dists, heuristic="power").estimate(integrand, 50_000, rng=9)
    assert_unbiased(pw, integrand.exact)
    assert bal.variance != pytest.approx(pw.variance, rel=0.01)


# ---------------------------------------------------------------------------------------
# standard errors
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("heuristic", ["balance", "power", "optimal"])
@pytest.mark.parametrize("name", ["sin", "cos8-hemisphere"])
def test_stderr_calibration(name, heuristic):
    integrand, dists = techniques(name)
    if heuristic == "optimal" and name == "cos8-hemisphere":
        pytest.skip("zero variance: f is a multiple of the Phong density")
    mis = MIS(dists, [0.4, 0.6], heuristic)
    R, n = 200, 1000
    u = np.random.default_rng(10).random((R, n // mis.evals_per_unit, mis.unit_dim()))
    z = mis.estimate(integrand, n, points=u).zscore(integrand.exact)
    assert 0.8 < np.std(z, ddof=1) < 1.2, np.std(z, ddof=1)
    assert abs(np.mean(z)) < 4 / np.sqrt(R)


def test_extra_reports_counts_and_contributions():
    integrand, dists = techniques("glossy-light")
    est = MIS(dists, [1, 3]).estimate(integrand, 10_000, rng=1)
    assert est.extra["counts"] == [2500, 7500]
    contrib = est.extra["variance_contributions"]
    assert contrib.shape == (2,)
    # independent techniques: the variance of the unit sums is the sum of the terms' variances
    # (sample estimates of both: equal within a few % at 2500 units)
    assert est.stderr**2 == pytest.approx(contrib.sum(), rel=0.1)
    assert est.variance == pytest.approx(10_000 * est.stderr**2)
    assert est.n == 10_000
    assert est.to_dict()["counts"] == [2500, 7500]


# ---------------------------------------------------------------------------------------
# settings, counts, warnings
# ---------------------------------------------------------------------------------------
def test_split_counts():
    assert split_counts(10, [0.5, 0.5]).tolist() == [5, 5]
    assert split_counts(10, [1, 0, 2]).tolist() == [3, 0, 7]
    assert split_counts(7, [0.01, 0.99]).tolist() == [2, 5]  # at least 2 per active technique
    for n in range(6, 60):
        c = split_counts(n, [0.13, 0.3, 0.57])
        assert c.sum() == n and c.min() >= 2
    with pytest.raises(ValueError, match="n"):
        split_counts(3, [1, 1])


@pytest.mark.parametrize("fractions", [[-0.5, 1.5], [np.nan, 1], [np.inf, 1], [0.5, 0.3, 0.2], [0, 0], [[1, 1]]])
def test_invalid_fractions(fractions):
    integrand, dists = techniques("sin")
    with pytest.raises(ValueError, match="fractions"):
        MIS(dists, fractions)
    with pytest.raises(ValueError, match="probabilities"):
        OneSampleMIS(dists, fractions)


def test_invalid_settings():
    integrand, dists = techniques("sin")
    with pytest.raises(ValueError, match="balance, power, maximum, cutoff, optimal"):
        MIS(dists, heuristic="veach")
    with pytest.raises(ValueError, match="optimal"):
        OneSampleMIS(dists, heuristic="optimal")
    with pytest.raises(ValueError, match="beta"):
        MIS(dists, heuristic="power", beta=0)
    with pytest.raises(ValueError, match="alpha"):
        MIS(dists, heuristic="cutoff", alpha=1.5)
    with pytest.raises(ValueError, match="optimal_pilot"):
        MIS(dists, heuristic="balance", optimal_pilot=0.1)
    with pytest.raises(ValueError, match="distributions"):
        MIS([])
    with pytest.raises(TypeError, match="pdf"):
        MIS([object()])
    with pytest.raises(ValueError, match="dimension"):  # 1D techniques for a 2D integrand
        MIS(dists).estimate(get("smooth-2d"), 100, rng=0)


def test_bias_warning_when_support_is_missed():
    integrand = get("sin")  # support [0, pi/2]; these cover [0, 1] only
    with pytest.warns(BiasWarning):
        MIS([D.UniformInterval(0, 0.5), D.UniformInterval(0.5, 1)]).estimate(integrand, 100, rng=0)
    with pytest.warns(BiasWarning):
        OneSampleMIS([D.UniformInterval(0, 0.5), D.UniformInterval(0.5, 1)]).estimate(integrand, 100, rng=0)
    # a technique with no samples gets weight 0: the others alone must cover the support
    with pytest.warns(BiasWarning):
        MIS([D.UniformInterval(0, np.pi / 2), D.UniformInterval(0, 1)], [0, 1]).estimate(integrand, 100, rng=0)


def test_heuristic_weights():
    q = np.array([[1.0, 3.0], [2.0, 2.0], [0.0, 0.0], [1.0, 19.0]])
    np.testing.assert_allclose(mis_weights(q, "balance"), [[0.25, 0.75], [0.5, 0.5], [0, 0], [0.05, 0.95]])
    np.testing.assert_allclose(mis_weights(q, "power"), [[0.1, 0.9], [0.5, 0.5], [0, 0], [1 / 362, 361 / 362]])
    np.testing.assert_allclose(mis_weights(q, "maximum"), [[0, 1], [0.5, 0.5], [0, 0], [0, 1]])
    np.testing.assert_allclose(mis_weights(q, "cutoff", alpha=0.1), [[0.25, 0.75], [0.5, 0.5], [0, 0], [0, 1]])
    big = np.array([1e200, 3e200])  # the power heuristic is scaled: no overflow
    np.testing.assert_allclose(mis_weights(big, "power"), [0.1, 0.9])


def test_chunks_and_point_sets():
    integrand, dists = techniques("glossy-light")
    for h in ("balance", "optimal"):
        a = MIS(dists, heuristic=h).estimate(integrand, 30_000, rng=2)
        b = MIS(dists, heuristic=h).estimate(integrand, 30_000, rng=2, chunk=4096)
        assert a.value == pytest.approx(b.value, rel=1e-12)
        assert a.stderr == pytest.approx(b.stderr, rel=1e-8)
    est = MIS(dists).estimate(integrand, 2**14, rng=3, points="sobol")
    assert abs(est.value - integrand.exact) < 4 * est.stderr


# ---------------------------------------------------------------------------------------
# batched use (the renderer calls MIS for all pixels at once)
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("variant", list(VARIANTS))
def test_batched_integrand(variant):
    base, dists = techniques("sin")
    scales = np.array([0.5, 1.0, 3.0])
    batched = Integrand(lambda x: scales[:, None] * np.sin(x[..., 0]), base.domain, scales, "scaled-sin")
    mis = MIS(dists, [0.3, 0.7], **VARIANTS[variant])
    est = mis.estimate(batched, 4000, rng=21)
    assert np.shape(est.value) == (3,) and np.shape(est.stderr) == (3,)
    for b, s in enumerate(scales):
        one = Integrand(lambda x, s=s: s * np.sin(x[..., 0]), base.domain, s)
        ref = mis.estimate(one, 4000, rng=21)
        assert est.value[b] == pytest.approx(ref.value, rel=1e-10)
        assert est.stderr[b] == pytest.approx(ref.stderr, rel=1e-6)
    if variant != "optimal":
        assert est.extra["variance_contributions"].shape == (3, 2)


@pytest.mark.parametrize("heuristic", ["balance", "power", "optimal"])
def test_batched_frames(heuristic):
    """Per-pixel normals: Oriented cosine/Phong techniques with axes (B, 1, 3) and
    f = max(0, w.n_b)^8.  Rotations keep everything, so each pixel's estimate equals the
    unrotated one with the same uniforms."""
    rng = np.random.default_rng(3)
    axes = rng.normal(size=(4, 3))
    axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
    integrand, dists = techniques("cos8-hemisphere")
    f = Integrand(lambda w: np.clip(np.sum(w * axes[:, None, :], -1), 0, None) ** 8, "sphere", 2 * np.pi / 9)
    oriented = [Oriented(d, axes[:, None, :]) for d in dists]
    mis = MIS(oriented, [0.7, 0.3], heuristic, probe=False)
    est = mis.estimate(f, 2000, rng=4)
    ref = MIS(dists, [0.7, 0.3], heuristic).estimate(integrand, 2000, rng=4)
    np.testing.assert_allclose(est.value, ref.value, rtol=1e-9)
    one = OneSampleMIS(oriented, [0.7, 0.3], "balance", probe=False).estimate(f, 2000, rng=4)
    ref1 = OneSampleMIS(dists, [0.7, 0.3]).estimate(integrand, 2000, rng=4)
    np.testing.assert_allclose(one.value, ref1.value, rtol=1e-9)


def test_optimal_per_unit_keeps_the_emitted_term_out_of_its_fit():
    """The renderer's emitted light (``add_emitted``) is a last column: the coefficient comes
    from (Y, H) alone, and each fold f of units (unit j in fold j % 4) gives
    mean_f(Y + E) - a_{-f} mean_f(H - 1), a_{-f} the slope of Y on H over the other folds;
    the residual variance is that of Y + E - a_{-f(j)} H (on Veach's plates with rough plastic,
    pixels on the edge of a bright emitter came out 1.38x too bright at 64 spp when E was
    fitted with Y; 1.00 apart)."""
    g = np.random.default_rng(3)
    m = 64
    h = g.normal(size=(200, m))
    y = 2.0 + 0.5 * h + 0.1 * g.normal(size=(200, m))
    e = np.where(h > 1.5, 40.0, 0.0)                       # emitted light seen with the control's tail
    est = MIS(["a", "b"], heuristic="optimal")
    out = est.add_emitted(np.stack([y, h], -1), e)
    assert out.shape == (200, m, 3)
    value, stderr = est.fold(out)
    fold = np.arange(m) % 4
    resid = np.empty_like(y)
    for f in range(4):
        hs, ys = h[:, fold != f], y[:, fold != f]
        hc = hs - hs.mean(-1, keepdims=True)
        a = np.sum(hc * ys, -1) / np.sum(hc * hc, -1)                  # least squares on the other folds
        resid[:, fold == f] = (y + e - a[:, None] * h)[:, fold == f]
    assert np.allclose(value, resid.mean(-1), rtol=1e-12)
    assert np.allclose(stderr ** 2, resid.var(-1, ddof=1) / m, rtol=1e-9)
    truth = 2.0 + 40.0 * stats.norm.sf(1.5)                # E[Y + E], the controls of mean 0
    assert abs(np.mean(value) - truth) < 4 * np.std(value) / np.sqrt(200)
