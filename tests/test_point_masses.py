"""Point masses ("delta lights") on the mixed measure mu = length + counting on the atoms.

The catalogue's ``point-mass`` integrand: f = 3x^2 on [0, 1] plus a point mass c = 1/2 at
x0 = 0.3, int f dmu = 3/2.  Every estimator must stay unbiased when its techniques' densities
are taken w.r.t. mu (0 at the atom for a continuous technique, the atom's probability for a
sampler that produces it), and must refuse techniques that cannot produce the atom or that
claim a density there that does not match what they sample.
"""
import numpy as np
import pytest

import vrlab.distributions as D
import vrlab.integrands as I
from vrlab import Integrand
from vrlab.estimators import (MIS, RIS, RQMC, Antithetic, ControlVariate, DefensiveMixture, MonteCarlo,
                              MetropolisHastings, OneSampleMIS, Stratified)
from vrlab.testing import IntervalChart, assert_gof, chi2_gof, integrate

from conftest import check_calibrated, run_cli

X0, C, M = 0.3, 0.5, 0.25
EXACT = 1.0 + C
VAR_MIXTURE = 9 / (8 * (1 - M)) + C * C / M - EXACT**2          # = 1/4 (closed form, per sample)
RAMP = D.LinearInterval(0, 1, 0, 1)                               # p = 2x


@pytest.fixture
def it():
    return I.get("point-mass")


def continuous():
    return D.OffAtoms(RAMP, [X0])


def mixture():
    return D.PointMasses(RAMP, [X0], [M])


def delta():
    return D.PointMasses(None, [X0], [1.0])


class ContinuousPart:
    """The continuous part of a PointMasses, sampled and evaluated through its public
    sample/pdf (u0 mapped into [M, 1), pdf / (1 - M) off the atoms): for chi-square."""

    def __init__(self, pm):
        self.pm, self.dim_u = pm, pm.dim_u

    def sample(self, u):
        u = np.array(u, dtype=float)
        u[..., 0] = self.pm.atom_total + (1 - self.pm.atom_total) * u[..., 0]
        return self.pm.sample(u)

    def pdf(self, x):
        return self.pm.pdf(x) / (1 - self.pm.atom_total)


# -- the distributions ---------------------------------------------------------------------------
PM_CASES = {
    "ramp+1 atom": D.PointMasses(RAMP, [X0], [M]),
    "uniform+2 atoms": D.PointMasses(D.UniformInterval(-1, 2), [0.5, -0.25], [0.1, 0.3]),
    "normal+3 atoms": D.PointMasses(D.TruncatedNormal(0.2, 0.3, 0, 1), [0.1, 0.6, 0.9], [0.05, 0.2, 0.15]),
}
CHARTS = {"ramp+1 atom": IntervalChart(0, 1), "uniform+2 atoms": IntervalChart(-1, 2),
          "normal+3 atoms": IntervalChart(0, 1)}


@pytest.mark.parametrize("name", PM_CASES)
def test_continuous_part_chi_square(name):
    pm = PM_CASES[name]
    assert_gof(chi2_gof(ContinuousPart(pm), CHARTS[name], (40,), n=200_000, rng=3, name=name))


@pytest.mark.parametrize("name", [*PM_CASES, "pure delta"])
def test_atom_frequencies_match_masses(name):
    pm = PM_CASES.get(name) or D.PointMasses(None, [0.2, 0.7, 0.8], [0.5, 0.3, 0.2])
    n = 400_000
    x = pm.sample(np.random.default_rng(5).random((n, pm.dim_u)))[..., 0]
    for a, m in zip(pm.atoms, pm.masses):
        k = np.count_nonzero(x == a)
        z = (k - n * m) / np.sqrt(n * m * (1 - m)) if m < 1 else 0.0
        assert abs(z) < 4, (a, m, k / n, z)
    assert np.allclose(pm.pdf(pm.atoms[:, None]), pm.masses, rtol=0, atol=0)
    assert np.allclose(D.atom_mass(pm, pm.atoms[:, None]), pm.masses)
    if pm.base is not None:      # total probability: continuous part by quadrature + the masses
        chart = CHARTS[name]
        assert integrate(pm.pdf, chart, 400, quad=8) + pm.masses.sum() == pytest.approx(1.0, rel=1e-6)


@pytest.mark.parametrize("name", [*PM_CASES, "pure delta"])
def test_sample_pdf_invert_agree(name):
    pm = PM_CASES.get(name) or D.PointMasses(None, [0.2, 0.7, 0.8], [0.5, 0.3, 0.2])
    u = np.random.default_rng(8).random((20_000, pm.dim_u))
    x = pm.sample(u)
    at = np.isin(x[..., 0], pm.atoms)
    # continuous part: invert(sample(u)) = u; pdf = (1 - M) base.pdf there, > 0 where sampled
    assert np.allclose(pm.invert(x[~at]), u[~at], atol=1e-9)
    if pm.base is not None:
        assert np.allclose(pm.pdf(x[~at]), (1 - pm.atom_total) * pm.base.pdf(x[~at]))
        assert np.all(pm.pdf(x[~at]) > 0)
    else:
        assert at.all()
    # atoms: invert -> the middle of the atom's interval of u, which samples the atom again
    mid = pm.invert(pm.atoms[:, None])
    assert np.allclose(mid[:, 0], 0.5 * (pm.cdf[:-1] + pm.cdf[1:]))
    again = pm.sample(np.concatenate([mid, np.full((len(mid), pm.dim_u - 1), 0.5)], -1))
    assert np.array_equal(again[:, 0], pm.atoms)
    # every sampled atom's u lay in that atom's interval [C_{k-1}, C_k) of the cumulative masses
    for k, a in enumerate(pm.atoms):
        sel = x[..., 0] == a
        assert sel.any() and np.all((u[sel, 0] >= pm.cdf[k]) & (u[sel, 0] < pm.cdf[k + 1]))


def test_off_atoms():
    o = continuous()
    u = np.random.default_rng(1).random((1000, 1))
    assert np.array_equal(o.sample(u), RAMP.sample(u))
    assert o.pdf([[X0]])[0] == 0.0 and o.pdf([[0.5]])[0] == RAMP.pdf([[0.5]])[0]
    assert np.allclose(o.invert(o.sample(u)), u)
    assert D.atom_mass(o, [[X0]])[0] == 0.0
    mix = D.Mixture([o, mixture()], [0.5, 0.5])
    assert D.atom_mass(mix, [[X0], [0.5]]).tolist() == [0.5 * M, 0.0]
    assert mix.pdf([[X0]])[0] == 0.5 * M


@pytest.mark.parametrize("kwargs, name", [
    (dict(base=RAMP, atoms=[0.3], masses=[1.2]), "masses"),
    (dict(base=RAMP, atoms=[0.3], masses=[0.0]), "masses"),
    (dict(base=RAMP, atoms=[0.3], masses=[np.nan]), "masses"),
    (dict(base=RAMP, atoms=[0.3, 0.4], masses=[0.5, 0.5]), "masses"),        # sum 1 leaves no room for base
    (dict(base=None, atoms=[0.3, 0.4], masses=[0.5, 0.4]), "masses"),        # pure delta: must sum to 1
    (dict(base=RAMP, atoms=[0.3], masses=[0.1, 0.2]), "masses"),
    (dict(base=RAMP, atoms=[np.inf], masses=[0.1]), "atoms"),
    (dict(base=RAMP, atoms=[0.3, 0.3], masses=[0.1, 0.1]), "atoms"),
    (dict(base=RAMP, atoms=[], masses=[]), "atoms"),
    (dict(base=D.UniformBox([(0, 1), (0, 1)]), atoms=[0.3], masses=[0.1]), "base"),
    (dict(base=D.PointMasses(RAMP, [0.5], [0.1]), atoms=[0.3], masses=[0.1]), "base"),
])
def test_point_masses_arguments(raises_naming, kwargs, name):
    with raises_naming(ValueError, name):
        D.PointMasses(**kwargs)


def test_point_masses_argument_kinds(raises_naming):
    with raises_naming(TypeError, "base"):
        D.PointMasses("ramp", [0.3], [0.1])
    with raises_naming(TypeError, "masses"):
        D.PointMasses(RAMP, [0.3], ["a"])
    with raises_naming(ValueError, "atoms"):
        D.OffAtoms(RAMP, [0.3, 0.3])


# -- the integrand -------------------------------------------------------------------------------
def test_integrand_value_at_atom_and_closed_forms(it):
    assert it.exact == EXACT and it.atoms == ((X0, C),)
    x = np.array([[X0], [0.5], [np.nextafter(X0, 1)]])
    assert it(x).tolist() == [C, 0.75, pytest.approx(3 * X0**2)]
    assert it.continuous(x)[0] == pytest.approx(3 * X0**2)
    # int f dmu = quadrature of the continuous part + the weight; f2 is int f^2 dx off the atom
    chart = IntervalChart(0, 1)
    assert integrate(it.continuous, chart, 400, quad=8) + C == pytest.approx(EXACT, rel=1e-9)
    assert integrate(lambda x: it.continuous(x) ** 2, chart, 400, quad=8) == pytest.approx(it.f2, rel=1e-9)
    assert it.uniform_variance is None            # uniform sampling never produces the atom
    assert isinstance(it.uniform(), D.OffAtoms)
    assert "point-mass" in I.names() and "point-mass" not in I.names(atoms=False)


def test_mc_variance_on_the_mixed_measure(it):
    assert it.theory["var:mixture"] == pytest.approx(VAR_MIXTURE) == pytest.approx(0.25)
    assert I.mc_variance(it, it.techniques["mixture"]) == pytest.approx(VAR_MIXTURE, rel=1e-9)
    assert I.mc_variance(it, D.PointMasses(D.UniformInterval(0, 1), [X0], [0.4])) == \
        pytest.approx(1.8 / 0.6 + C * C / 0.4 - EXACT**2, rel=1e-9)
    assert I.mc_variance(it, it.techniques["continuous"]) == np.inf     # misses the atom: biased
    assert I.mc_variance(it) == np.inf
    with pytest.raises(ValueError, match="0.3"):     # a continuous density claimed at the atom
        I.mc_variance(it, RAMP)


@pytest.mark.parametrize("atoms, name", [
    ([(1.5, 1.0)], "atoms[0][0]"), ([(0.3, np.nan)], "atoms[0][1]"),
    ([(0.3, 1.0), (0.3, 2.0)], "atoms")])
def test_integrand_atom_arguments(raises_naming, atoms, name):
    with raises_naming(ValueError, name):
        Integrand(lambda x: x[..., 0], [(0, 1)], 1.0, atoms=atoms)


def test_integrand_atoms_need_a_1d_box(raises_naming):
    with raises_naming(ValueError, "atoms"):
        Integrand(lambda x: x[..., 0], [(0, 1), (0, 1)], 1.0, atoms=[(0.3, 1.0)])
    with raises_naming(TypeError, "atoms"):
        Integrand(lambda x: x[..., 0], [(0, 1)], 1.0, atoms=[0.3])


# -- estimators: unbiased on the mixed measure ---------------------------------------------------
def _target_continuous(x):           # a target with a (positive) value at the atom: fine
    return 3 * x[..., 0] ** 2 + 0.1


ESTIMATORS = {
    "is:mixture": lambda: MonteCarlo(mixture()),
    "is:named": lambda: MonteCarlo("mixture"),
    "mis-balance:continuous+delta": lambda: MIS([continuous(), delta()]),
    "mis-power:continuous+delta": lambda: MIS([continuous(), delta()], heuristic="power"),
    "mis-max:continuous+delta": lambda: MIS([continuous(), delta()], heuristic="maximum"),
    "mis-balance:continuous+mixture": lambda: MIS([continuous(), mixture()], fractions=[1, 3]),
    "mis-power:continuous+mixture": lambda: MIS([continuous(), mixture()], heuristic="power"),
    "mis-cutoff:continuous+mixture": lambda: MIS([continuous(), mixture()], heuristic="cutoff", alpha=0.5),
    "mis-optimal:continuous+mixture": lambda: MIS([continuous(), mixture()], heuristic="optimal"),
    "onesample-balance:continuous+delta": lambda: OneSampleMIS([continuous(), delta()], [0.7, 0.3]),
    "onesample-power:continuous+mixture": lambda: OneSampleMIS([continuous(), mixture()], heuristic="power"),
    "ris:|f|": lambda: RIS(mixture(), "|f|", 8),
    "ris:continuous-target": lambda: RIS(mixture(), _target_continuous, 4),
    "antithetic": lambda: Antithetic(mixture()),
    # a control's integral is w.r.t. mu too: h = x read on mu has the point mass h(0.3) = 0.3
    "cv:optimal": lambda: ControlVariate(lambda x: x[..., 0], 0.5 + X0, distribution=mixture()),
    "cv:alpha=1": lambda: ControlVariate(lambda x: x[..., 0], 0.5 + X0, alpha=1.0, distribution=mixture()),
    "defensive": lambda: DefensiveMixture([continuous(), mixture()]),
    "defensive:no-controls": lambda: DefensiveMixture([continuous(), mixture()], controls=False),
    "stratified": lambda: Stratified(distribution=mixture()),
    "rqmc": lambda: RQMC(MonteCarlo(mixture()), replicates=8),
}


@pytest.mark.parametrize("name", ESTIMATORS)
def test_unbiased_on_point_mass(it, name):
    est = ESTIMATORS[name]()
    e = est.estimate(it, 1 << 18, rng=21 + len(name))      # 2^18: RQMC's 8 Sobol' sets of 2^15
    assert np.isfinite(e.stderr) and e.stderr > 0
    assert abs(e.value - EXACT) < 4 * e.stderr, (e.value, e.stderr)


@pytest.mark.parametrize("name", ["is:mixture", "antithetic", "ris:|f|", "onesample-balance:continuous+delta"])
def test_calibrated_on_point_mass(it, name):
    est = ESTIMATORS[name]()
    check_calibrated(est, it, VAR_MIXTURE if name == "is:mixture" else None, seed=4)


def test_importance_variance_matches_closed_form(it):
    e = MonteCarlo(mixture()).estimate(it, 400_000, rng=9)
    assert abs(e.value - EXACT) < 4 * e.stderr
    # Y = 2 w.p. 1/4, else 2X with X ~ 2x: kurtosis small, the sample variance is within 1 %
    assert e.variance == pytest.approx(VAR_MIXTURE, rel=0.02)
    assert e.stderr == pytest.approx(np.sqrt(VAR_MIXTURE / 400_000), rel=0.01)


def test_mis_balance_with_a_delta_light_gives_the_atom_weight_one(it):
    """The atom is produced by the delta technique alone: w = 1 there, its sample contributes
    exactly c; the continuous technique's unit value is f / p_cont, Var = 9/8 - 1 per unit."""
    est = MIS([continuous(), delta()])
    e = est.estimate(it, 400_000, rng=2)
    assert abs(e.value - EXACT) < 4 * e.stderr
    assert e.extra["variance_contributions"][1] == 0.0               # the atom: no variance
    assert e.variance == pytest.approx(2 * (9 / 8 - 1), rel=0.03)    # N x (Var_cont / (N/2))
    w = est.weights(np.array([[X0], [0.5]]), np.array([1, 1]))
    assert w.tolist() == [[0.0, 1.0], [1.0, 0.0]]


# -- mutations: a wrong density at the atom biases, and is refused -------------------------------
def _units(est, it, n=200_000, seed=0):
    u = np.random.default_rng(seed).random((n, est.unit_dim(it)))
    v = est.unit_values(it, u)
    return v.mean(), v.std(ddof=1) / np.sqrt(n)


def test_mutation_continuous_claims_lebesgue_density_in_mis(it, raises_naming):
    est = MIS([RAMP, delta()])                   # RAMP.pdf(0.3) = 0.6: w.r.t. length, not mu
    mean, se = _units(est, it)
    assert abs(mean - EXACT) > 10 * se           # the atom gets weight 1/1.6: biased by -0.1875
    assert mean == pytest.approx(1.0 + C / 1.6, abs=5 * se)
    with raises_naming(ValueError, "distributions[0]", "OffAtoms"):
        est.estimate(it, 1000, rng=0)
    with pytest.raises(ValueError, match="different measures"):   # its mixture refuses length + mu
        OneSampleMIS([RAMP, delta()])
    good_mean, good_se = _units(MIS([continuous(), delta()]), it)
    assert abs(good_mean - EXACT) < 4 * good_se


class WrongMass(D.PointMasses):
    """A mixture whose pdf at the atom is twice the probability it samples it with."""

    def pdf(self, x):
        p = super().pdf(x)
        return np.where(np.asarray(x)[..., 0] == X0, 2 * M, p)


def test_mutation_mixture_with_wrong_mass(it, raises_naming):
    est = MonteCarlo(WrongMass(RAMP, [X0], [M]), probe=False)
    mean, se = _units(est, it)
    assert abs(mean - EXACT) > 10 * se and mean == pytest.approx(EXACT - C / 2, abs=5 * se)
    with raises_naming(ValueError, "distribution"):
        est.estimate(it, 1000, rng=0)
    with pytest.raises(ValueError, match="0.3"):
        I.mc_variance(it, WrongMass(RAMP, [X0], [M]))


REFUSED = {   # techniques that can never produce the atom: refused, naming the atom and the argument
    "mc": (lambda: MonteCarlo(), "distribution"),
    "is:continuous": (lambda: MonteCarlo("continuous"), "distribution"),
    "is:plain-ramp": (lambda: MonteCarlo(RAMP), "distribution"),
    "mis:two-continuous": (lambda: MIS([continuous(), D.OffAtoms(D.UniformInterval(0, 1), [X0])]), "distributions[0]"),
    "onesample:continuous": (lambda: OneSampleMIS([continuous(), D.OffAtoms(RAMP, [X0])]), "distributions[0]"),
    "mis:delta-unused": (lambda: MIS([continuous(), delta()], fractions=[1, 0]), "distributions[0]"),
    "antithetic": (lambda: Antithetic(), "distribution"),
    "stratified": (lambda: Stratified(), "distribution"),
    "rqmc": (lambda: RQMC(replicates=4), "distribution"),
    "cv": (lambda: ControlVariate(lambda x: x[..., 0], 0.8), "distribution"),
    "ris:uniform-source": (lambda: RIS(D.OffAtoms(D.UniformInterval(0, 1), [X0]), "|f|", 4), "source"),
    "defensive:continuous": (lambda: DefensiveMixture([continuous()]), "distributions"),
}


@pytest.mark.parametrize("name", REFUSED)
def test_techniques_that_cannot_reach_the_atom_are_refused(it, raises_naming, name):
    make, arg = REFUSED[name]
    with raises_naming(ValueError, arg, "0.3"):
        make().estimate(it, 4096, rng=0)


def test_ris_target_zero_at_the_atom_is_refused(it, raises_naming):
    est = RIS(mixture(), lambda x: np.where(x[..., 0] == X0, 0.0, 3 * x[..., 0] ** 2), 4)
    with raises_naming(ValueError, "target", "0.3"):
        est.estimate(it, 1000, rng=0)


def test_metropolis_refuses_point_masses(it, raises_naming):
    mh = MetropolisHastings(lambda x: 3 * x[..., 0] ** 2 + 0.1, domain=[(0, 1)])
    with raises_naming(ValueError, "integrand", "point-mass"):
        mh.estimate(it, 4096, rng=0)


# -- the lab ------------------------------------------------------------------------------------
def test_lab_recipes_on_point_mass():
    from vrlab.lab import applicable, explain

    ok = applicable("point-mass")
    assert ok == ["is:mixture", "mis-balance", "mis-power", "mis-max", "mis-cutoff", "mis-optimal", "onesample",
                  "defensive"]
    why = explain("point-mass")
    for name in ("mc", "is:continuous", "antithetic", "stratified", "jittered", "rqmc-sobol", "ris:8"):
        assert "x = 0.3" in why[name] and "PointMasses" in why[name]


def test_lab_cli_runs_point_mass(capsys):
    code, out, err = run_cli(capsys, ["lab", "--integrand", "point-mass", "--estimators",
                                      "is:mixture,mis-balance,onesample", "--n", "256,1024", "--reps", "20",
                                      "--no-progress"])
    assert code == 0, err
    assert "point-mass" in out and "is:mixture" in out and "mis-balance" in out
    code, out, err = run_cli(capsys, ["lab", "--integrand", "point-mass", "--estimators", "mc", "--n", "64",
                                      "--reps", "2", "--no-progress"])
    assert code == 2 and "x = 0.3" in err
    code, out, err = run_cli(capsys, ["lab", "--list"])
    assert code == 0 and "point-mass" in out and "exact 1.5" in out
