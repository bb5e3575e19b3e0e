"""Mitsuba 3's reflectance models in vrlab (issue 22): values, samples and images against
Mitsuba 3 ``scalar_rgb`` through its Python API, and the delta lobes in the estimators.

Values: ``eval`` (f |cos|), ``pdf`` and ``sample`` (same uniforms -> same direction, weight and
pdf) on random direction pairs, vrlab's ``wo`` = Mitsuba's ``si.wi``
(:mod:`vrlab.testing.mitsuba_bsdf`).  Images: a scene per family rendered by both and judged by
Mitsuba's render-test criterion plus an image-mean z-test
(:func:`vrlab.testing.mitsuba.assert_agrees_with_mitsuba`).
"""
import numpy as np
import pytest

pytest.importorskip("mitsuba")

from test_mitsuba_elements import EMITTERS, SHAPES, _envmap_file, scene  # noqa: E402
from vrlab.render import load_scene, render  # noqa: E402
from vrlab.render.bsdfs.conductor import Conductor  # noqa: E402
from vrlab.testing.mitsuba import assert_agrees_with_mitsuba  # noqa: E402
from vrlab.testing.mitsuba_bsdf import bsdf_eval_pdf, bsdf_sample, mitsuba_bsdf  # noqa: E402

N = 400


def directions(n: int, seed: int, upper: bool = True) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    if upper:
        v[:, 2] = np.abs(v[:, 2]) + 1e-3
        v /= np.linalg.norm(v, axis=-1, keepdims=True)
    return v


def assert_close(a, b, rtol=1e-4, atol=1e-6, what=""):
    a, b = np.asarray(a, float), np.asarray(b, float)
    bad = ~(np.abs(a - b) <= atol + rtol * np.abs(b))
    assert not bad.any(), f"{what}: {int(bad.sum())} of {bad.size} differ, e.g. {a[bad][:3]} vs {b[bad][:3]}"


# ------------------------------------------------------------------ conductor (smooth)
CONDUCTORS = {"none": {}, "Au": {"material": "Au"}, "Cu": {"material": "Cu"},
              "eta-k": {"eta": 1.2, "k": 3.4, "specular_reflectance": 0.8}}


@pytest.mark.parametrize("name", sorted(CONDUCTORS))
def test_conductor_samples_equal_mitsubas(name):
    kw = CONDUCTORS[name]
    ours = Conductor(**kw)
    theirs = mitsuba_bsdf({"type": "conductor", **kw})
    wo, u = directions(N, 1), np.random.default_rng(2).random((N, 2))
    r = bsdf_sample(theirs, wo, u[:, 0], u)
    wi, weight, pdf = ours.sample(wo, u)
    assert_close(wi, r.wi, 0, 1e-6, "wi")
    assert_close(weight, r.weight, 1e-5, 1e-7, "weight")
    assert_close(pdf, r.pdf, 0, 0, "pdf")
    ev, p = bsdf_eval_pdf(theirs, wo, directions(N, 3))         # a delta lobe: 0 off its direction
    assert np.all(ev == 0) and np.all(p == 0)
    assert np.all(ours.eval(wo, directions(N, 3)) == 0) and np.all(ours.pdf(wo, directions(N, 3)) == 0)


def test_conductor_from_the_back_reflects_nothing():
    wi, weight, pdf = Conductor(material="Au").sample(-directions(10, 4), np.full((10, 2), 0.5))
    assert np.all(weight == 0)


def test_conductor_parameters_are_checked(raises_naming):
    with raises_naming(ValueError, "material"):
        Conductor(material="Au", eta=1.0)
    with raises_naming(ValueError, "material"):
        Conductor(material="Unobtainium")
    with raises_naming(ValueError, "eta"):
        Conductor(eta=-1.0)


# ------------------------------------------------------------------ images
MIRROR_BALL = ('<shape type="sphere"><point name="center" value="-0.3, 0.5, 0"/><float name="radius" value="0.5"/>'
               '<bsdf type="conductor"><string name="material" value="Au"/></bsdf></shape>')


@pytest.mark.parametrize("estimator", ["mis-power", "mis-optimal"])
def test_mirror_ball_agrees_with_mitsuba(tmp_path, estimator):
    env = _envmap_file(tmp_path)
    assert_agrees_with_mitsuba(scene(MIRROR_BALL + f'<emitter type="envmap"><string name="filename" value="{env}"/>'
                                     '</emitter>'), estimator=estimator)


def test_mirror_ball_by_bsdf_sampling_agrees_with_mitsuba():
    """BSDF sampling alone (the mirror's atom has probability 1) under a constant sky: the
    envmap's small sun would give the floor's pixels too heavy a tail for a per-pixel z-test."""
    assert_agrees_with_mitsuba(scene(MIRROR_BALL + EMITTERS["constant"], lights=False), estimator="bsdf")


def test_estimators_that_cannot_reach_a_mirror_are_refused(raises_naming):
    sc = load_scene(scene(MIRROR_BALL))
    for est in ("light", "cosine"):
        with raises_naming(ValueError, "estimator", "conductor"):
            render(sc, 1, est, width=4, height=3)
