"""``light_selection="bvh"`` (vrlab.render.light_tree): pbrt-v4's light BVH picks the light per
shading point; renders stay unbiased against uniform selection, P_j at a point sums to 1,
and the density of a sample is the density ``pdf`` reports (needed by MIS)."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import vrlab
from conftest import render_pair, run_cli
from test_render import EMIT, FLOOR, RECT_LIGHT, SPHERE_LIGHT, bonferroni_z, scene
from vrlab.render.direct import DirectLighting

# rectangle lights facing down, one tilted to face away from half the floor, and a disk
RECTS = RECT_LIGHT + f"""<shape type="rectangle">
    <transform name="to_world"><scale x="0.2" y="0.5"/><rotate x="1" angle="90"/><rotate z="1" angle="60"/>
      <translate x="-0.6" y="0.8" z="-0.3"/></transform>{EMIT}</shape>
  <shape type="disk"><transform name="to_world"><scale value="0.15"/><rotate x="1" angle="90"/>
      <translate x="0.5" y="0.6" z="0.4"/></transform>{EMIT}</shape>"""
ENV = '<emitter type="constant"><rgb name="radiance" value="0.2"/></emitter>'


def _z(a, b):
    """Per-pixel z of two renders; pixels with no variance in either (the black sky) must agree."""
    (ia, sa), (ib, sb) = a, b
    d, s = ia.astype(float) - ib, np.sqrt(sa.astype(float) ** 2 + sb.astype(float) ** 2)
    return np.where(s > 0, d / np.where(s > 0, s, 1.0), np.where(d == 0, 0.0, np.inf))


def _mean_z(a, b):
    """z of the image means (green channel: the channels of a pixel are correlated, its pixels
    are not), each mean's standard error from its pixels'."""
    (ia, sa), (ib, sb) = (tuple(x[..., 1] for x in r) for r in (a, b))
    n = ia.size
    se = np.sqrt((sa.astype(float) ** 2).sum() + (sb.astype(float) ** 2).sum()) / n
    return (ia.astype(float).mean() - ib.astype(float).mean()) / se


@pytest.mark.parametrize("strategy", ["light", "mis-power"])
def test_many_lights_bvh_is_unbiased_against_uniform(strategy):
    kw = dict(width=12, height=9)
    bvh = render_pair("many_lights", 64, strategy, rng=1, light_selection="bvh", **kw)
    uni = render_pair("many_lights", 256, strategy, rng=2, light_selection="uniform", **kw)
    z = _z(bvh, uni)
    assert np.max(np.abs(z)) < bonferroni_z(z.size)
    assert abs(_mean_z(bvh, uni)) < 4


@pytest.mark.parametrize("strategy", ["light", "mis-power"])
@pytest.mark.parametrize("extra", ["", ENV], ids=["rectangles", "rectangles+environment"])
def test_rectangle_lights_bvh_is_unbiased_against_uniform(strategy, extra):
    _assert_bvh_agrees_with_uniform(RECTS + extra, strategy, 256, seeds=(3, 4))


def _assert_bvh_agrees_with_uniform(lights_xml: str, strategy: str, spp: int, seeds: tuple) -> None:
    """The floor lit by ``lights_xml`` and a small sphere light, seen from above: bvh and
    uniform selection agree per pixel (Bonferroni) and in the image mean."""
    sc = scene(FLOOR + lights_xml + SPHERE_LIGHT.replace('value="0.3"', 'value="0.1"'),
               origin="0, 2.5, 0.01", fov=70, width=10, height=8)
    bvh = render_pair(sc, spp, strategy, rng=seeds[0], light_selection="bvh")
    uni = render_pair(sc, 256, strategy, rng=seeds[1], light_selection="uniform")
    z = _z(bvh, uni)
    assert np.max(np.abs(z)) < bonferroni_z(z.size)
    assert abs(_mean_z(bvh, uni)) < 4


def _lights(extra=""):
    sc = scene(FLOOR + RECTS + SPHERE_LIGHT + extra)
    return DirectLighting(sc, "bvh").lights


def _floor_points(m, seed):
    g = np.random.default_rng(seed)
    p = np.column_stack([g.uniform(-2, 2, m), np.zeros(m), g.uniform(-2, 2, m)])
    return p, np.tile([0.0, 1.0, 0.0], (m, 1))


@pytest.mark.parametrize("extra", ["", ENV])
def test_selection_probabilities_sum_to_at_most_one_and_match_samples(extra):
    lights = _lights(extra)
    assert lights.tree is not None and (len(lights.tree.infinite) == 1) == bool(extra)
    p, n = _floor_points(200, 0)
    L = len(lights)
    table = np.stack([lights.selection_pmf(p, np.full(len(p), j), n) for j in range(L)], 1)
    assert np.all(table.sum(1) <= 1 + 1e-12) and np.mean(np.abs(table.sum(1) - 1) < 1e-12) > 0.5
    if extra:                                     # pbrt's mix: the environment gets 1 / (1 + 1)
        np.testing.assert_allclose(table[:, lights.tree.infinite[0]], 0.5)
    u3 = np.random.default_rng(1).random((len(p), 3))
    j, w, pdf, front, y, le = lights.sample(p, u3, n)
    ok = j >= 0
    assert ok.mean() > 0.5 and np.all(pdf[~ok] == 0) and not front[~ok].any()
    # the density of each sample is the one pdf() reports for it (MIS needs both to agree)
    back = lights.pdf(p[ok], w[ok], j[ok], None, n[ok])
    np.testing.assert_allclose(back, pdf[ok], rtol=1e-6)


def test_a_light_facing_away_is_never_selected_there():
    """Points above the plane of the tilted rectangle, behind it, cannot see it: P = 0."""
    lights = _lights()
    p, n = _floor_points(400, 2)
    j = np.random.default_rng(3).integers(0, len(lights), len(p))
    pmf = lights.selection_pmf(p, j, n)
    u = np.random.default_rng(4).random((len(p), 3))
    js, *_ = lights.sample(p, u, n)
    # a sample's light always has P > 0 at its point
    has = js >= 0
    assert np.all(lights.selection_pmf(p[has], js[has], n[has]) > 0)
    assert np.all(pmf >= 0)


def test_cli_accepts_light_selection_bvh(tmp_path, capsys):
    out = tmp_path / "img.npy"
    code, _, err = run_cli(capsys, ["render", "many_lights", "--spp", "2", "--width", "8", "--height", "6",
                                    "--light-selection", "bvh", "-o", str(out)])
    assert code == 0, err
    assert np.load(out).shape == (6, 8, 3)
    code, _, err = run_cli(capsys, ["render", "many_lights", "--light-selection", "tree", "-o", str(out)])
    assert code == 2 and "bvh" in err


# three spots over the floor, one tilted: pbrt-v4's cone bounds (theta_o = beam, theta_e =
# cutoff - beam) must keep every point of the falloff ramp selectable
SPOTS = "".join(f"""<emitter type="spot"><rgb name="intensity" value="{i}"/>
    <float name="cutoff_angle" value="{cut}"/><float name="beam_width" value="{beam}"/>
    <transform name="to_world"><lookat origin="{o}" target="{t}" up="0, 0, 1"/></transform></emitter>"""
                for i, cut, beam, o, t in [(3, 30, 15, "0.5, 1, 0.2", "0.4, 0, 0.3"),
                                           (2, 25, 25, "-0.6, 0.8, -0.4", "-0.5, 0, -0.5"),
                                           (4, 40, 10, "0, 0.7, 0.8", "0.8, 0, 0.1")])


def _spot_angles(lights, p):
    """(spot light indices, angle from each spot's axis to every point (m, k), cutoffs (k,))."""
    ids = [j for j in range(len(lights)) if getattr(getattr(lights.lights[j], "emitter", None), "type", "") == "spot"]
    ems = [lights.lights[j].emitter for j in ids]
    unit = [(p - e.position) / np.linalg.norm(p - e.position, axis=1)[:, None] for e in ems]
    ang = np.stack([np.arccos(np.clip(u @ e.emission_cone()[0], -1, 1)) for u, e in zip(unit, ems)], 1)
    return ids, ang, np.array([e._cut for e in ems])


def test_spot_cones_select_exactly_where_the_spot_shines():
    """P(spot | p) > 0 wherever the spot's falloff is positive (angle < cutoff, the ramp
    included) and 0 beyond; the probabilities still sum to 1."""
    lights = _lights(SPOTS)
    p, n = _floor_points(3000, 5)
    ids, ang, cut = _spot_angles(lights, p)
    assert len(ids) == 3
    for k, j in enumerate(ids):
        pmf = lights.selection_pmf(p, np.full(len(p), j), n)
        inside, outside = ang[:, k] < cut[k] - 1e-6, ang[:, k] > cut[k] + 1e-6
        assert inside.sum() > 20 and outside.sum() > 20
        assert np.all(pmf[inside] > 0) and np.all(pmf[outside] == 0)
    table = np.stack([lights.selection_pmf(p, np.full(len(p), j), n) for j in range(len(lights))], 1)
    assert np.all(table.sum(1) <= 1 + 1e-12) and np.mean(np.abs(table.sum(1) - 1) < 1e-12) > 0.5


def test_a_spot_cone_without_its_ramp_fails(monkeypatch):
    """Mutation: theta_e = 0 (the cone ends at the beam width) starves the ramp."""
    from vrlab.render.emitters.spot import SpotLight

    real = SpotLight.emission_cone
    monkeypatch.setattr(SpotLight, "emission_cone", lambda self: (real(self)[0], real(self)[1], 1.0 - 1e-12))
    with pytest.raises(AssertionError):
        test_spot_cones_select_exactly_where_the_spot_shines()


def test_a_sheared_spot_bounds_every_direction():
    from vrlab.render.emitters.spot import SpotLight

    m = np.eye(4)
    m[0, 0] = 2.0
    assert SpotLight(to_world=m).emission_cone() is None
    w, cos_o, cos_e = SpotLight(to_world=np.diag([3.0, 3.0, -3.0, 1.0]), cutoff_angle=30, beam_width=10).emission_cone()
    np.testing.assert_allclose(w, [0, 0, -1])
    np.testing.assert_allclose([cos_o, cos_e], np.cos(np.deg2rad([10, 20])), atol=1e-6)


@pytest.mark.parametrize("strategy", ["light", "mis-power"])
def test_spot_lights_bvh_is_unbiased_against_uniform(strategy):
    _assert_bvh_agrees_with_uniform(SPOTS, strategy, 128, seeds=(5, 6))


# -- lighting code asks every element through its protocol (issue 34, part 4.3) ------------------
LIGHTING = ("render/light_tree.py", "render/direct.py", "render/light_set.py", "render/lights.py",
            "render/emitters/area.py")
#: hasattr(x, ...) or getattr(x, "name", default): a probe of what an element is
_PROBE = re.compile(r"\bhasattr\(|\bgetattr\([^,()]+,\s*[\"'][a-z_]+[\"']\s*,")


def _probes(text: str) -> list[str]:
    return [line.strip() for line in text.splitlines() if _PROBE.search(line)]


def test_lighting_code_asks_elements_instead_of_probing_them():
    """No hasattr / getattr-with-default in the lighting code: every emitter and shape answers
    (light_bounds, emission_cone, is_delta, is_infinite, corners, barycentrics, has_barycentrics
    have defaults on the base classes), and the scan finds a probe where there is one."""
    from vrlab.render.emitters import Emitter
    from vrlab.render.registry import registered
    from vrlab.render.shapes import Shape

    root = Path(vrlab.__file__).parent
    found = {f: _probes((root / f).read_text()) for f in LIGHTING}
    assert not any(found.values()), found
    assert _probes('if getattr(l, "is_delta", False):') and _probes("ok = hasattr(s, 'corners')")
    for name, cls in registered("emitter").items():
        assert issubclass(cls, Emitter) and callable(cls.light_bounds) and callable(cls.emission_cone), name
    for name, cls in registered("shape").items():
        assert issubclass(cls, Shape) and callable(cls.corners) and isinstance(cls.has_barycentrics, bool), name


def test_elements_answer_the_light_bvh_and_the_shading_points():
    """The answers the lighting code reads: a point light its position (a box of size 0) and every
    direction, an area emitter no bounds of its own; a rectangle its 4 corners, a sphere none;
    only meshes give barycentrics."""
    from vrlab.render.emitters.area import AreaEmitter
    from vrlab.render.emitters.point import PointLight
    from vrlab.render.shapes.rectangle import Rectangle
    from vrlab.render.shapes.sphere import Sphere

    lo, hi, w, cos_o, cos_e = PointLight(position=(1.0, 2.0, 3.0)).light_bounds()
    assert np.array_equal(lo, [1, 2, 3]) and np.array_equal(hi, lo) and cos_o == -1.0
    assert AreaEmitter(1.0).light_bounds() is None
    assert Rectangle().corners().shape == (4, 3) and Sphere().corners() is None
    assert not Rectangle().has_barycentrics and Rectangle().barycentrics(np.zeros((1, 3)), np.zeros(1, int)) is None
