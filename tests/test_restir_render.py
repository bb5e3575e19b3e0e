"""ReSTIR in the renderer (preset "restir", vrlab/render/reuse.py): per-pixel reservoirs of light
candidates with spatial reuse among the pixels of a block.  Pairwise and balance weights are
unbiased on the closed-form scene and against MIS references with occlusion, the naive 1/M
normalisation darkens a scene with occlusion, a dropped reconnection Jacobian or a target read
at the wrong pixel is caught, the image does not depend on the workers, and reuse lowers the
error of RIS at equal samples."""
from __future__ import annotations

import multiprocessing as mp
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from conftest import DroppedJacobian, WrongPixelTarget

from test_render import CENTRE_TOL, EMIT, FLOOR, RECT_LIGHT, bonferroni_z, exact_image, scene
from vrlab.estimators import RIS, ReSTIR
from vrlab.render import PRESETS, preset, render

SC = scene(FLOOR + RECT_LIGHT)
EXACT = exact_image("rectangle", SC)

# a 1 x 1 light 1.5 above the floor, a diffuse sphere under it: a shadow with a wide penumbra
LIGHT = f"""<shape type="rectangle">
    <transform name="to_world"><scale value="0.5"/><rotate x="1" angle="90"/>
      <translate x="0.3" y="1.5" z="0"/></transform>{EMIT}</shape>"""
BLOCKER = """<shape type="sphere"><point name="center" x="0" y="0.6" z="0"/><float name="radius" value="0.3"/>
  <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>"""
VIEW = dict(origin="0, 4, 2", target="0, 0, 0", up="0, 1, 0", fov=30, width=24, height=16)
OCCLUDED = scene(FLOOR + LIGHT + BLOCKER, **VIEW)
# the same with a checkerboard floor of about one pixel per square: neighbours' targets differ 19x
CHECKER_FLOOR = """<shape type="rectangle">
    <transform name="to_world"><scale value="10"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><texture type="checkerboard" name="reflectance">
      <rgb name="color0" value="0.05"/><rgb name="color1" value="0.95"/>
      <transform name="to_uv"><scale x="100" y="100"/></transform></texture></bsdf>
  </shape>"""
CHECKERED = scene(CHECKER_FLOOR + LIGHT + BLOCKER, **VIEW)


# DroppedJacobian (the reconnection's G_c / G_s left out) and WrongPixelTarget: tests/conftest.py


_REFS: dict = {}


def reference(sc, key: str):
    """A mis-power render with many samples: ``(value, stderr)`` green channel (cached)."""
    if key not in _REFS:
        ref = render(sc, 8192, "mis-power", rng=0)
        _REFS[key] = ref.value[..., 1].astype(float), ref.stderr[..., 1].astype(float)
    return _REFS[key]


def pixel_z(est, ref) -> np.ndarray:
    """Per-pixel z of a render against a reference, both standard errors (green channel)."""
    v, s = est.value[..., 1].astype(float), est.stderr[..., 1].astype(float)
    return (v - ref[0]) / np.sqrt(s**2 + ref[1] ** 2 + 1e-30)


def seeds_z(sc, est, ref, spp: int = 64, seeds: int = 6) -> float:
    """z of the image mean over independent seeds against the reference's: pixels of one seed
    are correlated (reuse), seeds are not, so the error of the mean is taken over seeds."""
    means = [render(sc, spp, est, rng=[11, s]).value[..., 1].astype(float).mean() for s in range(seeds)]
    se = np.std(means, ddof=1) / np.sqrt(seeds)
    return float((np.mean(means) - ref[0].mean()) / np.sqrt(se**2 + np.sum(ref[1] ** 2) / ref[1].size ** 2))


# ---------------------------------------------------------------------------------------
# unbiasedness
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("mis", ["pairwise", "balance"])
def test_closed_form_scene(mis):
    """Per-pixel z over spp (units of different sample indices are independent) and the image
    mean with its error bounded by the pixels' mean one (pixels of a unit are correlated)."""
    est = render(SC, 512, ReSTIR(8, 4, 3.0, 1, mis), rng=3)
    img, se = est.value.astype(float), est.stderr.astype(float)
    se = np.sqrt(se**2 + (CENTRE_TOL * EXACT) ** 2)
    z = (img - EXACT) / se
    assert np.max(np.abs(z)) < bonferroni_z(EXACT.size), z
    assert abs((img[..., 1].mean() - EXACT[..., 1].mean()) / se[..., 1].mean()) < 4


@pytest.mark.parametrize("mis", ["pairwise", "balance"])
def test_unbiased_with_occlusion_against_mis(mis):
    ref = reference(OCCLUDED, "occluded")
    z = pixel_z(render(OCCLUDED, 512, ReSTIR(8, 4, 3.0, 1, mis), rng=1), ref)
    assert np.max(np.abs(z)) < bonferroni_z(z.size), np.max(np.abs(z))
    assert abs(seeds_z(OCCLUDED, ReSTIR(8, 4, 3.0, 1, mis), ref)) < 4


def test_one_over_m_is_biased_by_occlusion():
    """Neighbours in shadow bring no sample where the receiving pixel sees the light, yet 1/M
    counts their M: the penumbra darkens (measured: image mean -12 %, z about -40 over seeds)."""
    ref = reference(OCCLUDED, "occluded")
    z = seeds_z(OCCLUDED, ReSTIR(8, 4, 3.0, 1, "1/M"), ref)
    assert z < -6, z


# ---------------------------------------------------------------------------------------
# mutations that must fail
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("mis", ["pairwise", "balance"])
def test_a_dropped_jacobian_is_caught(mis):
    """The light is close to the floor relative to the view: G_c / G_s of neighbours within 3
    pixels is far from 1, and without it pixels are off by many standard errors (measured max
    |z| 16 pairwise, 21 balance at 1024 spp; the correct estimator 3.6)."""
    ref = reference(OCCLUDED, "occluded")
    z = pixel_z(render(OCCLUDED, 1024, DroppedJacobian(8, 4, 3.0, 1, mis), rng=1), ref)
    assert np.max(np.abs(z)) > 10, np.max(np.abs(z))


@pytest.mark.parametrize("mis", ["pairwise", "balance"])
def test_a_target_read_at_the_wrong_pixel_is_caught(mis):
    """A checkerboard floor: the receiving pixel's target is unbiased, the neighbour's brightens
    every pixel a little (the bias is spread, not local: measured mean per-pixel z 1.74
    pairwise, 0.74 balance, against -0.01 and -0.003 for the correct weights; max |z| 4.6 and
    5.8 against 3.5)."""
    ref = reference(CHECKERED, "checkered")
    good = pixel_z(render(CHECKERED, 1024, ReSTIR(8, 4, 3.0, 1, mis), rng=1), ref)
    bad = pixel_z(render(CHECKERED, 1024, WrongPixelTarget(8, 4, 3.0, 1, mis), rng=1), ref)
    assert np.max(np.abs(good)) < bonferroni_z(good.size) and abs(good.mean()) < 0.3, (np.abs(good).max(), good.mean())
    assert bad.mean() > 0.5, bad.mean()


# ---------------------------------------------------------------------------------------
# determinism, variance, protocol
# ---------------------------------------------------------------------------------------
def test_bit_identical_for_workers_and_executors():
    sc = scene(FLOOR + LIGHT + BLOCKER, **{**VIEW, "width": 48, "height": 30})        # 1440 pixels: 2 tiles
    est = ReSTIR(4, 3, 2.0, 1, "balance")
    one = render(sc, 4, est, rng=9)
    two = render(sc, 4, est, rng=9, workers=2)
    np.testing.assert_array_equal(one.value, two.value)
    np.testing.assert_array_equal(one.stderr, two.stderr)
    with ProcessPoolExecutor(2, mp_context=mp.get_context("spawn")) as pool:
        spawned = render(sc, 4, est, rng=9, executor=pool, workers=2)
    np.testing.assert_array_equal(one.value, spawned.value)


def test_reuse_lowers_the_error_of_ris_on_many_lights():
    """At equal spp, with the same 16 candidates, spatial reuse has a lower per-pixel relative
    variance than RIS on the many-lights scene: median over pixels of stderr^2 / value^2
    (the median: pixels that see a light have the variance of their emitted light in both)
    measured 0.029 against 0.078."""
    kw = dict(rng=2, width=48, height=36)
    ris = render("many_lights", 8, RIS("light", target="unshadowed", m=16), **kw)
    restir = render("many_lights", 8, ReSTIR(16, 5, 3.0, 1, "pairwise"), **kw)
    scale = np.maximum((ris.value.astype(float) + restir.value.astype(float)) / 2, 1e-3) ** 2
    rel = [float(np.median(e.stderr.astype(float) ** 2 / scale)) for e in (ris, restir)]
    assert rel[1] < 0.6 * rel[0], rel


def test_preset_and_refusals(raises_naming):
    assert "restir" in PRESETS
    est, units = preset("restir", ris_candidates=12)
    assert est.candidates == 12 and est.mis == "pairwise" and units == 1
    a = render(SC, 4, "restir", rng=5, ris_candidates=12)
    b = render(SC, 4, ReSTIR(12, 5, 3.0, 1, "pairwise"), rng=5)
    np.testing.assert_array_equal(a.value, b.value)
    with raises_naming(ValueError, "source"):
        render(SC, 4, ReSTIR(4, 2, source="bsdf"))
    with raises_naming(ValueError, "target"):
        render(SC, 4, ReSTIR(4, 2, target="|f|"))
    with raises_naming(ValueError, "units"):
        render(SC, 4, ReSTIR(4, 2), units=2)
    mirror = scene(FLOOR.replace('<bsdf type="diffuse">', '<bsdf type="conductor"><!--').replace(
        "</bsdf>", "--></bsdf>") + RECT_LIGHT)
    with raises_naming(ValueError, "estimator"):                  # a delta lobe: light points never reach it
        render(mirror, 4, ReSTIR(4, 2))
