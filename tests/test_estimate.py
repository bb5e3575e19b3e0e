"""Moments (chunked = one-shot, merge associativity, batches) and Estimate (ci, zscore, to_dict, efficiency)."""
import json
import math

import numpy as np
import pytest
from scipy import stats

from vrlab.estimate import Estimate, Moments


def _oneshot(v):
    v = np.asarray(v, float)
    mean = v.mean(-1)
    return mean, np.sum((v - mean[..., None]) ** 2, -1)


def _chunked(v, size):
    mom = Moments()
    for lo in range(0, v.shape[-1], size):
        mom.add(v[..., lo:lo + size])
    return mom


@pytest.mark.parametrize("size", [1, 7, 1000])
def test_chunked_equals_oneshot(size):
    rng = np.random.default_rng(1)
    v = 3.0 + rng.standard_exponential(2503) * 2.0   # skewed, non-zero mean, n not a multiple of any size
    mom = _chunked(v, size)
    mean, m2 = _oneshot(v)
    assert mom.count == v.size
    assert mom.mean == pytest.approx(mean, rel=1e-12)
    assert mom.m2 == pytest.approx(m2, rel=1e-12)
    assert mom.variance == pytest.approx(np.var(v, ddof=1), rel=1e-12)


def test_large_offset_is_stable():
    # Welford/Chan merging does not cancel catastrophically: variance 1 around a mean of 1e8
    rng = np.random.default_rng(2)
    v = 1e8 + rng.standard_normal(10_000)
    mean = math.fsum(v) / v.size
    exact = math.fsum((x - mean) ** 2 for x in v) / (v.size - 1)
    assert _chunked(v, 7).variance == pytest.approx(exact, rel=1e-8)


def test_merge_is_associative_and_matches_all_at_once():
    rng = np.random.default_rng(3)
    parts = [rng.normal(size=k) for k in (5, 40, 333)]

    def mom(p):
        return Moments().add(p)

    left = mom(parts[0]).merge(mom(parts[1])).merge(mom(parts[2]))
    right = mom(parts[0]).merge(mom(parts[1]).merge(mom(parts[2])))
    mean, m2 = _oneshot(np.concatenate(parts))
    for m in (left, right):
        assert m.count == 378
        assert m.mean == pytest.approx(mean, rel=1e-12)
        assert m.m2 == pytest.approx(m2, rel=1e-12)
    assert left.mean == pytest.approx(right.mean, rel=1e-13)
    assert left.m2 == pytest.approx(right.m2, rel=1e-13)


def test_merge_with_empty_and_empty_block():
    a = Moments().add(np.array([1.0, 2.0, 4.0]))
    before = (a.count, float(a.mean), float(a.m2))
    a.merge(Moments())
    a.add(np.zeros(0))
    assert (a.count, float(a.mean), float(a.m2)) == before
    b = Moments().merge(Moments().add(np.array([1.0, 2.0, 4.0])))
    assert (b.count, float(b.mean), float(b.m2)) == before


def test_merge_does_not_alias_the_other_accumulator():
    other = Moments().add(np.array([[1.0, 3.0], [2.0, 6.0]]))
    keep = (other.mean.copy(), other.m2.copy())
    mine = Moments().merge(other)
    mine.add(np.array([[10.0, 10.0], [0.0, 0.0]]))
    np.testing.assert_array_equal(other.mean, keep[0])
    np.testing.assert_array_equal(other.m2, keep[1])


def test_batched_shapes():
    rng = np.random.default_rng(4)
    v = rng.normal(size=(3, 4, 101))
    mom = _chunked(v, 10)
    assert np.shape(mom.mean) == (3, 4) and np.shape(mom.variance) == (3, 4)
    np.testing.assert_allclose(mom.mean, v.mean(-1), rtol=1e-12)
    np.testing.assert_allclose(mom.variance, v.var(-1, ddof=1), rtol=1e-12)
    est = Estimate.from_moments(mom, n_evals=101)
    assert est.value.shape == (3, 4) and est.stderr.shape == (3, 4)
    np.testing.assert_allclose(est.stderr, np.sqrt(v.var(-1, ddof=1) / 101), rtol=1e-12)
    lo, hi = est.ci()
    assert lo.shape == hi.shape == (3, 4)
    assert est.zscore(0.0).shape == (3, 4)
    d = est.to_dict()
    assert np.shape(d["value"]) == (3, 4)
    json.dumps(d)


def test_variance_needs_two_samples():
    assert np.isnan(Moments().add(np.array([1.0])).variance)
    assert np.all(np.isnan(Moments().add(np.ones((2, 1))).variance))


def _estimate():
    mom = Moments().add(np.array([1.0, 2.0, 3.0, 4.0, 10.0]))
    return Estimate.from_moments(mom, n_evals=10, seconds=0.5, method="test", alpha=np.float64(1.5))


def test_from_moments_fields():
    e = _estimate()
    v = np.array([1.0, 2.0, 3.0, 4.0, 10.0])
    assert e.value == pytest.approx(4.0)
    assert e.variance == pytest.approx(np.var(v, ddof=1))
    assert e.stderr == pytest.approx(np.sqrt(np.var(v, ddof=1) / 5))
    assert (e.n, e.n_evals, e.seconds, e.method) == (5, 10, 0.5, "test")
    assert isinstance(e.value, float) and isinstance(e.stderr, float)


def test_ci_and_zscore():
    e = _estimate()
    lo, hi = e.ci(0.95)
    z = stats.norm.ppf(0.975)
    assert lo == pytest.approx(e.value - z * e.stderr) and hi == pytest.approx(e.value + z * e.stderr)
    lo90, hi90 = e.ci(0.9)
    assert lo < lo90 < e.value < hi90 < hi
    assert e.zscore(3.0) == pytest.approx((e.value - 3.0) / e.stderr)
    for bad in (0, 1, 1.5, -0.1):
        with pytest.raises(ValueError, match="level"):
            e.ci(bad)


def test_zscore_with_zero_stderr_does_not_warn():
    e = Estimate(1.0, 0.0, 10, 10)
    with np.errstate(all="raise"):
        assert np.isinf(e.zscore(0.0))
        assert np.isnan(e.zscore(1.0))


def test_efficiency():
    e = _estimate()
    assert e.efficiency == pytest.approx(1.0 / (e.stderr**2 * 0.5))
    assert np.isinf(Estimate(1.0, 0.0, 10, 10, seconds=1.0).efficiency)


def test_to_dict_is_plain_json():
    d = _estimate().to_dict()
    text = json.dumps(d)
    back = json.loads(text)
    assert back["value"] == pytest.approx(4.0) and back["n"] == 5 and back["n_evals"] == 10
    assert back["method"] == "test" and back["alpha"] == 1.5
    assert set(back) >= {"value", "stderr", "n", "n_evals", "seconds", "method", "variance"}


def test_samples_along_another_axis():
    # Moments.add(values, axis=k) equals moving the samples to the last axis first
    rng = np.random.default_rng(3)
    v = rng.standard_exponential((40, 17, 3))
    a = Moments().add(v, axis=1)
    b = Moments().add(np.moveaxis(v, 1, -1))
    assert a.count == b.count == 17
    np.testing.assert_allclose(a.mean, b.mean, rtol=1e-13)
    np.testing.assert_allclose(a.m2, b.m2, rtol=1e-12)
    np.testing.assert_allclose(a.variance, np.var(v, axis=1, ddof=1), rtol=1e-12)


def test_image_mean_and_its_standard_error():
    from vrlab.metrics import image_mean

    v = np.arange(24, dtype=float).reshape(2, 4, 3)
    e = np.full((2, 4, 3), 2.0)
    m, s = image_mean(v, e)
    assert np.allclose(m, v.reshape(-1, 3).mean(0)) and np.allclose(s, np.sqrt(8 * 4.0) / 8)
    with pytest.raises(ValueError, match="value, stderr"):
        image_mean(v, e[0])


# -- sample values whose variance float64 cannot carry: refused, never a silent inf or 0 ----------
@pytest.mark.parametrize("scale", [1e200, 1e-200, 1e-160])
def test_samples_whose_squares_leave_float64_are_refused(raises_naming, scale):
    """1e200: squared deviations overflow (the stderr was inf); 1e-200 and 1e-160: they
    underflow and the variance and stderr were silently 0."""
    v = scale * np.random.default_rng(3).random(1000)
    with raises_naming(ValueError, "values", "rescale"):
        Moments().add(v)


@pytest.mark.parametrize("scale", [1e140, 1e-140])
def test_extreme_but_representable_samples_keep_their_variance(scale):
    v = scale * np.random.default_rng(4).random(1000)
    mom = _chunked(v, 64)
    assert mom.variance / scale**2 == pytest.approx(np.var(v / scale, ddof=1), rel=1e-9)


def test_equal_tiny_samples_have_variance_zero_and_float32_is_not_checked():
    assert Moments().add(np.full(50, 1e-200)).variance == 0.0
    mom = Moments().add(np.float32(1e-30) * np.arange(8, dtype=np.float32))   # squares 1e-60: fine in float64
    assert mom.variance > 0


@pytest.mark.parametrize("a, b", [(0.0, 1e160), (1e-200, 2e-200)])
def test_merges_that_overflow_or_underflow_are_refused(raises_naming, a, b):
    """Two blocks of equal samples each (zero spread) whose means differ by 1e160 (the
    merged squares overflow) or by 1e-200 (they underflow to a variance of 0)."""
    mom = Moments().add(np.full(10, a))
    with raises_naming(ValueError, "values"):
        mom.add(np.full(10, b))


@pytest.mark.parametrize("recipe", ["mc", "stratified", "mis-optimal", "cv", "rqmc-sobol", "antithetic"])
@pytest.mark.parametrize("scale", [1e200, 1e-200])
def test_estimators_refuse_an_integrand_beyond_float64s_variance(raises_naming, recipe, scale):
    """Every accumulator (Moments, the CoMoments of regression estimators, Stratified's
    per-stratum variances) refuses instead of returning an inf or 0 error bar."""
    from vrlab import Integrand
    from vrlab.integrands import get
    from vrlab.lab.registry import build

    g = get("exp")
    scaled = Integrand(lambda x: scale * g.f(x), g.domain, exact=scale * g.exact, name="exp-scaled",
                       techniques=g.techniques, controls={"x": (lambda x: x[..., 0], 0.5)})
    est, points = build(recipe, scaled)
    with raises_naming(ValueError, "values", "rescale"):
        est.estimate(scaled, 4096, rng=1, points=points)
