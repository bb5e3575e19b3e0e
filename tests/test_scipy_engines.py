"""SciPy's own generic QMC engine tests, run on vrlab's ``Halton``, ``Sobol`` and ``LatinHypercube``.

SciPy ships ``scipy/stats/tests/test_qmc.py`` in its wheel; the test classes below
subclass its ``TestHalton``, ``TestLHS`` and ``TestSobol`` with vrlab's engines as
``qmce``.  Several SciPy test methods name ``qmc.LatinHypercube`` / ``qmc.Sobol``
directly instead of ``self.qmce``; a fixture points the test module's ``qmc`` at a
namespace in which those three classes are vrlab's, so those tests check vrlab too
(everything else in it, ``qmc.discrepancy`` ..., is SciPy's).

Left out, each with its reason next to it: only the tests that compare against SciPy's
own *scrambled* numbers (random permutations / matrices drawn by SciPy's algorithm,
which a different scrambling algorithm cannot reproduce).  Unscrambled values are
compared as SciPy wrote them (and match bit for bit).
"""
from __future__ import annotations

import types

import pytest

sq = pytest.importorskip("scipy.stats.tests.test_qmc",
                         reason="this SciPy build does not ship its tests (scipy/stats/tests/test_qmc.py)")

from scipy.stats import qmc  # noqa: E402

from vrlab import points as vp  # noqa: E402

_SCRAMBLED_VALUES = ("compares with SciPy's own scrambled numbers (drawn by SciPy's scrambling algorithm); "
                     "vrlab's scrambling is a different algorithm with the same distribution")


class _VrlabQMC(types.ModuleType):
    """``scipy.stats.qmc`` with ``Halton``, ``Sobol`` and ``LatinHypercube`` replaced by vrlab's."""

    Halton = vp.Halton
    Sobol = vp.Sobol
    LatinHypercube = vp.LatinHypercube

    def __getattr__(self, name):
        return getattr(qmc, name)


@pytest.fixture(autouse=True)
def _vrlab_qmc(monkeypatch):
    monkeypatch.setattr(sq, "qmc", _VrlabQMC("qmc"))


class TestVrlabHalton(sq.TestHalton):
    qmce = vp.Halton

    @pytest.mark.parametrize("scramble", sq.QMCEngineTests.scramble, ids=sq.QMCEngineTests.ids)
    def test_sample(self, scramble):
        if scramble:
            pytest.skip(_SCRAMBLED_VALUES)
        super().test_sample(scramble)

    @pytest.mark.skip(reason=_SCRAMBLED_VALUES + " (test_workers checks them to 1e-3)")
    def test_workers(self):
        pass  # pragma: no cover


class TestVrlabLHS(sq.TestLHS):
    qmce = vp.LatinHypercube


class TestVrlabSobol(sq.TestSobol):
    qmce = vp.Sobol

    @pytest.mark.parametrize("scramble", sq.QMCEngineTests.scramble, ids=sq.QMCEngineTests.ids)
    def test_sample(self, scramble):
        if scramble:
            pytest.skip(_SCRAMBLED_VALUES + " (and SciPy's default bits=30, vrlab's 52)")
        super().test_sample(scramble)


# --------------------------------------------------------------------------------------
# vrlab's side of the SciPy conventions, beyond SciPy's own tests
# --------------------------------------------------------------------------------------
import warnings  # noqa: E402

import numpy as np  # noqa: E402

ALL = [vp.Independent, vp.Stratified, vp.LatinHypercube, vp.Halton, vp.Sobol, vp.CranleyPatterson]


@pytest.mark.parametrize("cls", ALL + [vp.Hammersley])
def test_seed_is_the_legacy_name_of_rng(cls, raises_naming):
    kw = {"scramble": True} if cls in (vp.Halton, vp.Hammersley) else {}
    np.testing.assert_array_equal(cls(3, seed=7, **kw).random(16), cls(3, rng=7, **kw).random(16))
    with raises_naming(TypeError, "rng", "seed"):
        cls(3, rng=7, seed=7)


@pytest.mark.parametrize("cls", ALL + [vp.Hammersley])
@pytest.mark.parametrize("kind", ["generator", "bit_generator"])
def test_generator_rng_spawns_a_child(cls, kind):
    """As SciPy's QMCEngine: the caller's generator is not shared (its later draws change
    nothing), each engine made from it gets the next child."""
    kw = {"scramble": True} if cls in (vp.Halton, vp.Hammersley) else {}

    def make(g):
        return cls(3, rng=g if kind == "generator" else g.bit_generator, **kw)

    g = np.random.default_rng(5)
    eng = make(g)
    g.random(1000)                                      # the caller's own draws
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)    # Sobol's balance warning
        x = eng.random(9)
        np.testing.assert_array_equal(eng.reset().random(9), x)
        h = np.random.default_rng(5)
        np.testing.assert_array_equal(make(h).random(9), x)   # same child: independent of the draws
        assert not np.array_equal(make(h).random(9), x)        # the next engine: the next child


@pytest.mark.parametrize("cls", ALL)
def test_zero_dimensions(cls):
    eng = cls(0, rng=1)
    assert eng.random(4).shape == (4, 0)
    assert eng.random(0).shape == (0, 0)


@pytest.mark.parametrize("cls", [vp.Halton, vp.Sobol, vp.LatinHypercube])
@pytest.mark.parametrize("optimization", ["random-cd", "lloyd"])
def test_optimization_is_reproducible_and_improves(cls, optimization):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        eng = cls(2, optimization=optimization, rng=3)
        x = eng.random(32)
        np.testing.assert_array_equal(eng.reset().random(32), x)
        assert x.shape == (32, 2) and np.all((x >= 0) & (x < 1))
        plain = cls(2, rng=3).random(32)
    if optimization == "random-cd":
        assert qmc.discrepancy(x) <= qmc.discrepancy(plain)
    assert repr(eng).count(optimization) == 1
    if eng.randomized:
        assert all(r.optimization == optimization for r in eng.replicate(2, rng=1))


def test_lhs_scramble_false_is_centered():
    np.testing.assert_array_equal(vp.LatinHypercube(3, scramble=False, rng=4).random(20),
                                  vp.LatinHypercube(3, centered=True, rng=4).random(20))
    assert vp.LatinHypercube(3).scramble is True and vp.LatinHypercube(3, centered=True).scramble is False


@pytest.mark.parametrize("scramble", [False, True])
def test_lhs_strength_2_is_an_orthogonal_array(scramble):
    p, d = 7, 8
    x = vp.LatinHypercube(d, strength=2, scramble=scramble, rng=9).random(p * p)
    cells = np.floor(x * p * p).astype(int)
    assert all(sorted(cells[:, j]) == list(range(p * p)) for j in range(d))    # a Latin hypercube
    coarse = cells // p
    for i in range(d):
        for j in range(i + 1, d):                                            # strength 2: all p^2 pairs
            assert len(set(zip(coarse[:, i], coarse[:, j]))) == p * p


@pytest.mark.parametrize("bits", [40, 52, 64])
def test_sobol_fast_forward_beyond_32_bits(bits):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        ref = vp.Sobol(3, bits=bits, rng=2).random(64)
        for k, m in ((0, 5), (1, 17), (6, 30), (33, 1)):
            eng = vp.Sobol(3, bits=bits, rng=2)
            eng.random(k)
            np.testing.assert_array_equal(eng.fast_forward(m).random(8), ref[k + m:k + m + 8])
        eng = vp.Sobol(2, bits=bits, scramble=False).fast_forward(2 ** 39)      # no draw-and-discard
        assert eng.random(1).shape == (1, 2)


def test_estimator_engines_share_the_estimators_generator():
    """vrlab.estimators' engines draw from the estimator's generator itself (numbers for a seed
    unchanged), and the fast path for points=None gives the same numbers as the engine."""
    from vrlab.estimators.base import point_engine, uniform_blocks

    a = np.vstack(list(uniform_blocks(None, 3, 100, np.random.default_rng(1), 32)))
    b = np.vstack(list(uniform_blocks("independent", 3, 100, np.random.default_rng(1), 32)))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, np.random.default_rng(1).random((100, 3)))
    g = np.random.default_rng(2)
    x = point_engine(vp.LatinHypercube, 2, g).random(10)
    np.testing.assert_array_equal(x, vp.LatinHypercube(2, rng=2).random(10))


@pytest.mark.parametrize("d", [1.5, -1, "2", None, True, np.float64(2.0)])
@pytest.mark.parametrize("cls", [vp.Halton, vp.Sobol, vp.LatinHypercube])
def test_the_message_scipy_pins_for_a_bad_d(cls, d):
    with pytest.raises(ValueError, match=r"d must be a non-negative integer"):
        cls(d)


def test_unscrambled_halton_is_scipys_bit_for_bit():
    """d <= 32 and n <= 2^16, compared with scipy.stats.qmc.Halton itself (not the rounded 7/9 of
    its test table): Halton(d)'s columns are Halton(32)'s first d, and each draw continues exactly."""
    ref = qmc.Halton(32, scramble=False).random(1 << 16)
    np.testing.assert_array_equal(vp.Halton(32).random(1 << 16), ref)
    for d in range(1, 33):
        np.testing.assert_array_equal(vp.Halton(d).random(1 << 10), qmc.Halton(d, scramble=False).random(1 << 10))
    e = vp.Halton(32)
    np.testing.assert_array_equal(np.concatenate([e.random(7), e.random(1000), e.random(30000)]), ref[:31007])
    np.testing.assert_array_equal(vp.Halton(32).fast_forward(40000).random(100), ref[40000:40100])
