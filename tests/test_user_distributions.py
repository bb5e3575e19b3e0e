"""Techniques whose support is wider than the integrand's domain, and users' duck-typed
distributions that break the protocol: the integral is over the domain (points off it count 0),
and a bad density, sample or value is refused naming it, never folded in silently."""
import numpy as np
import pytest

import vrlab.distributions as D
from vrlab import Integrand
from vrlab.estimators import RIS, ControlVariate, DefensiveMixture, MIS, MonteCarlo, OneSampleMIS, ReSTIR

N = 40_000


def _z(est, exact):
    return (est.value - exact) / est.stderr


# -- the integral is over the domain: samples off it count 0 --------------------------------------
WIDER = {
    # an exponential on [0, inf) for f = 3 x^2 on [0, 1]: 13 % of its samples lie beyond 1
    "exponential-on-box": (Integrand(lambda x: 3 * x[..., 0] ** 2, [(0, 1)], exact=1.0,
                                     techniques={"wide": D.Exponential(2.0), "fit": D.LinearInterval(0, 1, 0, 1)})),
    # the whole sphere for cos(theta) on the hemisphere: half its samples lie below the equator
    "sphere-on-hemisphere": (Integrand(lambda w: w[..., 2], "hemisphere", exact=np.pi,
                                       techniques={"wide": D.UniformSphere(), "fit": D.CosineHemisphere()})),
    # a box around the unit disk for 1 + x on the disk
    "box-on-disk": (Integrand(lambda x: 1 + x[..., 0], "disk", exact=np.pi,
                              techniques={"wide": D.UniformBox([(-1.2, 1.2), (-1.2, 1.2)]), "fit": D.Disk(1.0)})),
}


@pytest.mark.parametrize("make", [lambda: MonteCarlo("wide"), lambda: MIS(["wide", "fit"]),
                                  lambda: MIS(["wide", "fit"], heuristic="power"), lambda: OneSampleMIS(["wide", "fit"]),
                                  None],
                         ids=["mc", "mis-balance", "mis-power", "onesample", "cv"])
@pytest.mark.parametrize("case", sorted(WIDER))
def test_points_outside_the_domain_count_zero(case, make):
    """Before, f was evaluated off the domain: the exponential gave 182 +- 60 for 1, the sphere
    0 for pi.  The control h = 1 has the domain's volume as its integral, so it must be cut to
    the domain too."""
    integrand = WIDER[case]
    est = make() if make else ControlVariate(lambda x: np.ones(x.shape[:-1]), integrand.volume, distribution="wide")
    e = est.estimate(integrand, N, rng=3)
    assert abs(_z(e, integrand.exact)) < 4, (e.value, e.stderr)


def test_points_of_the_wrong_shape_or_nan_are_refused(raises_naming):
    f = Integrand(lambda x: x[..., 0], [(0, 1)], exact=0.5)
    with raises_naming(ValueError, "points", "1-dimensional"):
        f(np.linspace(0.1, 0.9, 7))                         # (n,) instead of (n, 1)
    with raises_naming(ValueError, "points", "NaN"):
        f(np.array([[0.5], [np.nan]]))


def test_complex_integrand_values_are_refused(raises_naming):
    """np.asarray(..., float) dropped the imaginary part with a ComplexWarning."""
    f = Integrand(lambda x: x[..., 0] + 1j, [(0, 1)], exact=0.5)
    with raises_naming(TypeError, "real numbers", "complex"):
        MonteCarlo().estimate(f, 1000, rng=1)


# -- a user's distribution that breaks the protocol -------------------------------------------------
class Linear:
    """A user's duck-typed distribution: density 2x on [0, 1] (the protocol: dim_u, sample, pdf)."""

    dim_u = 1

    def sample(self, u):
        return np.sqrt(np.asarray(u)[..., :1])

    def pdf(self, x):
        return 2 * np.asarray(x)[..., 0]


def _broken(**methods):
    d = Linear()
    for k, v in methods.items():
        setattr(d, k, v)
    return d


BAD_PDFS = {
    "complex": (lambda x: 2 * np.asarray(x)[..., 0] + 0j, TypeError, "real numbers"),
    "nan": (lambda x: np.full(np.shape(x)[:-1], np.nan), ValueError, "nan"),
    "negative": (lambda x: -2 * np.asarray(x)[..., 0], ValueError, ">= 0"),
    "inf": (lambda x: np.full(np.shape(x)[:-1], np.inf), ValueError, "finite"),
    "shape (n, 1)": (lambda x: 2 * np.asarray(x), ValueError, "one value per point"),
    "one scalar": (lambda x: 2.0, ValueError, "one scalar"),
}
ESTIMATORS = {
    "mc": lambda d: MonteCarlo(d),
    "mis": lambda d: MIS([d, Linear()]),
    "mis-power": lambda d: MIS([d, Linear()], heuristic="power"),
    "onesample": lambda d: OneSampleMIS([d, Linear()]),
    "defensive": lambda d: DefensiveMixture([d]),
    "ris": lambda d: RIS(d, lambda x: x[..., 0], 4),
}
F = Integrand(lambda x: 3 * x[..., 0] ** 2, [(0, 1)], exact=1.0)


@pytest.mark.parametrize("estimator", sorted(ESTIMATORS))
@pytest.mark.parametrize("bad", sorted(BAD_PDFS))
def test_a_bad_density_is_refused_naming_the_pdf(raises_naming, bad, estimator):
    """Before: NaN, negative and inf densities gave 0 +- 0 (ratio() reads them as 'no
    density'), a scalar was broadcast (z = -26), a complex one lost its imaginary part, and
    an (n, 1) one failed deep inside with numpy's 'truth value is ambiguous'."""
    pdf, exc, words = BAD_PDFS[bad]
    with raises_naming(exc, "pdf", words):
        ESTIMATORS[estimator](_broken(pdf=pdf)).estimate(F, 2048, rng=2)


@pytest.mark.parametrize("estimator", ["mc", "mis", "ris"])
def test_samples_of_the_wrong_shape_are_refused(raises_naming, estimator):
    """(n,) points for a 1-dimensional domain: an IndexError or numpy's reshape error before."""
    d = _broken(sample=lambda u: np.sqrt(np.asarray(u)[..., 0]))
    with raises_naming(ValueError, "shape"):
        ESTIMATORS[estimator](d).estimate(F, 2048, rng=2)


def test_restir_refuses_a_source_with_the_wrong_sample_shape(raises_naming):
    rows = Integrand(lambda x: np.stack([3 * x[..., 0] ** 2] * 4), [(0, 1)], exact=np.ones(4))
    d = _broken(sample=lambda u: np.sqrt(np.asarray(u)[..., 0]))
    with raises_naming(ValueError, "source", "shape"):
        ReSTIR(candidates=4, neighbours=1, radius=1, source=d).estimate(rows, 512, rng=2)


def test_balance_mis_drops_samples_where_their_own_density_is_zero():
    """A technique whose pdf is 0 where it samples: its samples cannot have been drawn, so they
    count 0 (ratio()'s rule, which the other heuristics already followed).  The balance
    shortcut f / sum_k c_k p_k counted them: 2.0 for 1."""
    zero = _broken(pdf=lambda x: np.zeros(np.shape(x)[:-1]))
    for heuristic in ("balance", "power"):
        e = MIS([zero, Linear()], heuristic=heuristic).estimate(F, N, rng=4)
        assert abs(_z(e, 1.0)) < 4, (heuristic, e.value)


def test_importance_sampling_refuses_a_density_that_is_zero_at_all_its_samples(raises_naming):
    zero = _broken(pdf=lambda x: np.zeros(np.shape(x)[:-1]))
    with raises_naming(ValueError, "pdf is 0 at all"):
        MonteCarlo(zero, probe=False).estimate(F, 2048, rng=5)


def test_a_complex_or_misshapen_ris_target_is_refused(raises_naming):
    with raises_naming(TypeError, "target", "real numbers"):
        RIS(Linear(), lambda x: x[..., 0] + 0j, 4).estimate(F, 512, rng=6)
    with raises_naming(ValueError, "target", "one value per point"):
        RIS(Linear(), lambda x: x, 4).estimate(F, 512, rng=6)
