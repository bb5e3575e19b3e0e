"""vrlab.testing.mitsuba: Mitsuba 3's render-test criterion, Mitsuba references with per-sample
variance, and vrlab judged by them on small (32x24) scenes.

The criterion is checked on synthetic images against its closed form (Sidak level, z threshold,
the 99.75 % rule, the variance floor); the reference's variance against the spread of two
independent references; vrlab against Mitsuba on three scenes (diffuse floor under a rectangle
and a sphere light; a GGX plate; a cube lit by a disk), and four deliberately wrong scenes must
fail: the camera moved by half a pixel, an emitter's radiance or the floor's reflectance off by
3 %.  Costs about 40 s on this 2-core machine at load 5 (other people's tests running), about
half of it in Mitsuba; ``VRLAB_RENDER_TEST_SAMPLES`` shrinks the two full agreement checks.
"""
from __future__ import annotations

import math
import subprocess
import sys
from statistics import NormalDist

import numpy as np
import pytest

from vrlab.testing.mitsuba import (DEFAULT_SAMPLES, SRGB_TO_XYZ, assert_agrees_with_mitsuba, mean_z_test,
                                   mitsuba_reference, render_test, rgb_to_xyz, sample_budget, xyz_stderr_bound)

W, H = 32, 24
FOV, DIST = 55.0, math.hypot(1.9, 3.2)          # floor scene: horizontal fov, camera-target distance
HALF_PIXEL = 0.5 * 2 * DIST * math.tan(math.radians(FOV / 2)) / W   # at the target, in scene units
MUTATION_SAMPLES = 2_000_000                     # fixed: the wrong scenes must fail at this budget

HEAD = """<scene version="3.0.0">
  <default name="ox" value="0"/><default name="L" value="8"/><default name="Ls" value="2, 3, 4"/>
  <default name="rho" value="0.2, 0.5, 0.8"/>
  <integrator type="direct"/>
  <sensor type="perspective">
    <float name="fov" value="{fov}"/>
    <transform name="to_world"><lookat origin="$ox, {origin}" target="$ox, {target}" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/>
      <rfilter type="box"/></film>
  </sensor>
  <shape type="rectangle"><transform name="to_world"><scale value="10"/><rotate x="1" angle="-90"/>{floor_shift}
    </transform><bsdf type="diffuse"><rgb name="reflectance" value="$rho"/></bsdf></shape>
"""
BLACK = '<bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>'


def _emitter(value: str) -> str:
    return f'{BLACK}<emitter type="area"><rgb name="radiance" value="{value}"/></emitter>'


# a rectangle light (back side seen: a black bar) and a sphere light seen directly
FLOOR_SCENE = HEAD.format(fov=FOV, origin="2.2, 3.2", target="0.3, 0", floor_shift="") + f"""
  <shape type="rectangle"><transform name="to_world"><scale x="0.5" y="0.3"/><rotate x="1" angle="90"/>
    <translate x="-0.4" y="1" z="0"/></transform>{_emitter("$L")}</shape>
  <shape type="sphere"><point name="center" x="0.7" y="0.5" z="0.2"/><float name="radius" value="0.25"/>
    {_emitter("$Ls")}</shape>
</scene>"""
CONDUCTOR_SCENE = HEAD.format(fov=50, origin="1.2, 3", target="0, 0", floor_shift='<translate y="-0.3"/>') + f"""
  <shape type="rectangle"><transform name="to_world"><scale value="1.5"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="roughconductor"><string name="distribution" value="ggx"/><float name="alpha" value="0.2"/>
      <string name="material" value="none"/><boolean name="sample_visible" value="false"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale x="0.6" y="0.4"/><rotate x="1" angle="105"/>
    <translate x="0" y="1.2" z="-1.2"/></transform>{_emitter("20")}</shape>
</scene>"""
CUBE_SCENE = HEAD.format(fov=50, origin="1.8, 3.4", target="0.3, 0", floor_shift="") + f"""
  <shape type="cube"><transform name="to_world"><scale value="0.35"/><rotate y="1" angle="30"/>
    <translate x="-0.2" y="0.35" z="0.1"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.6, 0.5"/></bsdf></shape>
  <shape type="disk"><transform name="to_world"><scale value="0.4"/><rotate x="1" angle="120"/>
    <translate x="0.6" y="1.3" z="0.8"/></transform>{_emitter("$L")}</shape>
</scene>"""


# ----------------------------------------------------------------------------- the criterion
def test_render_test_is_mitsubas_criterion():
    """Closed forms: alpha_s = 1 - 0.99^(1/768) (pixels, not pixel-channels), z threshold
    Phi^-1(1 - alpha_s/2), p = 2(1 - Phi(z)), z = |d| sqrt(spp / max(var, 1e-4)), and the image
    passes with 5 failing pixel-channels of 2304 (99.78 % >= 99.75 %) but not with 6."""
    rng = np.random.default_rng(1)
    ref = rng.uniform(0.2, 1.0, (H, W, 3))
    var = rng.uniform(0.01, 0.5, (H, W, 3))
    spp = 100
    ok = render_test(ref + rng.normal(0, np.sqrt(var / spp)), ref, var, spp)
    assert ok.passed and ok.n_entries == H * W * 3, ok
    a_s = 1 - 0.99 ** (1 / (H * W))
    assert ok.alpha_sidak == pytest.approx(a_s, rel=1e-9)
    assert ok.z_threshold == pytest.approx(-NormalDist().inv_cdf(a_s / 2), rel=1e-9)
    w = ok.worst[0]
    assert w.z == pytest.approx(abs(w.image - w.reference) * math.sqrt(spp / var[w.row, w.col, w.channel]))
    assert w.p_value == pytest.approx(2 * (1 - NormalDist().cdf(w.z)), rel=1e-6)
    assert w.z == pytest.approx(ok.z.max())
    for n_bad, passed in ((5, True), (6, False)):
        img = ref.copy()
        img.reshape(-1)[:n_bad] += 10 * np.sqrt(var.reshape(-1)[:n_bad] / spp)   # z = 10
        r = render_test(img, ref, var, spp)
        assert (r.passed, r.n_failed) == (passed, n_bad), r
    assert "FAILED" in str(r) and "(0, 0, 0) z=10" in str(r)
    # the variance floor: var = 0 and |d| = 1e-3 at 100 spp gives z = 1e-3 * 10 / 1e-2 = 1
    zero = np.zeros((H, W, 3))
    assert render_test(zero + 1e-3, zero, zero, spp).z == pytest.approx(1.0)
    assert render_test(zero + 1e-3, zero, zero, spp, var_floor=0).n_failed == zero.size


def test_mean_z_test_closed_form():
    """d = 0.02, per-pixel stderrs 0.1 and 0.05: z = d sqrt(P) / sqrt(0.1^2 + 0.05^2) = 4.96 (P = 768)."""
    ref = np.full((H, W, 3), 0.5)
    r = mean_z_test(ref + [0.02, 0.0, -0.002], np.full_like(ref, 0.1), ref, np.full_like(ref, 0.05))
    expect = np.array([0.02, 0.0, -0.002]) * math.sqrt(H * W) / math.hypot(0.1, 0.05)
    np.testing.assert_allclose(r.z, expect, rtol=1e-9)
    assert not r.passed and "FAILED" in str(r)
    assert mean_z_test(ref, ref * 0 + 0.1, ref, ref * 0 + 0.05).passed


def test_arguments_are_checked(raises_naming):
    a = np.zeros((H, W, 3))
    with raises_naming(ValueError, "image", "ref_mean", "ref_var"):
        render_test(np.zeros((H, W + 1, 3)), a, a, 4)
    with raises_naming(ValueError, "ref_var"):
        render_test(a, a, a - 1, 4)
    with raises_naming(ValueError, "image"):
        render_test(a + np.nan, a, a, 4)
    with raises_naming(TypeError, "spp"):
        render_test(a, a, a, 4.5)
    with raises_naming(ValueError, "alpha"):
        render_test(a, a, a, 4, alpha=1.0)
    with raises_naming(ValueError, "stderr"):
        mean_z_test(a, a - 1, a, a)
    with raises_naming(ValueError, "rgb"):
        rgb_to_xyz(np.zeros((4, 2)))
    with raises_naming(ValueError, "scene"):
        mitsuba_reference('<scene><integrator type="direct"/></scene>', 4)     # no version
    with raises_naming(TypeError, "scene"):
        mitsuba_reference(3, 4)
    with raises_naming(ValueError, "reference"):                       # a 2x2 reference for a 32x24 scene
        assert_agrees_with_mitsuba(FLOOR_SCENE, reference=(np.zeros((2, 2, 3)), np.zeros((2, 2, 3)), 16))
    with raises_naming(ValueError, "base"):
        assert_agrees_with_mitsuba(FLOOR_SCENE, base="/no/such/folder")


def test_lazy_export():
    """``vrlab.testing`` names the harness without importing it; the harness imports Mitsuba
    only to render."""
    code = ("import sys, vrlab.testing as t; a = 'vrlab.testing.mitsuba' in sys.modules; f = t.render_test; "
            "print(a, f.__module__, 'mitsuba' in sys.modules, 'render_test' in dir(t))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "vrlab.testing.mitsuba", "False", "True"], out


def test_sample_budget(monkeypatch, raises_naming):
    monkeypatch.delenv("VRLAB_RENDER_TEST_SAMPLES", raising=False)
    assert sample_budget() == DEFAULT_SAMPLES == 2_000_000 and sample_budget(1000) == 1000
    monkeypatch.setenv("VRLAB_RENDER_TEST_SAMPLES", "3e5")
    assert sample_budget() == 300_000 and sample_budget(1000) == 1000
    monkeypatch.setenv("VRLAB_RENDER_TEST_SAMPLES", "lots")
    with raises_naming(ValueError, "VRLAB_RENDER_TEST_SAMPLES"):
        sample_budget()


# ----------------------------------------------------------------------------- Mitsuba's side
@pytest.fixture(scope="module")
def mi():
    mitsuba = pytest.importorskip("mitsuba")
    return mitsuba


def test_colour_matrix_is_mitsubas(mi):
    mi.set_variant("scalar_rgb")
    cols = np.array([list(mi.srgb_to_xyz(mi.Color3f(*e))) for e in np.eye(3)])
    np.testing.assert_allclose(SRGB_TO_XYZ, cols.T, rtol=1e-6)
    np.testing.assert_allclose(xyz_stderr_bound([1.0, 0, 0]), cols[0], rtol=1e-6)


def test_reference_variance_is_per_sample(mi):
    """Two independent references (512 spp: two batches of 256 each): (m1 - m2) / sqrt((v1 +
    v2) / spp) has standard deviation 1 over the ~1300 pixel-channels with var > 1e-3 (0.9-1.1:
    +-3 of its own standard errors 1/sqrt(2n), n ~ 430 pixels, their channels correlated)."""
    spp = 512
    m1, v1 = mitsuba_reference(FLOOR_SCENE, spp, seed=0)
    m2, v2 = mitsuba_reference(FLOOR_SCENE, spp, seed=1)
    assert m1.shape == v1.shape == (H, W, 3) and np.all(v1 >= 0)
    sel = (v1 > 1e-3) & (v2 > 1e-3)
    z = (m1 - m2)[sel] / np.sqrt((v1 + v2)[sel] / spp)
    assert sel.sum() > 1000 and 0.9 < z.std() < 1.1, z.std()
    # the sphere light seen directly: every sample is its radiance (2, 3, 4), variance 0
    np.testing.assert_allclose(m1[10, 22], rgb_to_xyz([2.0, 3.0, 4.0]), rtol=1e-5)
    assert np.all(v1[10, 22] < 1e-3 * m1[10, 22] ** 2)


def test_moment_scene_and_relative_paths(mi, tmp_path, raises_naming):
    """A scene already using ``moment`` gives the same numbers; an obj file named relative to
    ``base`` is found (and missing without it)."""
    wrapped = FLOOR_SCENE.replace('<integrator type="direct"/>',
                                  '<integrator type="moment"><integrator type="direct" name="d"/></integrator>')
    a, b = mitsuba_reference(FLOOR_SCENE, 8, seed=3), mitsuba_reference(wrapped, 8, seed=3)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    (tmp_path / "quad.obj").write_text("v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 4 3 2\n")
    obj = FLOOR_SCENE.replace('<shape type="rectangle"><transform name="to_world"><scale value="10"/>'
                              '<rotate x="1" angle="-90"/>\n    </transform>',
                              '<shape type="obj"><string name="filename" value="quad.obj"/>'
                              '<transform name="to_world"><scale value="10"/></transform>')
    assert obj != FLOOR_SCENE
    with raises_naming(ValueError, "scene"):
        mitsuba_reference(obj, 4)
    agreement = assert_agrees_with_mitsuba(obj, base=tmp_path, samples=300_000)
    print(agreement)


# ----------------------------------------------------------------------------- vrlab vs Mitsuba
@pytest.fixture(scope="module")
def floor_reference(mi):
    spp = 4 * (MUTATION_SAMPLES // (W * H))
    return (*mitsuba_reference(FLOOR_SCENE, spp, seed=7), spp)


def test_floor_agrees(floor_reference):
    a = assert_agrees_with_mitsuba(FLOOR_SCENE, samples=MUTATION_SAMPLES, reference=floor_reference, rng=1)
    print(a)


@pytest.mark.parametrize("scene", [CONDUCTOR_SCENE, CUBE_SCENE], ids=["roughconductor", "cube-disk"])
def test_agrees_with_mitsuba(mi, scene):
    a = assert_agrees_with_mitsuba(scene, rng=2, seed=5)         # VRLAB_RENDER_TEST_SAMPLES or 2e6
    print(a)


@pytest.mark.parametrize("params,render_test_fails", [
    ({"ox": HALF_PIXEL}, True),                 # camera moved sideways by half a pixel
    ({"Ls": "2.06, 3.09, 4.12"}, True),         # the sphere light 3 % brighter (seen directly)
    ({"rho": "0.206, 0.515, 0.824"}, True),     # floor reflectance 3 % higher
    ({"L": 8 * 0.97}, False),                   # the rectangle light 3 % darker (seen only reflected)
], ids=["camera-half-pixel", "sphere-radiance", "reflectance", "rect-radiance"])
def test_wrong_scenes_fail(floor_reference, params, render_test_fails):
    """Against the unmodified scene's reference each wrong scene fails; all but the dimmed
    rectangle light (1.5 % of the image mean, caught by the mean test at ~15 sigma) fail
    Mitsuba's per-pixel criterion itself."""
    with pytest.raises(AssertionError) as info:
        assert_agrees_with_mitsuba(FLOOR_SCENE, samples=MUTATION_SAMPLES, reference=floor_reference, rng=1,
                                   params=params)
    print(info.value)
    assert ("render test FAILED" in str(info.value)) or not render_test_fails, str(info.value)
