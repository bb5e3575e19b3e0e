"""Tests for vrlab.render.poisson.screened_poisson (gradient-domain reconstruction)."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from vrlab import Estimate
from vrlab.render.poisson import screened_poisson


def _image(shape, seed=0):
    rng = np.random.default_rng(seed)
    img = rng.random(shape)
    return img + 0.5  # positive, irregular: no accidental symmetry


def _grads(img):
    return np.diff(img, axis=1), np.diff(img, axis=0)


def _rel(a, b):
    return np.linalg.norm(a - b) / np.linalg.norm(b)


def _forward(n):
    """(n-1, n) forward-difference matrix, built independently of the module."""
    rows = np.repeat(np.arange(n - 1), 2)
    cols = np.stack([np.arange(n - 1), np.arange(1, n)], axis=1).ravel()
    vals = np.tile([-1.0, 1.0], n - 1)
    return sp.csr_matrix((vals, (rows, cols)), shape=(n - 1, n))


def _operators(h, w):
    """Dx, Dy acting on a row-major (h*w) vector."""
    return sp.kron(sp.identity(h), _forward(w)), sp.kron(_forward(h), sp.identity(w))


SHAPES = [(17, 23, 3), (23, 17, 1), (1, 31, 3), (29, 1, 3), (1, 1, 2), (2, 2, 1), (12, 9)]


@pytest.mark.parametrize("norm", ["l2", "l1"])
@pytest.mark.parametrize("alpha", [0.01, 0.2, 3.0])
@pytest.mark.parametrize("shape", SHAPES)
def test_exact_inputs_give_the_image_back(shape, alpha, norm):
    img = _image(shape)
    gx, gy = _grads(img)
    y = screened_poisson(img, gx, gy, alpha=alpha, norm=norm)
    assert y.shape == img.shape
    assert _rel(y, img) < 1e-6


@pytest.mark.parametrize("norm", ["l2", "l1"])
def test_accepts_estimates(norm):
    img = _image((8, 10, 3))
    gx, gy = _grads(img)
    wrap = lambda a: Estimate(a, np.zeros_like(a), 4, 4)  # noqa: E731
    y = screened_poisson(wrap(img), wrap(gx), wrap(gy), norm=norm)
    assert _rel(y, img) < 1e-6


@pytest.mark.parametrize("norm", ["l2", "l1"])
def test_wrong_sign_or_shift_gives_a_wrong_image(norm):
    img = _image((24, 20, 3))
    gx, gy = _grads(img)
    ok = screened_poisson(img, gx, gy, alpha=0.05, norm=norm)
    assert _rel(ok, img) < 1e-6
    flipped = screened_poisson(img, -gx, -gy, alpha=0.05, norm=norm)
    assert _rel(flipped, img) > 0.1
    # shift the gradients by one pixel (dx[y, x] taken as I(x, y) - I(x-1, y))
    gx_s = np.roll(gx, 1, axis=1)
    gy_s = np.roll(gy, 1, axis=0)
    shifted = screened_poisson(img, gx_s, gy_s, alpha=0.05, norm=norm)
    assert _rel(shifted, img) > 0.1


@pytest.mark.parametrize("alpha", [0.01, 0.2, 2.0])
@pytest.mark.parametrize("shape", [(19, 13, 3), (1, 16, 2), (16, 1, 1)])
def test_l2_satisfies_the_normal_equations(shape, alpha):
    rng = np.random.default_rng(3)
    h, w, c = shape
    p = rng.standard_normal(shape)
    gx = rng.standard_normal((h, w - 1, c))
    gy = rng.standard_normal((h - 1, w, c))
    y = screened_poisson(p, gx, gy, alpha=alpha)
    dx, dy = _operators(h, w)
    a = (alpha ** 2 * sp.identity(h * w) + dx.T @ dx + dy.T @ dy).tocsc()
    b = alpha ** 2 * p.reshape(h * w, c) + dx.T @ gx.reshape(-1, c) + dy.T @ gy.reshape(-1, c)
    res = a @ y.reshape(h * w, c) - b
    assert np.linalg.norm(res) < 1e-10 * np.linalg.norm(b)
    ref = spla.spsolve(a, b).reshape(shape)
    assert np.allclose(y, ref, rtol=1e-9, atol=1e-9)


def test_large_alpha_tends_to_the_primal():
    rng = np.random.default_rng(4)
    p = rng.standard_normal((15, 11, 3))
    gx, gy = rng.standard_normal((15, 10, 3)), rng.standard_normal((14, 11, 3))
    errs = {}
    for norm in ("l2", "l1"):
        errs[norm] = [_rel(screened_poisson(p, gx, gy, alpha=a, norm=norm), p) for a in (1.0, 10.0, 1e3)]
        assert errs[norm][0] > errs[norm][1] > errs[norm][2]
        assert errs[norm][2] < 1e-4
    assert errs["l2"][0] > 0.1


def _objective(y, p, gx, gy, alpha):
    return (alpha ** 2 * np.sum((y - p) ** 2) + np.abs(gx - np.diff(y, axis=1)).sum()
            + np.abs(gy - np.diff(y, axis=0)).sum())


def test_l1_lowers_its_objective_and_resists_outliers():
    img = np.cumsum(_image((20, 20, 1), seed=5), axis=1) / 5
    gx, gy = _grads(img)
    rng = np.random.default_rng(6)
    p = img + 0.2 * rng.standard_normal(img.shape)
    gx_bad, gy_bad = gx.copy(), gy.copy()
    gx_bad[10, 10, 0] += 50.0  # one wild gradient sample (a firefly)
    gy_bad[5, 3, 0] -= 50.0
    y2 = screened_poisson(p, gx_bad, gy_bad, alpha=0.2, norm="l2")
    y1 = screened_poisson(p, gx_bad, gy_bad, alpha=0.2, norm="l1")
    assert _objective(y1, p, gx_bad, gy_bad, 0.2) < 0.9 * _objective(y2, p, gx_bad, gy_bad, 0.2)
    assert _rel(y1, img) < 0.3 * _rel(y2, img)
    # no random small perturbation lowers the L1 objective noticeably (near a minimum)
    f1 = _objective(y1, p, gx_bad, gy_bad, 0.2)
    for k in range(5):
        d = 1e-3 * rng.standard_normal(y1.shape)
        assert _objective(y1 + d, p, gx_bad, gy_bad, 0.2) > f1 - 1e-3 * f1


def test_iterations_and_tol_are_used():
    rng = np.random.default_rng(7)
    p = rng.standard_normal((12, 12, 1))
    gx, gy = rng.standard_normal((12, 11, 1)), rng.standard_normal((11, 12, 1))
    one = screened_poisson(p, gx, gy, norm="l1", iterations=1)
    many = screened_poisson(p, gx, gy, norm="l1", iterations=50, tol=0.0)
    assert _rel(one, many) > 1e-4
    assert _objective(many, p, gx, gy, 0.2) < _objective(one, p, gx, gy, 0.2)


def test_two_dimensional_input_gives_two_dimensional_output():
    img = _image((6, 7))
    gx, gy = _grads(img)
    y = screened_poisson(img, gx, gy)
    assert y.shape == (6, 7)
    assert _rel(y, img) < 1e-6


GOOD = _image((5, 6, 3))
GX, GY = _grads(GOOD)


def _nan(a, where):
    a = a.copy()
    a[where] = np.nan
    return a


@pytest.mark.parametrize("kwargs, exc, name", [
    (dict(primal=GOOD[..., 0]), ValueError, "dx"),
    (dict(primal=np.zeros((0, 6, 3))), ValueError, "primal"),
    (dict(primal=np.zeros(5)), ValueError, "primal"),
    (dict(primal=np.zeros((5, 6, 3, 1))), ValueError, "primal"),
    (dict(primal=_nan(GOOD, (1, 1, 1))), ValueError, "primal"),
    (dict(primal="abc"), TypeError, "primal"),
    (dict(primal=None), TypeError, "primal"),
    (dict(primal=GOOD + 1j), TypeError, "primal"),
    (dict(dx=GY), ValueError, "dx"),
    (dict(dx=GX[:, :, :2]), ValueError, "dx"),
    (dict(dx=np.roll(GOOD, 1, axis=1)), ValueError, "dx"),
    (dict(dx=_nan(GX, (0, 0, 0))), ValueError, "dx"),
    (dict(dx=np.where(GX > 0, np.inf, GX)), ValueError, "dx"),
    (dict(dx=[["a"]]), TypeError, "dx"),
    (dict(dy=GX), ValueError, "dy"),
    (dict(dy=GY[:-1]), ValueError, "dy"),
    (dict(dy=_nan(GY, (2, 1, 0))), ValueError, "dy"),
    (dict(dy=None), TypeError, "dy"),
    (dict(alpha=0), ValueError, "alpha"),
    (dict(alpha=-0.5), ValueError, "alpha"),
    (dict(alpha=np.nan), ValueError, "alpha"),
    (dict(alpha=np.inf), ValueError, "alpha"),
    (dict(alpha=1e-200), ValueError, "alpha"),
    (dict(alpha="0.2"), TypeError, "alpha"),
    (dict(alpha=None), TypeError, "alpha"),
    (dict(alpha=True), TypeError, "alpha"),
    (dict(norm="L3"), ValueError, "norm"),
    (dict(norm=""), ValueError, "norm"),
    (dict(norm=2), TypeError, "norm"),
    (dict(iterations=2.5), TypeError, "iterations"),
    (dict(iterations=20.0), TypeError, "iterations"),
    (dict(iterations="20"), TypeError, "iterations"),
    (dict(iterations=0), ValueError, "iterations"),
    (dict(iterations=-3), ValueError, "iterations"),
    (dict(tol=-1e-3), ValueError, "tol"),
    (dict(tol=np.nan), ValueError, "tol"),
    (dict(tol="small"), TypeError, "tol"),
])
def test_bad_input_names_the_argument(kwargs, exc, name, raises_naming):
    args = dict(primal=GOOD, dx=GX, dy=GY, alpha=0.2, norm="l2")
    args.update(kwargs)
    with raises_naming(exc, name):
        screened_poisson(args.pop("primal"), args.pop("dx"), args.pop("dy"), **args)


def test_bad_estimate_value_names_the_argument(raises_naming):
    est = Estimate(_nan(GX, (0, 0, 0)), np.zeros_like(GX), 1, 1)
    with raises_naming(ValueError, "dx"):
        screened_poisson(GOOD, est, GY)


@pytest.mark.parametrize("transpose", [False, True])
def test_l1_meets_the_optimality_condition_in_one_dimension(transpose):
    # On a 1 x N line, 2 alpha^2 (y - p) = D^T s has one solution s (a cumulative sum), and
    # y minimises alpha^2||y - p||^2 + ||g - D y||_1 iff |s| <= 1 and s = sign(g - D y)
    # wherever g != D y.
    rng = np.random.default_rng(8)
    n, alpha = 40, 0.5
    line = np.cumsum(rng.standard_normal(n))
    g = np.diff(line) + 0.3 * rng.standard_normal(n - 1)
    g[[5, 20, 31]] += [4.0, -6.0, 3.0]
    p = line + 0.5 * rng.standard_normal(n)
    if transpose:
        y = screened_poisson(p[:, None], np.zeros((n, 0)), g[:, None], alpha=alpha, norm="l1",
                             iterations=300, tol=1e-12)[:, 0]
    else:
        y = screened_poisson(p[None], g[None], np.zeros((0, n)), alpha=alpha, norm="l1",
                             iterations=300, tol=1e-12)[0]
    s = -np.cumsum(2 * alpha ** 2 * (y - p))[:-1]
    r = g - np.diff(y)
    assert np.abs(s).max() < 1 + 1e-3
    big = np.abs(r) > 1e-2
    assert big.sum() >= 3  # at least the three outliers are not fitted
    assert np.allclose(s[big], np.sign(r[big]), atol=1e-2)
