"""Tests of vrlab.points: engine API, exact values, stratification, scrambles, replicates."""
from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest
from scipy import stats
from scipy.stats import qmc

import vrlab.points as P
from vrlab.points import (
    CranleyPatterson,
    Halton,
    Hammersley,
    Independent,
    LatinHypercube,
    Sobol,
    Stratified,
    discrepancy,
    make_points,
    radical_inverse,
    replicates,
)

NAMES = ["independent", "stratified", "lhs", "halton", "hammersley", "sobol", "cranley-patterson"]

# engines that enumerate one sequence of points: fast_forward(k).random(m) == rows k..k+m
SEQUENCES = {
    "independent": lambda: Independent(3, rng=11),
    "halton": lambda: Halton(3, scramble=False),
    "halton-perm": lambda: Halton(3, scramble=True, rng=11),
    "halton-owen": lambda: Halton(3, scramble="owen", rng=11),
    "hammersley-n": lambda: Hammersley(3, n=1000, scramble=True, rng=11),
    "hammersley-plain": lambda: Hammersley(3, n=1000),
    "sobol": lambda: Sobol(3, rng=11),
    "sobol-plain": lambda: Sobol(3, scramble=False),
    "cp-halton": lambda: CranleyPatterson(Halton(3, scramble=False), rng=11),
    "cp-scipy": lambda: CranleyPatterson(qmc.Halton(3, scramble=True, rng=4), rng=11),
}


def _digits_to_phi(i: int, b: int) -> float:
    """Reference radical inverse in exact rational arithmetic."""
    from fractions import Fraction
    x, w = Fraction(0), Fraction(1, b)
    while i:
        i, r = divmod(i, b)
        x += r * w
        w /= b
    return float(x)


def _cells(x: np.ndarray, counts) -> np.ndarray:
    """Points per cell of the grid with per-axis ``counts`` (flattened)."""
    counts = np.asarray(counts)
    idx = np.floor(x * counts).astype(np.int64)
    return np.bincount(np.ravel_multi_index(tuple(idx.T), tuple(counts)), minlength=int(np.prod(counts)))


# --------------------------------------------------------------------------------------
# engine API
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("d", [1, 2, 5])
@pytest.mark.parametrize("n", [0, 1, 7, 64])
def test_shape_dtype_range(name, d, n):
    eng = make_points(name, d, rng=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # Sobol: n not a power of 2
        x = eng.random(n)
    assert x.shape == (n, d) and x.dtype == np.float64
    assert np.all((x >= 0) & (x < 1))
    assert eng.d == d and eng.num_generated == n


@pytest.mark.parametrize("name", NAMES)
def test_reset_returns_self_and_repeats(name):
    eng = make_points(name, 4, rng=5)
    a = eng.random(32)
    if name != "hammersley":          # a Hammersley set cannot be extended (tested below)
        eng.random(32)
    assert eng.reset() is eng
    np.testing.assert_array_equal(eng.random(32), a)
    assert eng.fast_forward(0) is eng


@pytest.mark.parametrize("key", sorted(SEQUENCES))
@pytest.mark.parametrize("k,m", [(0, 16), (5, 11), (64, 64), (300, 17)])
def test_fast_forward_sequences(key, k, m):
    fresh = SEQUENCES[key]()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        ref = fresh.random(k + m)[k:]
        eng = SEQUENCES[key]()
        assert eng.fast_forward(k) is eng
        got = eng.random(m)
    np.testing.assert_array_equal(got, ref)
    assert eng.num_generated == k + m


@pytest.mark.parametrize("cls", [Stratified, LatinHypercube])
def test_fast_forward_sets_discards_one_set(cls):
    # point sets with a size: SciPy's convention, fast_forward(k) draws and discards a k-point set
    a = cls(2, rng=8)
    a.random(9)
    b = cls(2, rng=8)
    assert b.fast_forward(9) is b
    np.testing.assert_array_equal(b.random(16), a.random(16))


@pytest.mark.parametrize("key", sorted(SEQUENCES))
def test_split_calls_equal_one_call(key):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        whole = SEQUENCES[key]().random(700)
        eng = SEQUENCES[key]()
        parts = np.vstack([eng.random(m) for m in (1, 2, 97, 0, 300, 300)])
    np.testing.assert_array_equal(parts, whole)


@pytest.mark.parametrize("name", NAMES)
def test_reproducible_from_seed(name):
    kw = {"scramble": True} if name in ("halton", "hammersley", "sobol") else {}
    a = make_points(name, 3, rng=123, **kw).random(64)
    b = make_points(name, 3, rng=123, **kw).random(64)
    c = make_points(name, 3, rng=np.random.SeedSequence(123), **kw).random(64)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, c)
    other = make_points(name, 3, rng=124, **kw).random(64)
    assert not np.array_equal(a, other)


def test_generator_argument_spawns_a_child_and_reset_restores():
    # as scipy.stats.qmc engines: a Generator is not drawn from directly, a child is spawned
    # from it, so the caller's own later draws do not change the engine's points
    g = np.random.default_rng(9)
    eng = Independent(2, rng=g)
    g.random(100)
    a = eng.random(5)
    np.testing.assert_array_equal(a, np.random.default_rng(9).spawn(1)[0].random((5, 2)))
    np.testing.assert_array_equal(eng.reset().random(5), a)
    assert not np.array_equal(Independent(2, rng=g).random(5), a)   # the next child
    # the same child as SciPy's engines: Sobol wraps SciPy and gives SciPy's points
    np.testing.assert_array_equal(Sobol(2, bits=30, rng=np.random.default_rng(3)).random(8),
                                  qmc.Sobol(2, rng=np.random.default_rng(3)).random(8))


# --------------------------------------------------------------------------------------
# radical inverse, Halton, Hammersley
# --------------------------------------------------------------------------------------
def test_radical_inverse_values():
    np.testing.assert_array_equal(radical_inverse(np.arange(8), 2), [0, .5, .25, .75, .125, .625, .375, .875])
    i = np.array([0, 1, 2, 3, 4, 5, 8, 9, 26, 12345, 2 ** 40 + 7, 2 ** 62 + 3])
    for b in (2, 3, 5, 7, 131, 7919, 65537):
        ref = [_digits_to_phi(int(k), b) for k in i]
        np.testing.assert_allclose(radical_inverse(i, b), ref, rtol=0, atol=1e-15)
    assert radical_inverse(np.arange(12).reshape(3, 4), 3).shape == (3, 4)
    assert radical_inverse(5, 2) == 0.625


def test_radical_inverse_bad_input():
    with pytest.raises(TypeError, match="i must"):
        radical_inverse(np.array([0.5]), 2)
    with pytest.raises(ValueError, match="non-negative"):
        radical_inverse([-1], 2)
    with pytest.raises(ValueError, match="base"):
        radical_inverse([1], 1)
    with pytest.raises(TypeError, match="base"):
        radical_inverse([1], 2.0)


@pytest.mark.parametrize("d", [1, 2, 7, 32, 50])
def test_halton_equals_scipy(d):
    # bit for bit: the radical inverse is summed in SciPy's order (least significant digit first)
    ours = Halton(d, scramble=False)
    ref = qmc.Halton(d, scramble=False)
    np.testing.assert_array_equal(ours.random(1000), ref.random(1000))
    ours.fast_forward(100_000)
    ref.fast_forward(100_000)
    np.testing.assert_array_equal(ours.random(70_000), ref.random(70_000))  # crosses 2^16 blocks
    np.testing.assert_array_equal(ours.random(3), ref.random(3))
    assert ours.base == [int(p) for p in P.first_primes(d)]


def test_halton_large_index_and_first_point():
    assert np.all(Halton(4, scramble=False).random(1) == 0.0)  # index 0 first
    eng = Halton(3, scramble=False).fast_forward(2 ** 33 - 5)
    x = eng.random(10)
    ref = np.array([[_digits_to_phi(2 ** 33 - 5 + i, b) for b in (2, 3, 5)] for i in range(10)])
    np.testing.assert_allclose(x, ref, rtol=0, atol=1e-15)


@pytest.mark.parametrize("n", [1, 8, 100, 1024])
def test_hammersley_definition(n):
    x = Hammersley(5, scramble=False).random(n)
    np.testing.assert_array_equal(x[:, 0], np.arange(n) / n)
    np.testing.assert_array_equal(x[:, 1:], Halton(4, scramble=False).random(n))


def test_hammersley_fixed_size_semantics():
    # n=None: the size is fixed by the first draw; a further draw raises, reset allows another size
    eng = Hammersley(2, scramble=False)
    eng.random(16)
    with pytest.raises(ValueError, match="Hammersley"):
        eng.random(1)
    np.testing.assert_array_equal(eng.reset().random(4)[:, 0], [0, .25, .5, .75])
    # fast_forward(k).random(m) == rows k..k+m of the (k+m)-point set
    np.testing.assert_array_equal(Hammersley(3, scramble=False).fast_forward(5).random(11),
                                  Hammersley(3, scramble=False).random(16)[5:])
    # n given: the engine walks through the n rows
    e = Hammersley(2, n=10, scramble=False)
    np.testing.assert_array_equal(np.vstack([e.random(4), e.random(6)]), Hammersley(2, scramble=False).random(10))
    with pytest.raises(ValueError, match="10-point"):
        e.random(1)
    with pytest.raises(ValueError):
        Hammersley(2, n=10).fast_forward(11)


def test_hammersley_scrambled_is_stratified_and_uniform():
    x = Hammersley(3, scramble=True, rng=2).random(81)
    assert np.all(np.bincount((x[:, 0] * 81).astype(int), minlength=81) == 1)
    assert np.all(np.bincount((x[:, 2] * 81).astype(int), minlength=81) == 1)  # base 3
    assert not np.array_equal(x, Hammersley(3, scramble=False).random(81))


# --------------------------------------------------------------------------------------
# scrambled Halton
# --------------------------------------------------------------------------------------
def _permutation_reference(eng: Halton, n: int) -> np.ndarray:
    """x = sum_k pi_k(d_k) b^{-k-1} over all scrambled digit positions, in exact rationals."""
    from fractions import Fraction
    out = np.empty((n, eng.d))
    for j, dim in enumerate(eng._dims[0].dims):   # the per-column group (bases <= 2**12)
        perms, b = dim.digits.perms, eng.base[j]
        for i in range(n):
            q, x = i, Fraction(0)
            for k in range(len(perms)):
                q, r = divmod(q, b)
                x += Fraction(int(perms[k][r]), b ** (k + 1))
            out[i, j] = float(x)
    return out


def test_permutation_scramble_matches_formula():
    eng = Halton(4, scramble=True, rng=17)
    np.testing.assert_allclose(eng.random(60), _permutation_reference(eng, 60), rtol=0, atol=2e-16)


@pytest.mark.parametrize("scramble", [True, "owen"])
def test_scrambled_halton_keeps_stratification(scramble):
    eng = Halton(6, scramble=scramble, rng=21)
    x = eng.random(3 ** 8)
    for j, b in enumerate(eng.base):
        for k in range(1, 9):
            m = b ** k
            if m > len(x):
                break
            counts = np.bincount(np.floor(x[:m, j] * m).astype(int), minlength=m)
            assert np.all(counts == 1), (b, k)
    # the check can fail: a deliberately broken "scramble" (independent jitter of up to 1/4
    # per point, which moves points across the 1/8 intervals) does not pass it
    y = (Halton(1, scramble=False).random(8)[:, 0] + np.random.default_rng(1).random(8) / 4) % 1
    assert not np.all(np.bincount(np.floor(y * 8).astype(int), minlength=8) == 1)


@pytest.mark.parametrize("scramble", [True, "owen"])
def test_scrambled_halton_differs(scramble):
    a = Halton(3, scramble=scramble, rng=1).random(100)
    assert not np.allclose(a, Halton(3, scramble=False).random(100))
    assert not np.allclose(a, Halton(3, scramble=scramble, rng=2).random(100))
    assert not np.allclose(a, Halton(3, scramble="owen" if scramble is True else True, rng=1).random(100))


@pytest.mark.parametrize("scramble", [True, "owen"])
def test_scrambled_points_uniform_over_replicates(scramble):
    # randomised QMC: every single point is U[0,1)^d over independent scrambles (KS per coordinate,
    # Sidak-corrected); the unscrambled points would fail (they are constants)
    R, idx = 400, [0, 1, 7, 100]
    reps = replicates("halton", R, rng=2024, d=3, scramble=scramble)
    x = np.stack([e.random(101)[idx] for e in reps])        # (R, 4, 3)
    pvals = [stats.kstest(x[:, a, j], "uniform").pvalue for a in range(len(idx)) for j in range(3)]
    alpha = 1 - (1 - 0.01) ** (1 / len(pvals))
    assert min(pvals) > alpha, min(pvals)
    # chi-square on the pooled marginal of a long run of one engine
    u = Halton(5, scramble=scramble, rng=3).random(5000)
    for j in range(5):
        counts = np.bincount((u[:, j] * 10).astype(int), minlength=10)
        assert stats.chisquare(counts).pvalue > 1e-3


def test_owen_scramble_nested_and_limits():
    eng = Halton(2, scramble="owen", rng=5)
    x = eng.random(3 ** 6)
    # nested: indices congruent mod b^k lie in the same b-adic interval of length b^-k
    for j, b in enumerate(eng.base):
        for k in (1, 2, 3):
            cell = np.floor(x[:, j] * b ** k).astype(int)
            grp = np.arange(len(x)) % b ** k
            assert all(len(np.unique(cell[grp == g])) == 1 for g in range(b ** k))
    # owen differs from a plain digit permutation: the map of digit 1 depends on digit 0
    d1 = np.floor(x[:16, 0] * 4).astype(int) % 2                  # scrambled digit 1 (base 2)
    orig1 = (np.arange(16) >> 1) & 1
    orig0 = np.arange(16) & 1
    flips = {int(o0): set((d1 ^ orig1)[orig0 == o0].tolist()) for o0 in (0, 1)}
    assert all(len(v) == 1 for v in flips.values())               # one flip per node
    with pytest.raises(ValueError, match="2\\*\\*32"):
        Halton(1, scramble="owen", rng=1).fast_forward(2 ** 32).random(1)


def test_rqmc_beats_mc_on_smooth_integrand():
    # variance of the mean of f(u) = prod(3 u^2)/... over replicates: scrambled Halton << MC
    def f(u):
        return np.prod(1.0 + 0.5 * (u - 0.5), axis=1)

    def spread(points):
        reps = replicates(points, 40, rng=7, d=3, **({"scramble": True} if points != "independent" else {}))
        return np.var([f(e.random(512)).mean() for e in reps])

    v_mc = spread("independent")
    assert spread("halton") < v_mc / 20
    assert spread("sobol") < v_mc / 20


# --------------------------------------------------------------------------------------
# stratified and Latin hypercube
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("d,m", [(1, 50), (2, 8), (3, 4), (4, 3)])
def test_stratified_one_point_per_cell(d, m):
    x = Stratified(d, rng=4).random(m ** d)
    assert np.all(_cells(x, [m] * d) == 1)
    # the same check fails for points that are not stratified
    y = Independent(d, rng=4).random(m ** d)
    assert not np.all(_cells(y, [m] * d) == 1)
    # ... and for a broken stratifier that jitters over two cells
    z = np.clip(x + (np.random.default_rng(0).random(x.shape) - 0.5) / m, 0, 1 - 1e-12)
    assert not np.all(_cells(z, [m] * d) == 1)


def test_stratified_grids():
    assert P.balanced_strata(64, 2) == (8, 8)
    assert P.balanced_strata(12, 2) == (4, 3)
    assert P.balanced_strata(7, 3) == (7, 1, 1)
    assert P.balanced_strata(2 ** 10, 3) == (16, 8, 8)
    for n, d in [(12, 2), (30, 3), (7, 2), (1, 3)]:
        eng = Stratified(d, rng=1)
        assert np.all(_cells(eng.random(n), eng.grid(n)) == 1)
    eng = Stratified(2, strata=(4, 2), rng=1)
    assert np.all(_cells(eng.random(24), (4, 2)) == 3)
    with pytest.raises(ValueError, match="multiple"):
        eng.random(10)
    with pytest.raises(ValueError, match="strata"):
        Stratified(2, strata=(4,))


@pytest.mark.parametrize("d,n", [(1, 10), (3, 100), (8, 37)])
@pytest.mark.parametrize("centered", [False, True])
def test_lhs_one_point_per_row_stratum(d, n, centered):
    x = LatinHypercube(d, centered=centered, rng=6).random(n)
    for j in range(d):
        assert np.all(np.bincount(np.floor(x[:, j] * n).astype(int), minlength=n) == 1)
    if centered:
        np.testing.assert_allclose((x * n) % 1, 0.5)
    y = Independent(d, rng=6).random(n)
    assert not all(np.all(np.bincount(np.floor(y[:, j] * n).astype(int), minlength=n) == 1) for j in range(d))


def test_sets_give_fresh_randomness_each_call():
    for cls in (Stratified, LatinHypercube):
        eng = cls(2, rng=1)
        assert not np.array_equal(eng.random(16), eng.random(16))


# --------------------------------------------------------------------------------------
# Sobol, Cranley-Patterson
# --------------------------------------------------------------------------------------
def test_sobol_wraps_scipy():
    np.testing.assert_array_equal(Sobol(4, scramble=False).random(64), qmc.Sobol(4, scramble=False).random(64))
    np.testing.assert_array_equal(Sobol(4, rng=3, bits=30).random(64), qmc.Sobol(4, rng=3).random(64))
    # vrlab's scrambled default is 52 bits (see the Sobol docstring for why)
    np.testing.assert_array_equal(Sobol(4, rng=3).random(64), qmc.Sobol(4, rng=3, bits=52).random(64))
    with pytest.warns(UserWarning):
        Sobol(2, rng=1).random(10)     # SciPy's balance-property warning is kept
    eng = Sobol(2, rng=1)
    assert eng.random_base2(4).shape == (16, 2) and eng.num_generated == 16


def test_cranley_patterson_shift_mod_1_and_torus_distances():
    base = Halton(3, scramble=False)
    cp = CranleyPatterson(Halton(3, scramble=False), rng=12)
    u, x = base.random(200), cp.random(200)
    assert np.all((x >= 0) & (x < 1))
    np.testing.assert_allclose(x, (u + cp.shift) % 1.0, rtol=0, atol=1e-15)
    assert np.any(u + cp.shift >= 1)                     # the wrap actually happens

    def torus(a):
        diff = np.abs(a[:, None, :] - a[None, :, :])
        return np.minimum(diff, 1 - diff)

    np.testing.assert_allclose(torus(x), torus(u), rtol=0, atol=1e-12)
    # a shift without the modulo would leave the cube; a scaling would change the distances
    assert not np.allclose(torus((u * 0.9 + cp.shift) % 1), torus(u), atol=1e-6)


def test_cranley_patterson_forms():
    a = CranleyPatterson(2, rng=1).random(8)             # default: shifted unscrambled Halton
    np.testing.assert_allclose((a - CranleyPatterson(2, rng=1).shift) % 1,
                               Halton(2, scramble=False).random(8), atol=1e-15)
    b = CranleyPatterson(2, points="sobol", rng=1, scramble=False).random(8)
    assert b.shape == (8, 2)
    c = CranleyPatterson(qmc.Sobol(2, scramble=False), rng=1).random(8)
    np.testing.assert_allclose((c - CranleyPatterson(qmc.Sobol(2), rng=1).shift) % 1,
                               qmc.Sobol(2, scramble=False).random(8), atol=1e-15)
    with pytest.raises(TypeError, match="base"):
        CranleyPatterson("halton")


# --------------------------------------------------------------------------------------
# replicates
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("points,kw", [
    (Halton(2, scramble=True, rng=0), {}),
    (Halton(2, scramble="owen", rng=0), {}),
    (Sobol(2, rng=0), {}),
    (CranleyPatterson(Halton(2, scramble=False)), {}),
    (Independent(2), {}),
    (LatinHypercube(2), {}),
    ("hammersley", {"d": 2, "scramble": True}),
    (Stratified, {"d": 2}),
    (qmc.Sobol, {"d": 2}),
    (qmc.Halton, {"d": 2, "scramble": True}),
    (lambda g: Halton(2, scramble="owen", rng=g), {}),
])
def test_replicates_differ_and_are_reproducible(points, kw):
    reps = replicates(points, 4, rng=99, **kw)
    again = replicates(points, 4, rng=99, **kw)
    other = replicates(points, 4, rng=100, **kw)
    xs = [r.random(16) for r in reps]
    for a, b in itertools.combinations(xs, 2):
        assert not np.allclose(a, b)
    for a, r in zip(xs, again):
        np.testing.assert_array_equal(a, r.random(16))
    assert not np.allclose(xs[0], other[0].random(16))
    # replicates are new engines, not the instance itself
    assert all(r is not points for r in reps)


def test_replicates_use_spawned_seeds():
    reps = Halton(2, scramble=True, rng=0).replicate(3, rng=np.random.SeedSequence(5))
    children = np.random.SeedSequence(5).spawn(3)
    for r, c in zip(reps, children):
        np.testing.assert_array_equal(r.random(8), Halton(2, scramble=True, rng=c).random(8))


@pytest.mark.parametrize("points,kw", [
    (Halton(2, scramble=False), {}),
    (Hammersley(2, scramble=False), {}),
    (Sobol(2, scramble=False), {}),
    ("halton", {"d": 2, "scramble": False}),
    (qmc.Halton, {"d": 2, "scramble": False}),
    (lambda g: qmc.Sobol(2, scramble=False, rng=g), {}),
])
def test_replicates_of_deterministic_set_raise(points, kw):
    with pytest.raises(ValueError, match="deterministic"):
        replicates(points, 3, rng=1, **kw)


def test_replicates_bad_input():
    with pytest.raises(TypeError, match="d is required"):
        replicates("halton", 2)
    with pytest.raises(TypeError, match="scipy"):
        replicates(qmc.Halton(2), 2)
    with pytest.raises(ValueError, match="R"):
        replicates(Halton(2, scramble=True), -1)
    assert replicates(Halton(2, scramble=True), 0) == []


# --------------------------------------------------------------------------------------
# discrepancy, factory, bad input
# --------------------------------------------------------------------------------------
def test_discrepancy_qmc_below_mc():
    n = 1024
    mc = discrepancy(Independent(2, rng=1).random(n))
    assert discrepancy(Sobol(2, rng=1).random(n)) < mc / 3
    assert discrepancy(Halton(2, scramble=False).random(n)) < mc / 3
    assert discrepancy(Halton(2, scramble=True, rng=1).random(n), method="L2-star") < discrepancy(
        Independent(2, rng=1).random(n), method="L2-star")
    with pytest.raises(ValueError, match="method"):
        discrepancy(np.zeros((4, 2)), method="XX")
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        discrepancy(np.full((4, 2), 2.0))


def test_defaults():
    # Halton/Hammersley: the textbook (unscrambled) sets unless asked; Sobol: SciPy's default
    assert Halton(2).scramble is False and not Halton(2).randomized
    assert Hammersley(2).scramble is False
    assert Sobol(2).scramble is True
    np.testing.assert_array_equal(Halton(3).random(50), Halton(3, scramble=False).random(50))


def test_make_points_names():
    assert isinstance(make_points("LHS", 2), LatinHypercube)
    assert isinstance(make_points("iid", 2), Independent)
    assert isinstance(make_points("jittered", 2), Stratified)
    assert make_points("halton", 3, scramble=False).scramble is False
    with pytest.raises(ValueError, match="allowed names.*halton"):
        make_points("halten", 2)
    with pytest.raises(TypeError, match="name"):
        make_points(3, 2)


@pytest.mark.parametrize("cls", [Independent, Stratified, LatinHypercube, Halton, Hammersley, Sobol])
def test_bad_arguments(cls, raises_naming):
    # d: like SciPy's engines, ValueError for anything but an integer >= 0 (d = 0 is allowed,
    # except for Hammersley, whose first coordinate is i/N)
    for bad in (-2, 2.5, "2", None, True, np.float64(2.0)) + ((0,) if cls is Hammersley else ()):
        with raises_naming(ValueError, "d"):
            cls(bad)
    eng = cls(2, rng=0)
    with raises_naming(ValueError, "n"):
        eng.random(-1)
    with raises_naming(TypeError, "n"):
        eng.random(2.0)
    with raises_naming(ValueError, "n"):
        eng.fast_forward(-1)
    with raises_naming(TypeError, "n"):
        eng.fast_forward("3")
    with raises_naming(TypeError, "rng"):
        cls(2, rng="seed")
    with raises_naming(TypeError, "rng"):
        cls(2, rng=1.5)
    with raises_naming(ValueError, "rng"):
        cls(2, rng=-1)
    with raises_naming(TypeError, "seed"):
        cls(2, seed="seed")
    with raises_naming(TypeError, "rng"):
        cls(2, rng=1, seed=1)
    for bad in (0, -2, 2.5, "a"):
        with raises_naming(ValueError, "workers"):
            eng.random(2, workers=bad)


def test_bad_scramble():
    with pytest.raises(ValueError, match="scramble"):
        Halton(2, scramble="sobol")
    with pytest.raises(TypeError, match="scramble"):
        Sobol(2, scramble="owen")
    with pytest.raises(ValueError, match="d must"):
        Sobol(30000)


def test_scipy_engines_work_as_point_sets():
    # anything with random(n) / d works where vrlab expects a point set
    for eng in (qmc.Halton(2, rng=1), qmc.Sobol(2, rng=1), qmc.LatinHypercube(2, rng=1)):
        x = CranleyPatterson(eng, rng=2).random(8)
        assert x.shape == (8, 2) and np.all((x >= 0) & (x < 1))


# --------------------------------------------------------------------------------------
# bad input: every public class and function names the argument
# --------------------------------------------------------------------------------------
ENGINES = [Independent, Stratified, LatinHypercube, Halton, Hammersley, Sobol, CranleyPatterson]


@pytest.mark.parametrize("cls", ENGINES)
@pytest.mark.parametrize("bad,exc", [(-1, ValueError), (2.5, TypeError), ("4", TypeError), (None, TypeError),
                                     (True, TypeError), (np.float64(3.0), TypeError), (2 ** 49, ValueError)])
def test_random_bad_n(cls, bad, exc, raises_naming):
    eng = cls(2, rng=0)
    with raises_naming(exc, "n"):
        eng.random(bad)
    if bad != 2 ** 49:
        with raises_naming(exc, "n"):
            eng.fast_forward(bad)


@pytest.mark.parametrize("kw,exc,names", [
    ({"l_bounds": [0, 1.5]}, ValueError, ["u_bounds"]),                 # SciPy: ValueError for non-integers
    ({"l_bounds": "ab"}, ValueError, ["u_bounds"]),
    ({"l_bounds": 3, "u_bounds": [1, 4]}, ValueError, ["l_bounds", "u_bounds"]),   # l >= u
    ({"l_bounds": [0, 0, 0], "u_bounds": [1, 2, 3]}, ValueError, ["l_bounds"]),   # wrong length
    ({"l_bounds": [[1, 2]]}, ValueError, ["u_bounds"]),
    ({"l_bounds": 2 ** 60}, ValueError, ["u_bounds"]),
    ({"l_bounds": 5, "endpoint": "yes"}, TypeError, ["endpoint"]),
    ({"l_bounds": 5, "n": -2}, ValueError, ["n"]),
    ({"l_bounds": 5, "workers": 0}, ValueError, ["workers"]),
])
@pytest.mark.parametrize("cls", [Halton, Sobol, LatinHypercube, Independent])
def test_integers_bad_bounds(cls, kw, exc, names, raises_naming):
    with raises_naming(exc, *names):
        cls(2, rng=0).integers(**kw)


def test_integers_values():
    x = Halton(2, scramble=False).integers(-3, u_bounds=[5, 7], n=64)
    ref = np.floor(Halton(2).random(64) * np.array([8.0, 10.0]) - 3).astype(np.int64)
    np.testing.assert_array_equal(x, ref)
    assert x.dtype == np.int64 and x.min() >= -3 and x[:, 0].max() <= 4
    y = Halton(2).integers(3, n=9, endpoint=True)
    assert y.min() == 0 and y.max() == 3
    assert Halton(0).integers(5, n=3).shape == (3, 0)


@pytest.mark.parametrize("make,exc,name", [
    (lambda: Halton(2, scramble="sobol"), ValueError, "scramble"),
    (lambda: Halton(2, scramble=None), ValueError, "scramble"),
    (lambda: Hammersley(2, scramble=1), ValueError, "scramble"),
    (lambda: Sobol(2, scramble="owen"), TypeError, "scramble"),
    (lambda: LatinHypercube(2, scramble="yes"), TypeError, "scramble"),
    (lambda: LatinHypercube(2, centered=1), TypeError, "centered"),
    (lambda: LatinHypercube(2, scramble=False, centered=False), ValueError, "centered"),
    (lambda: LatinHypercube(2, strength=3), ValueError, "strength"),
    (lambda: LatinHypercube(2, strength="2"), ValueError, "strength"),
    (lambda: LatinHypercube(2, strength=True), ValueError, "strength"),
    (lambda: LatinHypercube(2, strength=np.array([1, 2])), ValueError, "strength"),
    (lambda: LatinHypercube(2, strength=2).random(16), ValueError, "n"),
    (lambda: LatinHypercube(5, strength=2).random(9), ValueError, "d"),
    (lambda: LatinHypercube(2, strength=2).random(2 ** 44), ValueError, "n"),
    (lambda: Halton(2, optimization="toto"), ValueError, "optimization"),
    (lambda: Sobol(2, optimization=3), ValueError, "optimization"),
    (lambda: LatinHypercube(1, optimization="lloyd"), ValueError, "optimization"),
    (lambda: Halton(3, optimization="lloyd").random(2), ValueError, "n"),
    (lambda: Sobol(2, bits=65), ValueError, "bits"),
    (lambda: Sobol(2, bits=0), ValueError, "bits"),
    (lambda: Sobol(2, bits=2.5), TypeError, "bits"),
    (lambda: Sobol(Sobol.MAXDIM + 1), ValueError, "d"),
    (lambda: Sobol(2, scramble=False, bits=3).fast_forward(9), ValueError, "n"),
    (lambda: Sobol(2, bits=40).fast_forward(2 ** 41), ValueError, "n"),
    (lambda: Sobol(2).random_base2(-1), ValueError, "m"),
    (lambda: Sobol(2).random_base2(2.0), TypeError, "m"),
    (lambda: Sobol(2).random_base2(65), ValueError, "m"),
    (lambda: Halton(2 ** 23 + 1), ValueError, "d"),
    (lambda: Halton(1).fast_forward(2 ** 62).random(2), ValueError, "n"),
    (lambda: Halton(1).fast_forward(2 ** 63), ValueError, "n"),
    (lambda: Halton(1, scramble="owen").fast_forward(2 ** 32).random(1), ValueError, "n"),
    (lambda: Hammersley(2, n=0), ValueError, "n"),
    (lambda: Hammersley(2, n=2.5), TypeError, "n"),
    (lambda: Hammersley(2, n=4).random(5), ValueError, "n"),
    (lambda: Hammersley(2).fast_forward(2 ** 63), ValueError, "n"),
    (lambda: Stratified(2, strata=(2, 2, 2)), ValueError, "strata"),
    (lambda: Stratified(2, strata="ab"), ValueError, "strata"),
    (lambda: Stratified(2, strata=(2, 0)), ValueError, "strata"),
    (lambda: Stratified(2, strata=(2, 1.5)), TypeError, "strata"),
    (lambda: Stratified(2, strata=(2, [1, 2])), ValueError, "strata"),
    (lambda: Stratified(2, strata=(2, 2 ** 60)), ValueError, "strata"),
    (lambda: Stratified(2, strata=(2, 3)).random(7), ValueError, "n"),
    (lambda: Stratified(2).random(2 ** 41 + 1), ValueError, "n"),
    (lambda: Independent(2, rng=np.random.Generator(np.random.MT19937(1))).fast_forward(2 ** 40), ValueError, "n"),
    (lambda: LatinHypercube(3).random(10 ** 13), ValueError, "n"),            # memory: named, not NumPy's
    (lambda: Independent(2, rng=np.random.RandomState(1)), TypeError, "rng"),
    (lambda: Halton(2, seed=np.random.RandomState(1)), TypeError, "seed"),
    (lambda: Halton(2, rng=[1, -2]), TypeError, "rng"),
    (lambda: Halton(2, rng=np.bool_(True)), TypeError, "rng"),
])
def test_engine_bad_settings(make, exc, name, raises_naming):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)   # Sobol's balance-property warning
        with raises_naming(exc, name):
            make()


@pytest.mark.parametrize("make,exc,name", [
    (lambda: CranleyPatterson("halton"), TypeError, "base"),
    (lambda: CranleyPatterson(2.0), TypeError, "base"),
    (lambda: CranleyPatterson(True), TypeError, "base"),
    (lambda: CranleyPatterson(Halton), TypeError, "base"),
    (lambda: CranleyPatterson(-1), ValueError, "d"),
    (lambda: CranleyPatterson(2, points=3), TypeError, "points"),
    (lambda: CranleyPatterson(2, points="nope"), ValueError, "points"),
    (lambda: CranleyPatterson(Halton(2)).replicate(2, rng=-1), ValueError, "rng"),
    (lambda: CranleyPatterson(Halton(2), points="sobol"), TypeError, "points"),
    (lambda: CranleyPatterson(Halton(2), scramble=True), TypeError, "scramble"),
    (lambda: CranleyPatterson(2, points="halton", bogus=1), TypeError, "bogus"),
    (lambda: CranleyPatterson(2, rng="x"), TypeError, "rng"),
    (lambda: CranleyPatterson(Halton(2)).replicate(-1), ValueError, "R"),
    (lambda: CranleyPatterson(Halton(2)).replicate(2 ** 21), ValueError, "R"),
])
def test_cranley_patterson_bad_input(make, exc, name, raises_naming):
    with raises_naming(exc, name):
        make()


class _BrokenEngine:
    """A foreign engine whose blocks are wrong (shape, NaN, out of range)."""

    def __init__(self, d, block):
        self.d, self.block = d, block

    def random(self, n):
        return self.block(n)

    def reset(self):
        return self


@pytest.mark.parametrize("block", [lambda n: np.full((n, 2), np.nan), lambda n: np.full((n, 2), 1.5),
                                   lambda n: np.zeros((n, 3)), lambda n: np.zeros(n), lambda n: -np.ones((n, 2))])
def test_cranley_patterson_checks_wrapped_blocks(block, raises_naming):
    with raises_naming(ValueError, "base"):
        CranleyPatterson(_BrokenEngine(2, block), rng=1).random(4)


def test_cranley_patterson_engine_without_fast_forward(raises_naming):
    rows = iter(range(10 ** 6))
    eng = CranleyPatterson(_BrokenEngine(1, lambda n: np.array([[next(rows) / 100] for _ in range(n)])), rng=1)
    x = eng.fast_forward(3).random(2)                       # drawn and discarded: rows 3, 4 follow
    np.testing.assert_allclose((x - eng.shift) % 1, [[0.03], [0.04]])
    with raises_naming(ValueError, "n"):
        eng.fast_forward(2 ** 40)


@pytest.mark.parametrize("call,exc,names", [
    (lambda: replicates(Halton(2, scramble=True), 2.5), TypeError, ["R"]),
    (lambda: replicates(Halton(2, scramble=True), 2 ** 21), ValueError, ["R"]),
    (lambda: replicates(Halton(2, scramble=True), 2, d=3), ValueError, ["d"]),
    (lambda: replicates(Halton(2, scramble=True), 2, scramble=True), TypeError, ["scramble"]),
    (lambda: replicates("halton", 2, d=-1, scramble=True), ValueError, ["d"]),
    (lambda: replicates("halton", 2, d=2.5, scramble=True), ValueError, ["d"]),
    (lambda: replicates(3.5, 2), TypeError, ["points"]),
    (lambda: replicates(lambda g: Halton(2, rng=g, scramble=True), 2, d=2), TypeError, ["d"]),
    (lambda: replicates("halton", 2, d=2, rng="x", scramble=True), TypeError, ["rng"]),
    (lambda: Halton(2, scramble=True).replicate(-3), ValueError, ["R"]),
    (lambda: Halton(2, scramble=True).replicate("3"), TypeError, ["R"]),
    (lambda: Halton(2, scramble=True).replicate(2, rng=-1), ValueError, ["rng"]),
    (lambda: replicates("lhs", 2, d=2, rng=-5), ValueError, ["rng"]),
    (lambda: replicates("lhs", 2, d=2, rng=True), TypeError, ["rng"]),
    (lambda: make_points(None, 2), TypeError, ["name"]),
    (lambda: make_points("halton", 2, bogus=1), TypeError, ["bogus"]),
    (lambda: make_points("halton", "2"), ValueError, ["d"]),
    (lambda: discrepancy(np.zeros((4, 2)), method="cd"), ValueError, ["method"]),
    (lambda: discrepancy(np.zeros((4, 2)), method=None), TypeError, ["method"]),
    (lambda: discrepancy(np.zeros((4, 2)), workers=0), ValueError, ["workers"]),
    (lambda: discrepancy([[0.1, np.nan]]), ValueError, ["points"]),
    (lambda: discrepancy([[0.1, np.inf]]), ValueError, ["points"]),
    (lambda: discrepancy(np.zeros((0, 2))), ValueError, ["points"]),
    (lambda: discrepancy(np.zeros((3, 0))), ValueError, ["points"]),
    (lambda: discrepancy(np.zeros(4)), ValueError, ["points"]),
    (lambda: discrepancy([["a", "b"]]), TypeError, ["points"]),
    (lambda: discrepancy(np.full((2, 2), -0.5)), ValueError, ["points"]),
    (lambda: radical_inverse([1.5]), TypeError, ["i"]),
    (lambda: radical_inverse([True]), TypeError, ["i"]),
    (lambda: radical_inverse([-1]), ValueError, ["i"]),
    (lambda: radical_inverse([1], base=1), ValueError, ["base"]),
    (lambda: radical_inverse([1], base=2.0), TypeError, ["base"]),
    (lambda: radical_inverse([1], base=2 ** 64), ValueError, ["base"]),
    (lambda: P.first_primes(-1), ValueError, ["d"]),
    (lambda: P.first_primes(2.0), TypeError, ["d"]),
    (lambda: P.first_primes(2 ** 30), ValueError, ["d"]),
    (lambda: P.balanced_strata(0, 2), ValueError, ["n"]),
    (lambda: P.balanced_strata(8, 0), ValueError, ["d"]),
    (lambda: P.balanced_strata(8.0, 2), TypeError, ["n"]),
    (lambda: P.balanced_strata(2 ** 61 - 1, 2), ValueError, ["n"]),           # would factor for minutes
])
def test_helpers_bad_input(call, exc, names, raises_naming):
    with raises_naming(exc, *names):
        call()


def test_radical_inverse_large_base_needs_no_table():
    i = np.array([0, 1, 5, 10 ** 12 + 7, 2 ** 62])
    for base in (3, 65537, 10 ** 9 + 7, 2 ** 61 - 1):
        np.testing.assert_allclose(radical_inverse(i, base), [_digits_to_phi(int(k), base) for k in i],
                                   rtol=0, atol=4e-16)


# --------------------------------------------------------------------------------------
# Halton in high dimension: bounded memory, same points
# --------------------------------------------------------------------------------------
def test_halton_high_dimension_plain_equals_scipy_without_tables():
    from vrlab.points import radical

    before = set(radical._LSD_TABLES)
    eng = Halton(10_000)
    x = np.vstack([eng.random(3), eng.fast_forward(50).random(20)])
    assert set(radical._LSD_TABLES) == before                   # no per-base tables for small calls
    ref = qmc.Halton(10_000, scramble=False)
    y = ref.random(3)
    ref.fast_forward(50)
    np.testing.assert_array_equal(x, np.vstack([y, ref.random(20)]))


@pytest.mark.parametrize("scramble", [True, "owen"])
def test_halton_high_dimension_scrambled_tables_are_bounded(scramble):
    eng = Halton(10_000, scramble=scramble, rng=3)
    table_bytes = 0
    for group in eng._dims:
        for dim in getattr(group, "dims", []):
            digits = getattr(dim, "digits", None)
            table_bytes += digits.perms.nbytes if digits is not None else 0
            table_bytes += sum(t.nbytes for t in getattr(digits, "_tables", {}).values())
        table_bytes += sum(getattr(group, a).nbytes for a in ("a", "c") if hasattr(group, a))
    # full permutation tables (K b integers per coordinate) would be ~12 GB at d = 10^4
    assert table_bytes < 64 << 20
    x = eng.random(2)
    assert x.shape == (2, 10_000) and np.all((x >= 0) & (x < 1))
    eng = Halton(600, scramble=scramble, rng=3)                         # split calls, same points
    x = eng.random(5)
    np.testing.assert_array_equal(np.vstack([eng.reset().random(2), eng.random(3)]), x)


def test_affine_digit_scramble_matches_formula_and_stratifies():
    from fractions import Fraction

    eng = Halton(570, scramble=True, rng=5)
    group = eng._dims[-1]                                  # bases above 2**12: affine digit maps
    assert group.width == 570 - 564 and int(group.bases[0]) > 4096
    x = eng.random(4200)
    for c in (0, group.width - 1):
        b, j = int(group.bases[c]), 564 + c
        for i in (0, 1, 4099, 4199):
            q, ref = i, Fraction(0)
            for k in range(group.K):
                q, r = divmod(q, b)
                e = (int(group.a[k, c]) * r + int(group.c[k, c])) % b if int(group.a[k, c]) else 0
                ref += Fraction(e, b ** (k + 1))
            assert abs(x[i, j] - float(ref)) <= 2e-16
        m = b                                              # first b points: one per interval 1/b
        assert np.all(np.bincount(np.floor(x[:m, j] * m).astype(int), minlength=m) == 1)
    # point 0 is sum_k c_k b^(-k-1) with independent uniform c_k: uniform across the columns
    u = Halton(1564, scramble=True, rng=2).random(1)[0, 564:]
    assert stats.kstest(u, "uniform").pvalue > 1e-3
