"""Tests for vrlab.render: Mitsuba 3 XML subset parser and transforms."""
from __future__ import annotations

import numpy as np
import pytest

from vrlab.render import (SceneError, builtin_scene_path, list_builtin_scenes, load_scene,
                          transforms as tf)
from vrlab.render.sensors import HDRFilm, PerspectiveCamera

BUILTINS = ("box_ellipsoid", "cornell_box", "furnace", "many_lights", "veach_mis")

SENSOR = """
  <sensor type="perspective">
    <float name="fov" value="45"/>
    <sampler type="independent"><integer name="sample_count" value="8"/></sampler>
    <film type="hdrfilm">
      <integer name="width" value="32"/><integer name="height" value="16"/>
      <rfilter type="box"/>
    </film>
  </sensor>"""


def scene_xml(body: str, sensor: str = SENSOR, integrator: str = '<integrator type="direct"/>',
              head: str = '<scene version="3.0.0">') -> str:
    return f"{head}\n  {integrator}{sensor}\n{body}\n</scene>"


SHAPE = '<shape type="rectangle"/>'


# ----------------------------------------------------------------------------- builtins
@pytest.mark.parametrize("name", BUILTINS)
def test_builtin_scenes_load(name):
    assert name in list_builtin_scenes()
    scene = load_scene(builtin_scene_path(name))
    assert scene.shapes and scene.emitters
    assert scene.sensor.rfilter == "box"
    for s in scene.shapes:
        assert s.to_world.shape == (4, 4) and np.all(np.isfinite(s.to_world))


def test_builtin_unknown_name():
    with pytest.raises(ValueError, match="veach_mis"):
        builtin_scene_path("nope")


@pytest.mark.parametrize("name", BUILTINS)
def test_builtin_scenes_describe_themselves(name):
    """The description is the scene file's own <!-- vrlab: ... --> comment; the summary its first sentence."""
    from vrlab.render.builtin import describe_builtin_scene

    summary, full = describe_builtin_scene(name), describe_builtin_scene(name, full=True)
    assert 20 < len(summary) <= len(full) and full.startswith(summary) and not summary[0].islower()
    assert summary.endswith(".") and "vrlab:" not in full and "\n" not in full
    words = set(summary.lower().replace(",", " ").split())
    assert words & {"light", "lights", "emitting"}, summary          # says what lights the scene
    assert summary[1:] in " ".join(builtin_scene_path(name).read_text().split())   # written there, once


def test_describe_builtin_scene_errors(raises_naming, monkeypatch, tmp_path):
    from vrlab.render import builtin as loader

    with raises_naming(ValueError, "name"):
        loader.describe_builtin_scene("nope")
    with raises_naming(TypeError, "name"):
        loader.describe_builtin_scene(3)
    with raises_naming(TypeError, "full"):
        loader.describe_builtin_scene("furnace", full="yes")
    (tmp_path / "bare.xml").write_text(scene_xml(SHAPE))            # no description comment
    monkeypatch.setattr(loader, "_scenes_folder", lambda: tmp_path)
    with raises_naming(ValueError, "name"):
        loader.describe_builtin_scene("bare")


@pytest.mark.parametrize("name", BUILTINS)
def test_export_builtin_scene_loads_from_its_new_folder(name, tmp_path):
    from vrlab.render.builtin import export_builtin_scene

    files = export_builtin_scene(name, tmp_path / "new" / "folder")
    assert files[0] == tmp_path / "new" / "folder" / f"{name}.xml"
    assert files[0].read_bytes() == builtin_scene_path(name).read_bytes()
    copy, original = load_scene(files[0]), load_scene(builtin_scene_path(name))
    assert (copy.sensor.width, copy.sensor.height, copy.sensor.spp) == \
        (original.sensor.width, original.sensor.height, original.sensor.spp)
    assert len(copy.shapes) == len(original.shapes)
    for a, b in zip(copy.shapes, original.shapes):
        assert a.type == b.type and np.array_equal(a.to_world, b.to_world)


def test_export_copies_the_meshes_a_scene_uses(monkeypatch, tmp_path):
    from vrlab.render import builtin as loader

    shipped = tmp_path / "shipped"
    (shipped / "meshes").mkdir(parents=True)
    (shipped / "meshes" / "quad.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    mesh = '<shape type="obj"><string name="filename" value="meshes/quad.obj"/></shape>'
    (shipped / "mesh.xml").write_text("<!-- vrlab: a quad mesh. -->\n" + scene_xml(mesh + mesh + SHAPE))
    monkeypatch.setattr(loader, "_scenes_folder", lambda: shipped)
    out = tmp_path / "mine"
    files = loader.export_builtin_scene("mesh", out)
    assert files == [out / "mesh.xml", out / "meshes" / "quad.obj"]          # each file once
    scene = load_scene(out / "mesh.xml")
    assert [s.filename for s in scene.shapes[:2]] == [str(out / "meshes" / "quad.obj")] * 2
    assert scene.files == [out / "meshes" / "quad.obj"]
    with pytest.raises(FileExistsError, match="quad.obj"):
        loader.export_builtin_scene("mesh", out)
    (out / "mesh.xml").write_text("edited")
    assert loader.export_builtin_scene("mesh", out, overwrite=True) == files
    assert (out / "mesh.xml").read_text() == (shipped / "mesh.xml").read_text()


def test_export_builtin_scene_errors(raises_naming, tmp_path):
    from vrlab.render.builtin import export_builtin_scene

    with raises_naming(ValueError, "name"):
        export_builtin_scene("nope", tmp_path)
    with raises_naming(TypeError, "folder"):
        export_builtin_scene("furnace", 3)
    with raises_naming(ValueError, "folder"):
        export_builtin_scene("furnace", " ")
    with raises_naming(TypeError, "overwrite"):
        export_builtin_scene("furnace", tmp_path, overwrite=1)
    (tmp_path / "file").write_text("")
    with pytest.raises(NotADirectoryError, match="folder"):
        export_builtin_scene("furnace", tmp_path / "file")
    export_builtin_scene("furnace", tmp_path)
    with pytest.raises(FileExistsError, match="furnace.xml"):
        export_builtin_scene("furnace", tmp_path)


def test_many_lights_powers_span_three_orders():
    scene = load_scene(builtin_scene_path("many_lights"))
    assert len(scene.emitters) >= 100
    power = np.array([s.emitter.radiance.mean() * 4 * np.pi ** 2 * s.sphere()[1] ** 2
                      for s in scene.emitters])
    assert power.max() / power.min() >= 1e3


def test_veach_plates_reflect_lights_to_camera():
    """The mirror direction of the camera ray at each plate centre hits the light row."""
    scene = load_scene(builtin_scene_path("veach_mis"))
    cam = scene.sensor.origin
    plates = [s for s in scene.shapes if s.type == "rectangle" and s.bsdf.type == "roughconductor"]
    lights = [s for s in scene.shapes if s.type == "sphere"]
    assert len(plates) == 4 and len(lights) == 4
    alphas = [p.bsdf.alpha for p in plates]
    assert sorted(alphas) == [0.005, 0.02, 0.05, 0.1]
    radii = np.array([s.sphere()[1] for s in lights])
    power = np.array([s.emitter.radiance[0] for s in lights]) * radii ** 2
    np.testing.assert_allclose(power, power[0], rtol=1e-3)
    light_y, light_z = lights[0].center[1], lights[0].center[2]
    for p in plates:
        corner, e1, e2, n = p.rectangle()
        c = corner + 0.5 * (e1 + e2)
        wi = (c - cam) / np.linalg.norm(c - cam)
        r = wi - 2 * np.dot(wi, n) * n
        t = (light_z - c[2]) / r[2]
        assert t > 0
        assert abs(c[1] + t * r[1] - light_y) < 0.15


# ----------------------------------------------------------------------------- transforms
def test_rotate_z_maps_x_to_y():
    m = tf.rotate([0, 0, 1], 90)
    np.testing.assert_allclose(tf.transform_vectors(m, [1, 0, 0]), [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(tf.transform_vectors(tf.rotate([1, 0, 0], 90), [0, 1, 0]),
                               [0, 0, 1], atol=1e-12)


def test_composition_order_scale_translate():
    s, t = tf.scale(2), tf.translate([1, 0, 0])
    p = np.array([1.0, 0, 0])
    # Mitsuba: each op left-multiplies: <scale/><translate/> = T @ S
    np.testing.assert_allclose(tf.transform_points(tf.compose(s, t), p), [3, 0, 0])
    np.testing.assert_allclose(tf.transform_points(tf.compose(t, s), p), [4, 0, 0])
    xml = lambda ops: scene_xml(f'<shape type="rectangle"><transform name="to_world">{ops}'
                                '</transform></shape>')
    a = load_scene(xml('<scale value="2"/><translate x="1"/>')).shapes[0].to_world
    b = load_scene(xml('<translate value="1, 0, 0"/><scale value="2, 2, 2"/>')).shapes[0].to_world
    np.testing.assert_allclose(a, [[2, 0, 0, 1], [0, 2, 0, 0], [0, 0, 2, 0], [0, 0, 0, 1]])
    np.testing.assert_allclose(b, [[2, 0, 0, 2], [0, 2, 0, 0], [0, 0, 2, 0], [0, 0, 0, 1]])
    c = load_scene(xml('<translate x="1"/><rotate z="1" angle="90"/>')).shapes[0].to_world
    np.testing.assert_allclose(c[:3, 3], [0, 1, 0], atol=1e-12)   # R @ T


def test_matrix_is_row_major():
    vals = np.arange(16.0)
    np.testing.assert_array_equal(tf.matrix(vals), vals.reshape(4, 4))
    xml = scene_xml('<shape type="rectangle"><transform name="to_world">'
                    '<matrix value="1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1"/></transform></shape>')
    np.testing.assert_allclose(load_scene(xml).shapes[0].center, [5, 6, 7])


def test_lookat_conventions():
    o, t, up = np.array([1.0, 2, 3]), np.array([4.0, -1, 0.5]), np.array([0.0, 1, 0])
    m = tf.look_at(o, t, up)
    r = m[:3, :3]
    np.testing.assert_allclose(r.T @ r, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)
    d = (t - o) / np.linalg.norm(t - o)
    np.testing.assert_allclose(tf.transform_vectors(m, [0, 0, 1]), d, atol=1e-12)
    np.testing.assert_allclose(tf.transform_points(m, [0, 0, 0]), o)
    # local +x = normalize(cross(up, dir)) ("left"); local +y in the up half-space
    left = np.cross(up, d) / np.linalg.norm(np.cross(up, d))
    np.testing.assert_allclose(r[:, 0], left, atol=1e-12)
    assert r[:, 1] @ up > 0
    # camera at +z looking at the origin: image-left is world -x
    m2 = tf.look_at([0, 0, 5], [0, 0, 0], [0, 1, 0])
    np.testing.assert_allclose(m2[:3, 0], [-1, 0, 0], atol=1e-12)
    with pytest.raises(ValueError):
        tf.look_at([0, 0, 0], [0, 1, 0], [0, 2, 0])


def test_normals_use_inverse_transpose():
    m = tf.compose(tf.scale([1, 4, 1]), tf.rotate([0, 0, 1], 30), tf.translate([3, 1, 2]))
    rng = np.random.default_rng(1)
    n = rng.normal(size=(20, 3))
    tangent = np.cross(n, rng.normal(size=(20, 3)))          # tangents orthogonal to n
    n2, t2 = tf.transform_normals(m, n), tf.transform_vectors(m, tangent)
    np.testing.assert_allclose(np.sum(n2 * t2, axis=-1), 0, atol=1e-10)
    assert not np.allclose(np.sum(tf.transform_vectors(m, n) * t2, axis=-1), 0)
    assert tf.transform_points(m, np.zeros((2, 5, 3))).shape == (2, 5, 3)


# ----------------------------------------------------------------------------- parsing
def test_sensor_integrator_and_defaults():
    xml = scene_xml(SHAPE, integrator='<integrator type="direct">'
                    '<integer name="shading_samples" value="3"/>'
                    '<integer name="bsdf_samples" value="2"/></integrator>')
    s = load_scene(xml)
    assert (s.integrator.emitter_samples, s.integrator.bsdf_samples) == (3, 2)
    assert (s.sensor.width, s.sensor.height, s.sensor.spp) == (32, 16, 8)
    assert s.sensor.fov == 45 and s.sensor.fov_axis == "x" and s.sensor.fov_x == 45
    assert s.source == "<string>"
    np.testing.assert_array_equal(s.sensor.to_world, np.eye(4))
    # defaults: sampler 4 spp, film 768 x 576
    sensor = ('<sensor type="perspective"><float name="fov" value="30"/>'
              '<string name="fov_axis" value="y"/>'
              '<film type="hdrfilm"><rfilter type="box"/></film></sensor>')
    s = load_scene(scene_xml(SHAPE, sensor=sensor))
    assert (s.sensor.width, s.sensor.height, s.sensor.spp) == (768, 576, 4)
    assert s.sensor.fov_y == pytest.approx(30)
    assert s.sensor.fov_x > 30
    # fov_axis conventions (Mitsuba's parse_fov), aspect 4:3
    base = dict(fov=50.0, to_world=np.eye(4), film=HDRFilm(width=400, height=300))
    fx = PerspectiveCamera(fov_axis="x", **base)
    assert fx.fov_x == 50 and fx.fov_y < 50
    fy = PerspectiveCamera(fov_axis="y", **base)
    assert fy.fov_y == pytest.approx(50)
    assert PerspectiveCamera(fov_axis="smaller", **base).fov_x == pytest.approx(fy.fov_x)
    assert PerspectiveCamera(fov_axis="larger", **base).fov_x == 50
    fd = PerspectiveCamera(fov_axis="diagonal", **base)
    half_w, half_h = np.tan(np.deg2rad(fd.fov_x) / 2), np.tan(np.deg2rad(fd.fov_y) / 2)
    assert np.hypot(half_w, half_h) == pytest.approx(np.tan(np.deg2rad(25)))


def test_default_substitution_and_params():
    xml = scene_xml('<default name="r" value="0.25"/><default name="w" value="0.3"/>'
                    '<shape type="sphere"><float name="radius" value="$r"/>'
                    '<emitter type="area"><rgb name="radiance" value="$w, 1, 2"/></emitter></shape>')
    s = load_scene(xml)
    assert s.shapes[0].sphere()[1] == pytest.approx(0.25)
    np.testing.assert_allclose(s.shapes[0].emitter.radiance, [0.3, 1, 2])
    s = load_scene(xml, {"r": 2})
    assert s.shapes[0].sphere()[1] == pytest.approx(2)
    assert load_scene(builtin_scene_path("cornell_box"), {"res": 8}).sensor.width == 8
    # a parameter the scene never uses is an error, not silently ignored
    with pytest.raises(SceneError, match="'width'.*not used"):
        load_scene(builtin_scene_path("cornell_box"), {"width": 8})


def test_shapes_geometry_and_refs():
    body = """
    <bsdf type="diffuse" id="mat"><rgb name="reflectance" value="0.1, 0.2, 0.3"/></bsdf>
    <shape type="rectangle"><transform name="to_world"><scale x="2" y="3" z="1"/>
       <translate z="1"/></transform><ref id="mat"/>
       <boolean name="flip_normals" value="true"/>
       <emitter type="area"><float name="radiance" value="5"/></emitter></shape>
    <shape type="sphere"><point name="center" value="1, 0, 0"/><float name="radius" value="0.5"/>
       <transform name="to_world"><scale value="2"/><translate y="1"/></transform></shape>
    <shape type="ellipsoid"><vector name="radii" value="1, 2, 3"/></shape>
    <shape type="disk"><bsdf type="twosided"><bsdf type="phong">
       <float name="exponent" value="10"/></bsdf></bsdf></shape>
    <shape type="cube"/>"""
    rect, sph, ell, disk, cube = load_scene(scene_xml(body)).shapes
    np.testing.assert_allclose(rect.bsdf.reflectance, [0.1, 0.2, 0.3])
    np.testing.assert_allclose(rect.emitter.radiance, [5, 5, 5])
    corner, e1, e2, n = rect.rectangle()
    np.testing.assert_allclose(corner, [-2, -3, 1])
    np.testing.assert_allclose(e1, [4, 0, 0])
    np.testing.assert_allclose(e2, [0, 6, 0])
    np.testing.assert_allclose(n, [0, 0, -1])                # flipped
    c, r = sph.sphere()
    np.testing.assert_allclose(c, [2, 1, 0])                   # to_world @ T(center) @ S(r)
    assert r == pytest.approx(1.0)
    assert sph.bsdf.type == "diffuse" and sph.emitter is None
    np.testing.assert_allclose(ell.ellipsoid()[1], np.diag([1, 2, 3]))
    assert disk.bsdf.type == "twosided" and disk.bsdf.inner.type == "phong" and disk.bsdf.twosided
    assert disk.bsdf.inner.exponent == 10
    tri = cube.triangles()
    assert tri.shape == (12, 3, 3)
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert np.all(np.sum(normals * tri.mean(axis=1), axis=-1) > 0)   # outward winding
    assert rect.triangles().shape == (2, 3, 3)


def test_obj_shape(tmp_path):
    (tmp_path / "quad.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1 4/1\n")
    (tmp_path / "scene.xml").write_text(scene_xml(
        '<shape type="obj"><string name="filename" value="quad.obj"/></shape>'))
    shape = load_scene(tmp_path / "scene.xml").shapes[0]
    assert shape.triangles().shape == (2, 3, 3)
    (tmp_path / "n.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n")
    (tmp_path / "n.xml").write_text(scene_xml(
        '<shape type="obj"><string name="filename" value="n.obj"/></shape>'))
    smooth = load_scene(tmp_path / "n.xml").shapes[0]            # vertex normals: smooth shading
    assert smooth.has_shading_normals and smooth.normals.shape == (3, 3)
    (tmp_path / "f.xml").write_text(scene_xml(
        '<shape type="obj"><string name="filename" value="n.obj"/><boolean name="face_normals" value="true"/></shape>'))
    assert not load_scene(tmp_path / "f.xml").shapes[0].has_shading_normals


def test_error_has_line_number():
    xml = scene_xml('<shape type="rectangle"/>\n<shape type="torus"/>')
    with pytest.raises(SceneError) as info:
        load_scene(xml)
    line = xml.splitlines().index('<shape type="torus"/>') + 1
    assert f"line {line}" in str(info.value)
    assert "scene/shape" in str(info.value)


ROUGH = ('<shape type="rectangle"><bsdf type="roughconductor">{}</bsdf></shape>')
GOOD_ROUGH = '<boolean name="sample_visible" value="false"/>'
BAD = {
    "unknown shape": (scene_xml('<shape type="torus"/>'), ["torus", "rectangle", "ellipsoid"]),
    "unknown bsdf": (scene_xml('<shape type="cube"><bsdf type="hair"/></shape>'),
                     ["hair", "diffuse", "roughconductor", "phong"]),
    "unknown param": (scene_xml('<shape type="cube"><bsdf type="diffuse">'
                                '<float name="roughness" value="1"/></bsdf></shape>'),
                      ["roughness", "reflectance"]),
    "not a texture": (scene_xml('<shape type="cube"><bsdf type="diffuse"><bsdf type="diffuse" '
                                'name="reflectance"/></bsdf></shape>'), ["bsdf", "reflectance", "<rgb>"]),
    "unknown child": (scene_xml('<shape type="cube"><medium type="homogeneous"/></shape>'),
                      ["medium", "<bsdf>", "<emitter>"]),
    "top-level area emitter": (scene_xml(SHAPE + '<emitter type="area"><rgb name="radiance" value="1"/></emitter>'),
                               ["area", "nested inside a <shape>"]),
    "unknown emitter": (scene_xml(SHAPE + '<emitter type="laser"/>'), ["laser", "point", "spot", "area"]),
    "shape emitter type": (scene_xml('<shape type="cube"><emitter type="spot"/></shape>'),
                           ["spot", "area"]),
    "wrong integrator": (scene_xml(SHAPE, integrator='<integrator type="bdpt"/>'),
                         ["bdpt", "direct", "path"]),
    "infinite path": (scene_xml(SHAPE, integrator='<integrator type="path"/>'),
                      ["max_depth", "-1", "direct lighting"]),
    "deep path": (scene_xml(SHAPE, integrator='<integrator type="path"><integer name="max_depth" value="3"/>'
                            '</integrator>'), ["max_depth", "3"]),
    "mitchell": (scene_xml(SHAPE, sensor=SENSOR.replace('"box"', '"mitchell"')),
                 ["mitchell", "box", "gaussian", "tent"]),
    "sdfgrid": (scene_xml('<shape type="sdfgrid"/>'), ["sdfgrid", "signed distance"]),
    "fov_axis": (scene_xml(SHAPE, sensor=SENSOR.replace(
        '<float name="fov" value="45"/>', '<float name="fov" value="45"/>'
        '<string name="fov_axis" value="z"/>')), ["fov_axis", "diagonal"]),
    "material": (scene_xml(ROUGH.format(GOOD_ROUGH + '<string name="material" value="Unobtainium"/>')),
                 ["Unobtainium", "material", "Au"]),
    "distribution": (scene_xml(ROUGH.format(GOOD_ROUGH + '<string name="distribution" '
                                            'value="phong"/>')), ["distribution", "ggx"]),
    "missing type": (scene_xml('<shape/>'), ["shape", "type", "rectangle"]),
    "camera scale": (scene_xml(SHAPE, sensor=SENSOR.replace(
        '<sampler', '<transform name="to_world"><scale value="2"/></transform><sampler')),
        ["to_world", "rigid"]),
    "bad number": (scene_xml('<shape type="sphere"><float name="radius" value="abc"/></shape>'),
                   ["float", "radius", "abc"]),
    "bad rgb": (scene_xml('<shape type="cube"><emitter type="area"><rgb name="radiance" '
                          'value="1, 2"/></emitter></shape>'), ["rgb", "radiance"]),
    "unknown ref": (scene_xml('<bsdf type="diffuse" id="a"/><shape type="cube"><ref id="b"/>'
                              '</shape>'), ["ref", "'b'", "a"]),
    "undefined var": (scene_xml('<shape type="sphere"><float name="radius" value="$r"/></shape>'),
                      ["$r", "float"]),
    "no version": (scene_xml(SHAPE, head="<scene>"), ["scene", "version"]),
    "old version": (scene_xml(SHAPE, head='<scene version="0.6.0">'), ["0.6.0", "2.x", "3.x"]),
    "not xml": ("<scene version='3.0.0'><shape></scene>", ["XML"]),
    "unknown transform op": (scene_xml('<shape type="cube"><transform name="to_world">'
                                       '<shear value="1"/></transform></shape>'),
                             ["shear", "lookat", "matrix"]),
    "sphere nonuniform": (scene_xml('<shape type="sphere"><transform name="to_world">'
                                    '<scale x="1" y="2" z="1"/></transform></shape>'),
                          ["sphere", "ellipsoid"]),
    "pixel_format": (scene_xml(SHAPE, sensor=SENSOR.replace(
        '<rfilter', '<string name="pixel_format" value="xyz"/><rfilter')), ["xyz", "rgb"]),
    "missing include": (scene_xml(SHAPE + '<include filename="x.xml"/>'), ["include", "x.xml", "cannot read"]),
    "top-level junk": (scene_xml(SHAPE + '<medium type="homogeneous"/>'), ["medium", "<shape>", "<include>"]),
    "ref cycle": (scene_xml('<bsdf type="twosided" id="a"><ref id="a"/></bsdf><shape type="cube"><ref id="a"/>'
                            '</shape>'), ["cycle"]),
    "duplicate id": (scene_xml('<bsdf type="diffuse" id="a"/><bsdf type="diffuse" id="a"/>' + SHAPE),
                     ["duplicate id", "'a'"]),
    "unused ref child": (scene_xml('<bsdf type="diffuse" id="a"/><shape type="cube"><ref id="a"/><ref id="a"/>'
                                   '</shape>'), ["at most 1", "bsdf"]),
    "bad attribute": (scene_xml('<shape type="cube"><transform name="to_world">'
                                '<translate x="1" w="2"/></transform></shape>'), ["translate", "w"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_errors_name_element_and_supported(case):
    xml, needles = BAD[case]
    with pytest.raises(SceneError) as info:
        load_scene(xml)
    msg = str(info.value)
    for needle in needles:
        assert needle in msg, (case, msg)
    assert isinstance(info.value, ValueError)


def test_missing_file():
    with pytest.raises(SceneError, match="cannot read"):
        load_scene("/nonexistent/scene.xml")
