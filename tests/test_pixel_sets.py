"""Tests of vrlab.points.pixel_sets: padded stratified sets, shifted copies, SetSampler."""
from __future__ import annotations

import concurrent.futures
import multiprocessing
import pickle

import numpy as np
import pytest
from scipy.stats import qmc

from vrlab import distributions as D
from vrlab.points import (Halton, Independent, LatinHypercube, PaddedStratified, PointSet, SetSampler, ShiftedCopies,
                          Sobol, balanced_strata)
from vrlab.testing import BoxChart, IntervalChart, assert_gof, chi2_gof


# -- helpers -----------------------------------------------------------------------------------
def _padded_variant(count, n, groups, d, rng, shuffle="independent"):
    """The padded construction written out again, with the shuffle ``"independent"`` (per
    group, as it should be), ``"shared"`` (one permutation for every group) or ``None``:
    the last two are the mutants the tests below must reject."""
    u = np.empty((count, n, d))
    shared = np.argsort(rng.random((count, n)), axis=1)
    for g in groups:
        counts = balanced_strata(n, len(g))
        cells = np.stack(np.unravel_index(np.arange(n), counts), -1)
        strata = (cells + rng.random((count, n, len(g)))) / np.asarray(counts, float)
        order = {"independent": np.argsort(rng.random((count, n)), axis=1), "shared": shared,
                 None: np.broadcast_to(np.arange(n), (count, n))}[shuffle]
        u[..., list(g)] = np.take_along_axis(strata, order[..., None], axis=1)
    return u


class _Rows:
    """A point set for chi2_gof: row ``c`` is sample ``c mod n`` of set ``c`` (one sample per
    set, so the rows are independent), coordinates ``cols``."""

    def __init__(self, sets, cols):
        self.sets, self.cols = sets, list(cols)

    def random(self, count):
        u = self.sets(count)
        return u[np.arange(count), np.arange(count) % u.shape[1]][:, self.cols]


def _uniformity(sets, d, pairs):
    """chi-square tests (vrlab.testing harness): every coordinate alone and the given pairs."""
    res = [chi2_gof(D.UniformBox([(0, 1)]), IntervalChart(0, 1), (12,), n=20_000, points=_Rows(sets, [k]))
           for k in range(d)]
    res += [chi2_gof(D.UniformBox([(0, 1)] * 2), BoxChart([(0, 1)] * 2), (6, 6), n=20_000, points=_Rows(sets, p))
            for p in pairs]
    assert_gof(res)


def _cross_group_correlation_is_zero(u, a, b):
    """The within-set correlation of coordinates a and b, averaged over the sets, is 0 within
    4 standard errors (the sets are independent, so the average has an honest standard error)."""
    x, y = u[..., a] - u[..., a].mean(1, keepdims=True), u[..., b] - u[..., b].mean(1, keepdims=True)
    r = (x * y).sum(1) / np.sqrt((x * x).sum(1) * (y * y).sum(1))
    return abs(r.mean()) < 4 * r.std(ddof=1) / np.sqrt(len(r))


def _stratified_exactly(u, g):
    """Every set has exactly one point in every cell of group g's grid."""
    counts = balanced_strata(u.shape[1], len(g))
    idx = np.floor(u[..., list(g)] * np.asarray(counts)).astype(np.int64)
    flat = np.ravel_multi_index(tuple(np.moveaxis(idx, -1, 0)), counts)
    return np.array_equal(np.sort(flat, axis=1), np.broadcast_to(np.arange(u.shape[1]), flat.shape))


# -- PaddedStratified --------------------------------------------------------------------------
def test_padded_groups_default_and_given():
    assert PaddedStratified(5).groups == ((0, 1), (2, 3), (4,))
    assert PaddedStratified(4).groups == ((0, 1), (2, 3))
    assert PaddedStratified(1).groups == ((0,),)
    assert PaddedStratified(0).groups == ()
    assert PaddedStratified(6, [(4, 0, 2)]).groups == ((4, 0, 2), (1,), (3,), (5,))
    assert PaddedStratified(3, []).groups == ((0,), (1,), (2,))
    rep = PaddedStratified(4, [(0, 2)], rng=1).replicate(2, rng=3)
    assert [r.groups for r in rep] == [((0, 2), (1,), (3,))] * 2
    assert not np.array_equal(rep[0].random(4), rep[1].random(4))


@pytest.mark.parametrize("d, n, count", [(5, 12, 7), (2, 1, 3), (3, 7, 0), (0, 4, 2), (4, 0, 3), (6, 64, 5)])
def test_padded_shapes_and_range(d, n, count):
    eng = PaddedStratified(d, rng=2)
    u = eng.random_sets(count, n, np.random.default_rng(1))
    assert u.shape == (count, n, d) and u.dtype == np.float64
    assert np.all((u >= 0) & (u < 1))
    assert eng.random(n).shape == (n, d) and not eng.extensible
    # reset rewinds the engine's own stream
    first = PaddedStratified(d, rng=4).random(n)
    np.testing.assert_array_equal(PaddedStratified(d, rng=4).random_sets(1, n)[0], first)
    again = PaddedStratified(d, rng=4)
    again.random(n)
    np.testing.assert_array_equal(again.reset().random(n), first)


def test_padded_values_clamped_below_one():
    class Ones(np.random.Generator):            # every uniform at the largest float below 1
        def random(self, size=None, dtype=np.float64, out=None):
            return np.full(size, np.nextafter(1.0, 0.0))

    u = PaddedStratified(3).random_sets(2, 9, Ones(np.random.PCG64(0)))
    assert u.max() < 1.0


def test_padded_one_point_per_cell_of_every_group():
    for d, groups, n in [(5, None, 12), (5, None, 16), (6, [(4, 0, 2)], 8), (3, [(0, 1, 2)], 30), (2, None, 7)]:
        eng = PaddedStratified(d, groups, rng=3)
        u = eng.random_sets(300, n)
        for g in eng.groups:
            assert _stratified_exactly(u, g), (d, groups, n, g)
    # the check can fail: independent uniforms are not stratified
    assert not _stratified_exactly(np.random.default_rng(0).random((300, 12, 2)), (0, 1))


def test_padded_random_sets_do_not_depend_on_the_split():
    eng = PaddedStratified(5, [(0, 3)], rng=1)
    whole = eng.random_sets(5, 12, np.random.default_rng(7))
    g = np.random.default_rng(7)
    parts = np.concatenate([eng.random_sets(2, 12, g), eng.random_sets(0, 12, g), eng.random_sets(3, 12, g)])
    np.testing.assert_array_equal(whole, parts)
    # and it is the padded construction itself (the reference above, laid out differently)
    assert _stratified_exactly(whole, (0, 3)) and not np.array_equal(whole[0], whole[1])


def test_padded_every_coordinate_and_cross_group_pair_uniform():
    d, n = 5, 16
    eng = PaddedStratified(d, rng=5)
    _uniformity(lambda c: eng.random_sets(c, n), d, pairs=[(0, 1), (0, 2), (1, 3), (2, 4)])


@pytest.mark.parametrize("shuffle", [None, "shared"])
def test_uniformity_test_rejects_a_wrong_shuffle(shuffle):
    d, n = 5, 16
    groups = PaddedStratified(d).groups
    g = np.random.default_rng(6)
    _uniformity(lambda c: _padded_variant(c, n, groups, d, g), d, pairs=[(0, 2), (1, 3)])   # right: passes
    with pytest.raises(AssertionError, match="rejected"):
        _uniformity(lambda c: _padded_variant(c, n, groups, d, g, shuffle), d, pairs=[(0, 2), (1, 3)])


def test_padded_groups_uncorrelated_across_pixels_and_mutants_fail():
    d, n, count = 6, 16, 4000
    eng = PaddedStratified(d, rng=8)
    u = eng.random_sets(count, n)
    for a, b in [(0, 2), (1, 3), (0, 5), (2, 4)]:
        assert _cross_group_correlation_is_zero(u, a, b), (a, b)
    g = np.random.default_rng(9)
    for shuffle in (None, "shared"):           # without (independent) shuffles the groups correlate
        bad = _padded_variant(count, n, eng.groups, d, g, shuffle)
        assert _stratified_exactly(bad, (0, 1))                 # still stratified ...
        assert not _cross_group_correlation_is_zero(bad, 0, 2)  # ... but the groups move together
    assert _cross_group_correlation_is_zero(_padded_variant(count, n, eng.groups, d, g), 0, 2)


# -- ShiftedCopies -----------------------------------------------------------------------------
def _estimates(u):
    """Per-copy estimates of int prod_k (pi/2) sin(pi u_k) du = 1 over [0, 1)^d."""
    return np.prod(np.pi / 2 * np.sin(np.pi * u), axis=-1).mean(-1)


def _unbiased(est, exact):
    return abs(est.mean() - exact) < 4 * est.std(ddof=1) / np.sqrt(len(est))


def _pairs_uncorrelated(est):
    r = np.corrcoef(est[0::2], est[1::2])[0, 1]
    return abs(r) < 4 / np.sqrt(len(est) // 2)


def test_shifted_sobol_unbiased_independent_and_better_than_iid():
    d, n, R = 3, 32, 2000
    eng = ShiftedCopies(Sobol(d, scramble=False))
    u = eng.random_sets(R, n, np.random.default_rng(3))
    est = _estimates(u)
    assert _unbiased(est, 1.0)
    assert _pairs_uncorrelated(est)
    iid = _estimates(np.random.default_rng(4).random((R, n, d)))
    assert est.var() < iid.var() / 5
    # mutants: no shift (one copy R times: a biased constant), shifts shared by pairs of copies
    base = np.broadcast_to(eng.points(n), (R, n, d))
    assert not _unbiased(_estimates(base), 1.0)
    shifts = np.repeat(np.random.default_rng(5).random((R // 2, 1, d)), 2, axis=0)
    assert not _pairs_uncorrelated(_estimates((base + shifts) % 1.0))


def test_shifted_copies_are_the_shared_set_shifted_mod_1():
    src = Sobol(4, rng=1)
    eng = ShiftedCopies(src, rng=2)
    assert src.num_generated == 0                             # the engine given is not advanced
    pts = eng.points(16)
    assert eng.points(16) is pts and not pts.flags.writeable   # drawn once per n
    np.testing.assert_array_equal(pts, Sobol(4, rng=1).random(16))
    np.testing.assert_array_equal(eng.points(8), Sobol(4, rng=1).random(8))   # first n points for every n
    u = eng.random_sets(50, 16, np.random.default_rng(0))
    assert u.shape == (50, 16, 4) and np.all((u >= 0) & (u < 1))
    shift = (u - pts) % 1.0                                   # one shift per copy, the same for every point
    np.testing.assert_allclose(np.abs(((shift - shift[:, :1]) + 0.5) % 1.0 - 0.5), 0, atol=1e-12)
    assert np.all(np.ptp(shift[:, 0], axis=0) > 0.5)          # different shifts
    g = np.random.default_rng(0)
    np.testing.assert_array_equal(u, np.concatenate([eng.random_sets(20, 16, g), eng.random_sets(30, 16, g)]))
    assert eng.random(16).shape == (16, 4) and not eng.extensible
    reps = eng.replicate(2, rng=4)
    assert not np.array_equal(reps[0].random(16), reps[1].random(16))


# -- SetSampler --------------------------------------------------------------------------------
@pytest.mark.parametrize("points", [None, "independent", "iid", Independent, Independent(3, rng=1)])
def test_set_sampler_independent_is_gen_random_exactly(points):
    s = SetSampler(points, 3, 8, rng=1)
    assert s.iid and s.label == "independent" and s.engine is None
    np.testing.assert_array_equal(s.draw(5, np.random.default_rng(11)), np.random.default_rng(11).random((5, 8, 3)))


@pytest.mark.parametrize("points", ["stratified", "jittered", PaddedStratified, PaddedStratified(4, rng=2)])
def test_set_sampler_stratified_is_padded_random_sets(points):
    s = SetSampler(points, 4, 12, rng=1)
    assert not s.iid and s.label == "stratified"
    want = PaddedStratified(4).random_sets(6, 12, np.random.default_rng(2))
    np.testing.assert_array_equal(s.draw(6, np.random.default_rng(2)), want)
    s = SetSampler("stratified", 4, 12, groups=[(0, 3)])
    assert s.engine.groups == ((0, 3), (1,), (2,))


SHIFTED = [("sobol", "sobol"), ("halton", "halton"), ("lhs", "lhs"), (Sobol, "Sobol"), (Halton, "Halton"),
           (LatinHypercube, "LatinHypercube"), (qmc.Sobol, "scipy Sobol"), (qmc.Halton, "scipy Halton"),
           (lambda: Sobol(3, rng=4), "Sobol"), (lambda: qmc.Halton(3, rng=4), "scipy Halton")]


@pytest.mark.parametrize("points, label", SHIFTED)
def test_set_sampler_shifted_copies(points, label):
    if callable(points) and not isinstance(points, type):
        points = points()
    s = SetSampler(points, 3, 16, rng=5)
    assert not s.iid and s.label == label and isinstance(s.engine, ShiftedCopies)
    u = s.draw(40, np.random.default_rng(0))
    assert u.shape == (40, 16, 3) and u.dtype == np.float64 and np.all((u >= 0) & (u < 1))
    assert s.draw(0, np.random.default_rng(0)).shape == (0, 16, 3)
    if not isinstance(points, type) and not isinstance(points, str):   # an instance: its first points
        np.testing.assert_array_equal(s.engine.points(16), type(points)(3, rng=4).random(16))
    g = np.random.default_rng(1)
    np.testing.assert_array_equal(s.draw(5, np.random.default_rng(1)), np.concatenate([s.draw(2, g), s.draw(3, g)]))
    np.testing.assert_array_equal(SetSampler(points, 3, 16, rng=5).draw(2, np.random.default_rng(0)), u[:2])


def test_set_sampler_scrambles_and_seeds():
    plain = Sobol(2, scramble=False).random(8)
    a = SetSampler("sobol", 2, 8, rng=1).engine.points(8)
    assert not np.array_equal(a, plain) and np.all(a[0] > 0)                  # scrambled
    assert not np.array_equal(a, SetSampler("sobol", 2, 8, rng=2).engine.points(8))
    np.testing.assert_array_equal(a, Sobol(2, rng=1).random(8))              # an int seeds it directly


@pytest.mark.parametrize("points", [None, "stratified", "sobol", qmc.Halton, LatinHypercube])
def test_set_sampler_pickles_with_identical_draws(points):
    s = SetSampler(points, 5, 8, rng=3)
    t = pickle.loads(pickle.dumps(s))
    np.testing.assert_array_equal(t.draw(7, np.random.default_rng(4)), s.draw(7, np.random.default_rng(4)))


def test_set_sampler_in_a_spawned_worker():
    s = SetSampler("sobol", 4, 8, rng=3)
    with concurrent.futures.ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as ex:
        got = ex.submit(s.draw, 6, np.random.default_rng(2)).result()
    np.testing.assert_array_equal(got, s.draw(6, np.random.default_rng(2)))


def test_set_sampler_dimension_mismatch(raises_naming):
    for eng in (Sobol(3, rng=1), qmc.Sobol(3, rng=1), PaddedStratified(3), Independent(3)):
        with raises_naming(ValueError, "points") as info:
            SetSampler(eng, 4, 8)
        assert "3" in str(info.value) and "4" in str(info.value)


class _Broken(PointSet):
    def _random(self, n):
        return np.full((n, self.d), 1.5)


@pytest.mark.parametrize("call, exc, name", [
    (lambda: SetSampler(3, 2, 4), TypeError, "points"),
    (lambda: SetSampler(object, 2, 4), TypeError, "points"),
    (lambda: SetSampler(object(), 2, 4), TypeError, "points"),
    (lambda: SetSampler([0.5, 0.5], 2, 4), TypeError, "points"),
    (lambda: SetSampler(np.zeros((4, 2)), 2, 4), TypeError, "points"),
    (lambda: SetSampler(PointSet, 2, 4), TypeError, "points"),
    (lambda: SetSampler(ShiftedCopies, 2, 4), TypeError, "points"),
    (lambda: SetSampler(qmc.QMCEngine, 2, 4), TypeError, "points"),
    (lambda: SetSampler("nope", 2, 4), ValueError, "points"),
    (lambda: SetSampler(_Broken(2), 2, 4), ValueError, "points"),
    (lambda: SetSampler(None, 0, 4), ValueError, "d"),
    (lambda: SetSampler(None, 2.0, 4), TypeError, "d"),
    (lambda: SetSampler(None, "2", 4), TypeError, "d"),
    (lambda: SetSampler(None, 2, 0), ValueError, "n"),
    (lambda: SetSampler(None, 2, 4.5), TypeError, "n"),
    (lambda: SetSampler(None, 2, True), TypeError, "n"),
    (lambda: SetSampler("sobol", 2, 4, rng="x"), TypeError, "rng"),
    (lambda: SetSampler("sobol", 2, 4, groups=[(0, 1)]), TypeError, "groups"),
    (lambda: SetSampler(PaddedStratified(2), 2, 4, groups=[(0, 1)]), TypeError, "groups"),
    (lambda: SetSampler("stratified", 3, 4, groups=[(0, 0)]), ValueError, "groups"),
    (lambda: SetSampler("stratified", 3, 4, groups=[(0, 1), (1, 2)]), ValueError, "groups"),
    (lambda: SetSampler("stratified", 3, 4, groups=[(0, 3)]), ValueError, "groups"),
    (lambda: SetSampler("stratified", 3, 4, groups=[()]), ValueError, "groups"),
    (lambda: SetSampler("stratified", 3, 4, groups=[0, 1]), TypeError, "groups"),
    (lambda: SetSampler("stratified", 3, 4, groups="01"), TypeError, "groups"),
    (lambda: SetSampler("stratified", 3, 4, groups=[(0.0, 1)]), TypeError, "groups"),
    (lambda: SetSampler(None, 2, 4).draw(-1, np.random.default_rng()), ValueError, "count"),
    (lambda: SetSampler(None, 2, 4).draw(2.0, np.random.default_rng()), TypeError, "count"),
    (lambda: SetSampler("sobol", 2, 4).draw("3", np.random.default_rng()), TypeError, "count"),
    (lambda: SetSampler(None, 2, 4).draw(3, None), TypeError, "gen"),
    (lambda: SetSampler("stratified", 2, 4).draw(3, 7), TypeError, "gen"),
    (lambda: SetSampler("sobol", 2, 4).draw(3, np.random.RandomState(0)), TypeError, "gen"),
    (lambda: PaddedStratified(2).random_sets(2, 4, rng=3), TypeError, "rng"),
    (lambda: PaddedStratified(2).random_sets(-1, 4), ValueError, "count"),
    (lambda: PaddedStratified(2).random_sets(1, 1.5), TypeError, "n"),
    (lambda: PaddedStratified(-1), ValueError, "d"),
    (lambda: ShiftedCopies(Sobol), TypeError, "base"),
    (lambda: ShiftedCopies(3), TypeError, "base"),
    (lambda: ShiftedCopies(_Broken(2)).random_sets(2, 4), ValueError, "base"),
    (lambda: ShiftedCopies(Sobol(2)).random_sets(2, 4, rng=np.random.RandomState(0)), TypeError, "rng"),
    (lambda: ShiftedCopies(Sobol(2)).random_sets(2.0, 4), TypeError, "count"),
])
def test_bad_arguments(raises_naming, call, exc, name):
    with raises_naming(exc, name):
        call()

