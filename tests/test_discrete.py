"""Discrete distributions: alias table and CDF table.

Every test runs with both builds of the alias table, the NumPy one and the compiled kernel
(``kernels="numpy"`` / ``"numba"``, set as AliasTable's default by the ``alias_kernels``
fixture; the CDF-table tests simply run twice).  Chi-square fit of the indices, exactness of the table (the pmf it encodes against
w / sum(w), up to n = 10^7), zero weights never drawn, bad weights rejected with a
message naming the problem, edge uniforms, batching, the remapped leftover uniform,
and checks that the chi-square harness does reject a wrong table.
"""
import numpy as np
import pytest
from scipy import stats
from scipy.special import softmax

from vrlab.distributions.discrete import AliasTable, CDFTable, _accurate_total
from vrlab.testing import assert_gof, chi2_discrete, pooled_chi2

CLASSES = [AliasTable, CDFTable]
ONE_MINUS = np.nextafter(1.0, 0.0)


@pytest.fixture(autouse=True, params=["numpy", "numba"])
def alias_kernels(request, monkeypatch):
    """Every AliasTable built in a test of this module uses ``kernels=request.param``."""
    monkeypatch.setitem(AliasTable.__init__.__kwdefaults__, "kernels", request.param)
    return request.param


def _weights(name):
    rng = np.random.default_rng(7)
    if name == "uniform":
        return np.full(10, 2.5)
    if name == "power-law":
        return np.arange(1, 201, dtype=float) ** -1.5
    if name == "zeros":
        w = rng.random(60) ** 2
        w[[0, 3, 4, 17, 30, 59]] = 0.0
        return w
    if name == "n=1":
        return np.array([3.0])
    if name == "two-valued":
        return np.where(rng.random(500) < 0.3, 5.0, 1.0)
    if name == "large":  # above the alias sampler's small-table limit: packed words
        w = rng.exponential(size=150_000) ** 2
        w[rng.random(w.size) < 0.1] = 0.0
        return w
    raise KeyError(name)


GOF = ["uniform", "power-law", "zeros", "n=1", "two-valued", "large"]
N_GOF = len(GOF) * len(CLASSES)


def implied_alias_pmf(t: AliasTable) -> np.ndarray:
    """(q_i + sum over columns j with alias_j = i of (1 - q_j)) / n, from the public table."""
    q = np.asarray(t.q, dtype=float)
    return (q + np.bincount(np.asarray(t.alias), weights=1.0 - q, minlength=t.n)) / t.n


def max_rel_err(got, w):
    want = w / w.sum()
    pos = want > 0
    assert np.all(got[~pos] == 0.0)
    return float(np.max(np.abs(got[pos] - want[pos]) / want[pos]))


# --- goodness of fit ------------------------------------------------------------------

@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
@pytest.mark.parametrize("name", GOF)
def test_chi_square(cls, name):
    w = _weights(name)
    t = cls(w)
    n_draws = 2_000_000 if w.size > 10_000 else 200_000
    u = np.random.default_rng(20261121).random(n_draws)
    i = t.sample(u)
    assert i.dtype.kind == "i" and i.shape == u.shape
    res = chi2_discrete(i, t.pmf(), name=f"{cls.__name__}/{name}")
    assert res.outside == 0
    assert_gof(res, alpha=0.01, m=N_GOF)


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_chi_square_rejects_a_perturbed_distribution(cls):
    """The harness can fail: samples of weights with one entry 2% too large, tested
    against the intended pmf, are rejected."""
    w = np.array([1.0, 2.0, 3.0, 4.0])
    wrong = w.copy()
    wrong[3] *= 1.02
    u = np.random.default_rng(5).random(1_000_000)
    res = chi2_discrete(cls(wrong).sample(u), w / w.sum())
    with pytest.raises(AssertionError, match="chi-square test rejected"):
        assert_gof(res, alpha=0.01)
    assert_gof(chi2_discrete(cls(w).sample(u), w / w.sum()), alpha=0.01)  # and the right one passes


def test_chi_square_rejects_a_corrupted_alias_column():
    """A table bug (one column's split point off by 0.02) is caught by the harness."""
    w = np.array([1.0, 2.0, 3.0, 4.0])
    t = AliasTable(w)
    col = int(np.flatnonzero((t.q > 0.05) & (t.q < 0.95))[0])
    t._thresh = t._thresh.copy()
    t._thresh[col] += 0.02
    res = chi2_discrete(t.sample(np.random.default_rng(6).random(1_000_000)), w / w.sum())
    with pytest.raises(AssertionError):
        assert_gof(res, alpha=0.01)


# --- exactness of the tables ----------------------------------------------------------

def test_alias_table_reproduces_weights_at_ten_million():
    rng = np.random.default_rng(11)
    w = rng.pareto(1.5, size=10_000_000)
    w[rng.random(w.size) < 0.05] = 0.0
    t = AliasTable(w)
    assert t.n == w.size
    assert np.all((t.q >= 0) & (t.q <= 1))
    assert max_rel_err(implied_alias_pmf(t), w) <= 1e-9


@pytest.mark.parametrize("name", ["power-law", "zeros", "two-valued", "large"])
def test_alias_table_invariants(name):
    w = _weights(name)
    t = AliasTable(w)
    q, alias = np.asarray(t.q), np.asarray(t.alias)
    assert q.shape == alias.shape == (w.size,)
    assert np.all((q >= 0) & (q <= 1))
    assert np.all((alias >= 0) & (alias < w.size))
    used = q < 1
    assert np.all(w[alias[used]] > 0), "an alias that can be drawn points at a zero weight"
    assert np.all(q[w == 0] == 0)
    assert max_rel_err(implied_alias_pmf(t), w) <= 1e-12
    assert max_rel_err(t.table_pmf(), w) <= 1e-12


@pytest.mark.parametrize("w", [
    np.r_[np.ones(30_000), 2.0],                                          # one heavy item
    1.0 + np.random.default_rng(3).random(50_000) * 1e-13,                # ties within ulps
    np.r_[1 + np.random.default_rng(4).random(20_000) * 1e-13,
          1 - np.random.default_rng(5).random(20_000) * 1e-13],
    np.random.default_rng(6).integers(1, 4, 50_000).astype(float),      # repeated values
], ids=["one-heavy", "jitter", "jitter-both", "repeated"])
def test_alias_exact_lookup_agrees(w):
    """The float interval look-up and the forced exact one give valid, exact tables."""
    fast, exact = AliasTable(w), AliasTable(w, _exact=True)
    for t in (fast, exact):
        assert np.all((t.q >= 0) & (t.q <= 1))
        assert max_rel_err(implied_alias_pmf(t), w) <= 1e-11
    np.testing.assert_allclose(fast.table_pmf(), exact.table_pmf(), rtol=1e-12, atol=0)


FAMILIES = {
    "uniform(0,1)": lambda r, n: r.random(n),
    "integers 1-4": lambda r, n: r.integers(1, 5, n).astype(float),
    "1 + 1e-12 noise": lambda r, n: 1 + r.random(n) * 1e-12,
    "1 or 1 + 1e-15": lambda r, n: np.where(r.random(n) < 0.5, 1.0, 1 + 1e-15),
    "pareto(0.5)": lambda r, n: r.pareto(0.5, n),
    "lognormal(0, 10)": lambda r, n: np.exp(r.normal(0, 10, n)),
    "ones and one n": lambda r, n: np.r_[np.ones(n - 1), float(n)],
    "90% zeros": lambda r, n: np.where(np.arange(n) % 10 == 3, r.random(n) + 0.1, 0.0),
    "k/7 pattern": lambda r, n: (np.arange(n) % 7 + 1) / 7.0,
}


@pytest.mark.parametrize("n", [97, 20_000])
@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_alias_table_weight_families(family, n):
    """Valid, exact tables for awkward weight families (ties, near-uniform, huge range)."""
    rng = np.random.default_rng(n)
    w = FAMILIES[family](rng, n)
    t = AliasTable(w)
    assert np.all((t.q >= 0) & (t.q <= 1))
    assert max_rel_err(implied_alias_pmf(t), w) <= 1e-11
    u = rng.random(5000)
    i, r = t.sample(u, return_remapped=True)
    assert np.array_equal(i, t.sample(u)) and np.all(w[i] > 0) and np.all((r >= 0) & (r < 1))


def test_uniform_weights_are_exact():
    for n in (1, 2, 7, 1000):
        t = AliasTable(np.full(n, 0.1))
        assert np.all(t.q == 1.0) and np.array_equal(t.alias, np.arange(n))
        assert np.all(implied_alias_pmf(t) == 1.0 / n)
        c = CDFTable(np.full(n, 0.1))
        assert c.cdf[-1] == 1.0


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_softmax_of_ones(cls):
    """softmax(ones(1533)) sums to 1 only up to rounding; numpy's choice rejects it
    ("probabilities do not sum to 1"), ours must not."""
    p = softmax(np.ones(1533))
    t = cls(p)
    np.testing.assert_allclose(t.pmf(), 1 / 1533, rtol=1e-15)
    if cls is AliasTable:
        assert np.all(implied_alias_pmf(t) == 1 / 1533)
    i = t.sample(np.random.default_rng(1).random(300_000))
    assert_gof(chi2_discrete(i, t.pmf()), alpha=0.01, m=2)
    # a near-uniform variant goes through the general construction
    w2 = softmax(1 + np.random.default_rng(2).random(1533) * 1e-9)
    t2 = cls(w2)
    i2 = t2.sample(np.linspace(0, ONE_MINUS, 5000))
    assert np.all((i2 >= 0) & (i2 < 1533))
    if cls is AliasTable:
        assert max_rel_err(implied_alias_pmf(t2), w2) <= 1e-13


def test_cdf_table_is_accurate():
    """CDF steps are exact to a couple of ulps of C (absolute: a cumulative table
    cannot resolve a 1e-16 step next to C = 0.9; the alias table can)."""
    w = _weights("large")
    t = CDFTable(w)
    assert np.all(np.diff(t.cdf) >= 0) and t.cdf[-1] == 1.0
    want, got = w / w.sum(), t.table_pmf()
    assert np.all(got[want == 0] == 0)
    assert np.max(np.abs(got - want)) <= 4 * 2.0**-53
    big = want > 1e-6
    assert np.max(np.abs(got[big] - want[big]) / want[big]) <= 1e-9


def test_accurate_total_both_ways():
    """The normalising sum is correctly rounded (vs math.fsum) to an ulp or two, with
    long double and with the split sums used where long double is plain double."""
    import math
    rng = np.random.default_rng(8)
    for w in (rng.random(100_000) * 1e-3, rng.pareto(1.0, 50_000) * 1e200, np.full(7, 0.1),
              np.r_[1.0, np.full(10_000, 2.0**-60)]):
        exact = math.fsum(w)
        for extended in (True, False):
            assert math.isclose(float(_accurate_total(w, extended)), exact, rel_tol=2.3e-16, abs_tol=0)


# --- zero weights, edges, shapes ------------------------------------------------------

@pytest.mark.parametrize("reps", [1, 20_000], ids=["n=11", "n=220000"])
@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_zero_weights_never_drawn(cls, reps):
    w = np.tile([0.0, 0.0, 1.0, 0.0, 1e-300, 3.0, 0.0, 0.0, 2.0, 0.0, 0.0], reps)
    t = cls(w)
    n = w.size
    rng = np.random.default_rng(9)
    edges = np.r_[0.0, ONE_MINUS, np.arange(n) / n, np.nextafter(np.arange(1, n + 1) / n, 0)]
    u = np.r_[edges, rng.random(1_000_000)]
    i = t.sample(u)
    assert np.all(w[i] > 0)
    i2, r = t.sample(u, return_remapped=True)
    assert np.array_equal(i, i2) and np.all(w[i2] > 0)
    assert np.all((r >= 0) & (r < 1))
    assert np.all(t.pmf(np.flatnonzero(w == 0)) == 0)


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
@pytest.mark.parametrize("n", [1, 3, 7, 1000, 100_001, 300_007])
def test_edge_uniforms_give_valid_indices(cls, n):
    w = np.random.default_rng(n).random(n) + 0.01
    t = cls(w)
    u = np.array([0.0, 2.0**-53, 0.5, np.nextafter(0.5, 0), ONE_MINUS, np.nextafter(ONE_MINUS, 0)])
    i = t.sample(u)
    assert np.all((i >= 0) & (i < n))
    i2, r = t.sample(u, return_remapped=True)
    assert np.array_equal(i, i2)
    assert np.all((r >= 0) & (r < 1))


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_batched_shapes(cls):
    t = cls(_weights("power-law"))
    rng = np.random.default_rng(4)
    u = rng.random((4, 5))
    i = t.sample(u)
    assert i.shape == (4, 5)
    assert np.array_equal(i.ravel(), [int(t.sample(x)) for x in u.ravel()])  # one at a time agrees
    assert np.array_equal(t.sample(u[..., None]), i)          # (..., 1): dim_u = 1 axis dropped
    assert t.sample(rng.random((6, 1))).shape == (6,)
    assert t.sample(0.3).shape == ()
    assert t.sample([0.1, 0.2]).shape == (2,)
    i2, r = t.sample(u, return_remapped=True)
    assert i2.shape == r.shape == (4, 5) and np.array_equal(i, i2)
    assert t.sample_remap(u)[1].shape == (4, 5)
    big = rng.random(3 * 65536 + 17)  # crosses the alias sampler's blocks
    assert np.array_equal(t.sample(big), t.sample(big.reshape(-1, 1)))
    assert np.array_equal(t.sample(big)[-100:], t.sample(big[-100:]))


@pytest.mark.parametrize("reps", [1, 30_000], ids=["n=7", "n=210000"])
@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_remapped_uniform_is_uniform_and_independent(cls, reps):
    """Given each index (class i mod 7), the leftover uniform is U[0,1): a KS test per
    class and a chi-square on the joint (class, decile) table, Šidák-corrected."""
    base = np.array([0.5, 3.0, 0.0, 1.0, 2.0, 0.25, 4.0])
    w = np.tile(base, reps)
    t = cls(w)
    u = np.random.default_rng(12).random(400_000)
    i, r = t.sample(u, return_remapped=True)
    assert np.array_equal(i, t.sample(u))
    assert np.all((r >= 0) & (r < 1))
    k = i % 7
    pos = np.flatnonzero(base > 0)
    level = 1 - (1 - 0.01) ** (1 / (len(pos) + 1))
    for cl in pos:
        assert stats.kstest(r[k == cl], "uniform").pvalue > level, f"class {cl}"
    bins = 10
    joint = np.bincount(k * bins + np.minimum((r * bins).astype(int), bins - 1), minlength=7 * bins)
    expected = len(u) * np.repeat(base / base.sum(), bins) / bins
    res = pooled_chi2(joint, expected, name="joint (index, decile)")
    assert res.outside == 0 and res.pvalue > level, res.message()


def test_remapped_uniform_test_can_fail():
    """Feeding the raw u instead of the remapped one is caught (it depends on the index)."""
    w = np.array([1.0, 2.0, 3.0])
    t = AliasTable(w)
    u = np.random.default_rng(13).random(200_000)
    i = t.sample(u)
    assert min(stats.kstest(u[i == k], "uniform").pvalue for k in range(3)) < 1e-6


# --- bad weights ----------------------------------------------------------------------

@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
@pytest.mark.parametrize("weights, words", [
    ([1.0, 2.0, 0.5, -1.0, 2.0], ["negative", "index 3"]),
    ([1.0, np.nan, 2.0], ["NaN", "index 1"]),
    ([1.0, 2.0, np.inf], ["infinite", "index 2"]),
    ([1.0, -np.inf], ["infinite", "index 1"]),
    ([0.0, 0.0, 0.0], ["zero"]),
    ([], ["empty"]),
    ([[1.0, 2.0], [3.0, 4.0]], ["1-D", "(2, 2)"]),
    (3.0, ["1-D"]),
    (["a", "b"], ["real numbers"]),
], ids=["negative", "nan", "inf", "-inf", "all-zero", "empty", "2-D", "scalar", "strings"])
def test_bad_weights_raise(cls, weights, words):
    with pytest.raises(ValueError) as info:
        cls(weights)
    msg = str(info.value)
    assert msg.startswith("weights:")
    for word in words:
        assert word in msg, msg


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_huge_weights_whose_sum_overflows(cls):
    w = np.array([1e308, 1e308, 0.0, 1e308, 5e307])
    t = cls(w)
    assert t.total == np.inf
    want = np.array([2, 2, 0, 2, 1]) / 7
    np.testing.assert_allclose(t.pmf(), want, rtol=1e-15)
    i = t.sample(np.random.default_rng(3).random(100_000))
    assert_gof(chi2_discrete(i, want), alpha=0.01, m=2)
    tiny = cls(np.array([1e-320, 3e-320, 0.0]))  # subnormal weights: rescaled, not underflowed
    np.testing.assert_allclose(tiny.pmf(), [0.25, 0.75, 0.0], rtol=1e-3)


# --- protocol -------------------------------------------------------------------------

@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_protocol(cls):
    w = np.array([1.0, 0.0, 3.0])
    t = cls(w)
    assert t.dim_u == 1 and t.measure == "counting" and t.n == len(t) == 3
    assert t.total == 4.0
    np.testing.assert_array_equal(t.pmf(), [0.25, 0.0, 0.75])
    np.testing.assert_array_equal(t.probabilities, t.pmf())
    np.testing.assert_array_equal(t.pmf([2, 0, -1, 3]), [0.75, 0.25, 0.0, 0.0])
    np.testing.assert_array_equal(t.pdf(np.array([[0, 2]])), [[0.25, 0.75]])
    assert t.pmf(2.0) == 0.75
    with pytest.raises(ValueError):
        t.pmf(0.5)
    with pytest.raises(TypeError):
        t.pmf(np.array([True]))
    i, p = t.sample_pdf(np.array([0.1, 0.9]))
    np.testing.assert_array_equal(p, t.pmf(i))
    assert cls.__name__ in repr(t)
    w2 = w.copy()
    t2 = cls(w2)
    w2[:] = [5.0, 5.0, 5.0]  # the caller's array changes later: the distribution does not
    np.testing.assert_array_equal(t2.pmf(), [0.25, 0.0, 0.75])
