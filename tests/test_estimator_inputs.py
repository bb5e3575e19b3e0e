"""Bad input to integrands, estimators and Estimate: a clear error naming the argument.

Each case here used to give a silent wrong answer, a hang or a message from deep inside
NumPy (see the issue on contracts).  Every test would fail without the check it names.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

import vrlab
from vrlab.distributions import LinearInterval, UniformInterval
from vrlab.estimators import (MIS, RIS, RQMC, Antithetic, BiasWarning, ControlVariate, CRNDifference,
                              DefensiveMixture, MetropolisHastings, MonteCarlo, OneSampleMIS, Stratified)
from vrlab.integrands import as_integrand, get

SIN = get("sin")


def unit_square(f, exact=None):
    return vrlab.Integrand(f, [(0, 1), (0, 1)], exact, "g")


def every_estimator():
    dists = [UniformInterval(0, np.pi / 2), LinearInterval(0, np.pi / 2, 0.0, 1.0)]
    return {
        "MonteCarlo": MonteCarlo(), "Antithetic": Antithetic(), "MIS": MIS(dists),
        "OneSampleMIS": OneSampleMIS(dists), "ControlVariate": ControlVariate(lambda x: x[..., 0], np.pi**2 / 8),
        "DefensiveMixture": DefensiveMixture([dists[1]]), "Stratified": Stratified(),
        "RQMC": RQMC(replicates=4), "RIS": RIS(dists[0], lambda x: np.sin(x[..., 0]), 4),
    }


ESTIMATORS = list(every_estimator())


# ---------------------------------------------------------------------------------------
# the integrand contract
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ESTIMATORS)
@pytest.mark.parametrize("bad, why", [
    (lambda x: np.sin(x), "shape"),                                   # (n, 1) for (n,)
    (lambda x: 1.0, "scalar"),
    (lambda x: np.where(x[..., 0] > 1.0, np.nan, np.sin(x[..., 0])), "finite"),
    (lambda x: np.where(x[..., 0] > 1.0, np.inf, np.sin(x[..., 0])), "finite"),
])
def test_integrand_output_is_checked_by_every_estimator(name, bad, why, raises_naming):
    integrand = vrlab.Integrand(bad, [(0, np.pi / 2)], 1.0, "wrong")
    with raises_naming(ValueError, "'wrong'") as info:
        every_estimator()[name].estimate(integrand, 512, rng=1)
    assert why in str(info.value) or (why == "scalar" and "one scalar" in str(info.value))


def test_integrand_error_names_the_first_bad_point(raises_naming):
    integrand = unit_square(lambda x: np.where(x[..., 0] < 0.5, np.nan, x[..., 1]))
    with raises_naming(ValueError, "'g'") as info:
        integrand(np.array([[0.9, 0.1], [0.3, 0.7], [0.2, 0.5]]))
    assert "[0.3, 0.7]" in str(info.value) and "2 non-finite" in str(info.value)


def test_batched_integrands_keep_working():
    batch = unit_square(lambda x: np.stack([x[..., 0], 2 * x[..., 1]]))    # (2, n): two integrals
    est = MonteCarlo().estimate(batch, 4096, rng=2)
    assert np.shape(est.value) == (2,)
    np.testing.assert_allclose(est.value, [0.5, 1.0], atol=5 * np.max(est.stderr))


def test_complex_or_text_output_is_a_type_error(raises_naming):
    with raises_naming(TypeError, "'g'"):
        unit_square(lambda x: np.array(["a"] * len(x)))(np.zeros((3, 2)))


@pytest.mark.parametrize("integrand, exc", [(np.sin, TypeError), (lambda x: x, TypeError), (42, TypeError),
                                            ("no-such-integrand", ValueError)])
def test_estimators_accept_only_integrands_or_catalogue_names(integrand, exc, raises_naming):
    with raises_naming(exc, "integrand"):
        MonteCarlo().estimate(integrand, 100, rng=0)


def test_catalogue_name_is_an_integrand():
    assert as_integrand("sin").name == "sin"
    est = MonteCarlo().estimate("sin", 4000, rng=3)
    assert abs(est.zscore(1.0)) < 4


@pytest.mark.parametrize("kwargs, exc, arg", [
    ({"exact": "abc"}, TypeError, "exact"), ({"exact": np.nan}, ValueError, "exact"),
    ({"exact": [1.0, np.inf]}, ValueError, "exact"), ({"f2": -1.0}, ValueError, "f2"),
    ({"f2": "x"}, TypeError, "f2"), ({"name": 3}, TypeError, "name"),
    ({"theory": [1]}, TypeError, "theory"), ({"techniques": {"p": 3}}, TypeError, "techniques['p']"),
    ({"domain": [(1, 0)]}, ValueError, "domain"), ({"domain": "cube"}, ValueError, "domain"),
    ({"f": "sin"}, TypeError, "f"),
])
def test_integrand_constructor(kwargs, exc, arg, raises_naming):
    args = {"f": np.sin, "domain": [(0, 1)], **kwargs}
    with raises_naming(exc, arg):
        vrlab.Integrand(args.pop("f"), args.pop("domain"), **args)


def test_control_output_is_checked(raises_naming):
    est = ControlVariate(lambda x: np.full(x.shape[:-1], np.nan), 1.0)
    with raises_naming(ValueError, "control[0]"):
        est.estimate(SIN, 256, rng=0)


# ---------------------------------------------------------------------------------------
# n, chunk, points and rng: the same for every estimator
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ESTIMATORS)
@pytest.mark.parametrize("n, exc", [(0, ValueError), (-5, ValueError), (16.7, TypeError), ("100", TypeError),
                                    (True, TypeError)])
def test_bad_n(name, n, exc, raises_naming):
    with raises_naming(exc, "n"):
        every_estimator()[name].estimate(SIN, n, rng=0)


@pytest.mark.parametrize("name", ESTIMATORS)
@pytest.mark.parametrize("chunk, exc", [(0, ValueError), (-1, ValueError), (2.5, TypeError), (None, TypeError)])
def test_bad_chunk_is_refused_not_a_hang(name, chunk, exc, raises_naming):
    with raises_naming(exc, "chunk"):
        every_estimator()[name].estimate(SIN, 512, rng=0, chunk=chunk)


@pytest.mark.parametrize("name", ["MonteCarlo", "Antithetic", "MIS", "ControlVariate"])
@pytest.mark.parametrize("value", [1.0, 1.5, -0.1, np.nan, np.inf])
def test_points_arrays_are_checked(name, value, raises_naming):
    est = every_estimator()[name]
    m = 512 // est.evals_per_unit if name != "MIS" else 512
    u = np.random.default_rng(0).random((m, est.dim_u(SIN)))
    u[7, 0] = value
    with raises_naming(ValueError, "points"):
        est.estimate(SIN, 512, rng=0, points=u)


@pytest.mark.parametrize("rng, exc", [("seed", TypeError), (-3, ValueError), (1.5, TypeError)])
def test_bad_rng(rng, exc, raises_naming):
    with raises_naming(exc, "rng"):
        MonteCarlo().estimate(SIN, 100, rng=rng)


# ---------------------------------------------------------------------------------------
# estimator settings
# ---------------------------------------------------------------------------------------
DISTS = [UniformInterval(0, np.pi / 2), LinearInterval(0, np.pi / 2, 0.0, 1.0)]


@pytest.mark.parametrize("make, exc, arg", [
    (lambda: MIS(DISTS, beta="abc"), TypeError, "beta"),
    (lambda: MIS(DISTS, beta=np.nan), ValueError, "beta"),
    (lambda: MIS(DISTS, beta=0), ValueError, "beta"),
    (lambda: MIS(DISTS, heuristic="cutoff", alpha=1.5), ValueError, "alpha"),
    (lambda: MIS(DISTS, heuristic="nope"), ValueError, "heuristic"),
    (lambda: MIS(DISTS, fractions=[1, "a"]), TypeError, "fractions"),
    (lambda: MIS(DISTS, fractions=[1, -1]), ValueError, "fractions"),
    (lambda: MIS(DISTS, fractions=[0, 0]), ValueError, "fractions"),
    (lambda: MIS(DISTS, fractions=[1, 2, 3]), ValueError, "fractions"),
    (lambda: MIS(DISTS, heuristic="optimal", optimal_pilot="x"), TypeError, "optimal_pilot"),
    (lambda: MIS(DISTS, heuristic="optimal", optimal_pilot=1.0), ValueError, "optimal_pilot"),
    (lambda: MIS(DISTS, heuristic="optimal", optimal_ridge=-1.0), ValueError, "optimal_ridge"),
    (lambda: MIS(DISTS, heuristic="optimal", optimal_ridge="x"), TypeError, "optimal_ridge"),
    (lambda: MIS(DISTS, heuristic="balance", optimal_ridge=1.0), ValueError, "optimal_ridge"),
    (lambda: MIS([]), ValueError, "distributions"),
    (lambda: MIS([DISTS[0], 42]), TypeError, "distributions[1]"),
    (lambda: MIS([DISTS[0], ""]), ValueError, "distributions[1]"),
    (lambda: MIS(DISTS, probe="no"), TypeError, "probe"),
    (lambda: OneSampleMIS(DISTS, beta="abc"), TypeError, "beta"),
    (lambda: OneSampleMIS(DISTS, heuristic="optimal"), ValueError, "heuristic"),
    (lambda: OneSampleMIS(DISTS, probabilities=[np.nan, 1]), ValueError, "probabilities"),
    (lambda: MonteCarlo(np.sin), TypeError, "distribution"),
    (lambda: MonteCarlo(probe="yes"), TypeError, "probe"),
    (lambda: Antithetic(42), TypeError, "distribution"),
    (lambda: ControlVariate(42, 1.0), TypeError, "control"),
    (lambda: ControlVariate("h", 1.0), ValueError, "control_integral"),
    (lambda: ControlVariate(np.sin), TypeError, "control_integral"),
    (lambda: ControlVariate([np.sin, "h"], [1.0, 1.0]), TypeError, "control"),
    (lambda: ControlVariate(np.sin, "abc"), TypeError, "control_integral"),
    (lambda: ControlVariate(np.sin, np.nan), ValueError, "control_integral"),
    (lambda: ControlVariate(np.sin, 1.0, alpha="best"), ValueError, "alpha"),
    (lambda: ControlVariate(np.sin, 1.0, alpha=np.inf), ValueError, "alpha"),
    (lambda: DefensiveMixture(DISTS, defensive=1.0), ValueError, "defensive"),
    (lambda: DefensiveMixture(DISTS, defensive="abc"), TypeError, "defensive"),
    (lambda: DefensiveMixture(DISTS, probabilities=[1, 0]), ValueError, "probabilities"),
    (lambda: DefensiveMixture(DISTS, controls="no"), TypeError, "controls"),
    (lambda: DefensiveMixture([]), TypeError, "distributions"),
    (lambda: Stratified(strata=0), ValueError, "strata"),
    (lambda: Stratified(strata=2.5), TypeError, "strata"),
    (lambda: Stratified(allocation="best"), ValueError, "allocation"),
    (lambda: Stratified(defensive="abc"), TypeError, "defensive"),
    (lambda: Stratified(pilot=1), ValueError, "pilot"),
    (lambda: RQMC(replicates=1), ValueError, "replicates"),
    (lambda: RQMC(replicates=3.0), TypeError, "replicates"),
    (lambda: RQMC(base="mc"), TypeError, "base"),
    (lambda: RIS(DISTS[0], np.sin, "abc"), TypeError, "m"),
    (lambda: RIS(DISTS[0], np.sin, 0), ValueError, "m"),
    (lambda: RIS(42, np.sin, 4), TypeError, "source"),
    (lambda: RIS(DISTS[0], 42, 4), TypeError, "target"),
    (lambda: CRNDifference(common="yes"), TypeError, "common"),
    (lambda: CRNDifference("mc"), TypeError, "estimator"),
    (lambda: MetropolisHastings(np.sin, step="abc"), TypeError, "step"),
    (lambda: MetropolisHastings(np.sin, step=0.0), ValueError, "step"),
    (lambda: MetropolisHastings(np.sin, large_step_prob=1.5), ValueError, "large_step_prob"),
    (lambda: MetropolisHastings(np.sin, normalization="abc"), TypeError, "normalization"),
    (lambda: MetropolisHastings(np.sin, normalization=np.nan), ValueError, "normalization"),
    (lambda: MetropolisHastings(np.sin, boundary="bounce"), ValueError, "boundary"),
    (lambda: MetropolisHastings(np.sin, n_chains=0), ValueError, "n_chains"),
    (lambda: MetropolisHastings("pi"), TypeError, "target"),
])
def test_estimator_settings(make, exc, arg, raises_naming):
    with raises_naming(exc, arg):
        make()


def test_crn_needs_a_pair_of_integrands(raises_naming):
    with raises_naming(TypeError, "integrand"):
        CRNDifference().estimate(SIN, 100, rng=0)
    with raises_naming(TypeError, "integrand[1]"):
        CRNDifference().estimate((SIN, np.sin), 100, rng=0)


# ---------------------------------------------------------------------------------------
# Metropolis-Hastings: targets that cannot give the integral
# ---------------------------------------------------------------------------------------
def test_mh_warns_where_the_target_is_zero_but_f_is_not():
    f = unit_square(lambda x: np.ones(x.shape[:-1]), 1.0)
    half = MetropolisHastings(lambda x: (x[..., 0] < 0.5).astype(float), n_chains=8, burn_in=16)
    with pytest.warns(BiasWarning, match="target"):
        half.estimate(f, 2048, rng=1)
    full = MetropolisHastings(lambda x: np.ones(x.shape[:-1]), n_chains=8, burn_in=16)
    with warnings.catch_warnings():
        warnings.simplefilter("error", BiasWarning)
        full.estimate(f, 2048, rng=1)        # no warning where pi covers f


def test_mh_target_zero_everywhere_is_an_error(raises_naming):
    f = unit_square(lambda x: np.ones(x.shape[:-1]), 1.0)
    zero = MetropolisHastings(lambda x: np.zeros(x.shape[:-1]), n_chains=8, burn_in=16)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BiasWarning)
        with raises_naming(ValueError, "target"):
            zero.estimate(f, 2048, rng=1)
        with raises_naming(ValueError, "target"):
            zero.expectation(lambda x: x[..., 0], 64, rng=1)


# ---------------------------------------------------------------------------------------
# Estimate
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("level, exc", [(1.0, ValueError), (0, ValueError), ("95%", TypeError), (np.nan, ValueError)])
def test_estimate_ci_level(level, exc, raises_naming):
    est = MonteCarlo().estimate(SIN, 100, rng=0)
    with raises_naming(exc, "level"):
        est.ci(level)


@pytest.mark.parametrize("exact, exc", [("one", TypeError), (np.nan, ValueError)])
def test_estimate_zscore_exact(exact, exc, raises_naming):
    est = MonteCarlo().estimate(SIN, 100, rng=0)
    with raises_naming(exc, "exact"):
        est.zscore(exact)


@pytest.mark.parametrize("rng", [True, np.bool_(False)])
def test_bool_is_not_a_seed(rng, raises_naming):
    from vrlab._rng import as_generator, spawn

    with raises_naming(TypeError, "rng"):
        as_generator(rng)
    with raises_naming(TypeError, "rng"):
        spawn(rng, 2)
    with raises_naming(TypeError, "k"):
        spawn(1, 2.0)


@pytest.mark.parametrize("kwargs, exc, arg", [({"seed": "x"}, TypeError, "seed"), ({"seed": -1}, ValueError, "seed"),
                                              ({"quick": "yes"}, TypeError, "quick"), ({"out": 3}, TypeError, "out")])
def test_demo_arguments_are_checked_before_any_work(kwargs, exc, arg, raises_naming, tmp_path):
    from vrlab.demo import run_demo

    with raises_naming(exc, arg):
        run_demo(**{"out": tmp_path / "demo", **kwargs})
    assert not (tmp_path / "demo").exists()


def test_demo_out_must_be_a_folder(raises_naming, tmp_path):
    from vrlab.demo import run_demo

    (tmp_path / "file").write_text("x")
    with raises_naming(ValueError, "out"):
        run_demo(tmp_path / "file")


@pytest.mark.parametrize("make, arg", [
    (lambda: MIS([DISTS[0], "light"]), "distributions[1]"),
    (lambda: OneSampleMIS(["uniform", "light"]), "distributions[1]"),
    (lambda: MonteCarlo("light"), "distribution"),
    (lambda: Antithetic("light"), "distribution"),
    (lambda: ControlVariate("lambertian"), "control[0]"),
    (lambda: ControlVariate(np.sin, 1.0, distribution="light"), "distribution"),
    (lambda: DefensiveMixture(["light"]), "distributions[0]"),
    (lambda: RIS("light", np.sin, 4), "source"),
    (lambda: RIS(DISTS[0], "unshadowed", 4), "target"),
])
def test_unknown_technique_names_are_named_at_estimate(make, arg, raises_naming):
    """Technique, control and target names resolve per integrand: an integrand without that
    name gives a ValueError naming the argument (and listing the names it has)."""
    integrand = vrlab.Integrand(lambda x: np.sin(x[..., 0]), [(0, np.pi / 2)], 1.0, techniques={"uniform": DISTS[0]})
    with raises_naming(ValueError, arg):
        make().estimate(integrand, 64, rng=0)


# ---------------------------------------------------------------------------------------
# issue 23, item 8: the last kinds of bad input, each named
# ---------------------------------------------------------------------------------------
def test_a_distribution_of_the_wrong_dimension_is_refused(raises_naming):
    from vrlab.distributions import UniformSphere

    with raises_naming(ValueError, "distribution") as info:
        MonteCarlo(UniformSphere()).estimate(SIN, 1000, rng=0)
    assert "3-dimensional" in str(info.value) and "1-dimensional" in str(info.value)
    with raises_naming(ValueError, "distributions[0]"):
        MIS([UniformSphere(), UniformInterval(0, np.pi / 2)]).estimate(SIN, 1000, rng=0)
    with raises_naming(ValueError, "source"):
        RIS(UniformSphere(), lambda x: np.ones(x.shape[:-1]), 4).estimate(SIN, 1000, rng=0)


def test_a_control_integral_of_the_wrong_shape_is_refused(raises_naming):
    with raises_naming(ValueError, "control_integral"):
        ControlVariate(lambda x: x[..., 0], [1.0, 2.0, 3.0]).estimate(SIN, 1000, rng=0)   # scalar f: not 3 integrals
    batch = unit_square(lambda x: np.stack([x[..., 0], 2 * x[..., 1]]), [0.5, 1.0])
    est = ControlVariate(lambda x: x[..., 0], [0.5, 0.5], alpha=1.0).estimate(batch, 4096, rng=0)
    assert np.shape(est.value) == (2,)                                               # one per batch element: fine


@pytest.mark.parametrize("x0, exc", [([np.nan, 0.5], ValueError), ([0.5, 0.5, 0.5], ValueError),
                                     ([[0.1, 0.2]] * 3, ValueError), ("a", TypeError), ([np.inf, 0.1], ValueError)])
def test_metropolis_names_a_bad_start(x0, exc, raises_naming):
    mh = MetropolisHastings(lambda x: np.ones(x.shape[:-1]))
    with raises_naming(exc, "x0"):
        mh.run(10, 4, 0, 0, x0=x0)
