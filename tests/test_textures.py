"""Textures against Mitsuba 3 (``scalar_rgb``, through its Python API): ``bitmap`` (8/16-bit sRGB
and raw PNG, grey, grey + alpha, RGBA, palette, EXR float/half/Y; nearest and bilinear; the
three wrap modes; ``to_uv`` as a scene-file ``<transform>`` and as a 3 x 3 matrix),
``checkerboard`` (rgb, float, spectrum and texture colours) and ``mesh_attribute`` (vertex and
face attributes on a mesh), at a few hundred random uv in [-1.5, 2.5]^2: eval, eval_1 and
mean to 1e-5; then the error messages."""
from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest

from vrlab.render.loader import build
from vrlab.render.meshes import MeshData
from vrlab.render.textures import BitmapTexture, Checkerboard, MeshAttribute, SurfacePoints
from vrlab.render.xml_props import Ctx, SceneError, parse_xml

mi = pytest.importorskip("mitsuba")
mi.set_variant("scalar_rgb")
from PIL import Image  # noqa: E402
import OpenEXR  # noqa: E402

H, W = 5, 7                     # rows x columns: unequal, so a transposed or flipped image shows
N = 300
TOL = 1e-5


def write_png16(path, a):
    """A 16-bit PNG (filter 0 rows): Pillow writes no 16-bit colour PNG."""
    a = np.asarray(a)
    h, w = a.shape[:2]
    ctype = {1: 0, 2: 4, 3: 2, 4: 6}[1 if a.ndim == 2 else a.shape[2]]
    rows = a.astype(">u2").reshape(h, -1).view(np.uint8)
    raw = np.concatenate([np.zeros((h, 1), np.uint8), rows], 1).tobytes()

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, ctype, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def write_exr(path, a, half=False):
    a = np.asarray(a, np.float16 if half else np.float32)
    names = {1: "Y", 3: "RGB", 4: "RGBA"}[a.shape[2]]
    channels = {c: a[..., k].copy() for k, c in enumerate(names)}
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, channels) as f:
        f.write(str(path))


def make_image(kind, folder):
    """``(filename, Mitsuba's extra parameters, ours)`` of one kind of test image."""
    rng = np.random.default_rng(sum(map(ord, kind)))
    path = folder / f"{kind}.{'exr' if kind.startswith('exr') else 'png'}"
    raw = kind.endswith("_raw")
    base = kind.removesuffix("_raw")
    if base in ("srgb8", "grey8", "rgba8", "la8"):
        mode, c = {"srgb8": ("RGB", 3), "grey8": ("L", 1), "rgba8": ("RGBA", 4), "la8": ("LA", 2)}[base]
        a = rng.integers(0, 256, (H, W, c), dtype=np.uint8)
        Image.fromarray(a[..., 0] if c == 1 else a, mode).save(path)
    elif base == "palette8":
        Image.fromarray(rng.integers(0, 256, (H, W, 3), dtype=np.uint8)).quantize(6).save(path)
    elif base in ("rgb16", "grey16"):
        write_png16(path, rng.integers(0, 65536, (H, W, 3) if base == "rgb16" else (H, W)))
    elif base == "exr_rgb":
        write_exr(path, 3 * rng.random((H, W, 3)))
    elif base == "exr_rgba_half":
        write_exr(path, rng.random((H, W, 4)), half=True)
    elif base == "exr_y":
        write_exr(path, rng.random((H, W, 1)))
    theirs = {"raw": raw, "format": "variant"}        # full precision (Mitsuba's auto: fp16 for 16 bits)
    return path, theirs, {"raw": raw}


def random_uv(seed, n=N, low=-1.5, high=2.5):
    """float32-representable uv (Mitsuba's are float32)."""
    return np.random.default_rng(seed).uniform(low, high, (n, 2)).astype(np.float32).astype(float)


def mitsuba_values(params, uv, si_extra=None, one=True):
    """Mitsuba's eval (N, 3), eval_1 (N,) and mean() of the texture ``params`` at ``uv``."""
    tex = mi.load_dict(params) if isinstance(params, dict) else params
    rgb, scalar = np.empty((len(uv), 3)), np.empty(len(uv))
    si = mi.SurfaceInteraction3f()
    for k, (u, v) in enumerate(uv):
        si.uv = mi.Point2f(u, v)
        if si_extra is not None:
            si_extra(si, k)
        rgb[k] = tex.eval(si)
        if one:
            scalar[k] = tex.eval_1(si)
    return rgb, scalar, tex


def away_from_edges(x, margin=1e-4):
    """Rows of ``x`` (N, 2) whose coordinates are farther than ``margin`` from an integer:
    a nearest lookup or a checkerboard cell that float32 rounding cannot change."""
    f = x - np.floor(x)
    return np.all(np.minimum(f, 1 - f) > margin, axis=1)


def affine_uv(m3, uv):
    return uv @ m3[:2, :2].T + m3[:2, 2]


def build_xml(xml, folder):
    """vrlab's object of one element (Mitsuba's ``load_string`` needs its ``version``)."""
    ctx = Ctx(folder)
    return build(ctx, parse_xml(xml.replace(' version="3.0.0"', ""), "<string>", ctx))


def check_against_mitsuba(ours, params, uv, *, nearest_res=None, m3=None, one=True):
    rgb, scalar, tex = mitsuba_values(params, uv, one=one)
    si = SurfacePoints(uv)
    keep = np.ones(len(uv), bool)
    if nearest_res is not None:                 # leave out points within 1e-4 texel of a texel edge
        keep = away_from_edges(affine_uv(np.eye(3) if m3 is None else m3, uv) * nearest_res)
        assert keep.sum() > 0.9 * len(uv)
    np.testing.assert_allclose(ours.eval(si)[keep], rgb[keep], rtol=TOL, atol=TOL)
    if one:
        np.testing.assert_allclose(ours.eval_1(si)[keep], scalar[keep], rtol=TOL, atol=TOL)
    return tex


IMAGES = ["srgb8", "srgb8_raw", "grey8", "grey8_raw", "rgba8", "la8", "palette8", "rgb16", "rgb16_raw",
          "grey16", "exr_rgb", "exr_rgba_half", "exr_y"]


@pytest.mark.parametrize("filter_type", ["bilinear", "nearest"])
@pytest.mark.parametrize("kind", IMAGES)
def test_bitmap_matches_mitsuba(tmp_path, kind, filter_type):
    path, theirs, ours_kw = make_image(kind, tmp_path)
    ours = BitmapTexture(path, filter_type=filter_type, **ours_kw)
    params = {"type": "bitmap", "filename": str(path), "filter_type": filter_type, **theirs}
    tex = check_against_mitsuba(ours, params, random_uv(1), nearest_res=(W, H) if filter_type == "nearest" else None)
    assert ours.mean_1() == pytest.approx(tex.mean(), rel=TOL, abs=TOL)
    assert ours.resolution == (W, H)


@pytest.mark.parametrize("wrap_mode", ["repeat", "mirror", "clamp"])
@pytest.mark.parametrize("filter_type", ["bilinear", "nearest"])
@pytest.mark.parametrize("kind", ["srgb8", "exr_y"])
def test_bitmap_wrap_modes_match_mitsuba(tmp_path, kind, filter_type, wrap_mode):
    path, theirs, ours_kw = make_image(kind, tmp_path)
    ours = BitmapTexture(path, filter_type=filter_type, wrap_mode=wrap_mode, **ours_kw)
    params = {"type": "bitmap", "filename": str(path), "filter_type": filter_type, "wrap_mode": wrap_mode, **theirs}
    check_against_mitsuba(ours, params, random_uv(2), nearest_res=(W, H) if filter_type == "nearest" else None)


TO_UV_XML = ('<transform name="to_uv"><scale x="2" y="0.5"/><rotate z="1" angle="30"/>'
             '<translate x="0.25" y="-0.1"/></transform>')


@pytest.mark.parametrize("filter_type", ["bilinear", "nearest"])
def test_to_uv_from_a_scene_file_matches_mitsuba(tmp_path, filter_type):
    """A ``<transform>`` (4 x 4) read by vrlab's loader and by Mitsuba's."""
    path, _, _ = make_image("srgb8", tmp_path)
    xml = (f'<texture type="bitmap" version="3.0.0"><string name="filename" value="{path}"/>'
           f'<string name="filter_type" value="{filter_type}"/><string name="wrap_mode" value="mirror"/>'
           f'{TO_UV_XML}</texture>')
    ours = build_xml(xml, tmp_path)
    theirs = mi.load_string(xml)
    m3 = np.array(mi.traverse(theirs)["to_uv"].matrix, float)
    check_against_mitsuba(ours, theirs, random_uv(3), nearest_res=(W, H) if filter_type == "nearest" else None, m3=m3)


def test_to_uv_as_a_3x3_matrix_matches_mitsuba(tmp_path):
    path, theirs, _ = make_image("grey8", tmp_path)
    m3 = np.array([[1.5, 0.4, 0.3], [-0.2, 0.8, -0.6], [0.0, 0.0, 1.0]])
    ours = BitmapTexture(path, to_uv=m3, wrap_mode="clamp")
    params = {"type": "bitmap", "filename": str(path), "wrap_mode": "clamp", "to_uv": mi.ScalarTransform3f(m3),
              **theirs}
    check_against_mitsuba(ours, params, random_uv(4))


def test_tiny_images_match_mitsuba_upsampling(tmp_path):
    """Mitsuba upsamples an image narrower than 2 texels; the values are those of the image."""
    a = np.random.default_rng(5).integers(0, 256, (4, 1, 3), dtype=np.uint8)
    Image.fromarray(a).save(tmp_path / "thin.png")
    ours = BitmapTexture(tmp_path / "thin.png", wrap_mode="clamp")
    check_against_mitsuba(ours, {"type": "bitmap", "filename": str(tmp_path / "thin.png"), "wrap_mode": "clamp"},
                          random_uv(6, 100))


def test_fp16_format_rounds_as_mitsuba(tmp_path):
    """``format="fp16"`` (Mitsuba's default for 16-bit images) stores half-precision texels:
    equal to Mitsuba's to one half-precision ulp at most (2^-11 below 1)."""
    path, _, _ = make_image("rgb16", tmp_path)
    ours = BitmapTexture(path, format="fp16", filter_type="nearest")
    assert np.array_equal(ours.texels, ours.texels.astype(np.float16))
    uv = random_uv(7, 100)
    keep = away_from_edges(uv * (W, H))
    rgb, _, _ = mitsuba_values({"type": "bitmap", "filename": str(path), "filter_type": "nearest"}, uv, one=False)
    assert np.abs(ours.eval(SurfacePoints(uv))[keep] - rgb[keep]).max() <= 2.0 ** -11


CHECKER_CASES = {
    "defaults": "",
    "rgb": '<rgb name="color0" value="0.9, 0.1, 0.3"/><rgb name="color1" value="0.05, 0.6, 0.2"/>',
    "float_and_spectrum": ('<float name="color0" value="0.7"/>'
                           '<spectrum name="color1" value="400:0.1, 550:0.8, 700:0.3"/>'),
    "texture_and_to_uv": ('<texture type="bitmap" name="color1"><string name="filename" value="IMG"/></texture>'
                          '<rgb name="color0" value="0.2, 0.3, 0.9"/>' + TO_UV_XML),
}


@pytest.mark.parametrize("case", sorted(CHECKER_CASES))
def test_checkerboard_matches_mitsuba(tmp_path, case):
    path, _, _ = make_image("srgb8", tmp_path)
    xml = f'<texture type="checkerboard" version="3.0.0">{CHECKER_CASES[case].replace("IMG", str(path))}</texture>'
    ours, theirs = build_xml(xml, tmp_path), mi.load_string(xml)
    uv = random_uv(8)
    m3 = np.array(mi.traverse(theirs)["to_uv"].matrix, float) if "to_uv" in case else np.eye(3)
    keep = away_from_edges(2 * affine_uv(m3, uv))         # cells are half a unit wide
    check_against_mitsuba(ours, theirs, uv[keep])
    assert ours.mean_1() == pytest.approx(theirs.mean(), rel=TOL)


def test_checkerboard_cells():
    """color0 on [0, 1/2]^2 and (1/2, 1)^2 of each unit square (Mitsuba's (fu > 1/2) == (fv > 1/2))."""
    tex = Checkerboard([1, 0, 0], [0, 0, 1])
    uv = np.array([[0.1, 0.1], [0.6, 0.6], [0.5, 0.5], [0.6, 0.1], [0.1, 0.6], [-0.1, 0.1], [1.2, 0.1]])
    np.testing.assert_array_equal(tex.eval(uv)[:, 0], [1, 1, 1, 0, 0, 0, 1])
    np.testing.assert_allclose(tex.mean(), [0.5, 0, 0.5])


def small_mesh():
    """Three triangles with a 3-channel and a 1-channel attribute per vertex and per face."""
    rng = np.random.default_rng(9)
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.5], [2, 0.5, 0.2]], float)
    faces = np.array([[0, 1, 2], [1, 3, 2], [1, 4, 3]])
    va = {"vertex_color": rng.random((5, 3)), "vertex_weight": rng.random((5, 1))}
    fa = {"face_color": rng.random((3, 3)), "face_weight": rng.random(3)[:, None]}
    ours = MeshData(vertices, faces, vertex_attributes=va, face_attributes=fa)
    theirs = mi.Mesh("m", len(vertices), len(faces), has_vertex_normals=False, has_vertex_texcoords=False)
    params = mi.traverse(theirs)
    params["vertex_positions"] = vertices.ravel()
    params["faces"] = faces.ravel()
    params.update()
    for name, a in {**va, **fa}.items():
        theirs.add_attribute(name, a.shape[1], a.ravel().tolist())
    return ours, theirs


@pytest.mark.parametrize("name", ["vertex_color", "vertex_weight", "face_color", "face_weight"])
def test_mesh_attribute_matches_mitsuba(tmp_path, name):
    mesh, theirs = small_mesh()
    rng = np.random.default_rng(10)
    prim = rng.integers(0, 3, 200)
    b = rng.random((200, 2)).astype(np.float32).astype(float)
    b = np.where(b.sum(1, keepdims=True) > 1, 1 - b, b)               # inside the triangle
    points = np.einsum("n,nk->nk", 1 - b.sum(1), mesh.vertices[mesh.faces[prim, 0]]) \
        + b[:, :1] * mesh.vertices[mesh.faces[prim, 1]] + b[:, 1:] * mesh.vertices[mesh.faces[prim, 2]]

    def hit(si, k):                      # Mitsuba finds the barycentrics from the hit point
        si.prim_index, si.p, si.shape = int(prim[k]), mi.Point3f(*points[k]), theirs

    one = "weight" in name
    xml = f'<texture type="mesh_attribute" version="3.0.0"><string name="name" value="{name}"/>' \
          '<float name="scale" value="2.5"/></texture>'
    ours = build_xml(xml, tmp_path)
    rgb, scalar, _ = mitsuba_values(mi.load_string(xml), np.zeros((200, 2)), hit, one=one)
    si = SurfacePoints(np.zeros((200, 2)), prim, b, mesh)
    np.testing.assert_allclose(ours.eval(si), rgb, rtol=TOL, atol=TOL)
    if one:
        np.testing.assert_allclose(ours.eval_1(si), scalar, rtol=TOL, atol=TOL)


# -- errors ----------------------------------------------------------------------------------

def test_bitmap_bad_inputs(tmp_path, raises_naming):
    path, _, _ = make_image("srgb8", tmp_path)
    with raises_naming(ValueError, "filter_type"):
        BitmapTexture(path, filter_type="cubic")
    with raises_naming(ValueError, "wrap_mode"):
        BitmapTexture(path, wrap_mode="border")
    with raises_naming(ValueError, "format"):
        BitmapTexture(path, format="fp32")
    with raises_naming(TypeError, "raw"):
        BitmapTexture(path, raw="yes")
    with raises_naming(ValueError, "filename"):
        BitmapTexture(tmp_path / "missing.png")
    with raises_naming(ValueError, "filename"):
        BitmapTexture(tmp_path / "x.tif")
    with raises_naming(ValueError, "filename"):
        BitmapTexture(path, data=np.zeros((2, 2, 3)))
    with raises_naming(ValueError, "data"):
        BitmapTexture(data=np.zeros((2, 2, 2)))
    with raises_naming(ValueError, "to_uv"):
        BitmapTexture(path, to_uv=np.eye(2))
    Image.new("CMYK", (3, 2)).save(tmp_path / "cmyk.jpg")
    with raises_naming(ValueError, "filename"):
        BitmapTexture(tmp_path / "cmyk.jpg")
    tex = BitmapTexture(path)
    tex.wrap_mode = "border"
    with raises_naming(ValueError, "wrap_mode"):
        tex.validate()
    tex.wrap_mode = "repeat"
    with raises_naming(ValueError, "si.uv"):
        tex.eval(np.zeros((4, 3)))
    with raises_naming(ValueError, "si.uv"):
        tex.eval(np.full((4, 2), np.nan))
    bad = f'<texture type="bitmap" version="3.0.0"><string name="filename" value="{path}"/>'
    with pytest.raises(SceneError, match="unknown parameter 'colour'"):
        build_xml(bad + '<float name="colour" value="1"/></texture>', tmp_path)
    with pytest.raises(SceneError, match="wrap_mode"):
        build_xml(bad + '<string name="wrap_mode" value="border"/></texture>', tmp_path)
    with pytest.raises(SceneError, match="missing.png"):
        build_xml(bad.replace(str(path), "missing.png") + "</texture>", tmp_path)


def test_data_array_and_checkerboard_bad_inputs(raises_naming):
    tex = BitmapTexture(data=np.arange(6.0).reshape(2, 3), filter_type="nearest")
    np.testing.assert_allclose(tex.eval(np.array([[0.5, 0.75]]))[0], [4, 4, 4])        # row 1 = bottom half
    with raises_naming(ValueError, "color0"):
        Checkerboard(color0=[1, 2])
    with raises_naming(TypeError, "color1"):
        Checkerboard(color1="red")
    with raises_naming(ValueError, "to_uv"):
        Checkerboard(to_uv=np.ones((2, 3)))


def test_mesh_attribute_bad_inputs(raises_naming):
    mesh, _ = small_mesh()
    si = SurfacePoints(np.zeros((2, 2)), np.array([0, 2]), np.full((2, 2), 0.25), mesh)
    with raises_naming(ValueError, "name"):
        MeshAttribute("color")
    with raises_naming(TypeError, "name"):
        MeshAttribute(3)
    with raises_naming(ValueError, "scale"):
        MeshAttribute("vertex_color", scale=np.inf)
    with raises_naming(ValueError, "name"):
        MeshAttribute("vertex_albedo").eval(si)
    with raises_naming(ValueError, "name"):
        MeshAttribute("vertex_color").eval_1(si)
    with raises_naming(ValueError, "si.prim"):
        MeshAttribute("face_color").eval(si._replace(prim=None))
    with raises_naming(ValueError, "si.prim"):
        MeshAttribute("face_color").eval(si._replace(prim=np.array([0, 3])))
    with raises_naming(ValueError, "si.bary"):
        MeshAttribute("vertex_color").eval(si._replace(bary=None))
    with raises_naming(ValueError, "si.shape"):
        MeshAttribute("vertex_color").eval(si._replace(shape=None))
    with pytest.raises(NotImplementedError, match="mean"):
        MeshAttribute("vertex_color").mean()
