"""``vrlab.testing.check_estimator`` on every registered recipe (parametrised from the registry,
not a hand list), on a user's estimator, and on deliberately broken ones, which must fail it
naming the check (issue 23, item 3)."""
from __future__ import annotations

import numpy as np
import pytest

import user_estimators
from vrlab.estimators import Estimator, MonteCarlo, recipes
from vrlab.integrands import get as catalogue_integrand, names
from vrlab.lab import registry
from vrlab.render import preset
from vrlab.testing import check_estimator

INTEGRANDS = [n for n in names() if n != "gauss-bump"]      # the bump's narrow peak needs far more samples


def _lab_case(name: str):
    """The first catalogue integrand the lab recipe builds for: (concrete name, integrand, estimator, points)."""
    for integrand in INTEGRANDS:
        for concrete in registry.candidates(integrand):
            if concrete.split(":")[0] != name:
                continue
            try:
                est, points = registry.build(concrete, integrand)
            except ValueError:
                continue
            return concrete, integrand, est, points
    pytest.fail(f"recipe {name!r} builds for no catalogue integrand")


@pytest.mark.filterwarnings("ignore")
@pytest.mark.parametrize("name", list(recipes("lab")))
def test_every_lab_recipe_passes_the_common_checks(name):
    concrete, integrand, est, points = _lab_case(name)
    out = check_estimator(est, integrand, points=points, render=False)
    assert out["unbiased"] == "ok" and out["params"] == "ok" and out["pickle"] == "ok", (concrete, out)
    assert out["protocol"] == "ok", (concrete, out)


@pytest.mark.filterwarnings("ignore")
@pytest.mark.parametrize("heuristic", ["balance", "power", "maximum", "cutoff", "optimal"])
def test_multi_sample_mis_folds_through_accumulate(heuristic):
    """MIS.estimate runs unit_outputs -> accumulate -> summarize (issue 23): the fold check
    runs (not skipped) and passes, with unequal whole-number fractions too."""
    from vrlab.estimators import MIS

    integrand = catalogue_integrand("glossy-light")
    for fractions in ([1, 1], [1, 3]):
        out = check_estimator(MIS(["brdf", "light"], fractions, heuristic), integrand, render=False)
        assert out["fold"] == "ok" and out["unbiased"] == "ok", out


@pytest.mark.parametrize("name", list(recipes("render")))
def test_every_render_preset_passes_the_common_checks(name):
    est, _ = preset(name)
    out = check_estimator(est)
    assert out["render"] == "ok", out


def test_a_users_estimator_passes():
    out = check_estimator(user_estimators.LightBSDFMIS())
    assert out["render"] == "ok" and out["pickle"] == "ok"


class DroppedPdf(MonteCarlo):
    """A mistake: f(x) instead of f(x) / p(x)."""

    def unit_values(self, integrand, u):
        return integrand(self_dist(self, integrand).sample(u))


def self_dist(est, integrand):
    from vrlab.estimators.base import resolve_distribution
    return resolve_distribution(est.distribution, integrand)


class HiddenSetting(MonteCarlo):
    """A mistake: a setting that is not a constructor argument (clone loses it)."""

    def __init__(self, distribution=None, scale: float = 1.0):
        super().__init__(distribution)
        self._scale = scale

    def unit_values(self, integrand, u):
        return self._scale * super().unit_values(integrand, u)


class LocalDensity(MonteCarlo):
    """Fine, but defined in a test module whose lambda setting cannot be pickled."""


@pytest.mark.parametrize("broken, check", [
    (lambda: user_estimators.LightBSDFMIS(weight_scale=2.0), "render"),     # MIS weights summing to 2
    (lambda: DroppedPdf(), "unbiased"),                                     # a dropped pdf
    (lambda: HiddenSetting(scale=2.0), "params"),                           # a setting outside get_params
])
def test_broken_estimators_fail_naming_the_check(broken, check):
    with pytest.raises(AssertionError, match=rf"check_estimator\[{check}\]"):
        check_estimator(broken())


class EmittedDropped(MonteCarlo):
    """A renderer hook overridden with other parameters than the documented ``(outputs, emitted)``."""

    def add_emitted(self, outputs):
        return outputs


class RenamedCore(MonteCarlo):
    """A core method whose parameter is renamed (``integrand`` -> ``f``: keyword callers break)."""

    def unit_dim(self, f):
        return super().unit_dim(f)


class HalfSpatial(MonteCarlo):
    """``spatial = True`` but only one of the three spatial hooks."""

    spatial = True

    def spatial_dim(self, integrand):
        return 2


class FractionalCandidates(MonteCarlo):
    candidates_per_unit = 1.5


@pytest.mark.parametrize("broken, says", [
    (EmittedDropped, r"add_emitted\(self, outputs\): the renderer hook is documented as add_emitted\(self, outputs"),
    (RenamedCore, r"unit_dim\(self, f\): the core method"),
    (HalfSpatial, r"spatial = True but spatial_check, spatial_outputs not overridden"),
    (FractionalCandidates, r"candidates_per_unit must be an integer >= 0"),
])
def test_overrides_off_the_documented_protocol_fail_the_protocol_check(broken, says):
    """The estimator protocol's two parts (vrlab.estimators.hooks): overrides keep the documented
    signatures and types; each of these mistakes fails check_estimator[protocol]."""
    with pytest.raises(AssertionError, match=rf"check_estimator\[protocol\]: {broken.__name__} .*{says}"):
        check_estimator(broken(), "sin", spawn=False, render=False)
    assert check_estimator(MonteCarlo(), "sin", spawn=False, render=False)["protocol"] == "ok"


def test_unpicklable_settings_fail_the_pickle_check():
    from vrlab.estimators import ControlVariate

    with pytest.raises(AssertionError, match=r"check_estimator\[pickle\]"):
        check_estimator(ControlVariate(lambda x: x[..., 0], 0.5), "exp")


def test_estimate_that_bypasses_accumulate_fails_the_fold_check():
    class Bypass(MonteCarlo):
        def estimate(self, integrand, n, *, rng=None, points=None, chunk=1 << 18):
            e = super().estimate(integrand, n, rng=rng, points=points, chunk=chunk)
            e.value = np.asarray(e.value) + 1e-6 * np.asarray(e.stderr)      # not what summarize says
            return e

    Bypass.__module__, Bypass.__qualname__ = __name__, "Bypass"
    globals()["Bypass"] = Bypass
    with pytest.raises(AssertionError, match=r"check_estimator\[fold\]"):
        check_estimator(Bypass(), "sin", spawn=False)


def test_check_estimator_needs_an_estimator(raises_naming):
    with raises_naming(TypeError, "estimator"):
        check_estimator(np.mean)
    assert issubclass(DroppedPdf, Estimator)
