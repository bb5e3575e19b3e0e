"""Gradient-domain rendering (issue 13): CRN gradients on the pixel integrand and the screened
Poisson reconstruction, against closed forms, the variance formula and Mitsuba references."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from test_render import CENTRE_TOL, FLOOR, L_E, RECT_LIGHT, RHO, bonferroni_z, exact_image, polygon_irradiance, scene
from vrlab.render import PixelIntegrand, render_gradient_domain, screened_poisson
from vrlab.render.accel.geometry import SceneGeometry

SC = scene(FLOOR + RECT_LIGHT, fov=20, width=10, height=8)     # a smooth irradiance gradient across the image
EXACT = exact_image("rectangle", SC)


def exact_box(sc, k: int = 16) -> np.ndarray:
    """The exact pixel values (H, W, 3): the closed form averaged over a k x k grid of
    positions in each pixel (the box filter; its error is O(1/k^2) of the second derivative)."""
    h, w = sc.sensor.height, sc.sensor.width
    sub = (np.arange(k) + 0.5) / k
    su = np.stack(np.meshgrid(sub, sub, indexing="ij"), -1).reshape(-1, 2)           # (k^2, 2)
    pix = np.stack(np.divmod(np.arange(h * w), w), -1)
    o, d = sc.sensor.pixel_rays(pix[:, None, :], np.broadcast_to(su, (h * w, k * k, 2)))
    hits = SceneGeometry(sc).intersect(o.reshape(-1, 3), d.reshape(-1, 3))
    corner, e1, e2, _ = sc.shapes[1].rectangle()
    verts = np.array([corner, corner + e1, corner + e1 + e2, corner + e2])
    e = polygon_irradiance(hits.p, np.array([0.0, 1.0, 0.0]), verts, L_E).reshape(h * w, k * k).mean(1)
    return (np.asarray(RHO) / np.pi * e[:, None]).reshape(h, w, 3)


BOX = exact_box(SC)
DATA = Path(__file__).resolve().parents[1] / "vrlab" / "render" / "scenes" / "mitsuba"


@pytest.fixture(scope="module")
def crn():
    return render_gradient_domain(SC, 256, "mis-power", rng=1)


def _z(est, exact, tol, rows=slice(None), cols=slice(None)):
    """z-scores of an Estimate's value (or its [rows, cols] part) against ``exact``."""
    se = np.sqrt(est.stderr[rows, cols].astype(float) ** 2 + tol**2)
    return (est.value[rows, cols] - exact) / se


def test_shapes_and_closed_form(crn):
    h, w = EXACT.shape[:2]
    assert crn.primal.value.shape == (h, w, 3)
    assert crn.dx.value.shape == crn.dx.stderr.shape == (h, w - 1, 3)
    assert crn.dy.value.shape == crn.dy.stderr.shape == (h - 1, w, 3)
    exact_dx, exact_dy = np.diff(EXACT, axis=1), np.diff(EXACT, axis=0)
    # the closed form is at the pixel centre, the estimate a box average: second order
    bound = bonferroni_z(EXACT.size * 3)
    tol = CENTRE_TOL * EXACT.max()
    for est, exact in ((crn.primal, EXACT), (crn.dx, exact_dx), (crn.dy, exact_dy)):
        assert np.max(np.abs(_z(est, exact, tol))) < bound
    # the test can fail: a shift off by one pixel or a gradient of the wrong sign
    assert np.max(np.abs(_z(crn.dx, -exact_dx, tol))) > bound
    assert np.max(np.abs(_z(crn.dy, -exact_dy, tol))) > bound
    # a one-pixel shift changes a gradient by its second difference (a few %): pooled over
    # the image against the exact box-filtered pixels, the right pairing passes and the
    # shifted one fails
    box_dx, box_dy = np.diff(BOX, axis=1), np.diff(BOX, axis=0)

    def pooled(est, exact, **where):
        z = _z(est, exact, 1e-6 * BOX.max(), **where)
        return abs(z.sum()) / np.sqrt(z.size)

    assert pooled(crn.dx, box_dx) < 4 and pooled(crn.dy, box_dy) < 4 and pooled(crn.primal, BOX) < 4
    assert pooled(crn.dx, box_dx[:, 1:], cols=slice(None, -1)) > 4
    assert pooled(crn.dy, box_dy[1:], rows=slice(None, -1)) > 4


@pytest.mark.parametrize("mis", ["pairwise", "balance"])
def test_restir_gradients_are_unbiased_on_the_closed_form(mis):
    """A spatial estimator in the gradient domain: ReSTIR's primal and both gradients against
    the exact box-filtered pixels, per pixel (Bonferroni) and pooled; reuse correlates the
    pixels of a pass (neighbour correlation about 0.3, notebook 13: the honest standard error
    of a sum is up to ~1.6x the independent one), so the pooled bound is 4 x 1.6.  The
    gradient of the wrong sign fails."""
    from vrlab.estimators import ReSTIR

    g = render_gradient_domain(SC, 64, ReSTIR(candidates=4, neighbours=3, radius=2, mis=mis), rng=4)
    box_dx, box_dy = np.diff(BOX, axis=1), np.diff(BOX, axis=0)
    for est, exact in ((g.primal, BOX), (g.dx, box_dx), (g.dy, box_dy)):
        z = _z(est, exact, 1e-6 * BOX.max())
        assert abs(z.sum()) / np.sqrt(z.size) < 4 * 1.6 and np.max(np.abs(z)) < bonferroni_z(z.size)
    for est, wrong in ((g.dx, -box_dx), (g.dy, -box_dy)):
        z = _z(est, wrong, 1e-6 * BOX.max())
        assert abs(z.sum()) / np.sqrt(z.size) > 4 * 1.6


def test_crn_gradient_variance_is_the_formula_and_below_independent(crn):
    """Per pixel, the CRN gradient's variance is Var[a] + Var[b] - 2 Cov[a, b] of the two
    neighbours' samples under shared uniforms (measured here separately, from other seeds,
    with the public pixel integrand); and it is far below independent differences."""
    integ = PixelIntegrand(SC, "mis-power")
    h, w = SC.sensor.height, SC.sensor.width
    rows, cols = np.divmod(np.arange(h * w), w)
    keep = cols < w - 1
    pix = np.stack([rows, cols], -1)[keep]
    u = np.random.default_rng(7).random((len(pix), 1024, integ.dim))
    a, b = integ.values(pix + [0, 1], u), integ.values(pix, u)            # (P, S, 3)
    va, vb = a.var(1, ddof=1), b.var(1, ddof=1)
    cov = ((a - a.mean(1, keepdims=True)) * (b - b.mean(1, keepdims=True))).sum(1) / (a.shape[1] - 1)
    predicted = (va + vb - 2 * cov).reshape(h, w - 1, 3)
    measured = crn.dx.stderr.astype(float) ** 2 * crn.dx.n
    ratio = measured.sum() / predicted.sum()
    assert 0.8 < ratio < 1.25, ratio
    assert not 0.8 < measured.sum() / (va + vb).sum() < 1.25              # the covariance term matters
    indep = render_gradient_domain(SC, 256, "mis-power", rng=1, common=False)
    assert np.mean(crn.dx.stderr ** 2) < 0.5 * np.mean(indep.dx.stderr ** 2)
    assert np.mean(crn.dy.stderr ** 2) < 0.5 * np.mean(indep.dy.stderr ** 2)
    bound = bonferroni_z(indep.dx.value.size)
    assert np.max(np.abs(_z(indep.dx, np.diff(EXACT, axis=1), CENTRE_TOL * EXACT.max()))) < bound


def test_l2_reconstruction_is_unbiased_on_the_closed_form():
    """The L2 reconstruction is linear in (primal, dx, dy), so the mean of independent
    replicates converges to the exact image: z-test with the replicates' standard error."""
    reps = np.array([render_gradient_domain(SC, 16, "mis-power", rng=[3, r]).reconstruct(alpha=0.2)
                     for r in range(24)])
    mean, se = reps.mean(0), reps.std(0, ddof=1) / np.sqrt(len(reps))
    z = (mean - BOX) / np.sqrt(se**2 + (1e-6 * BOX) ** 2)
    assert np.max(np.abs(z)) < bonferroni_z(z.size) + 1                     # t with 23 dof
    g = reps[..., 1].mean(axis=(1, 2))             # image means (one channel: they are proportional)
    assert abs((g.mean() - BOX[..., 1].mean()) / (g.std(ddof=1) / np.sqrt(len(g)))) < 4
    # the test can fail: a reconstruction from gradients of the wrong sign is biased
    bad = np.array([screened_poisson(g.primal, -g.dx.value, -g.dy.value) for g in
                    (render_gradient_domain(SC, 16, "mis-power", rng=[3, r]) for r in range(4))])
    assert np.max(np.abs((bad.mean(0) - BOX) / np.sqrt(se**2 + (1e-6 * BOX) ** 2))) > 10


@pytest.mark.parametrize("name", ["cornell_box", "veach_mis"])
def test_l2_reconstruction_agrees_with_mitsuba(name):
    ref, ref_err = np.load(DATA / f"{name}_mean.npy"), np.load(DATA / f"{name}_stderr.npy")
    h, w, _ = ref.shape
    reps = np.array([render_gradient_domain(name, 8, "mis-power", rng=[5, r], width=w, height=h).reconstruct()
                     for r in range(8)])
    # the image mean of each replicate against the reference's (the reconstruction correlates
    # neighbouring pixels, so the error bar comes from the replicates, not from pixel stderrs)
    m = reps.mean(axis=(1, 2, 3))
    z = (m.mean() - ref.mean()) / np.sqrt(m.var(ddof=1) / len(m) + np.sum(ref_err**2) / ref.size**2)
    assert abs(z) < 4, z


def test_gradient_inputs_are_checked(raises_naming):
    with raises_naming(ValueError, "spp"):
        render_gradient_domain(SC, 1)
    with raises_naming(TypeError, "common"):
        render_gradient_domain(SC, 4, common="yes")
    with raises_naming(ValueError, "estimator"):
        render_gradient_domain(SC, 4, "nope")
