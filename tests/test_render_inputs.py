"""Bad inputs to the renderer's public entry points: each gives a clear error naming the argument.

Scenes are tiny (4 x 3 pixels, 1 spp) so that the whole module runs in seconds.
"""
from __future__ import annotations

import numpy as np
import pytest

from vrlab.render import (AreaEmitter, Scene, SceneError, builtin_scene_path, load_scene, read_obj, register,
                          registered, render)
from vrlab.points import Sobol
from vrlab.render import transforms as tf
from vrlab.distributions import Beckmann
from vrlab.render.bsdfs import Diffuse, Phong, RoughConductor, TwoSided
from vrlab.render.compare import compare, compare_figure
from vrlab.render.direct import DirectLighting
from vrlab.render.integrators import DirectIntegrator, PathIntegrator
from vrlab.render.sensors import HDRFilm, IndependentSampler, PerspectiveCamera
from vrlab.render.shapes import Mesh, Rectangle, Sphere
from vrlab.render.accel.geometry import SceneGeometry
from vrlab.render.image import load_image, rel_mse, save_image, srgb_encode
from vrlab.render.light_set import LightSet

NAN, INF = float("nan"), float("inf")

# ----------------------------------------------------------------------------- a tiny scene
XML = """<scene version="3.0.0">
  <integrator type="direct">{integ}</integrator>
  <sensor type="perspective">
    <float name="fov" value="{fov}"/>{clip}
    <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="{spp}"/>{seed}</sampler>
    <film type="hdrfilm">
      <integer name="width" value="{width}"/><integer name="height" value="3"/>{film}
      <rfilter type="box"/>
    </film>
  </sensor>
  <shape type="sphere">
    <float name="radius" value="{radius}"/>
    <transform name="to_world">{transform}</transform>
    <emitter type="area"><rgb name="radiance" value="{radiance}"/></emitter>
  </shape>
  <shape type="rectangle">
    <bsdf type="diffuse"><rgb name="reflectance" value="{reflectance}"/></bsdf>
  </shape>
  <shape type="disk">
    <bsdf type="roughconductor">
      <float name="alpha" value="{alpha}"/><boolean name="sample_visible" value="false"/>
    </bsdf>
  </shape>
  <shape type="cube">
    <transform name="to_world"><translate z="-3"/></transform>
    <bsdf type="phong"><float name="exponent" value="{exponent}"/></bsdf>
  </shape>
</scene>"""
GOOD = dict(integ="", fov="40", clip="", spp="1", seed="", width="4", film="", radius="0.5",
            transform='<translate y="2"/>', radiance="2", reflectance="0.5", alpha="0.1", exponent="10")


def xml(**changes) -> str:
    return XML.format(**{**GOOD, **changes})


def tiny() -> Scene:
    return load_scene(xml())


def test_the_tiny_scene_renders():
    est = render(tiny(), 1, rng=0)
    assert est.value.shape == est.stderr.shape == (3, 4, 3) and np.all(np.isfinite(est.value))
    assert est.n == 1


# (changes, words the message must contain)
BAD_XML = {
    "fov 0": (dict(fov="0"), ["fov", "> 0", "< 180"]),
    "fov 180": (dict(fov="180"), ["fov"]),
    "fov negative": (dict(fov="-10"), ["fov"]),
    "fov nan": (dict(fov="nan"), ["fov", "finite"]),
    "fov inf": (dict(fov="inf"), ["fov", "finite"]),
    "fov text": (dict(fov="wide"), ["fov", "wide"]),
    "width 0": (dict(width="0"), ["width", ">= 1"]),
    "width negative": (dict(width="-4"), ["width"]),
    "width float": (dict(width="4.5"), ["width", "integer"]),
    "width huge": (dict(width="100000"), ["width", "65536"]),
    "spp 0": (dict(spp="0"), ["sample_count", ">= 1"]),
    "spp text": (dict(spp="many"), ["sample_count", "integer"]),
    "seed negative": (dict(seed='<integer name="seed" value="-1"/>'), ["seed"]),
    "near_clip 0": (dict(clip='<float name="near_clip" value="0"/>'), ["near_clip"]),
    "far < near": (dict(clip='<float name="near_clip" value="2"/><float name="far_clip" value="1"/>'),
                   ["far_clip", "near_clip"]),
    "file_format": (dict(film='<string name="file_format" value="jpeg"/>'), ["file_format", "openexr"]),
    "radius 0": (dict(radius="0"), ["radius", "> 0"]),
    "radius negative": (dict(radius="-1"), ["radius"]),
    "radius nan": (dict(radius="nan"), ["radius", "finite"]),
    "radius huge": (dict(radius="1e300"), ["to_world", "1e+08"]),
    "radius tiny": (dict(radius="1e-15"), ["to_world", "scale"]),
    "translate nan": (dict(transform='<translate x="nan"/>'), ["translate", "finite"]),
    "translate far": (dict(transform='<translate x="1e12"/>'), ["to_world"]),
    "scale 0": (dict(transform='<scale value="0"/>'), ["to_world", "singular"]),
    "rotate angle inf": (dict(transform='<rotate x="1" angle="inf"/>'), ["rotate", "angle"]),
    "rotate zero axis": (dict(transform='<rotate x="0" angle="30"/>'), ["rotate", "axis"]),
    "projective matrix": (dict(transform='<matrix value="1 0 0 0  0 1 0 0  0 0 1 0  0 0 1 1"/>'),
                          ["to_world", "affine"]),
    "non-uniform sphere": (dict(transform='<scale x="1" y="2" z="1"/>'), ["sphere", "ellipsoid"]),
    "radiance negative": (dict(radiance="-1"), ["radiance", "[0, "]),
    "radiance nan": (dict(radiance="nan"), ["radiance", "finite"]),
    "radiance huge": (dict(radiance="1e20"), ["radiance", "1e+15"]),
    "radiance two values": (dict(radiance="1, 2"), ["radiance", "1 or 3"]),
    "reflectance negative": (dict(reflectance="-0.5"), ["reflectance"]),
    "reflectance inf": (dict(reflectance="inf"), ["reflectance", "finite"]),
    "alpha 0": (dict(alpha="0"), ["alpha", "> 0"]),
    "alpha negative": (dict(alpha="-0.1"), ["alpha"]),
    "alpha huge": (dict(alpha="1e9"), ["alpha", "10000"]),
    "exponent negative": (dict(exponent="-1"), ["exponent", ">= 0"]),
    "exponent huge": (dict(exponent="1e9"), ["exponent"]),
    "emitter_samples negative": (dict(integ='<integer name="emitter_samples" value="-1"/>'),
                                 ["emitter_samples", ">= 0"]),
    "bsdf_samples float": (dict(integ='<integer name="bsdf_samples" value="1.5"/>'),
                           ["bsdf_samples", "integer"]),
    "both samples 0": (dict(integ='<integer name="shading_samples" value="0"/>'),
                       ["emitter_samples", "bsdf_samples"]),
    "emitter_samples huge": (dict(integ='<integer name="emitter_samples" value="1000000000"/>'),
                             ["emitter_samples", "1024"]),
    # above vrlab.limits.MAX_SAMPLES: refused at load with its file and line, not later by render
    "emitter_samples 2000": (dict(integ='<integer name="emitter_samples" value="2000"/>'),
                             ["emitter_samples", "1024", "line 2"]),
    "xml junk": (dict(integ='<integer name="bsdf_samples" value="1"'), ["well-formed"]),
}


@pytest.mark.parametrize("case", sorted(BAD_XML))
def test_bad_xml_value_names_element_line_and_file(tmp_path, case):
    changes, words = BAD_XML[case]
    path = tmp_path / "scene.xml"
    path.write_text(xml(**changes))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    msg = str(info.value)
    assert str(path) in msg and "line" in msg, msg
    for w in words:
        assert w in msg, (case, msg)


def test_bad_xml_points_at_the_property_line():
    text = xml(alpha="0")
    line = next(i for i, s in enumerate(text.splitlines(), 1) if 'name="alpha"' in s)
    with pytest.raises(SceneError, match=f"line {line} of <string>"):
        load_scene(text)


def test_duplicate_default_and_undefined_parameter():
    head = '<scene version="3.0.0"><default name="r" value="1"/><default name="r" value="2"/>'
    with pytest.raises(SceneError, match="duplicate"):
        load_scene(xml(radius="$r").replace('<scene version="3.0.0">', head))
    with pytest.raises(SceneError, match=r"\$r"):
        load_scene(xml(radius="$r"))


# ----------------------------------------------------------------------------- load_scene params
PARAM_XML = xml(radius="$r").replace('<scene version="3.0.0">',
                                     '<scene version="3.0.0"><default name="r" value="0.5"/>')


@pytest.mark.parametrize("value, exc", [(NAN, ValueError), (INF, ValueError), (None, TypeError),
                                        ({"a": 1}, TypeError), ([[1, 2]], ValueError), ([NAN], ValueError),
                                        (1 + 2j, TypeError)])
def test_params_bad_value_names_params(raises_naming, value, exc):
    with raises_naming(exc, "params"):
        load_scene(PARAM_XML, {"r": value})


@pytest.mark.parametrize("value, words", [(-1, ["radius", "$r", "params"]), (0, ["radius", "$r"]),
                                          ("abc", ["radius", "abc", "$r"]), ("1e300", ["$r"])])
def test_params_bad_substitution_names_the_parameter(value, words):
    with pytest.raises(SceneError) as info:
        load_scene(PARAM_XML, {"r": value})
    for w in words:
        assert w in str(info.value), str(info.value)


def test_params_kinds(raises_naming):
    assert load_scene(PARAM_XML, {"r": 0.25}).shapes[0].sphere()[1] == pytest.approx(0.25)
    assert load_scene(PARAM_XML, {"r": np.float32(2)}).shapes[0].sphere()[1] == pytest.approx(2)
    with raises_naming(TypeError, "params"):
        load_scene(PARAM_XML, [("r", 1)])
    with raises_naming(TypeError, "params"):
        load_scene(PARAM_XML, {1: 1})
    with raises_naming(ValueError, "params"):
        load_scene(PARAM_XML, {"not a name": 1})
    with raises_naming(SceneError, "params"):
        load_scene(PARAM_XML, {"unused": 1})


@pytest.mark.parametrize("source, exc", [(12, TypeError), (None, TypeError), (b"<scene/>", TypeError),
                                         ("", ValueError), ("/nonexistent/scene.xml", SceneError)])
def test_load_scene_bad_source(raises_naming, source, exc):
    with pytest.raises(exc):
        load_scene(source)
    if exc is not SceneError:
        with raises_naming(exc, "source"):
            load_scene(source)


def test_builtin_scene_path_bad_name(raises_naming):
    with raises_naming(TypeError, "name"):
        builtin_scene_path(3)
    with raises_naming(ValueError, "name"):
        builtin_scene_path("nope")


# ----------------------------------------------------------------------------- OBJ files
OBJ_BAD = {
    "nan vertex": ("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", 3, "finite"),
    "inf vertex": ("v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n", 3, "finite"),
    "text vertex": ("v 0 0 0\nv a b c\n", 2, "not numbers"),
    "short vertex": ("v 0 0\n", 1, "3 numbers"),
    "index out of range": ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", 4, "out of range"),
    "index 0": ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 4, "start at 1"),
    "negative out of range": ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", 4, "out of range"),
    "float index": ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 2.5\n", 4, "integer"),
    "two-vertex face": ("v 0 0 0\nv 1 0 0\nf 1 2\n", 3, "at least 3"),
}


@pytest.mark.parametrize("case", sorted(OBJ_BAD))
def test_read_obj_bad_line_names_file_and_line(tmp_path, case):
    text, line, words = OBJ_BAD[case]
    path = tmp_path / "m.obj"
    path.write_text(text)
    with pytest.raises(ValueError, match=f"m.obj:{line}: .*{words}"):
        read_obj(path)
    (tmp_path / "s.xml").write_text(xml().replace(
        '<shape type="rectangle">', '<shape type="obj"><string name="filename" value="m.obj"/></shape>'
        '<shape type="rectangle">'))
    with pytest.raises(SceneError, match=f"filename.*line .* of .*s.xml.*m.obj:{line}"):
        load_scene(tmp_path / "s.xml")


@pytest.mark.parametrize("text, words", [("v 0 0 0\nv 1 0 0\nv 0 1 0\n", "no faces"), ("", "no faces")])
def test_read_obj_empty_or_degenerate(tmp_path, text, words):
    path = tmp_path / "m.obj"
    path.write_text(text)
    with pytest.raises(ValueError, match=words):
        read_obj(path)


@pytest.mark.parametrize("text, words", [("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", "zero area"),
                                         ("v 0 0 0\nv 1e30 0 0\nv 0 1 0\nf 1 2 3\n", "within")])
def test_obj_shape_degenerate_or_huge_names_the_element(tmp_path, text, words):
    (tmp_path / "m.obj").write_text(text)
    (tmp_path / "s.xml").write_text(xml().replace(
        '<shape type="rectangle">', '<shape type="obj"><string name="filename" value="m.obj"/></shape>'
        '<shape type="rectangle">'))
    with pytest.raises(SceneError, match=f"shape.*s.xml.*{words}"):
        load_scene(tmp_path / "s.xml")


def test_obj_shape_missing_file_names_filename(tmp_path):
    (tmp_path / "s.xml").write_text(xml().replace(
        '<shape type="rectangle">', '<shape type="obj"><string name="filename" value="gone.obj"/></shape>'
        '<shape type="rectangle">'))
    with pytest.raises(SceneError, match="filename.*s.xml.*gone.obj"):
        load_scene(tmp_path / "s.xml")


def test_read_obj_unreadable(tmp_path, raises_naming):
    with raises_naming(ValueError, "path"):
        read_obj(tmp_path / "missing.obj")
    with raises_naming(ValueError, "path"):
        read_obj(tmp_path)
    (tmp_path / "bin.obj").write_bytes(b"v \xff\xfe 0 0\n")
    with pytest.raises(ValueError, match="bin.obj:1"):
        read_obj(tmp_path / "bin.obj")
    with raises_naming(TypeError, "path"):
        read_obj(3)


# ----------------------------------------------------------------------------- Python constructors
def sensor(**kw):
    film = {k: kw.pop(k) for k in ("width", "height") if k in kw}
    spp = kw.pop("sample_count", 1)
    base = dict(fov=40.0, fov_axis="x", to_world=np.eye(4))
    return PerspectiveCamera(film=HDRFilm(**{"width": 4, "height": 3, **film}),
                             sampler=IndependentSampler(sample_count=spp), **{**base, **kw})


BAD_SENSOR = [("fov", 0, ValueError), ("fov", 180, ValueError), ("fov", NAN, ValueError), ("fov", "40", TypeError),
              ("fov_axis", "z", ValueError), ("fov_axis", 1, TypeError),
              ("to_world", np.eye(3), ValueError), ("to_world", np.full((4, 4), NAN), ValueError),
              ("to_world", np.diag([2.0, 2, 2, 1]), ValueError), ("to_world", "eye", TypeError),
              ("width", 0, ValueError), ("width", -3, ValueError), ("width", 4.0, TypeError),
              ("width", True, TypeError), ("height", 0, ValueError), ("height", 10**6, ValueError),
              ("sample_count", 0, ValueError), ("sample_count", 1.5, TypeError), ("focal_length", "fifty", ValueError),
              ("near_clip", 0, ValueError), ("far_clip", 1e-3, ValueError),
              ("principal_point_offset_x", NAN, ValueError)]


@pytest.mark.parametrize("name, value, exc", BAD_SENSOR)
def test_sensor_constructor(raises_naming, name, value, exc):
    kw = {name: value}
    if name == "focal_length":
        kw["fov"] = None
    with raises_naming(exc, name):
        sensor(**kw)


def test_sensor_too_many_pixels(raises_naming):
    with raises_naming(ValueError, "width", "height"):
        sensor(width=65536, height=65536)


def test_film_crop_window(raises_naming):
    with raises_naming(ValueError, "crop_width"):
        HDRFilm(width=8, height=8, crop_offset_x=4, crop_width=5)
    with raises_naming(ValueError, "crop_offset_y"):
        HDRFilm(width=8, height=8, crop_offset_y=8)
    with raises_naming(TypeError, "rfilter"):
        HDRFilm(rfilter="box")


@pytest.mark.parametrize("kw, exc, name", [
    (dict(emitter_samples=-1), ValueError, "emitter_samples"),
    (dict(bsdf_samples=1.5), TypeError, "bsdf_samples"), (dict(emitter_samples=0, bsdf_samples=0), ValueError,
                                                          "bsdf_samples"),
    (dict(hide_emitters="no"), TypeError, "hide_emitters")])
def test_integrator_constructor(raises_naming, kw, exc, name):
    with raises_naming(exc, name):
        DirectIntegrator(**{"emitter_samples": 1, "bsdf_samples": 1, **kw})


@pytest.mark.parametrize("depth", [-1, 0, 3, 1.5, True])
def test_path_depth_outside_direct_lighting(raises_naming, depth):
    with raises_naming(ValueError, "max_depth"):
        PathIntegrator(max_depth=depth)


@pytest.mark.parametrize("make, exc, name", [
    (lambda: Diffuse(reflectance=-0.1), ValueError, "reflectance"),
    (lambda: Diffuse(reflectance=NAN), ValueError, "reflectance"),
    (lambda: Diffuse(reflectance="red"), TypeError, "reflectance"),
    (lambda: Diffuse(reflectance=[0.1, 0.2]), ValueError, "reflectance"),
    (lambda: RoughConductor(alpha=0), ValueError, "alpha"), (lambda: RoughConductor(alpha=INF), ValueError, "alpha"),
    (lambda: RoughConductor(alpha="rough"), TypeError, "alpha"),
    (lambda: RoughConductor(distribution="phong"), ValueError, "distribution"),
    (lambda: RoughConductor(sample_visible="yes"), TypeError, "sample_visible"),
    (lambda: Phong(exponent=-1), ValueError, "exponent"), (lambda: Phong(exponent=NAN), ValueError, "exponent"),
    (lambda: Phong(ks=-1), ValueError, "ks"), (lambda: TwoSided("diffuse"), TypeError, "bsdf"),
    (lambda: TwoSided(TwoSided(Diffuse())), ValueError, "bsdf")])
def test_bsdf_constructor(raises_naming, make, exc, name):
    with raises_naming(exc, name):
        make()


@pytest.mark.parametrize("value, exc", [(NAN, ValueError), (-1, ValueError), (INF, ValueError),
                                        ([1, 2], ValueError), ("bright", TypeError), (None, TypeError)])
def test_emitter_constructor(raises_naming, value, exc):
    with raises_naming(exc, "radiance"):
        AreaEmitter(value)


SINGULAR = np.diag([1.0, 1.0, 0.0, 1.0])
PROJECTIVE = np.eye(4)
PROJECTIVE[3, 2] = 1.0


@pytest.mark.parametrize("cls, kw, exc, name", [
    (Rectangle, dict(to_world=SINGULAR), ValueError, "to_world"),
    (Rectangle, dict(to_world=PROJECTIVE), ValueError, "to_world"),
    (Rectangle, dict(to_world=np.full((4, 4), NAN)), ValueError, "to_world"),
    (Rectangle, dict(to_world=np.eye(4) * 1e10), ValueError, "to_world"),
    (Rectangle, dict(to_world=[[1, 2]]), ValueError, "to_world"),
    (Rectangle, dict(bsdf="diffuse"), TypeError, "bsdf"), (Rectangle, dict(emitter=2.0), TypeError, "emitter"),
    (Rectangle, dict(flip_normals="no"), TypeError, "flip_normals"),
    (Sphere, dict(to_world=np.diag([1.0, 2, 1, 1])), ValueError, "to_world"),
    (Sphere, dict(radius=0), ValueError, "radius"), (Sphere, dict(center=[1, 2]), ValueError, "center"),
    (Mesh, dict(vertices=None, faces=None), ValueError, "vertices"),
    (Mesh, dict(vertices=[[0, 0, NAN]], faces=[[0, 0, 0]]), ValueError, "vertices"),
    (Mesh, dict(vertices=np.eye(3), faces=[[0, 1, 3]]), ValueError, "faces"),
    (Mesh, dict(vertices=np.eye(3), faces=[[0.0, 1.0, 2.0]]), ValueError, "faces"),
    (Mesh, dict(vertices=np.eye(3), faces=np.zeros((0, 3), int)), ValueError, "faces"),
    (Mesh, dict(vertices=np.eye(3) * 1e7, faces=[[0, 1, 2]], to_world=np.diag([100.0, 1, 1, 1])), ValueError,
     "vertices")])
def test_shape_constructor(raises_naming, cls, kw, exc, name):
    with raises_naming(exc, name):
        cls(**kw)


def test_register_checks_its_arguments(raises_naming):
    with raises_naming(ValueError, "kind"):
        register("light", "mine")
    with raises_naming(ValueError, "name"):
        register("bsdf", "1st")
    with raises_naming(TypeError, "register"):
        register("bsdf", "mine")(int)
    with raises_naming(TypeError, "register"):
        register("shape", "mine")(Diffuse)
    with raises_naming(ValueError, "name"):
        @register("bsdf", "diffuse")
        class Other(Diffuse):
            pass
    with raises_naming(ValueError, "kind"):
        registered("lights")
    assert registered("bsdf")["diffuse"] is Diffuse


def test_scene_constructor(raises_naming):
    good = tiny()
    with raises_naming(ValueError, "shapes"):
        Scene(good.integrator, good.sensor, [])
    with raises_naming(TypeError, "shapes"):
        Scene(good.integrator, good.sensor, [1])
    with raises_naming(TypeError, "sensor"):
        Scene(good.integrator, None, good.shapes)
    with raises_naming(TypeError, "integrator"):
        Scene("direct", good.sensor, good.shapes)
    with raises_naming(TypeError, "source"):
        Scene(good.integrator, good.sensor, good.shapes, source=3)


def test_changes_in_place_are_checked_by_render(raises_naming):
    sc = tiny()
    sc.sensor.film.width = 0
    with raises_naming(ValueError, "width"):
        render(sc, 1)
    sc = tiny()
    sc.shapes[0].emitter.radiance = np.array([NAN, 1, 1])
    with raises_naming(ValueError, "radiance"):
        render(sc, 1)
    sc = tiny()
    sc.shapes[1].bsdf.reflectance = -1.0
    with raises_naming(ValueError, "reflectance"):
        sc.validate()
    with raises_naming(ValueError, "width"):          # with_size runs the checks
        tiny().with_size(width=-2)


# ----------------------------------------------------------------------------- render()
BAD_RENDER = [
    ("spp", 0, ValueError), ("spp", -1, ValueError), ("spp", 1.5, TypeError), ("spp", "4", TypeError),
    ("spp", True, TypeError), ("spp", 10**12, ValueError),
    ("estimator", "best", ValueError), ("estimator", 42, TypeError), ("estimator", None, TypeError),
    ("rng", "seed", TypeError), ("rng", -1, ValueError), ("rng", 1.5, TypeError), ("rng", True, TypeError),
    ("points", "nope", ValueError), ("points", "sobel", ValueError), ("points", 42, TypeError),
    ("light_selection", "max", ValueError), ("light_selection", None, TypeError),
    ("emitter_samples", -1, ValueError), ("emitter_samples", 1.5, TypeError), ("emitter_samples", 10**9, ValueError),
    ("bsdf_samples", -1, ValueError), ("bsdf_samples", "1", TypeError),
    ("ris_candidates", -1, ValueError), ("ris_candidates", 2.0, TypeError), ("ris_candidates", 10**9, ValueError),
    ("workers", 0, ValueError), ("workers", 2.5, TypeError), ("workers", 10**6, ValueError),
    ("chunk_pixels", 0, ValueError), ("chunk_pixels", 1.0, TypeError),
    ("width", 0, ValueError), ("width", -4, ValueError), ("width", 4.5, TypeError),
    ("height", 0, ValueError), ("height", 10**6, ValueError),
    ("progress", 3, TypeError)]


@pytest.mark.parametrize("name, value, exc", BAD_RENDER)
def test_render_bad_argument(raises_naming, name, value, exc):
    args = {"spp": 1, name: value}
    with raises_naming(exc, name):
        render(tiny(), **args)


@pytest.mark.parametrize("kw, name", [
    (dict(estimator="ris", ris_candidates=0), "ris_candidates"),
    (dict(estimator="bsdf", bsdf_samples=0), "bsdf_samples"),
    (dict(estimator="light", emitter_samples=0), "emitter_samples"),
    (dict(emitter_samples=0, bsdf_samples=0), "bsdf_samples"),
    (dict(points=Sobol(2)), "points"),                   # an engine of another dimension than the pixel's
    (dict(chunk_pixels=1000, spp=100000, spp_batch=100000), "chunk_pixels")])
def test_render_bad_combination(raises_naming, kw, name):
    with raises_naming(ValueError, name):
        render(tiny(), **{"spp": 1, **kw})


def test_render_bad_estimator_object(raises_naming):
    """Estimator objects are checked against the shading integrand: techniques it does not
    have name ``distribution``; an estimator without per-sample unit values names ``estimator``."""
    from vrlab.estimators import MonteCarlo, Stratified

    with raises_naming(ValueError, "distribution"):
        render(tiny(), 1, MonteCarlo("nope"))
    with raises_naming(TypeError, "estimator"):
        render(tiny(), 1, Stratified())
    with raises_naming(TypeError, "estimator"):
        render(tiny(), 1, estimator=MonteCarlo)          # the class, not an instance


def test_render_accepts_paths_xml_and_builtin_names(tmp_path, raises_naming):
    path = tmp_path / "scene.xml"
    path.write_text(xml())
    a = render(path, 1, rng=3).value
    b = render(str(path), 1, rng=3).value
    c = render(xml(), 1, rng=3).value
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, c)
    img = render("furnace", 1, rng=0, width=4, height=3).value
    assert img.shape == (3, 4, 3) and np.all(np.isfinite(img))
    with raises_naming(ValueError, "scene"):
        render("no_such_scene", 1)
    with raises_naming(TypeError, "scene"):
        render(3, 1)
    with raises_naming(TypeError, "scene"):
        render(None, 1)
    with pytest.raises(SceneError, match="cannot read"):
        render(tmp_path / "missing.xml", 1)


@pytest.mark.parametrize("strategy", ["light", "mis-power", "mixture", "ris", "cv"])
def test_power_selection_with_black_emitters_renders_black(strategy):
    """Every emitter black: power selection has nothing to weigh, falls back to uniform,
    and the image is black (as with uniform selection)."""
    sc = load_scene(xml(radiance="0"))
    img = render(sc, 1, strategy, light_selection="power", rng=0).value
    np.testing.assert_array_equal(img, 0.0)
    ref = render(sc, 1, strategy, light_selection="uniform", rng=0).value
    np.testing.assert_array_equal(ref, 0.0)


@pytest.mark.parametrize("selection", ["uniform", "bvh"])
def test_every_preset_renders_a_scene_without_emitters_black(selection):
    """No emitter at all: every preset gives a black image (RIS evaluated f at an empty
    reservoir's placeholder point, light 0, and failed with an IndexError when there was none)."""
    from vrlab.render import PRESETS

    text = xml().replace('<emitter type="area"><rgb name="radiance" value="2"/></emitter>', "")
    sc = load_scene(text)
    assert not sc.emitters
    for strategy in PRESETS:
        img = render(sc, 3, strategy, light_selection=selection, rng=0).value
        np.testing.assert_array_equal(img, 0.0, err_msg=strategy)


def test_power_selection_with_one_black_emitter():
    text = xml().replace('<shape type="rectangle">', '<shape type="rectangle"><transform name="to_world">'
                         '<translate z="-9"/></transform><emitter type="area"><rgb name="radiance" '
                         'value="0"/></emitter></shape><shape type="rectangle">', 1)
    img = render(load_scene(text), 4, "mis-power", light_selection="power", rng=0).value
    assert np.all(np.isfinite(img)) and img.max() > 0


def test_direct_lighting_and_light_set_arguments(raises_naming):
    sc = tiny()
    with raises_naming(TypeError, "scene"):
        DirectLighting("scene.xml")
    with raises_naming(ValueError, "light_selection"):
        DirectLighting(sc, "max")
    with raises_naming(TypeError, "light_selection"):
        DirectLighting(sc, ["uniform"])
    with raises_naming(ValueError, "light_selection"):
        LightSet(sc.shapes, "max")
    with raises_naming(TypeError, "shapes"):
        LightSet([1, 2])


# ----------------------------------------------------------------------------- images
def test_save_image_bad_inputs(tmp_path, raises_naming):
    img = np.zeros((3, 4, 3))
    with raises_naming(ValueError, "path"):
        save_image(tmp_path / "x.jpg", img)
    with raises_naming(ValueError, "path"):
        save_image(tmp_path / "x", img)
    with raises_naming(ValueError, "path"):
        save_image(tmp_path / "missing" / "x.png", img)
    with raises_naming(TypeError, "path"):
        save_image(3, img)
    for bad in (np.zeros((3, 4)), np.zeros((3, 4, 4)), np.zeros((0, 4, 3)), np.zeros(3)):
        with raises_naming(ValueError, "img"):
            save_image(tmp_path / "x.npy", bad)
    with raises_naming(TypeError, "img"):
        save_image(tmp_path / "x.npy", "image")
    nan = img.copy()
    nan[1, 2, 0] = NAN
    with raises_naming(ValueError, "img"):
        save_image(tmp_path / "x.png", nan)
    nan[1, 2, 0] = INF
    with raises_naming(ValueError, "img"):
        save_image(tmp_path / "x.png", nan)
    for exposure, exc in ((0, ValueError), (-1, ValueError), (NAN, ValueError), ("2", TypeError)):
        with raises_naming(exc, "exposure"):
            save_image(tmp_path / "x.png", img, exposure)
    assert save_image(tmp_path / "ok.npy", nan).exists()     # .npy keeps the values as they are
    assert save_image(tmp_path / "ok.png", img).exists()


def test_save_image_png_exposure_auto_and_rounding(tmp_path, raises_naming):
    import matplotlib.image

    from vrlab.render.image import auto_exposure

    rng = np.random.default_rng(2)
    img = rng.pareto(1.5, (20, 30, 1)) * np.array([1.0, 0.8, 0.6])
    auto = matplotlib.image.imread(save_image(tmp_path / "auto.png", img, "auto"))
    fixed = matplotlib.image.imread(save_image(tmp_path / "fixed.png", img, auto_exposure(img)))
    np.testing.assert_array_equal(auto, fixed)
    # at most 3% of the pixels white (all three channels at 255), against many more at exposure 1
    white = (auto[..., :3] == 1.0).all(-1).mean()
    assert white <= 0.03 + 1 / 600
    assert (matplotlib.image.imread(save_image(tmp_path / "one.png", img))[..., :3] == 1.0).all(-1).mean() > 0.1
    # 8 bits by rounding: 1.0 is white (255, not the truncated 254), 0.2 -> round(255 srgb(0.2)) = 124
    grey = np.broadcast_to(np.array([1.0, 0.2, 0.0]), (2, 2, 3))
    px = matplotlib.image.imread(save_image(tmp_path / "grey.png", grey))[0, 0, :3] * 255
    np.testing.assert_array_equal(px, [255, np.rint(255 * srgb_encode(0.2)), 0])
    assert np.rint(255 * srgb_encode(0.2)) == 124 and np.floor(255 * srgb_encode(1.0)) == 254
    for bad in ("Auto", "bright", ""):
        with raises_naming(TypeError, "exposure"):
            save_image(tmp_path / "x.png", img, bad)
    # .npy ignores the exposure and keeps NaN
    nan = img.copy()
    nan[0, 0, 0] = NAN
    assert np.isnan(np.load(save_image(tmp_path / "x.npy", nan, "auto"))[0, 0, 0])


def test_load_image_bad_inputs(tmp_path, raises_naming):
    with raises_naming(ValueError, "path"):
        load_image(tmp_path / "missing.npy")
    with raises_naming(ValueError, "path"):
        load_image(tmp_path / "x.txt")
    np.save(tmp_path / "flat.npy", np.zeros((3, 4)))
    with raises_naming(ValueError, "path"):
        load_image(tmp_path / "flat.npy")
    np.save(tmp_path / "nan.npy", np.full((3, 4, 3), NAN))
    with raises_naming(ValueError, "reference"):
        load_image(tmp_path / "nan.npy", "reference")
    (tmp_path / "junk.npy").write_text("not numpy")
    with raises_naming(ValueError, "path"):
        load_image(tmp_path / "junk.npy")
    np.save(tmp_path / "ok.npy", np.ones((3, 4, 3)))
    assert load_image(tmp_path / "ok.npy").shape == (3, 4, 3)


def test_rel_mse_and_srgb_bad_inputs(raises_naming):
    a = np.ones((3, 4, 3))
    with raises_naming(ValueError, "ref"):
        rel_mse(a, np.ones((4, 3, 3)))
    with raises_naming(ValueError, "img"):
        rel_mse(np.full((3, 4, 3), NAN), a)
    with raises_naming(ValueError, "ref"):
        rel_mse(a, np.zeros((3, 4)))
    with raises_naming(ValueError, "linear"):
        srgb_encode(np.array([0.5, NAN]))
    with raises_naming(TypeError, "linear"):
        srgb_encode(np.array(["a"]))


def test_compare_bad_inputs(tmp_path, raises_naming):
    sc = tiny()
    for strategies, exc in (("bsdf", TypeError), ([], ValueError), (["bsdf", "bsdf"], ValueError),
                            (["best"], ValueError), ([3], TypeError)):
        with raises_naming(exc, "strategies"):
            compare(sc, strategies, 1, ref_spp=1)
    with raises_naming(ValueError, "spp"):
        compare(sc, ["bsdf"], 0, ref_spp=1)
    with raises_naming(ValueError, "ref_spp"):
        compare(sc, ["bsdf"], 1, ref_spp=0)
    with raises_naming(ValueError, "rng"):
        compare(sc, ["bsdf"], 1, rng=-1, ref_spp=1)
    with raises_naming(ValueError, "reference"):
        compare(sc, ["bsdf"], 1, reference=np.zeros((5, 5, 3)))
    with raises_naming(ValueError, "reference"):
        compare(sc, ["bsdf"], 1, reference=np.full((3, 4, 3), NAN))
    with raises_naming(TypeError, "equal_time"):
        compare(sc, ["bsdf"], 1, ref_spp=1, equal_time="yes")
    res = compare(sc, ["bsdf"], 1, ref_spp=1)
    with raises_naming(ValueError, "result"):
        compare_figure({}, tmp_path / "f.png")
    with raises_naming(ValueError, "path"):
        compare_figure(res, tmp_path / "f.xyz")
    with raises_naming(ValueError, "path"):
        compare_figure(res, tmp_path / "missing" / "f.png")
    with raises_naming(ValueError, "exposure"):
        compare_figure(res, tmp_path / "f.png", exposure=0)


# ----------------------------------------------------------------------------- transforms, BSDF models
@pytest.mark.parametrize("call, exc, name", [
    (lambda: tf.translate("abc"), TypeError, "translate"), (lambda: tf.translate([1, 2]), ValueError, "translate"),
    (lambda: tf.translate([1, NAN, 0]), ValueError, "translate"), (lambda: tf.scale([1, INF, 1]), ValueError, "scale"),
    (lambda: tf.rotate([0, 0, 1], NAN), ValueError, "angle"), (lambda: tf.rotate([0, 0, 1], "90"), TypeError, "angle"),
    (lambda: tf.rotate([0, 0, 0], 90), ValueError, "axis"), (lambda: tf.look_at([0, 0, 0], [0, 0, 0], [0, 1, 0]),
                                                            ValueError, "origin"),
    (lambda: tf.look_at([0, 0, 0], [0, 0, 1], [0, 0, 2]), ValueError, "up"),
    (lambda: tf.matrix(range(5)), ValueError, "values"), (lambda: tf.matrix("1 2"), TypeError, "values"),
    (lambda: tf.compose(np.eye(3)), ValueError, "ops"), (lambda: tf.transform_points(np.eye(3), [0, 0, 0]),
                                                         ValueError, "m"),
    (lambda: tf.transform_points(np.eye(4), [0, 0]), ValueError, "p"),
    (lambda: tf.transform_normals(SINGULAR, [0, 0, 1]), ValueError, "m")])
def test_transforms_bad_inputs(raises_naming, call, exc, name):
    with raises_naming(exc, name):
        call()


@pytest.mark.parametrize("call, exc, name", [
    (lambda: Diffuse(-0.1), ValueError, "reflectance"), (lambda: Diffuse(NAN), ValueError, "reflectance"),
    (lambda: Diffuse("grey"), TypeError, "reflectance"), (lambda: Diffuse([0.1, 0.2]), ValueError, "reflectance"),
    (lambda: RoughConductor(0.0), ValueError, "alpha"), (lambda: RoughConductor(1e9), ValueError, "alpha"),
    (lambda: RoughConductor("x"), TypeError, "alpha"), (lambda: RoughConductor(0.1, "phong"), ValueError, "distribution"),
    (lambda: RoughConductor(0.1, None), TypeError, "distribution"),
    (lambda: RoughConductor(0.1, specular_reflectance=INF), ValueError, "specular_reflectance"),
    (lambda: Phong(exponent=-1), ValueError, "exponent"), (lambda: Phong(exponent="30"), TypeError, "exponent"),
    (lambda: Phong(exponent=1e9), ValueError, "exponent"), (lambda: Phong(kd=NAN), ValueError, "kd"),
    (lambda: Phong(ks=-1), ValueError, "ks"), (lambda: Phong(kd=None), TypeError, "kd"),
    (lambda: Beckmann(0), ValueError, "alpha")])
def test_bsdf_models_bad_inputs(raises_naming, call, exc, name):
    with raises_naming(exc, name):
        call()


# ----------------------------------------------------------------------------- geometry
def test_scene_geometry_bad_inputs(raises_naming):
    sc = tiny()
    with raises_naming(TypeError, "scene"):
        SceneGeometry("scene")
    with raises_naming(ValueError, "only"):
        SceneGeometry(sc, [0, 9])
    with raises_naming(ValueError, "only"):
        SceneGeometry(sc, [1, 1])
    with raises_naming(TypeError, "only"):
        SceneGeometry(sc, [0.5])
    g = SceneGeometry(sc)
    o, d = np.zeros((2, 3)), np.array([[0, 0, 1.0], [0, 1.0, 0]])
    for kw, exc, name in ((dict(t_min=NAN), ValueError, "t_min"), (dict(t_min=-1.0), ValueError, "t_min"),
                          (dict(t_min="0"), TypeError, "t_min"), (dict(chunk=0), ValueError, "chunk"),
                          (dict(chunk=2.5), TypeError, "chunk")):
        with raises_naming(exc, name):
            g.intersect(o, d, **kw)
        with raises_naming(exc, name):
            g.distance(o, d, **kw)
    with raises_naming(ValueError, "origin"):
        g.intersect(np.zeros((2, 2)), d)
    with raises_naming(ValueError, "direction"):
        g.intersect(o, np.zeros((3, 3)))



def test_auto_exposure_key_and_clip_closed_forms(raises_naming):
    from vrlab.render.image import auto_exposure

    grey = np.full((8, 8, 3), 2.0)                  # log-average luminance 2 + 1e-4: key / that
    assert auto_exposure(grey) == pytest.approx(0.18 / (2.0 + 1e-4), rel=1e-12)
    # 2% of the pixels 1000x brighter (lights seen directly): with clip=0.03 the 97% quantile is a
    # dim pixel, so the key decides and the lights clip
    img = np.full((20, 20, 3), 0.5)
    img.reshape(-1, 3)[:8] = 500.0
    lum_avg = np.exp(0.98 * np.log(0.5 + 1e-4) + 0.02 * np.log(500 + 1e-4))
    assert auto_exposure(img) == pytest.approx(min(0.18 / lum_avg, 1 / 0.5), rel=1e-9)
    # clip=0.01: the 99% quantile is a light pixel, so the exposure keeps the lights at white
    assert auto_exposure(img, clip=0.01) == pytest.approx(1 / 500, rel=1e-9)
    # at most `clip` of the pixels reach white, for a heavy-tailed image
    rng = np.random.default_rng(3)
    heavy = rng.pareto(1.2, (64, 64, 1)) * np.ones(3)
    e = auto_exposure(heavy)
    assert ((heavy * e).min(-1) >= 1).mean() <= 0.03 + 1 / heavy[..., 0].size
    assert auto_exposure(np.zeros((4, 4, 3))) == 1.0
    with raises_naming(ValueError, "clip"):
        auto_exposure(grey, clip=1.5)
    with raises_naming(ValueError, "key"):
        auto_exposure(grey, key=0)
