"""The estimator protocol of ``vrlab.estimators.Estimator`` (issue 23, item 1): statistics carry
their own state, checkpoints and tiles use it, ``estimate`` runs ``accumulate``/``summarize``,
and nothing outside ``vrlab.estimators`` asks an estimator for its class or reads attributes
with ``getattr``."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import vrlab
from vrlab.estimate import Moments
from vrlab.estimators import ControlVariate, Estimator, MonteCarlo
from vrlab.estimators.regression import CoMoments

ROOT = Path(vrlab.__file__).parent


def _doc_table_names(heading: str) -> set[str]:
    """The member names in the first column of the docs/design.md table after ``heading``."""
    text = (ROOT.parent / "docs" / "design.md").read_text()
    rows = text[text.index(heading):].split("\n\n")[1].splitlines()[2:]
    return {m for row in rows for m in re.findall(r"`([a-z_]+)", row.split("|")[1])}


def test_the_protocol_has_two_documented_parts():
    """Every public member of Estimator is in exactly one part, the core on Estimator and the hooks
    on RenderHooks, both written down in docs/design.md; the lab asks for no hook."""
    from vrlab.estimators.hooks import CORE, RENDER_HOOKS, RenderHooks

    public = {n for n in dir(Estimator) if not n.startswith("_")} - {"CORE", "RENDER_HOOKS"}
    assert set(CORE) | set(RENDER_HOOKS) == public and not set(CORE) & set(RENDER_HOOKS)
    assert Estimator.CORE == CORE and Estimator.RENDER_HOOKS == RENDER_HOOKS
    assert all(n in Estimator.__dict__ for n in CORE) and all(n in RenderHooks.__dict__ for n in RENDER_HOOKS)
    assert _doc_table_names("The core:") == set(CORE)
    assert _doc_table_names("The renderer's hooks:") == set(RENDER_HOOKS)
    asks = re.compile(r"\.(" + "|".join(RENDER_HOOKS) + r")\b")
    lab = [str(p.relative_to(ROOT)) for p in (ROOT / "lab").rglob("*.py") if asks.search(p.read_text())]
    assert not lab, lab
    assert asks.search("est.spatial_dim(f)") and not asks.search("est.spatially")       # the scan can fail


def test_moments_state_round_trip_and_concat():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(3, 4, 50)), rng.normal(size=(3, 2, 50))
    ma, mb = Moments().add(a), Moments().add(b)
    back = Moments.from_state(ma.state())
    np.testing.assert_array_equal(back.mean, ma.mean)
    np.testing.assert_array_equal(back.m2, ma.m2)
    assert back.count == 50
    joined = Moments.concat([ma, mb], axis=1)
    whole = Moments().add(np.concatenate([a, b], axis=1))
    np.testing.assert_allclose(joined.mean, whole.mean, rtol=1e-12)
    np.testing.assert_allclose(joined.variance, whole.variance, rtol=1e-12)
    with pytest.raises(ValueError, match="state"):
        Moments.from_state({"count": 3})
    with pytest.raises(ValueError, match="parts"):
        Moments.concat([ma, Moments().add(b[..., :10])], axis=1)


def test_comoments_state_round_trip_and_concat():
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(4, 30, 2)), rng.normal(size=(2, 30, 2))
    ca, cb = CoMoments().add(a), CoMoments().add(b)
    back = CoMoments.from_state(ca.state())
    np.testing.assert_array_equal(back.comoment, ca.comoment)
    joined = CoMoments.concat([ca, cb], axis=0)
    np.testing.assert_allclose(joined.covariance, CoMoments().add(np.concatenate([a, b])).covariance, rtol=1e-12)


class Halved(MonteCarlo):
    """A MonteCarlo whose summarize reports half the mean: estimate() must show it."""

    def summarize(self, stats):
        value, stderr = super().summarize(stats)
        return value / 2, stderr / 2


def test_estimate_goes_through_accumulate_and_summarize():
    full = MonteCarlo().estimate("sin", 4096, rng=1)
    half = Halved().estimate("sin", 4096, rng=1)
    assert half.value == pytest.approx(full.value / 2, rel=1e-12)
    # and the renderer's fold of the same uniforms gives estimate()'s numbers (ControlVariate too)
    u = np.random.default_rng(2).random((4096, 1))
    for est in (MonteCarlo(), ControlVariate(lambda x: x[..., 0], np.pi**2 / 8)):
        value, stderr = est.fold(est.unit_outputs(vrlab.integrands.get("sin"), u))
        e = est.estimate("sin", 4096, points=u)
        assert e.value == pytest.approx(float(value), rel=1e-12) and e.stderr == pytest.approx(float(stderr), rel=1e-12)


class Sums:
    """A user's own statistics: count, sum and sum of squares (state/from_state/concat/merge)."""

    def __init__(self, count=0, s1=0.0, s2=0.0):
        self.count, self.s1, self.s2 = count, s1, s2

    def merge(self, other):
        self.count, self.s1, self.s2 = self.count + other.count, self.s1 + other.s1, self.s2 + other.s2
        return self

    def state(self):
        return {"kind": "Sums", "count": np.asarray(self.count), "s1": np.asarray(self.s1), "s2": np.asarray(self.s2)}

    @classmethod
    def from_state(cls, state):
        return cls(int(state["count"]), np.asarray(state["s1"]), np.asarray(state["s2"]))

    @classmethod
    def concat(cls, parts, axis=0):
        return cls(parts[0].count, np.concatenate([p.s1 for p in parts], axis), np.concatenate([p.s2 for p in parts], axis))


class SumsMC(MonteCarlo):
    """MonteCarlo with its own statistics class: checkpoints must not need a class table."""

    def accumulate(self, outputs):
        v = np.asarray(outputs, float)[..., 0]
        return Sums(v.shape[-1], v.sum(-1), (v * v).sum(-1))

    def summarize(self, stats):
        mean = stats.s1 / stats.count
        var = (stats.s2 - stats.count * mean * mean) / (stats.count - 1)
        return mean, np.sqrt(np.maximum(var, 0) / stats.count)

    def details(self, stats):
        return {}

    def statistics_from_state(self, state):
        return Sums.from_state(state)


def test_a_users_statistics_checkpoint_and_extend(tmp_path):
    from test_render import FLOOR, RECT_LIGHT, scene
    from vrlab.render import render

    sc = scene(FLOOR + RECT_LIGHT, width=40, height=30)           # 1200 pixels: two tiles
    path = tmp_path / "sums.npz"
    render(sc, 8, SumsMC("light"), rng=4, spp_batch=4, chunk_pixels=500, checkpoint=path)
    with np.load(path) as data:
        assert not any(k.endswith("_class") for k in data.files)   # no class table, no vars()
    extended = render(sc, 16, SumsMC("light"), rng=4, spp_batch=4, chunk_pixels=500, checkpoint=path)
    direct = render(sc, 16, SumsMC("light"), rng=4, spp_batch=4, chunk_pixels=500)
    np.testing.assert_array_equal(extended.value, direct.value)
    plain = render(sc, 16, MonteCarlo("light"), rng=4, spp_batch=4, chunk_pixels=500)
    np.testing.assert_allclose(direct.value, plain.value, rtol=1e-5, atol=1e-6)


CONCRETE = ("MonteCarlo", "Antithetic", "ControlVariate", "DefensiveMixture", "CRNDifference", "Stratified",
            "RQMC", "MetropolisHastings", "MIS", "OneSampleMIS", "RIS", "ReSTIR")


def test_no_class_checks_or_attribute_probes_of_estimators_outside_the_estimators():
    """The renderer, the lab and the CLIs use the protocol: no isinstance on a concrete estimator
    class, no getattr(estimator, "evals_per_unit"/"m"/"min_units", ...) outside vrlab.estimators."""
    isinstance_re = re.compile(r"isinstance\([^)]*\b(" + "|".join(CONCRETE) + r")\b")
    getattr_re = re.compile(r"getattr\(\s*[\w.]*(est|estimator)\w*\s*,\s*[\"'](evals_per_unit|min_units|m|per_unit|"
                            r"probabilities|candidates_per_unit)[\"']")
    bad = []
    for path in ROOT.rglob("*.py"):
        if "estimators" in path.relative_to(ROOT).parts[:1]:
            continue
        text = path.read_text()
        bad += [f"{path.name}: {m.group(0)}" for m in isinstance_re.finditer(text)]
        bad += [f"{path.name}: {m.group(0)}" for m in getattr_re.finditer(text)]
    assert not bad, bad


def test_protocol_defaults_are_documented_on_the_base_class():
    for name in ("dim_u", "unit_outputs", "accumulate", "summarize", "details", "statistics_from_state",
                 "min_units", "evals_per_unit", "traced_per_unit", "candidates_per_unit", "closed_form_per_unit",
                 "per_unit", "get_params", "clone"):
        assert hasattr(Estimator, name) and name in Estimator.__doc__ + "get_params clone", name
    assert MonteCarlo().min_units == 1 and MonteCarlo().per_unit and MonteCarlo().candidates_per_unit == 0
