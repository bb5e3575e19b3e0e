"""vrlab.render.plan: every setting of a render resolved and checked once, in a frozen object that
pickles; render(plan) gives the bytes of render(scene, ...) with the same settings."""
import dataclasses
import json
import pickle

import numpy as np
import pytest

from vrlab.estimators import MIS
from vrlab.kernels import numba_version
from vrlab.render import RenderPlan, plan, render, render_gradient_domain

#: what kernels="auto" (the default) runs where a compiled kernel has something to gain (RIS's
#: reservoirs; not cornell_box's rays, which the NumPy path tests all pairs), if numba imports
NUMBA = "numpy" if numba_version() is None else "numba"


def _auto(estimator) -> str:
    return NUMBA if estimator in ("ris", "restir") else "numpy"

SETTINGS = [
    dict(estimator="mis-power"),
    dict(estimator="ris", light_selection="power", ris_candidates=3, emitter_samples=2),
    dict(estimator=MIS(["light", "bsdf"], heuristic="balance"), points="stratified", spp_batch=3),
    dict(estimator="mis-optimal", workers=2),
]


@pytest.mark.parametrize("kw", SETTINGS)
def test_render_of_a_plan_equals_render_of_the_scene(kw):
    p = plan("cornell_box", 7, width=8, height=6, **kw)
    a = render(p, rng=4)
    b = render("cornell_box", 7, width=8, height=6, rng=4, **kw)
    assert np.array_equal(a.value, b.value) and np.array_equal(a.stderr, b.stderr)
    assert a.extra == b.extra and a.extra["kernels"] == _auto(kw["estimator"])
    c = render(pickle.loads(pickle.dumps(p)), rng=4)                   # the plan pickles
    assert np.array_equal(a.value, c.value)


def test_the_plan_is_resolved_once_and_frozen():
    p = plan("cornell_box", 4, "mis-balance", width=8, height=6, emitter_samples=2)
    assert isinstance(p, RenderPlan) and p.strategy == "mis-balance" and p.units == 1
    assert p.emitter_samples == 2 and p.bsdf_samples == 1 and p.unit_dim == p.integrand.unit_dim
    assert p.columns == 1 and p.size == (8, 6) and p.spp_batch == 4 and p.kernels == "numpy"
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.spp = 8
    text = repr(p)
    assert text.startswith("RenderPlan(film=8x6, estimator=MIS(") and "spp=4" in text and "kernels='numpy'" in text


def test_a_plan_refuses_settings_given_again(raises_naming):
    p = plan("cornell_box", 4, width=8, height=6)
    for key, value in (("spp", 8), ("estimator", "light"), ("light_selection", "power"), ("width", 4),
                       ("kernels", "numpy")):
        with raises_naming(ValueError, key):
            render(p, rng=0, **{key: value})


@pytest.mark.parametrize("kw, name", [({"kernels": "fast"}, "kernels"), ({"spp": 0}, "spp"),
                                      ({"emitter_samples": 2000}, "emitter_samples"),
                                      ({"ris_candidates": 0}, "ris_candidates"), ({"workers": 0}, "workers"),
                                      ({"estimator": "nope"}, "estimator")])
def test_plan_checks_each_setting_naming_it(raises_naming, kw, name):
    args = {"spp": 4, **kw}
    with raises_naming(ValueError, name):
        plan("cornell_box", width=8, height=6, **args)


def test_gradient_domain_of_a_plan_equals_that_of_the_scene():
    p = plan("cornell_box", 4, "light", width=8, height=6)
    a = render_gradient_domain(p, rng=2)
    b = render_gradient_domain("cornell_box", 4, "light", width=8, height=6, rng=2)
    for x, y in ((a.primal, b.primal), (a.dx, b.dx), (a.dy, b.dy)):
        assert np.array_equal(x.value, y.value)


def test_cli_json_reports_the_plan_and_the_kernels(capsys, tmp_path):
    from vrlab.cli import main

    code = main(["render", "furnace", "--spp", "4", "--width", "6", "--height", "4", "--json", "--no-progress",
                 "--kernels", "numpy", "-o", str(tmp_path / "x.npy")])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["kernels"] == "numpy" and out["plan"].startswith("RenderPlan(film=6x4")
    assert "strategy='mis-power'" in out["plan"]


def test_the_light_bvh_walk_runs_compiled_with_the_same_image():
    """kernels="numba" (and "auto" where it gains) runs the compiled ray queries (vrlab.render.accel.traverse_kernel) and,
    where the render selects lights by the BVH, the compiled light-BVH walk
    (vrlab.distributions.light_bvh_kernel): many_lights' image equals the NumPy path's bit for bit
    (its oracle; its rays hit the same primitives at the same float32 points), whatever the
    worker count; kernels="numpy" imports no numba (test_kernels)."""
    pytest.importorskip("numba")
    kw = dict(light_selection="bvh", width=24, height=18, rng=1)
    a = render("many_lights", 4, kernels="numpy", **kw)
    b = render("many_lights", 4, kernels="numba", **kw)
    c = render("many_lights", 4, kernels="auto", workers=2, **kw)
    assert (a.extra["kernels"], b.extra["kernels"], c.extra["kernels"]) == ("numpy", "numba", "numba")
    assert np.array_equal(a.value, b.value) and np.array_equal(a.value, c.value)
    # cornell_box: rays tested all pairs, uniform selection, no compiled estimator: nothing to gain
    assert render("cornell_box", 2, kernels="auto", width=8, height=6, rng=0).extra["kernels"] == "numpy"


def test_auto_kernels_compile_only_what_gains():
    """kernels="auto": the compiled ray walk where the NumPy path culls many quadrics
    (many_lights' 128 spheres), not where it tests a small scene all pairs (cornell_box), and
    there numba is not even imported; kernels="numba" always compiles."""
    import subprocess
    import sys

    from vrlab.render.accel.choice import compiled_walk_pays
    from vrlab.render import builtin_scene_path, load_scene

    small, many = load_scene(builtin_scene_path("cornell_box")), load_scene(builtin_scene_path("many_lights"))
    assert not compiled_walk_pays(small) and compiled_walk_pays(many)
    assert plan(many, 2, width=8, height=6).kernels == NUMBA
    assert plan(small, 2, width=8, height=6, kernels="numba" if NUMBA == "numba" else "auto").kernels == NUMBA
    code = ("import sys, vrlab.render as R; p = R.plan('cornell_box', 2, width=8, height=6); "
            "print(p.kernels, 'numba' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["numpy", "False"], out
