"""The chi-square harness itself: calibrated under the null, pools cells, fails loudly."""
import numpy as np
import pytest
from scipy import stats

from vrlab import distributions as D
from vrlab.testing import (AtlasChart, BoxChart, CapChart, DiskChart, EllipsoidChart, GofResult, HalfLineChart,
                           HemisphereChart, IntervalChart, ParallelogramChart, SphereChart, TriangleChart, assert_gof,
                           box_surface_chart, cell_integrals, chi2_discrete, chi2_gof, histogram, integrate,
                           pooled_chi2, sidak_threshold)
from vrlab.testing.stats import std_band, u_nodes


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


# -- bad input: every argument is checked, and nothing without samples can pass -------------------
UNIT = D.UniformInterval(0, 1)


class _Sampler:
    """Uniform on [0, 1] with a changeable sample map (NaN, off-chart, wrong shape...)."""

    dim_u = 1

    def __init__(self, warp):
        self.warp = warp

    def sample(self, u):
        return self.warp(np.array(u, dtype=float))

    def pdf(self, x):
        return np.ones(np.shape(x)[:-1])


@pytest.mark.parametrize("kw, exc, name", [
    ({"n": 0}, ValueError, "n"),
    ({"n": -5}, ValueError, "n"),
    ({"n": 16.7}, TypeError, "n"),
    ({"n": np.nan}, TypeError, "n"),
    ({"n": "1000"}, TypeError, "n"),
    ({"n": 10**12}, ValueError, "n"),
    ({"n": 1}, ValueError, "n"),            # too few samples for two pooled cells: no verdict
    ({"n": 8}, ValueError, "n"),
    ({"bins": (0,)}, ValueError, "bins"),
    ({"bins": (2.5,)}, TypeError, "bins"),
    ({"bins": 2.5}, TypeError, "bins"),
    ({"bins": (1,)}, ValueError, "bins"),   # one cell tests nothing
    ({"bins": (10, 10)}, ValueError, "bins"),
    ({"bins": ()}, ValueError, "bins"),
    ({"bins": "10"}, TypeError, "bins"),
    ({"bins": (10**9,)}, ValueError, "bins"),
    ({"quad": 0}, ValueError, "quad"),
    ({"quad": 2.0}, TypeError, "quad"),
    ({"quad": 10**6}, ValueError, "quad"),
    ({"sub": 0}, ValueError, "sub"),
    ({"sub": 10**7}, ValueError, "sub"),
    ({"min_expected": 0}, ValueError, "min_expected"),
    ({"min_expected": -1}, ValueError, "min_expected"),
    ({"min_expected": np.nan}, ValueError, "min_expected"),
    ({"min_expected": 1e12}, ValueError, "min_expected"),
    ({"rng": -1}, ValueError, "rng"),
    ({"rng": "seed"}, TypeError, "rng"),
    ({"points": 3}, TypeError, "points"),
    ({"name": 3}, TypeError, "name"),
    ({"dist": 3}, TypeError, "dist"),
    ({"dist": _Sampler(lambda u: u[:, 0])}, ValueError, "dist"),            # shape (n,) for (n, 1)
    ({"dist": _Sampler(lambda u: u[: len(u) // 2])}, ValueError, "dist"),   # half the samples
    ({"dist": _Sampler(lambda u: np.full(u.shape, "a"))}, TypeError, "dist"),
    ({"chart": 3}, TypeError, "chart"),
    ({"chart": SphereChart(), "bins": (4, 4)}, ValueError, "dist"),          # 1D samples on a sphere chart
])
def test_chi2_gof_bad_arguments(raises_naming, kw, exc, name):
    args = {"dist": UNIT, "chart": IntervalChart(0, 1), "bins": (10,), "n": 2000}
    args.update(kw)
    with raises_naming(exc, name):
        chi2_gof(args.pop("dist"), args.pop("chart"), args.pop("bins"), **args)


def test_chi2_gof_bad_point_sets(raises_naming):
    class Points:
        def __init__(self, values):
            self.values = values

        def random(self, n):
            return self.values(n)

    for values in (lambda n: np.full((n, 1), np.nan), lambda n: np.full((n, 1), 1.5), lambda n: np.zeros((n // 2, 1))):
        with raises_naming(ValueError, "points"):
            chi2_gof(UNIT, IntervalChart(0, 1), (10,), n=2000, points=Points(values))


def test_nan_and_off_chart_samples_fail():
    nan_some = _Sampler(lambda u: np.where(np.arange(len(u))[:, None] % 7 == 0, np.nan, u))
    res = chi2_gof(nan_some, IntervalChart(0, 1), (10,), n=10_000, rng=0)
    assert res.pvalue == 0 and res.nonfinite == 1429 and res.outside == 1429
    with pytest.raises(AssertionError, match="NaN or infinite"):
        assert_gof(res)
    for warp in (lambda u: np.full_like(u, np.nan), lambda u: np.full_like(u, np.inf), lambda u: u + 5.0):
        res = chi2_gof(_Sampler(warp), IntervalChart(0, 1), (10,), n=10_000, rng=0)
        assert res.pvalue == 0 and res.outside == 10_000
        with pytest.raises(AssertionError, match="outside the domain"):
            assert_gof(res)


def test_a_wrong_pdf_still_fails():
    class WrongPdf(D.LinearInterval):
        def pdf(self, x):          # claims uniform, samples the linear density
            return np.ones(np.shape(x)[:-1])

    res = chi2_gof(WrongPdf(0, 1, 0.2, 1.0), IntervalChart(0, 1), (20,), n=20_000, rng=3)
    assert res.pvalue < 1e-6
    with pytest.raises(AssertionError, match="rejected"):
        assert_gof(res)
    # and the right pdf passes with the same arguments
    assert_gof(chi2_gof(D.LinearInterval(0, 1, 0.2, 1.0), IntervalChart(0, 1), (20,), n=20_000, rng=3))


def test_a_pdf_with_nan_or_wrong_shape_is_an_error(raises_naming):
    class NanPdf(_Sampler):
        def pdf(self, x):
            return np.full(np.shape(x)[:-1], np.nan)

    class ShapePdf(_Sampler):
        def pdf(self, x):
            return np.ones(np.shape(x))            # (n, 1) instead of (n,)

    for cls in (NanPdf, ShapePdf):
        with raises_naming(ValueError, "dist"):
            chi2_gof(cls(lambda u: u), IntervalChart(0, 1), (10,), n=2000)


@pytest.mark.parametrize("call, exc, name", [
    (lambda: assert_gof([]), ValueError, "results"),
    (lambda: assert_gof([3]), TypeError, "results"),
    (lambda: assert_gof(None), TypeError, "results"),
    (lambda: assert_gof(GOOD, alpha=0), ValueError, "alpha"),
    (lambda: assert_gof(GOOD, alpha=1.5), ValueError, "alpha"),
    (lambda: assert_gof(GOOD, alpha=np.nan), ValueError, "alpha"),
    (lambda: assert_gof(GOOD, alpha="0.01"), TypeError, "alpha"),
    (lambda: assert_gof(GOOD, m=0), ValueError, "m"),
    (lambda: assert_gof([GOOD, GOOD], m=1), ValueError, "m"),
    (lambda: assert_gof(GOOD, m=2.5), TypeError, "m"),
    (lambda: sidak_threshold(0, 3), ValueError, "alpha"),
    (lambda: sidak_threshold(0.01, 0), ValueError, "m"),
    (lambda: sidak_threshold(0.01, 1.5), TypeError, "m"),
    (lambda: pooled_chi2([1, np.nan], [1, 1]), ValueError, "observed"),
    (lambda: pooled_chi2([-1, 20], [10, 10]), ValueError, "observed"),
    (lambda: pooled_chi2("ab", [1, 1]), TypeError, "observed"),
    (lambda: pooled_chi2([1, 2], [1, np.inf]), ValueError, "expected"),
    (lambda: pooled_chi2([1, 2], [1, -1]), ValueError, "expected"),
    (lambda: pooled_chi2([1, 2, 3], [1, 2]), ValueError, "expected"),
    (lambda: pooled_chi2([], []), ValueError, "expected"),
    (lambda: pooled_chi2([0, 0], [0, 0]), ValueError, "expected"),
    (lambda: pooled_chi2([10, 10], [10, 10], min_expected=0), ValueError, "min_expected"),
    (lambda: pooled_chi2([10, 10], [10, 10], name=3), TypeError, "name"),
    (lambda: pooled_chi2([10, 10], [10, 10], cells=[1]), ValueError, "cells"),
    (lambda: chi2_discrete([], [0.5, 0.5]), ValueError, "indices"),
    (lambda: chi2_discrete([0, 1, 1], [0.5, 0.5]), ValueError, "indices"),
    (lambda: chi2_discrete("ab", [0.5, 0.5]), TypeError, "indices"),
    (lambda: chi2_discrete([0, 1], [-0.5, 1.5]), ValueError, "pmf"),
    (lambda: chi2_discrete([0, 1], [np.nan, 1]), ValueError, "pmf"),
    (lambda: chi2_discrete([0, 1], []), ValueError, "pmf"),
    (lambda: chi2_discrete([0, 1], [0, 0]), ValueError, "pmf"),
    (lambda: chi2_discrete([0, 1], [[0.5, 0.5]]), ValueError, "pmf"),
    (lambda: chi2_discrete([0] * 100, [0.5, 0.5], min_expected=-1), ValueError, "min_expected"),
    (lambda: integrate(3, IntervalChart(0, 1)), TypeError, "fn"),
    (lambda: integrate(UNIT.pdf, "chart"), TypeError, "chart"),
    (lambda: integrate(UNIT.pdf, IntervalChart(0, 1), 0), ValueError, "bins"),
    (lambda: integrate(UNIT.pdf, IntervalChart(0, 1), 8.5), TypeError, "bins"),
    (lambda: integrate(UNIT.pdf, IntervalChart(0, 1), quad=0), ValueError, "quad"),
    (lambda: integrate(UNIT.pdf, IntervalChart(0, 1), 10**6, quad=100), ValueError, "quad"),
    (lambda: integrate(lambda x: np.full(x.shape[:-1], np.nan), IntervalChart(0, 1)), ValueError, "fn"),
    (lambda: integrate(lambda x: np.full(x.shape[:-1], np.inf), IntervalChart(0, 1)), ValueError, "fn"),
    (lambda: integrate(lambda x: x, IntervalChart(0, 1)), ValueError, "fn"),
    (lambda: integrate(lambda x: np.full(x.shape[:-1], "a"), IntervalChart(0, 1)), TypeError, "fn"),
    (lambda: cell_integrals(UNIT.pdf, IntervalChart(0, 1), (4, 4)), ValueError, "bins"),
    (lambda: cell_integrals(UNIT.pdf, IntervalChart(0, 1), (4,), sub=0), ValueError, "sub"),
    (lambda: histogram(np.zeros((3, 1)), 0), ValueError, "bins"),
    (lambda: histogram(np.zeros((3, 3)), (2, 2)), ValueError, "param"),
    (lambda: histogram(np.zeros((0, 2)), (2, 2)), ValueError, "param"),
    (lambda: histogram("abc", (2,)), TypeError, "param"),
    (lambda: GofResult("x", 1.0, 1, 2.0, 10, 10.0), ValueError, "pvalue"),
    (lambda: GofResult("x", np.nan, 1, 0.5, 10, 10.0), ValueError, "statistic"),
    (lambda: GofResult("x", 1.0, 0, 0.5, 10, 10.0), ValueError, "dof"),
    (lambda: GofResult(3, 1.0, 1, 0.5, 10, 10.0), TypeError, "name"),
    (lambda: std_band(1), ValueError, "r"),
    (lambda: std_band(10.5), TypeError, "r"),
    (lambda: std_band(10, alpha=1), ValueError, "alpha"),
    (lambda: u_nodes(3), ValueError, "d"),
    (lambda: u_nodes(1.0), TypeError, "d"),
    (lambda: u_nodes(2, cells=0), ValueError, "cells"),
    (lambda: u_nodes(2, quad=0), ValueError, "quad"),
    (lambda: u_nodes(2, cells=10**5), ValueError, "cells"),
])
def test_harness_functions_bad_arguments(raises_naming, call, exc, name):
    with raises_naming(exc, name):
        call()


GOOD = GofResult("good", 1.0, 1, 0.5, 100, 100.0)


def test_results_without_samples_or_with_bad_indices_fail():
    with pytest.raises(AssertionError, match="empty"):
        assert_gof(GofResult("empty", 0.0, 1, 1.0, 0, 0.0))
    res = chi2_discrete(np.array([0.0, 1.0, np.nan, 0.5] * 500), [0.5, 0.5])
    assert res.pvalue == 0 and res.outside == 1000 and res.nonfinite == 500
    with pytest.raises(AssertionError):
        assert_gof(res)


@pytest.mark.parametrize("make, exc, name", [
    (lambda: BoxChart([(0, np.nan)]), ValueError, "bounds"),
    (lambda: BoxChart([(0, np.inf)]), ValueError, "bounds"),
    (lambda: BoxChart([(1, 0)]), ValueError, "bounds"),
    (lambda: BoxChart([(0, 1)] * 3), ValueError, "bounds"),
    (lambda: BoxChart([]), ValueError, "bounds"),
    (lambda: BoxChart("ab"), TypeError, "bounds"),
    (lambda: IntervalChart(1, 1), ValueError, "a"),
    (lambda: IntervalChart("0", 1), TypeError, "a"),
    (lambda: IntervalChart(0, np.inf), ValueError, "b"),
    (lambda: HalfLineChart(0), ValueError, "scale"),
    (lambda: HalfLineChart(np.nan), ValueError, "scale"),
    (lambda: DiskChart(0), ValueError, "radius"),
    (lambda: DiskChart(-1), ValueError, "radius"),
    (lambda: DiskChart("1"), TypeError, "radius"),
    (lambda: DiskChart(1, (0, 0, 0)), ValueError, "center"),
    (lambda: DiskChart(1, (0, np.nan)), ValueError, "center"),
    (lambda: TriangleChart((0, 0), (1, 1), (2, 2)), ValueError, "a"),
    (lambda: TriangleChart((0, 0), (0, 0), (1, 0)), ValueError, "a"),
    (lambda: TriangleChart((0, 0), (1, 0, 0), (0, 1)), ValueError, "b"),
    (lambda: TriangleChart((0,), (1,), (2,)), ValueError, "a"),
    (lambda: TriangleChart((0, np.nan), (1, 0), (0, 1)), ValueError, "a"),
    (lambda: CapChart(1.0), ValueError, "z_min"),
    (lambda: CapChart(-1.5), ValueError, "z_min"),
    (lambda: CapChart("0"), TypeError, "z_min"),
    (lambda: CapChart(0, 0), ValueError, "power"),
    (lambda: SphereChart(-1), ValueError, "power"),
    (lambda: HemisphereChart(np.inf), ValueError, "power"),
    (lambda: ParallelogramChart((0, 0, 0), (1, 0, 0), (2, 0, 0)), ValueError, "edge1"),
    (lambda: ParallelogramChart((0, 0, 0), (0, 0, 0), (0, 1, 0)), ValueError, "edge2"),
    (lambda: ParallelogramChart((0, 0), (1, 0), (0, 1)), ValueError, "corner"),
    (lambda: EllipsoidChart((0, 0, 0), np.zeros((3, 3))), ValueError, "matrix"),
    (lambda: EllipsoidChart((0, 0, 0), np.eye(2)), ValueError, "matrix"),
    (lambda: EllipsoidChart((0, 0), np.eye(3)), ValueError, "center"),
    (lambda: AtlasChart([]), ValueError, "charts"),
    (lambda: AtlasChart(3), TypeError, "charts"),
    (lambda: AtlasChart([SphereChart()]), TypeError, "charts"),
    (lambda: box_surface_chart((0, 0, 0), -1), ValueError, "half_extents"),
    (lambda: box_surface_chart((0, 0, 0), (1, 1)), ValueError, "half_extents"),
    (lambda: box_surface_chart((0, 0), 1), ValueError, "center"),
    (lambda: box_surface_chart((0, 0, 0), 1, np.zeros((3, 3))), ValueError, "rotation"),
    (lambda: DiskChart().to_param("ab"), TypeError, "x"),
    (lambda: DiskChart().to_param(np.zeros((4, 3))), ValueError, "x"),
])
def test_chart_bad_arguments(raises_naming, make, exc, name):
    with raises_naming(exc, name):
        make()
