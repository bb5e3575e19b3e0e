"""The element registry and Mitsuba 3's scene-file conventions: registered classes, a user's own
element used from XML, include/path/ref/default, integrators, sensors (checked against
Mitsuba 3's own ``Sensor.sample_ray``), films, samplers and the cylinder shape (against
Mitsuba's ``Scene.ray_intersect``)."""
from __future__ import annotations

import numpy as np
import pytest

from vrlab.render import SceneError, load_scene, register, registered, render
from vrlab.render.bsdfs import Diffuse
from vrlab.render.registry import KINDS
from vrlab.render.shapes import Shape

mi = pytest.importorskip("mitsuba")
mi.set_variant("scalar_rgb")

SENSOR = """<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
  <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
  <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="12"/>
  <rfilter type="box"/></film></sensor>"""
LIGHT = """<shape type="rectangle"><transform name="to_world"><scale value="3"/></transform>
  <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
  <shape type="sphere"><point name="center" value="0, 0, 2"/><float name="radius" value="0.3"/>
  <emitter type="area"><rgb name="radiance" value="4"/></emitter></shape>"""


def scene_xml(body: str = LIGHT, sensor: str = SENSOR, integrator: str = '<integrator type="direct"/>',
              version: str = "3.0.0") -> str:
    return f'<scene version="{version}">{integrator}{sensor}{body}</scene>'


def test_every_kind_has_registered_elements_and_each_class_its_kind():
    for kind in KINDS:
        table = registered(kind)
        assert table, kind
        for name, cls in table.items():
            assert cls.kind == kind and cls.plugin_name == name, (kind, name)
    assert {"rectangle", "disk", "sphere", "cube", "obj", "cylinder"} <= set(registered("shape"))
    assert {"box", "tent", "gaussian"} <= set(registered("rfilter"))
    registered("shape")["mine"] = None                       # a copy: the registry is untouched
    assert "mine" not in registered("shape")


def test_the_scene_documentation_lists_every_registered_element():
    import vrlab.render.scene as doc

    for kind in KINDS:
        for name, cls in registered(kind).items():
            if not cls.__module__.startswith("vrlab.render.") or kind == "film":
                continue                                   # users' own elements (other tests) and hdrfilm
            assert f"``{name}``" in doc.__doc__, (kind, name)


def test_a_users_own_bsdf_loads_from_xml_and_renders():
    @register("bsdf", "test_halfdiffuse")
    class HalfDiffuse(Diffuse):
        """Half the reflectance of a diffuse BSDF (a user's element)."""

        @classmethod
        def from_props(cls, p):
            return cls(reflectance=0.5 * p.color("albedo", 1.0))

    body = LIGHT.replace('<bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>',
                         '<bsdf type="test_halfdiffuse"><rgb name="albedo" value="1.0"/></bsdf>')
    mine, ref = load_scene(scene_xml(body)), load_scene(scene_xml())
    assert isinstance(mine.shapes[0].bsdf, HalfDiffuse)
    a, b = render(mine, 4, rng=3), render(ref, 4, rng=3)
    np.testing.assert_allclose(a.value, b.value, rtol=1e-6)          # reflectance 0.5 both ways
    with pytest.raises(SceneError, match="unknown parameter 'reflectance'"):
        load_scene(scene_xml(LIGHT.replace('type="diffuse"', 'type="test_halfdiffuse"')))


def test_a_users_own_shape_with_its_own_intersection():
    from vrlab.render.shapes import CustomPart

    @register("shape", "test_slab")
    class Slab(Shape):
        """The plane z = height, hit from both sides (a user's element)."""

        def __init__(self, *, height=0.0, **common):
            super().__init__(**common)
            self.height = float(height)

        @classmethod
        def from_props(cls, p):
            return cls(height=p.float("height", 0.0), **cls.common(p))

        def parts(self):
            def intersect(o, d, t_min):
                with np.errstate(divide="ignore", invalid="ignore"):
                    t = (self.height - o[:, 2]) / d[:, 2]
                t = np.where(np.isfinite(t) & (t > t_min), t, np.inf)
                return t, np.broadcast_to([0.0, 0.0, 1.0], o.shape)
            return [CustomPart(intersect)]

        @property
        def area(self):
            return np.inf

    body = LIGHT.replace('<shape type="rectangle"><transform name="to_world"><scale value="3"/></transform>',
                         '<shape type="test_slab"><float name="height" value="0"/>')
    slab = render(load_scene(scene_xml(body)), 16, rng=1).value
    rect = render(load_scene(scene_xml()), 16, rng=1).value
    np.testing.assert_allclose(slab, rect, rtol=1e-4, atol=1e-6)   # the rectangle fills the view


def test_version_2_include_path_default_and_refs(tmp_path):
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "light.xml").write_text(
        '<scene version="2.1.0"><shape type="sphere"><point name="center" value="0, 0, 2"/>'
        '<float name="radius" value="$r"/><emitter type="area"><rgb name="radiance" value="4"/></emitter>'
        '</shape></scene>')
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "quad.obj").write_text("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n")
    body = ('<default name="r" value="0.3"/><default name="integrator" value="direct"/>'
            '<path value="meshes"/><include filename="parts/light.xml"/>'
            '<texture type="checkerboard" id="unused_texture_is_fine"/>' if "checkerboard" in registered("texture")
            else '<default name="r" value="0.3"/><default name="integrator" value="direct"/>'
                 '<path value="meshes"/><include filename="parts/light.xml"/>')
    body += ('<bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.5"/></bsdf>'
             '<shape type="obj"><string name="filename" value="quad.obj"/><ref id="grey"/></shape>')
    (tmp_path / "scene.xml").write_text(scene_xml(body, integrator='<integrator type="$integrator"/>',
                                                  version="2.0.0"))
    sc = load_scene(tmp_path / "scene.xml")
    assert [s.type for s in sc.shapes] == ["sphere", "obj"]
    assert sc.shapes[0].sphere()[1] == pytest.approx(0.3)
    assert sc.files[:2] == [tmp_path / "parts" / "light.xml", tmp_path / "meshes" / "quad.obj"]
    assert load_scene(tmp_path / "scene.xml", {"r": 0.5}).shapes[0].sphere()[1] == pytest.approx(0.5)
    (tmp_path / "loop.xml").write_text(scene_xml('<include filename="loop.xml"/>'))
    with pytest.raises(SceneError, match="includes itself"):
        load_scene(tmp_path / "loop.xml")


def test_named_refs_share_one_object():
    body = ('<bsdf type="diffuse" id="a"><rgb name="reflectance" value="0.2"/></bsdf>'
            '<shape type="rectangle"><ref id="a"/></shape><shape type="disk"><ref name="bsdf" id="a"/></shape>'
            '<shape type="cube"><bsdf type="twosided"><ref id="a"/></bsdf></shape>')
    sc = load_scene(scene_xml(body + LIGHT))            # a named ref is found by its kind, as in Mitsuba
    assert sc.shapes[0].bsdf is sc.shapes[1].bsdf is sc.shapes[2].bsdf.inner


@pytest.mark.parametrize("integrator, shading", [
    ('<integrator type="moment"><integrator type="direct"/></integrator>', True),
    ('<integrator type="path"><integer name="max_depth" value="2"/></integrator>', True),
    ('<integrator type="volpath"><integer name="max_depth" value="2"/></integrator>', True),
    ('<integrator type="moment"><integrator type="path"><integer name="max_depth" value="1"/>'
     '</integrator></integrator>', False)])
def test_integrators_render_what_they_are(integrator, shading):
    sc = load_scene(scene_xml(integrator=integrator))
    assert sc.integrator.shading is shading
    img = render(sc, 2, rng=0).value
    floor = img[0, 0]                                    # a corner pixel sees the lit floor only
    assert bool(floor.max() > 0) is shading
    assert img.max() == pytest.approx(4.0, rel=1e-5)     # the light seen directly


def test_hide_emitters():
    sc = load_scene(scene_xml(integrator='<integrator type="direct"><boolean name="hide_emitters" '
                                         'value="true"/></integrator>'))
    img = render(sc, 4, rng=0).value
    assert img.max() < 1.0                                # the light (4) is hidden; the floor is lit
    assert img[0, 0].max() > 0


# ----------------------------------------------------------------------------- sensors
def _film_positions(rng):
    return np.concatenate([rng.random((40, 2)), [[0, 0], [1, 1], [0.5, 0.5], [0, 1]]])


@pytest.mark.parametrize("sensor", [
    '<float name="fov" value="40"/>',
    '<float name="fov" value="30"/><string name="fov_axis" value="y"/>',
    '<float name="fov" value="50"/><string name="fov_axis" value="diagonal"/>',
    '<string name="focal_length" value="35mm"/>',
    '',                                                             # Mitsuba's 50 mm
    '<float name="fov" value="40"/><float name="principal_point_offset_x" value="0.1"/>'
    '<float name="principal_point_offset_y" value="-0.05"/><float name="near_clip" value="0.5"/>',
])
@pytest.mark.parametrize("crop", ["", '<integer name="crop_offset_x" value="3"/><integer name="crop_width" value="9"/>'
                                      '<integer name="crop_offset_y" value="2"/><integer name="crop_height" value="7"/>'])
@pytest.mark.parametrize("kind", ["perspective", "orthographic"])
def test_camera_rays_match_mitsuba(sensor, crop, kind):
    if kind == "orthographic":
        if "fov" in sensor or "focal" in sensor:
            pytest.skip("orthographic cameras have no field of view")
        sensor = sensor + '<transform name="to_world"><scale x="2" y="2"/><rotate y="1" angle="20"/>' \
                          '<translate x="0.3"/></transform>'
    else:
        sensor += '<transform name="to_world"><lookat origin="1, 2, 5" target="0, 0.5, 0" up="0, 1, 0"/></transform>'
    xml = scene_xml(sensor=f'<sensor type="{kind}">{sensor}<film type="hdrfilm"><integer name="width" value="20"/>'
                           f'<integer name="height" value="15"/>{crop}<rfilter type="box"/></film></sensor>')
    ours = load_scene(xml).sensor
    theirs = mi.load_string(xml).sensors()[0]
    crop_size = np.array([ours.width, ours.height])
    for s in _film_positions(np.random.default_rng(5)):
        ray, _ = theirs.sample_ray(0.0, 0.5, mi.Point2f(*s), mi.Point2f(0.5, 0.5))
        film = np.array([ours.film.crop_offset_x, ours.film.crop_offset_y]) + s * crop_size
        o, d = ours.rays(film[None])
        np.testing.assert_allclose(d[0], np.array(ray.d), atol=2e-6)
        np.testing.assert_allclose(o[0], np.array(ray.o), atol=2e-6 * (1 + np.abs(o).max()))


@pytest.mark.parametrize("lens", [
    '<float name="aperture_radius" value="0.1"/><float name="focus_distance" value="3"/>',
    '<float name="aperture_radius" value="0.25"/>',                        # focus at far_clip, as Mitsuba
    '<float name="aperture_radius" value="0.05"/><float name="focus_distance" value="1.5"/>'
    '<float name="fov" value="30"/><string name="fov_axis" value="y"/><float name="near_clip" value="0.3"/>',
])
def test_thinlens_rays_match_mitsuba(lens):
    """Mitsuba's ``sample_ray`` at random film and aperture samples: the concentric aperture
    map, the plane of focus, the near plane (origins and directions within float32 rounding)."""
    fov = "" if "fov" in lens else '<float name="fov" value="40"/>'
    xml = scene_xml(sensor=f'<sensor type="thinlens">{fov}{lens}<transform name="to_world"><lookat origin="1, 2, 5" '
                           'target="0, 0.5, 0" up="0, 1, 0"/></transform><film type="hdrfilm"><integer name="width" '
                           'value="20"/><integer name="height" value="15"/><rfilter type="box"/></film></sensor>')
    ours, theirs = load_scene(xml).sensor, mi.load_string(xml).sensors()[0]
    assert ours.camera_dims == 4
    rng = np.random.default_rng(6)
    pos, ap = rng.random((60, 2)), rng.random((60, 2))
    o, d = ours.rays(pos * [20, 15], np.float64, ap)
    for k in range(len(pos)):
        ray, weight = theirs.sample_ray(0.0, 0.5, mi.Point2f(*pos[k]), mi.Point2f(*ap[k]))
        np.testing.assert_allclose(d[k], np.array(ray.d), atol=2e-6)
        np.testing.assert_allclose(o[k], np.array(ray.o), atol=2e-6)
        assert np.allclose(np.array(weight), 1.0)


@pytest.mark.parametrize("lens, words", [
    ('', "aperture_radius"),
    ('<float name="aperture_radius" value="-0.1"/>', "aperture_radius"),
    ('<float name="aperture_radius" value="0.1"/><float name="focus_distance" value="0"/>', "focus_distance"),
])
def test_thinlens_refuses_a_bad_lens(lens, words):
    xml = scene_xml(sensor=f'<sensor type="thinlens"><float name="fov" value="40"/>{lens}</sensor>')
    with pytest.raises((SceneError, ValueError), match=words):
        load_scene(xml)


def test_samplers_map_to_point_sets():
    for plugin, points in [("independent", None), ("stratified", "stratified"), ("multijitter", "stratified"),
                           ("orthogonal", "lhs"), ("ldsampler", "sobol")]:
        sc = load_scene(scene_xml(sensor=SENSOR.replace('"independent"', f'"{plugin}"')))
        assert sc.sensor.sampler.points == points and sc.sensor.spp == 4
        est = render(sc, 4, rng=0)
        assert ("stderr_note" in est.extra) is (points is not None)       # the i.i.d. error bar is flagged


# ----------------------------------------------------------------------------- cylinder
CYLINDERS = [
    '<shape type="cylinder"/>',
    '<shape type="cylinder"><float name="radius" value="0.4"/><point name="p0" value="0.1, -0.2, 0.3"/>'
    '<point name="p1" value="0.5, 0.7, 1.1"/><boolean name="flip_normals" value="true"/></shape>',
    '<shape type="cylinder"><transform name="to_world"><scale value="0.5"/><rotate x="0.6" y="0.8" angle="30"/>'
    '<translate x="0.2"/></transform></shape>',
]


@pytest.mark.parametrize("kernels", ["numpy", "numba"])
@pytest.mark.parametrize("shape", CYLINDERS)
def test_cylinder_hits_and_area_match_mitsuba(shape, kernels):
    """Hits and normals of the ray tracer (all pairs with NumPy; the compiled BVH walk) against
    Mitsuba's ``ray_intersect``."""
    from vrlab.render.accel.geometry import SceneGeometry

    if kernels == "numba":
        pytest.importorskip("numba")
    xml = scene_xml(shape)
    ours = load_scene(xml).shapes[0]
    theirs = mi.load_string(xml)
    assert ours.area == pytest.approx(theirs.shapes()[0].surface_area(), rel=1e-6)
    rng = np.random.default_rng(2)
    o = rng.normal(size=(600, 3)) * 2
    d = rng.normal(size=(600, 3)) * 0.5 + ours.center - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    h = SceneGeometry(load_scene(xml), kernels=kernels).intersect(o, d)
    t, n = h.t, h.n
    for i in range(len(o)):
        si = theirs.ray_intersect(mi.Ray3f(mi.Point3f(*o[i]), mi.Vector3f(*d[i])))
        if not si.is_valid():
            assert not np.isfinite(t[i]), i
            continue
        assert t[i] == pytest.approx(si.t, rel=1e-5, abs=1e-5), i
        np.testing.assert_allclose(n[i], np.array(si.n), atol=1e-5)


def test_cylinder_refuses_a_sheared_cross_section():
    with pytest.raises(SceneError, match="to_world.*circle"):
        load_scene(scene_xml('<shape type="cylinder"><transform name="to_world"><scale x="2"/></transform></shape>'))


# ----------------------------------------------------------------------------- surface coordinates
UV_SHAPES = [
    '<shape type="rectangle"><transform name="to_world"><rotate x="1" angle="30"/><scale x="2"/></transform></shape>',
    '<shape type="disk"><transform name="to_world"><rotate y="1" angle="-20"/></transform></shape>',
    '<shape type="sphere"><point name="center" value="0.2, 0, 0"/><float name="radius" value="0.8"/></shape>',
    '<shape type="cylinder"><float name="radius" value="0.5"/><point name="p0" value="0, -1, 0"/>'
    '<point name="p1" value="0, 1, 0.3"/></shape>',
    '<shape type="cube"><transform name="to_world"><rotate x="1" y="2" z="0.5" angle="37"/><scale value="0.7"/>'
    '</transform></shape>',
]


@pytest.mark.parametrize("shape", UV_SHAPES)
def test_surface_coordinates_match_mitsuba(shape):
    xml = scene_xml(shape)
    ours = load_scene(xml)
    theirs = mi.load_string(xml)
    from vrlab.render.accel.geometry import SceneGeometry

    rng = np.random.default_rng(3)
    o = rng.normal(size=(400, 3)) * 3
    d = rng.normal(size=(400, 3)) * 0.3 - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    hits = SceneGeometry(ours).intersect(o, d)
    ok = hits.shape >= 0
    uv = ours.shapes[0].uv(hits.p[ok], hits.prim[ok])
    ref = []
    for i in np.flatnonzero(ok):
        si = theirs.ray_intersect(mi.Ray3f(mi.Point3f(*o[i]), mi.Vector3f(*d[i])))
        assert si.is_valid()
        ref.append(np.array(si.uv))
    assert ok.sum() > 100
    np.testing.assert_allclose(uv, np.array(ref), atol=2e-5)


def test_textured_emitter_light_and_bsdf_sampling_agree(tmp_path):
    """A checkerboard radiance on a cube light: light sampling (by area, radiance looked up at the
    sampled point), BSDF sampling (at the hit) and the control variate (whose closed form does not
    apply to a textured light, so it must step aside) give the same image mean."""
    body = LIGHT.split("<shape type=\"sphere\">")[0] + (
        '<shape type="cube"><transform name="to_world"><scale value="0.3"/><translate y="1.2"/></transform>'
        '<emitter type="area"><texture type="checkerboard" name="radiance"><rgb name="color0" value="3, 1, 0.5"/>'
        '<transform name="to_uv"><scale value="3"/></transform></texture></emitter></shape>')
    sc = load_scene(scene_xml(body))
    means = {}
    for est in ("light", "bsdf", "cv"):
        e = render(sc, 256, est, rng=7)
        floor = (slice(None), slice(None))
        means[est] = (e.value[floor].mean(), np.sqrt(np.sum(e.stderr[floor] ** 2)) / e.value[floor].size)
    for est in ("bsdf", "cv"):
        d = means[est][0] - means["light"][0]
        assert abs(d) < 4 * np.hypot(means[est][1], means["light"][1]), (est, means)


# ----------------------------------------------------------------------------- delta lights and environments
DELTA = ('<emitter type="point"><point name="position" value="0.5, 1.5, 0.5"/><rgb name="intensity" value="3"/>'
         '</emitter><emitter type="directional"><vector name="direction" value="0.3, -1, -0.2"/></emitter>')


def test_every_preset_is_unbiased_with_delta_and_environment_lights():
    """Point and directional (delta) lights beside a constant environment and a sphere light: the
    presets that reach every light agree in image mean (4 standard errors), and those that
    cannot reach the delta lights are refused, naming them."""
    sc = load_scene(scene_xml(LIGHT + DELTA + '<emitter type="constant"><rgb name="radiance" value="0.2"/></emitter>'))
    means = {}
    for est in ("mis-power", "mis-balance", "light", "mixture", "ris", "cv"):
        e = render(sc, 64, est, rng=3)
        means[est] = (e.value.mean(), np.sqrt(np.sum(e.stderr ** 2)) / e.value.size)
    ref, ref_se = means["mis-power"]
    for est, (m, se) in means.items():
        assert abs(m - ref) < 4 * np.hypot(se, ref_se), (est, means)
    for est in ("bsdf", "cosine", "uniform"):
        with pytest.raises(ValueError, match="estimator.*delta emitters.*point"):
            render(sc, 1, est)


def test_a_delta_light_has_no_bsdf_density():
    """MIS weights for a delta light: the BSDF technique's density there is 0 (Veach's
    condition), so MIS gives it full weight; a technique density that forgot this would
    make balance-heuristic MIS darker than light sampling."""
    from vrlab.render.pixels import PixelIntegrand

    sc = load_scene(scene_xml(LIGHT.split('<shape type="sphere">')[0] + DELTA))
    pi = PixelIntegrand(sc, "mis-balance")
    sh = pi.shading(0, np.array([[0.0, 0.0, 0.0]], np.float32), np.array([[0.0, 1.0, 0.0]], np.float32),
                    np.array([[0.0, 1.0, 0.0]], np.float32))
    x = sh.techniques["light"].sample(np.random.default_rng(0).random((1, 64, 3)))
    assert np.all(sh.techniques["bsdf"].pdf(x) == 0)
    assert np.all(sh.techniques["light"].pdf(x) > 0)


def test_sampling_weight_and_power_selection():
    from vrlab.render.light_set import LightSet

    sc = load_scene(scene_xml(LIGHT + DELTA.replace('<rgb name="intensity" value="3"/>',
                                                    '<rgb name="intensity" value="3"/><float name="sampling_weight" '
                                                    'value="2"/>')))
    lights = LightSet(sc.shapes, "uniform", sc.free_emitters, radius=5.0)
    np.testing.assert_allclose(lights.selection.pmf(np.arange(3)), [1 / 4, 2 / 4, 1 / 4])
    power = LightSet(sc.shapes, "power", sc.free_emitters, radius=5.0)
    # flux: pi x radiance x area for the sphere light, 4 pi I for the point light (times its
    # sampling_weight 2), pi r^2 E for the directional light
    w = np.array([np.pi * 4 * 4 * np.pi * 0.3 ** 2, 2 * 4 * np.pi * 3, np.pi * 25 * 1.0])
    np.testing.assert_allclose(power.selection.pmf(np.arange(3)), w / w.sum())
    with pytest.raises(SceneError, match="sampling_weight"):
        load_scene(scene_xml(LIGHT + DELTA.replace('<rgb name="intensity" value="3"/>',
                                                   '<float name="sampling_weight" value="-1"/>')))


def test_envmap_light_bsdf_and_mis_agree(tmp_path):
    """An environment map lighting a floor and a glossy sphere: luminance-sampled light sampling,
    BSDF sampling and MIS (also with Mitsuba's MIS compensation, unbiased under MIS) agree."""
    from vrlab.render.image import save_image

    img = np.random.default_rng(0).random((8, 16, 3)).astype(np.float32) * 0.5
    img[2, 10:12] = 8.0             # a bright patch; much brighter, BSDF sampling's tail outruns a z-test at 512 spp
    save_image(tmp_path / "env.exr", img)
    env = f'<emitter type="envmap"><string name="filename" value="{tmp_path / "env.exr"}"/>{{}}</emitter>'
    body = (LIGHT.split('<shape type="sphere">')[0] + '<shape type="sphere"><point name="center" value="0, 0, 0.5"/>'
            '<float name="radius" value="0.5"/><bsdf type="roughconductor"><float name="alpha" value="0.3"/></bsdf>'
            '</shape>')
    means = {}
    for name, extra, est in [("light", "", "light"), ("bsdf", "", "bsdf"), ("mis", "", "mis-power"),
                             ("mis-compensated", '<boolean name="mis_compensation" value="true"/>', "mis-power")]:
        e = render(load_scene(scene_xml(body + env.format(extra))), 512, est, rng=5)
        means[name] = (e.value.mean(), np.sqrt(np.sum(e.stderr ** 2)) / e.value.size)
    m0, s0 = means["mis"]
    for name, (m, s) in means.items():
        assert abs(m - m0) < 4 * np.hypot(s, s0), (name, means)


def test_an_emissive_mesh_is_sampled_as_a_light(tmp_path):
    """The issue's example: a scene lit by an emissive OBJ ball.  Light sampling (by area and by
    spherical triangles), BSDF sampling and MIS agree; before meshes were light surfaces the
    "light" image silently lost the ball's light."""
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float) * 0.3 + [0, 0, 1.2]
    f = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6],
                  [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    (tmp_path / "box.obj").write_text("".join(f"v {a} {b} {c}\n" for a, b, c in v) +
                                      "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f))
    floor = LIGHT.split('<shape type="sphere">')[0]
    body = floor + (f'<shape type="obj"><string name="filename" value="{tmp_path / "box.obj"}"/>'
                    '<boolean name="face_normals" value="true"/><emitter type="area"><rgb name="radiance" value="2"/>'
                    '{}</emitter></shape>')
    means = {}
    for name, extra, est in [("light", "", "light"), ("spherical", '<string name="triangle_sampling" '
                             'value="spherical"/>', "light"), ("bsdf", "", "bsdf"), ("mis", "", "mis-power")]:
        e = render(load_scene(scene_xml(body.format(extra))), 64, est, rng=2)
        means[name] = (e.value.mean(), np.sqrt(np.sum(e.stderr ** 2)) / e.value.size)
    m0, s0 = means["mis"]
    for name, (m, s) in means.items():
        assert abs(m - m0) < 4 * np.hypot(s, s0), (name, means)


@pytest.mark.parametrize("sensor, body, typo, meant", [
    (SENSOR.replace('name="fov"', 'name="fvo"'), LIGHT, "fvo", "fov"),            # fov not given: still suggested
    (SENSOR.replace('<float name="fov" value="40"/>', '<string name="focal_lenght" value="50mm"/>'), LIGHT,
     "focal_lenght", "focal_length"),
    (SENSOR.replace('<float name="fov" value="40"/>', '<float name="fov" value="40"/><string name="fov_axs" value="y"/>'),
     LIGHT, "fov_axs", "fov_axis"),
    (SENSOR, LIGHT.replace('name="radius"', 'name="radus"'), "radus", "radius"),
    (SENSOR, LIGHT.replace('name="radius"', 'name="zzzz"'), "zzzz", None),
])
def test_a_parameter_typo_suggests_the_close_parameters_of_the_element(sensor, body, typo, meant):
    """An unknown parameter's error suggests close matches (difflib) among all of the element's
    parameters, those given and those not (``fvo`` on a perspective sensor without ``fov``:
    did you mean 'fov'?), and lists them all; nothing close, no suggestion."""
    with pytest.raises(SceneError) as info:
        load_scene(scene_xml(body, sensor))
    text = str(info.value)
    assert f"unknown parameter '{typo}'" in text
    if meant is None:
        assert "did you mean" not in text
    else:
        assert f"(did you mean '{meant}'" in text                              # the closest first
        assert f" {meant}," in text.split("supported:")[1] + ","          # and listed among the supported
