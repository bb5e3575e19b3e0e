"""The one registry of named recipes (issue 23, item 2): the lab, the renderer's presets and
both CLIs' help read it, and a new estimator is one class plus one registration."""
from __future__ import annotations

import numpy as np
import pytest

import user_estimators
from vrlab import lab
from vrlab.estimators import MonteCarlo, recipes, register_recipe
from vrlab.estimators import registry as R
from vrlab.render import PRESETS, preset, render
from vrlab.render.presets import preset_help
from vrlab.testing import check_estimator


@pytest.fixture
def restore_registry():
    saved = dict(R._REGISTRY)
    yield
    R._REGISTRY.clear()
    R._REGISTRY.update(saved)


def test_one_registry_behind_the_lab_and_the_presets():
    every = recipes()
    assert set(recipes("lab")) == {r["recipe"].split("[")[0].split(":")[0] for r in lab.list_recipes()}
    assert tuple(PRESETS) == tuple(recipes("render"))
    assert set(recipes("lab")) | set(recipes("render")) == set(every)
    assert {"mis-power", "mis-balance", "cv", "ris"} <= set(recipes("lab")) & set(recipes("render"))
    assert preset_help()["mis-power"].endswith("as Mitsuba's direct integrator")
    with pytest.raises(ValueError, match="where"):
        recipes("elsewhere")


class Halfway(MonteCarlo):
    """A user's new estimator: MonteCarlo on the average of two techniques' samples (a mixture
    picked by the first uniform), here only to show the one registration."""


def _lab(integrand, arg):
    return Halfway(), None


def _render(emitter_samples, bsdf_samples, ris_candidates):
    return Halfway("cosine"), max(1, bsdf_samples)


def test_a_new_estimator_is_one_class_plus_one_registration(restore_registry, capsys):
    from vrlab.cli import main

    register_recipe("halfway", "Halfway(): a user's recipe", "importance", bias="unbiased", lab=_lab, render=_render,
                    render_help="a user's own strategy", needs="bsdf")
    assert "halfway" in PRESETS and "halfway" in recipes("lab")           # the views follow
    est, units = preset("halfway")
    assert isinstance(est, Halfway) and units == 1
    assert isinstance(lab.build("halfway", "sin")[0], Halfway)
    assert any(r["recipe"] == "halfway" for r in lab.list_recipes())
    img = render("furnace", 4, "halfway", rng=0, width=4, height=3)
    assert np.all(np.isfinite(img.value))
    with pytest.raises(SystemExit):
        main(["render", "--help"])
    assert "halfway: a user's own strategy" in " ".join(capsys.readouterr().out.split())
    with pytest.raises(ValueError, match="bsdf_samples"):
        preset("halfway", bsdf_samples=0)


@pytest.mark.parametrize("kw, exc, name", [
    ({"name": "a b"}, ValueError, "base"), ({"summary": 3}, TypeError, "summary"),
    ({"lab": None, "render": None}, TypeError, "register"), ({"render": 42}, TypeError, "register"),
    ({"needs": "both"}, ValueError, "needs"), ({"render_help": 1}, TypeError, "render_help"),
    ({"bias": "low"}, ValueError, "bias"), ({"bias": 0}, TypeError, "bias"),
])
def test_register_recipe_checks_its_arguments(restore_registry, raises_naming, kw, exc, name):
    args = {"name": "x", "summary": "s", "module": "importance", "bias": "unbiased", "lab": _lab, **kw}
    with raises_naming(exc, name):
        register_recipe(args.pop("name"), args.pop("summary"), args.pop("module"), **args)
    assert "x" not in recipes()


def test_recipes_returns_a_copy():
    got = recipes()
    got.pop("mc")
    assert "mc" in recipes()


def test_user_estimator_class_plus_registration_passes_the_common_checks(restore_registry):
    register_recipe("user-mis", "LightBSDFMIS(): a user's MIS", "importance", bias="unbiased",
                    render=lambda n_l, n_b, m: (user_estimators.LightBSDFMIS(), 1))
    assert check_estimator(preset("user-mis")[0])["render"] == "ok"


def test_a_recipe_must_state_its_bias(restore_registry):
    with pytest.raises(TypeError, match="bias"):
        register_recipe("nobias", "s", "importance", lab=_lab)
    assert all(r.bias in ("unbiased", "consistent", "biased") for r in recipes().values())
