"""The chi-square harness itself: calibrated under the null, pools cells, fails loudly."""
import numpy as np
import pytest
from scipy import stats

from vrlab import distributions as D
from vrlab.testing import (DiskChart, IntervalChart, SphereChart, assert_gof, cell_integrals, chi2_discrete,
                           chi2_gof, integrate, pooled_chi2, sidak_threshold)


def test_false_rejection_rate_is_calibrated():
    # Under the null the p-value is ~uniform: at level 0.05 about 5% of 300 tests reject.
    dist = D.LinearInterval(0, 1, 0.2, 1.0)
    rejections = sum(chi2_gof(dist, IntervalChart(0, 1), (20,), n=2000, rng=seed).pvalue < 0.05
                     for seed in range(300))
    lo, hi = stats.binom.ppf([0.0005, 0.9995], 300, 0.05)
    assert lo <= rejections <= hi


def test_pooling_keeps_every_pooled_cell_above_the_minimum():
    exp = np.array([0.1] * 30 + [2.0] * 5 + [50.0] * 4)
    obs = np.array([0] * 30 + [2] * 5 + [50] * 4)
    res = pooled_chi2(obs, exp, min_expected=5)
    # 3 + 10 = 13 units of small mass -> 2 pools (the leftover joins a large cell), plus 4 large cells
    assert res.dof + 1 <= 6 and res.pvalue > 0.5


def test_samples_where_pdf_is_zero_fail_with_a_message():
    class Leaky:
        dim_u, dim_x = 1, 1

        def sample(self, u):
            return u * 1.2  # 1/6 of the samples leave [0, 1]

        def pdf(self, x):
            return np.where((x[..., 0] >= 0) & (x[..., 0] <= 1), 1.0, 0.0)

    res = chi2_gof(Leaky(), IntervalChart(0, 1), (10,), n=10_000, rng=0)
    assert res.pvalue == 0 and res.outside > 0
    with pytest.raises(AssertionError, match="outside the domain"):
        assert_gof(res)


def test_wrong_normalisation_is_rejected():
    class Scaled(D.UniformSphere):
        def pdf(self, w):
            return 1.03 * super().pdf(w)

    assert integrate(Scaled().pdf, SphereChart(), 32) == pytest.approx(1.03)
    with pytest.raises(AssertionError, match="expected total"):
        assert_gof(chi2_gof(Scaled(), SphereChart(), (20, 20), n=400_000, rng=1))


def test_cell_integrals_are_exact_for_polynomials():
    # int over [0, 1] cells of 3 x^2 = (b^3 - a^3)
    got = cell_integrals(lambda x: 3 * x[..., 0] ** 2, IntervalChart(0, 1), (4,), quad=3)
    np.testing.assert_allclose(got, np.diff(np.linspace(0, 1, 5) ** 3))
    # disk area through the chart
    assert cell_integrals(lambda x: np.ones(x.shape[:-1]), DiskChart(2.0), (3, 5)).sum() == pytest.approx(4 * np.pi)


def test_discrete_harness_and_sidak():
    pmf = np.array([0.5, 0.25, 0.125, 0.125])
    idx = np.random.default_rng(0).choice(4, 20_000, p=pmf)
    assert chi2_discrete(idx, pmf).pvalue > 1e-3
    assert chi2_discrete(idx, [0.45, 0.3, 0.125, 0.125]).pvalue < 1e-6
    assert chi2_discrete(np.array([0, 1, 7]), pmf).outside == 1
    assert sidak_threshold(0.01, 1) == pytest.approx(0.01)
    assert sidak_threshold(0.01, 20) == pytest.approx(1 - 0.99 ** (1 / 20))
