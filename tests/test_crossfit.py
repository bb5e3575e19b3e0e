"""Cross-fitted regression (vrlab.estimators.crossfit): unbiased at every n where the fit on
the same units is not, error bars that match the spread, folds that never look at values,
and the statistics protocol (merge, concat, checkpoints)."""
import numpy as np
import pytest

from vrlab.estimators import MIS, ControlVariate
from vrlab.estimators.crossfit import FoldedCoMoments, crossfit_estimate, min_fit_units
from vrlab.estimators.regression import CoMoments, regression_estimate
from vrlab.integrands import catalogue as I

R = 20000


def skewed_units(n, seed=1):
    """Units (Y, H): H = Exp(1) - 1 (mean 0, skewed), Y = H + H^2 + noise, E[Y] = 1.  The fitted
    slope is correlated with mean(H), so a fit on the same units is biased."""
    g = np.random.default_rng(seed)
    h = g.exponential(size=(R, n)) - 1.0
    y = h + h ** 2 + 0.3 * g.normal(size=(R, n))
    return np.stack([y, h], -1)


def z_score(values, exact):
    return (np.mean(values) - exact) / (np.std(values, ddof=1) / np.sqrt(len(values)))


@pytest.mark.parametrize("n", [4, 6, 16])
def test_crossfit_is_unbiased_where_the_same_unit_fit_is_not(n):
    out = skewed_units(n)
    r = crossfit_estimate(FoldedCoMoments().add(out), 1)
    assert abs(z_score(r["value"], 1.0)) < 4
    same = regression_estimate(CoMoments().add(out), 0.0, "optimal")          # the mutation: no folds
    assert z_score(same["value"], 1.0) < -20


def test_a_fold_weighted_by_its_own_fit_is_biased(monkeypatch):
    """Mutation: each fold's coefficients fitted on every unit, its own included."""
    out = skewed_units(8)
    monkeypatch.setattr(FoldedCoMoments, "pooled", lambda self, skip=None, every=FoldedCoMoments.pooled: every(self))
    assert z_score(crossfit_estimate(FoldedCoMoments().add(out), 1)["value"], 1.0) < -20


@pytest.mark.parametrize("n", [8, 16, 64])
def test_reported_variance_matches_the_spread(n):
    out = skewed_units(n, seed=2)
    r = crossfit_estimate(FoldedCoMoments().add(out), 1)
    ratio = np.mean(r["stderr"] ** 2) / np.var(r["value"], ddof=1)
    assert 0.75 < ratio < 1.25, ratio


def test_too_few_units_for_a_fit_give_the_plain_mean():
    out = skewed_units(min_fit_units(1))         # 4 units: each fold's fit would see 3
    r = crossfit_estimate(FoldedCoMoments().add(out), 1)
    np.testing.assert_allclose(r["value"], out[..., 0].mean(-1), rtol=1e-12)
    assert np.all(r["alpha"] == 0)
    r5 = crossfit_estimate(FoldedCoMoments().add(skewed_units(5)), 1)
    assert np.any(r5["alpha"] != 0)


def test_folds_follow_the_unit_index_whatever_the_blocks():
    out = skewed_units(13)[:50]
    whole = FoldedCoMoments().add(out)
    assert [f.count for f in whole.folds] == [4, 3, 3, 3]
    singles = FoldedCoMoments()
    for j in range(13):
        singles.merge(FoldedCoMoments().add(out[:, j:j + 1]))
    threes = FoldedCoMoments()
    for j in range(0, 13, 3):
        threes.merge(FoldedCoMoments().add(out[:, j:j + 3]))
    ref = crossfit_estimate(whole, 1)["value"]
    for other in (singles, threes):
        assert sorted(f.count for f in other.folds) == [3, 3, 3, 4]
        got = crossfit_estimate(other, 1)["value"]
        assert np.isfinite(got).all() and abs(z_score(got - ref, 0.0)) < 4     # another valid partition
    np.testing.assert_allclose(crossfit_estimate(singles, 1)["value"], ref, rtol=1e-10)   # the same one


def test_state_round_trip_concat_and_old_states():
    out = skewed_units(10)[:6]
    st = FoldedCoMoments().add(out)
    back = FoldedCoMoments.from_state(st.state())
    np.testing.assert_array_equal(crossfit_estimate(back, 1)["value"], crossfit_estimate(st, 1)["value"])
    joined = FoldedCoMoments.concat([FoldedCoMoments().add(out[:2]), FoldedCoMoments().add(out[2:])])
    np.testing.assert_allclose(crossfit_estimate(joined, 1)["value"], crossfit_estimate(st, 1)["value"], rtol=1e-12)
    old = CoMoments().add(out).state()
    with pytest.raises(ValueError, match="state"):
        MIS(["a", "b"], heuristic="optimal").statistics_from_state(old)
    with pytest.raises(ValueError, match="state"):
        FoldedCoMoments.from_state({"kind": "FoldedCoMoments", "count": [1, 2], "mean": np.zeros((3, 2))})


@pytest.mark.parametrize("make", [
    lambda it: ControlVariate(lambda x: x[..., 0], 0.5),
    lambda it: MIS([it.uniform(), it.technique("linear") if "linear" in it.techniques else it.uniform()],
                   heuristic="optimal"),
])
@pytest.mark.parametrize("n", [2, 4, 8])
def test_fitted_lab_estimators_are_unbiased_at_tiny_n(make, n):
    """ControlVariate(alpha='optimal') and per-unit optimal MIS on a closed-form integrand,
    over 4000 independent seeds at n = 2..8 evaluations."""
    it = I.get("exp")
    est = make(it)
    vals = np.array([est.estimate(it, n * est.evals_per_unit, rng=s).value for s in range(4000)])
    assert abs(z_score(vals, it.exact)) < 4
