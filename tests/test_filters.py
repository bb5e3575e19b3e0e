"""Pixel reconstruction filters (vrlab.distributions.filters) against Mitsuba 3 and closed forms.

Mitsuba is the oracle for the weights: ``ReconstructionFilter.eval`` / ``eval_discretized`` /
``radius`` from its Python API, and the weights its scalar ``ImageBlock.put`` really splats.
The sampling side (chi-square, normalisation, inverse) is in tests/test_distributions.py.

Tolerances.  Box and tent weights are exact in float32 (1e-6).  Mitsuba evaluates the gaussian
as a degree-9 polynomial in float32 whose terms reach ~180 at the radius and cancel to ~1e-4,
so its values carry rounding errors of ~1e-5 (1.4e-5 at stddev 0.5, 2.2e-5 at 0.3 measured);
GAUSS_ATOL = 5e-5 allows for that and still rejects exp(-x^2/(2 s^2)) - exp(-8), the gaussian
Mitsuba's CUDA variants use (up to 4e-4 away), and any wrong stddev or radius.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate, special

from vrlab.distributions import FILTERS, BoxFilter, FilterWindow, GaussianFilter, TentFilter
from vrlab.distributions.filters import MI_FILTER_RESOLUTION as RES

GAUSS_ATOL = 5e-5
EXACT_ATOL = 1e-6


@pytest.fixture(scope="module")
def mi():
    import mitsuba

    mitsuba.set_variant("scalar_rgb")
    return mitsuba


# (Mitsuba plugin dict, vrlab filter of the same parameters, tolerance)
CASES = [
    ({"type": "box"}, lambda d: BoxFilter(discretized=d), EXACT_ATOL),
    ({"type": "tent"}, lambda d: TentFilter(discretized=d), EXACT_ATOL),
    ({"type": "tent", "radius": 1.5}, lambda d: TentFilter(1.5, discretized=d), EXACT_ATOL),
    ({"type": "gaussian"}, lambda d: GaussianFilter(discretized=d), GAUSS_ATOL),
    ({"type": "gaussian", "stddev": 0.3}, lambda d: GaussianFilter(0.3, discretized=d), GAUSS_ATOL),
    ({"type": "gaussian", "stddev": 1.0}, lambda d: GaussianFilter(1.0, discretized=d), GAUSS_ATOL),
]
IDS = [f"{c[0]['type']}-{c[0].get('radius', c[0].get('stddev', ''))}" for c in CASES]


def _grid(r):
    """Offsets inside the table's cells (10 %, 50 %, 90 % of each of the 62), none within a
    rounding error of a step of the discretised filter, and offsets beyond the radius."""
    cells = (np.arange(RES)[:, None] + np.array([0.1, 0.5, 0.9])).ravel() * r / RES
    return np.concatenate([cells, -cells, r * np.array([1.05, 1.3, -1.1, -2.0])])


@pytest.mark.parametrize("spec, make, atol", CASES, ids=IDS)
def test_weights_match_mitsuba(mi, spec, make, atol):
    ref = mi.load_dict(spec)
    f, fc = make(True), make(False)
    assert f.radius == pytest.approx(ref.radius(), rel=1e-7)
    x = _grid(f.radius)
    np.testing.assert_allclose(f.eval1(x), [ref.eval(v) for v in x], rtol=0, atol=atol)
    np.testing.assert_allclose(f.eval1_discretized(x), [ref.eval_discretized(v) for v in x], rtol=0, atol=atol)
    # the film's weights: the table for the scalar variants, the filter for the JIT ones
    np.testing.assert_allclose(f.weight1(x), f.eval1_discretized(x), rtol=0, atol=0)
    np.testing.assert_allclose(fc.weight1(x), np.where(np.abs(x) <= f.radius, f.eval1(x), 0.0), rtol=0, atol=0)


def test_box_half_open_like_mitsuba(mi):
    ref = mi.load_dict({"type": "box"})
    x = np.array([-0.5, 0.5, -0.25, 0.49])
    assert BoxFilter().eval1(x).tolist() == [ref.eval(v) for v in x] == [1.0, 0.0, 1.0, 1.0]


@pytest.mark.parametrize("spec, make, atol", CASES, ids=IDS)
def test_image_block_splats_our_weights(mi, spec, make, atol):
    """Mitsuba's scalar ImageBlock.put gives pixel c the weight eval(c - pos): ours, discretised."""
    f = make(True)
    n = 12
    for pos in [(6.27, 5.71), (5.52, 6.11)]:
        offsets = np.arange(n) + 0.5 - np.array(pos)[:, None]               # (2, n): pixel centre - pos
        steps = np.abs(offsets) * RES / f.radius
        near = steps < RES + 0.5                                            # the radius is a step too
        assert np.all(np.abs(steps - np.round(steps))[near] > 1e-3)      # no pixel on a table step
        block = mi.ImageBlock(mi.ScalarVector2u(n, n), mi.ScalarPoint2i(0, 0), 1, mi.load_dict(spec),
                              border=False)
        block.clear()
        block.put(mi.Point2f(*pos), [1.0])
        splat = np.array(block.tensor())[..., 0]                            # [y, x]
        ours = f.eval(np.stack(np.meshgrid(offsets[0], offsets[1], indexing="xy"), -1))
        np.testing.assert_allclose(splat, ours, rtol=0, atol=2 * atol)


@pytest.mark.parametrize("make, integral", [
    (lambda: BoxFilter(), 1.0),
    (lambda: BoxFilter(0.8, discretized=False), 1.6),
    (lambda: TentFilter(1.5, discretized=False), 1.5),
    (lambda: TentFilter(1.5), 1.5 * 32 / 31),                                # 2 r/31 sum_k (1 - k/31)
    # the polynomial is Mitsuba's fit of the windowed gaussian s sqrt(2 pi) erf(2 sqrt 2) - 8 s e^-8
    (lambda: GaussianFilter(0.7, discretized=False),
     0.7 * np.sqrt(2 * np.pi) * special.erf(2 * np.sqrt(2)) - 8 * 0.7 * np.exp(-8)),
])
def test_integral_closed_forms(make, integral):
    f = make()
    assert f.integral1 == pytest.approx(integral, rel=1e-4 if isinstance(f, GaussianFilter) else 1e-12)
    steps = np.linspace(-f.radius, f.radius, 2 * RES + 1)
    quad = sum(integrate.quad(f.pdf1, a, b, epsabs=1e-13)[0] for a, b in zip(steps[:-1], steps[1:]))
    assert quad == pytest.approx(1.0, abs=1e-10)


@pytest.mark.parametrize("f", [TentFilter(1.2), TentFilter(0.8, discretized=False), GaussianFilter(),
                               GaussianFilter(0.4, discretized=False)], ids=repr)
def test_cdf_is_the_integral_of_the_pdf(f):
    """cdf1 (= invert, the inverse of the sampler) against quadrature of pdf1."""
    x = np.array([-0.9, -0.35, 0.0, 0.2, 0.77, 1.0]) * f.radius
    steps = list(np.linspace(-f.radius, f.radius, 2 * RES + 1))
    quad = [integrate.quad(f.pdf1, -f.radius, v, points=[s for s in steps if -f.radius < s < v] or None,
                           limit=200, epsabs=1e-13)[0] for v in x]
    np.testing.assert_allclose(f.cdf1(x), quad, atol=1e-10)
    u = np.linspace(0, 1, 101)[1:-1]
    np.testing.assert_allclose(f.cdf1(f.sample1(u)), u, atol=1e-12)


def test_tent_quantiles_closed_form():
    f = TentFilter(2.0, discretized=False)
    # F(x) = (1 + x/r)^2 / 2 below 0: u = 1/8 at x = -r/2, u = 7/8 at x = r/2
    np.testing.assert_allclose(f.sample1(np.array([0.125, 0.5, 0.875])), [-1.0, 0.0, 1.0], atol=1e-15)


def test_estimator_of_the_filtered_pixel():
    """Averaging L(c + d) over sampled offsets gives int w L / int w; here L = d_x^2 + d_y,
    whose filtered mean is the 1D second moment (tent r: r^2/6; table: exact sum over steps)."""
    rng = np.random.default_rng(4)
    for f, second in [(TentFilter(1.5, discretized=False), 1.5**2 / 6),
                      (TentFilter(1.5), None)]:
        if second is None:   # int x^2 w_d / int w_d over the 31 steps on each side
            k, h = np.arange(RES), f.radius / RES
            second = 2 * np.sum(f.table * ((k + 1) ** 3 - k**3) * h**3 / 3) / f.integral1
        d = f.sample(rng.random((400_000, 2)))
        L = d[:, 0] ** 2 + d[:, 1]
        assert abs(L.mean() - second) <= 4 * L.std() / np.sqrt(len(L))


def test_window_is_the_filter_cut_to_the_film():
    f = TentFilter(discretized=False)
    w = f.window((0.0, -np.inf), (np.inf, 0.5))
    assert isinstance(w, FilterWindow)
    assert float(w.mass) == pytest.approx(0.5 * (1 - 0.125))                 # F(0.5) = 7/8
    x = w.sample(np.random.default_rng(2).random((1000, 2)))
    assert np.all((x[:, 0] >= 0) & (x[:, 1] <= 0.5))
    np.testing.assert_allclose(w.pdf(x), f.pdf(x) / w.mass)
    assert w.pdf([[-0.1, 0.0]])[0] == 0.0
    # per-pixel windows broadcast: one row per pixel
    lo = np.array([[-0.2, -1.0], [-1.0, -0.3]])
    ww = f.window(lo[:, None, :], (np.inf, np.inf))
    xs = ww.sample(np.random.default_rng(3).random((2, 50, 2)))
    assert xs.shape == (2, 50, 2) and np.all(xs >= lo[:, None, :])
    # a window holding the whole support is the filter itself
    u = np.random.default_rng(5).random((100, 2))
    np.testing.assert_allclose(GaussianFilter().window((-5, -5), (5, 5)).sample(u), GaussianFilter().sample(u),
                               atol=1e-12)


def test_registry_and_repr():
    assert FILTERS == {"box": BoxFilter, "tent": TentFilter, "gaussian": GaussianFilter}
    assert repr(GaussianFilter(0.25)) == "GaussianFilter(stddev=0.25, discretized=True)"
    assert GaussianFilter(0.25).radius == 1.0 and GaussianFilter().measure == "area"


@pytest.mark.parametrize("make, exc, match", [
    (lambda: GaussianFilter("0.5"), TypeError, "stddev"),
    (lambda: TentFilter(discretized="yes"), TypeError, "discretized"),
    (lambda: BoxFilter(radius=0.0), ValueError, "radius"),
    (lambda: FilterWindow("box", (0, 0), (1, 1)), TypeError, "filt"),
    (lambda: BoxFilter().window((np.nan, 0), (1, 1)), ValueError, "lo"),
    (lambda: BoxFilter().window((0, 0), (1, 1, 1)), ValueError, "hi"),
    (lambda: TentFilter().pdf(np.zeros((3, 1))), ValueError, r"\(\.\.\., 2\)"),
    (lambda: TentFilter().sample1("u"), TypeError, "u"),
])
def test_bad_input(make, exc, match):
    with pytest.raises(exc, match=match):
        make()
