"""ReSTIR in the lab: per-pixel reservoirs with spatial reuse on closed-form families of
integrands (one integral per pixel).  Pairwise and balance MIS are unbiased with occlusion,
the naive 1/M normalisation is measurably biased there, reuse lowers the variance, and a
dropped Jacobian or a target read at the wrong pixel is caught."""
import numpy as np
import pytest

from conftest import DroppedJacobian, WrongPixelTarget
from scipy.special import ndtr

from vrlab import distributions as D
from vrlab.estimators import RIS, ReSTIR
from vrlab.integrands import Integrand
from vrlab.testing import check_estimator

B = 16                                           # pixels of a row
A = np.linspace(-2.0, 2.0, B)                    # f_b(x) = exp(a_b x) ...
LO = 0.1 + 0.04 * np.arange(B)                   # ... blocked on [LO_b, LO_b + 0.25): a moving occluder
HI = LO + 0.25


def _col(v, xx):
    return np.asarray(v).reshape(np.shape(v) + (1,) * xx.ndim)


def shadowed(x):
    xx = x[..., 0]
    return np.exp(_col(A, xx) * xx) * ~((xx >= _col(LO, xx)) & (xx < _col(HI, xx)))


def unshadowed(x):
    """The target p̂_b: f_b without its occluder."""
    xx = x[..., 0]
    return np.exp(_col(A, xx) * xx)


MU = 0.5 + 0.06 * np.linspace(-1, 1, B)         # a bump drifting slowly along the row


def smooth(x):
    xx = x[..., 0]
    return np.exp(-0.5 * ((xx - _col(MU, xx)) / 0.15) ** 2)


SMOOTH_EXACT = 0.15 * np.sqrt(2 * np.pi) * (ndtr((1 - MU) / 0.15) - ndtr(-MU / 0.15))
SMOOTH = Integrand(smooth, [(0, 1)], SMOOTH_EXACT, "smooth-row")
SHADOWED = Integrand(shadowed, [(0, 1)], (np.expm1(A) - (np.exp(A * HI) - np.exp(A * LO))) / A, "shadowed-row")
# every pixel sees the same shadowed f (pixel 5's)
SAME = Integrand(lambda x: np.broadcast_to(shadowed(x)[5], (B,) + x.shape[:-1]), [(0, 1)],
                 np.full(B, SHADOWED.exact[5]), "same-row")

# pixel b integrates g(x / s_b) on [0, s_b): scaled copies of one shape, exact 2 s_b
SCALES = np.linspace(0.5, 1.0, 12)


def scaled(x):
    xx = x[..., 0]
    t = xx / _col(SCALES, xx)
    return np.where(t < 1, 1 + 3 * t * t, 0.0)


SCALED = Integrand(scaled, [(0, 1)], 2 * SCALES, "scaled-row")


class ScaleShift:
    """x -> x s_dst / s_src, Jacobian s_dst / s_src (a module-level class: picklable)."""

    def __call__(self, x, src, dst):
        k = SCALES[dst] / SCALES[src]
        return x * k[..., None], k


def passes_of(est, integrand, n, seed):
    """Unit values (pixels, n passes) from independent uniforms."""
    u = np.random.default_rng(seed).random((n, est.dim_u(integrand)))
    return est.unit_values(integrand, u)


def zscores(values, exact):
    """Per-pixel z of the mean over passes, and the pooled z (mean over pixels per pass first:
    pixels of one pass are correlated, passes are independent)."""
    n = values.shape[-1]
    z = (values.mean(-1) - exact) / (values.std(-1, ddof=1) / np.sqrt(n))
    pooled = (values - exact[:, None]).mean(0)
    return z, pooled.mean() / (pooled.std(ddof=1) / np.sqrt(n))


# ---------------------------------------------------------------------------------------
# unbiasedness with occlusion; 1/M biased
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("mis", ["pairwise", "balance"])
@pytest.mark.parametrize("target", [unshadowed, None], ids=["unshadowed", "abs-f"])
def test_pairwise_and_balance_are_unbiased_with_occlusion(mis, target):
    est = ReSTIR(16, 5, 3.0, 1, mis, target=target)
    z, pooled = zscores(passes_of(est, SHADOWED, 4000, 1), SHADOWED.exact)
    assert np.all(np.abs(z) < 4) and abs(pooled) < 4, (z, pooled)


@pytest.mark.parametrize("mis", ["pairwise", "balance"])
def test_two_reuse_passes_on_a_2d_grid_stay_unbiased(mis):
    """The row as a 2 x 8 grid (2-D neighbours), two passes of spatial reuse."""
    grid = Integrand(lambda x: shadowed(x).reshape((2, 8) + x.shape[:-1]), [(0, 1)],
                     SHADOWED.exact.reshape(2, 8), "shadowed-grid")
    est = ReSTIR(8, 3, 2.0, 2, mis, target=lambda x: unshadowed(x).reshape((2, 8) + x.shape[:-1]))
    v = passes_of(est, grid, 3000, 2)
    assert v.shape == (2, 8, 3000)
    z, pooled = zscores(v.reshape(B, -1), SHADOWED.exact)
    assert np.all(np.abs(z) < 4) and abs(pooled) < 4, (z, pooled)


def test_naive_1_over_m_is_biased_by_occlusion():
    """The lecture's point: a neighbour's reservoir never lands where the neighbour is occluded,
    so 1/M under-weights those points at the receiving pixel: the image darkens."""
    est = ReSTIR(16, 5, 3.0, 1, "1/M", target=unshadowed)
    v = passes_of(est, SHADOWED, 4000, 1)
    z, pooled = zscores(v, SHADOWED.exact)
    assert pooled < -6, pooled                      # measured: about -35
    assert np.mean(v.mean(-1) < SHADOWED.exact) > 0.8


def test_every_mode_agrees_where_every_pixel_shares_f():
    """Same f (and target) at every pixel: balance and pairwise weights reduce to M_s / M, so
    all three modes give the same values, and 1/M is unbiased."""
    vals = {mis: passes_of(ReSTIR(8, 4, 3.0, 1, mis), SAME, 3000, 3) for mis in ("pairwise", "balance", "1/M")}
    np.testing.assert_allclose(vals["balance"], vals["1/M"], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(vals["pairwise"], vals["1/M"], rtol=1e-12, atol=1e-12)
    z, pooled = zscores(vals["1/M"], SAME.exact)
    assert np.all(np.abs(z) < 4) and abs(pooled) < 4, (z, pooled)


# ---------------------------------------------------------------------------------------
# reuse helps; no reuse is RIS
# ---------------------------------------------------------------------------------------
def test_without_neighbours_it_is_ris_per_pixel():
    """neighbours = 0: pixel b's value is RIS's on f_b from pixel b's uniforms (the layout)."""
    c, n = 8, 200
    est = ReSTIR(c, 0, 1.0, 1, target=unshadowed)
    u = np.random.default_rng(4).random((n, est.dim_u(SMOOTH)))
    v = est.unit_values(SMOOTH, u)
    for b in (0, 7, 15):
        f_b = Integrand(lambda x, b=b: smooth(x)[b], [(0, 1)])
        ris = RIS(D.UniformInterval(0, 1), lambda x, b=b: unshadowed(x)[b], c)
        u_b = np.concatenate([u[:, b * c: (b + 1) * c], u[:, B * c + b * c: B * c + (b + 1) * c]], -1)
        np.testing.assert_allclose(v[b], ris.unit_values(f_b, u_b), rtol=1e-12)


@pytest.mark.parametrize("mis", ["pairwise", "balance"])
@pytest.mark.parametrize("family, target, most", [(SMOOTH, None, 0.45), (SHADOWED, unshadowed, 0.6)],
                         ids=["smooth-bump", "shadowed"])
def test_reuse_lowers_the_variance_per_pass(mis, family, target, most):
    """Same 8 candidates per pixel, 5 neighbours: the per-pass variance falls well below RIS's
    (neighbours = 0).  Measured ratios: about 0.35 (pairwise) and 0.32 (balance) on the
    drifting bump with the |f| target; 0.49 and 0.47 on the shadowed row with the unshadowed
    target.  (On a family that is nearly constant with the ideal target |f|, RIS is already
    almost exact and reuse gains nothing: the neighbours' shapes differ more than RIS errs.)"""
    ris = passes_of(ReSTIR(8, 0, 3.0, 1, mis, target=target), family, 3000, 5)
    reuse = passes_of(ReSTIR(8, 5, 3.0, 1, mis, target=target), family, 3000, 5)
    ratio = reuse.var(-1, ddof=1).mean() / ris.var(-1, ddof=1).mean()
    assert ratio < most, ratio
    z, pooled = zscores(reuse, family.exact)
    assert np.all(np.abs(z) < 4) and abs(pooled) < 4, (z, pooled)


# ---------------------------------------------------------------------------------------
# mutations that must fail
# ---------------------------------------------------------------------------------------
# DroppedJacobian and WrongPixelTarget (tests/conftest.py): the shift's Jacobian left out, and
# the neighbour's p̂ used where the receiving pixel's is needed


@pytest.mark.parametrize("mis", ["pairwise", "balance"])
def test_the_shift_jacobian_is_needed(mis):
    """Scaled copies with the scaling shift: unbiased with its Jacobian s_dst / s_src, biased
    without it; the identity shift is unbiased too (other supports, no Jacobian)."""
    good = zscores(passes_of(ReSTIR(8, 4, 3.0, 1, mis, shift=ScaleShift()), SCALED, 3000, 6), SCALED.exact)
    ident = zscores(passes_of(ReSTIR(8, 4, 3.0, 1, mis), SCALED, 3000, 6), SCALED.exact)
    bad = zscores(passes_of(DroppedJacobian(8, 4, 3.0, 1, mis, shift=ScaleShift()), SCALED, 3000, 6),
                  SCALED.exact)
    for z, pooled in (good, ident):
        assert np.all(np.abs(z) < 4) and abs(pooled) < 4, (z, pooled)
    assert np.max(np.abs(bad[0])) > 20, bad          # measured: 96 (the pooled z cancels: -0.9)


AC = 2.0 * (-1.0) ** np.arange(B)                # slopes alternating along the row


def checker(x):
    xx = x[..., 0]
    return np.exp(_col(AC, xx) * xx) * ~((xx >= _col(LO, xx)) & (xx < _col(HI, xx)))


def checker_target(x):
    xx = x[..., 0]
    return np.exp(_col(AC, xx) * xx)


CHECKER = Integrand(checker, [(0, 1)], (np.expm1(AC) - (np.exp(AC * HI) - np.exp(AC * LO))) / AC, "checker-row")


@pytest.mark.parametrize("mis", ["pairwise", "balance"])
def test_a_target_read_at_the_wrong_pixel_is_caught(mis):
    """Neighbours with other targets (alternating slopes): the receiving pixel's target is
    unbiased, the neighbour's in its place is not (measured pooled z about 17 pairwise, 10
    balance)."""
    good = zscores(passes_of(ReSTIR(16, 5, 3.0, 1, mis, target=checker_target), CHECKER, 4000, 1), CHECKER.exact)
    assert np.all(np.abs(good[0]) < 4) and abs(good[1]) < 4, good
    z, pooled = zscores(passes_of(WrongPixelTarget(16, 5, 3.0, 1, mis, target=checker_target), CHECKER, 4000, 1),
                        CHECKER.exact)
    assert abs(pooled) > 6 and np.max(np.abs(z)) > 5, (z, pooled)


# ---------------------------------------------------------------------------------------
# protocol, determinism, inputs
# ---------------------------------------------------------------------------------------
SMALL = Integrand(lambda x: shadowed(x)[:6], [(0, 1)], SHADOWED.exact[:6], "shadowed-6")


def test_check_estimator_on_a_batched_integrand():
    out = check_estimator(ReSTIR(4, 2, 2.0, 1, "pairwise"), SMALL, render=False)
    assert out["params"] == out["unbiased"] == out["fold"] == out["pickle"][:2] == "ok", out
    assert out["dimension"] == "ok"


def test_units_are_a_deterministic_function_of_their_uniforms():
    """Any split of the passes (chunks, workers, executors) gives bit-identical unit values."""
    est = ReSTIR(8, 3, 2.0, 2, "balance", target=unshadowed)
    u = np.random.default_rng(7).random((64, est.dim_u(SHADOWED)))
    whole = est.unit_values(SHADOWED, u)
    parts = np.concatenate([est.unit_values(SHADOWED, u[:5]), est.unit_values(SHADOWED, u[5:])], -1)
    np.testing.assert_array_equal(whole, parts)
    batched = est.unit_values(SHADOWED, u.reshape(4, 16, -1))            # leading replicate axes
    np.testing.assert_array_equal(batched.reshape(B, 64), whole)
    e = est.estimate(SHADOWED, 64, points=u)
    assert e.value.shape == (B,) and e.extra["shadow_rays"] == 64 * (1 + 2 * 12)
    assert e.extra["target_evals"] == 64 * 8


def test_needs_a_batched_integrand_for_neighbours(raises_naming):
    with raises_naming(ValueError, "neighbours"):
        ReSTIR(4, 2).estimate("sin", 100, rng=0)
    e = ReSTIR(4, 0).estimate("sin", 2000, rng=0)              # no reuse: RIS with |f|
    assert abs(e.value - 1.0) < 4 * e.stderr


@pytest.mark.parametrize("kw, exc, name", [
    ({"candidates": 0}, ValueError, "candidates"), ({"candidates": 2.5}, TypeError, "candidates"),
    ({"neighbours": -1}, ValueError, "neighbours"), ({"radius": 0.0}, ValueError, "radius"),
    ({"radius": -1}, ValueError, "radius"), ({"radius": "3"}, TypeError, "radius"),
    ({"radius": 1e9}, ValueError, "radius"), ({"radius": float("inf")}, ValueError, "radius"),
    ({"mis": "power"}, ValueError, "mis"), ({"mis": None}, TypeError, "mis"),
    ({"passes": 0}, ValueError, "passes"), ({"target": 3}, TypeError, "target"),
    ({"shift": 1.0}, TypeError, "shift"), ({"source": ""}, ValueError, "source"),
])
def test_bad_settings_are_refused_naming_the_argument(raises_naming, kw, exc, name):
    with raises_naming(exc, name):
        ReSTIR(**kw)


def test_a_radius_enumerating_too_many_offsets_is_refused(raises_naming):
    """(2r+1)^d offsets above limits.MAX_OFFSETS: a clear error, not minutes of enumeration."""
    cube = Integrand(lambda x: np.broadcast_to(smooth(x)[:8].reshape(2, 2, 2, *x.shape[:-1]),
                                               (2, 2, 2) + x.shape[:-1]), [(0, 1)], SMOOTH_EXACT[:8].reshape(2, 2, 2),
                     "smooth-cube")
    with raises_naming(ValueError, "radius"):
        ReSTIR(4, 2, radius=200).estimate(cube, 100, rng=0)
    e = ReSTIR(4, 2, radius=1.5).estimate(cube, 2000, rng=0)
    assert np.all(np.abs(e.value - cube.exact) < 4 * e.stderr + 1e-12)


def test_clone_and_label():
    est = ReSTIR(candidates=16, neighbours=3, radius=2.5, passes=2, mis="balance", target=unshadowed)
    assert repr(est.clone()) == repr(est)
    assert est.label == "ReSTIR[balance, c=16, k=3, r=2.5, passes=2]"
    assert est.traced_per_unit() == 1 + 2 * 12 and est.candidates_per_unit == 16
