"""Mitsuba's files load as they are (issue 35, part 5): ``vrlab render -D NAME=VALUE``,
``focus_distance`` on pinhole cameras, ``.hdr``/``.pfm`` images, and the ``volume`` texture
with a ``gridvolume`` (``.vol`` file).  Each against Mitsuba 3 ``scalar_rgb``: its loaders
(``mi.Bitmap``, ``mi.VolumeGrid``), its volume lookups, and its renders by the render-test
criterion (:mod:`vrlab.testing.mitsuba`); deliberately wrong variants must fail."""
from __future__ import annotations

import json
import struct

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba")

from conftest import run_cli   # noqa: E402
from test_mitsuba_elements import SHAPES, W, H, scene   # noqa: E402
from vrlab.render import load_scene   # noqa: E402
from vrlab.render.image import read_bitmap   # noqa: E402
from vrlab.render.textures import SurfacePoints   # noqa: E402
from vrlab.render.volumes.grid import read_vol, write_vol   # noqa: E402
from vrlab.testing.mitsuba import (assert_agrees_with_mitsuba, mean_z_test, mitsuba_reference, render_test,   # noqa: E402
                                   rgb_to_xyz, sample_budget, xyz_stderr_bound)


@pytest.fixture(autouse=True, scope="module")
def _variant():
    mi.set_variant("scalar_rgb")


# ----------------------------------------------------------------------------- -D NAME=VALUE
DEFINED = scene(SHAPES["cube"], integrator='<integrator type="path"><integer name="max_depth" value="$max_depth"/>'
                                           '</integrator>',
                sensor='<sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>'
                ).replace('<scene version="3.0.0">', '<scene version="3.0.0"><default name="max_depth" value="1"/>'
                                                     '<default name="spp" value="1"/>')


def _cli_render(capsys, tmp_path, *defines):
    path = tmp_path / "scene.xml"
    path.write_text(DEFINED)
    code, out, err = run_cli(capsys, ["render", str(path), *defines, "-o", str(tmp_path / "img.npy"), "--stderr-out",
                                      str(tmp_path / "err.npy"), "--workers", "1", "--no-progress", "--json"])
    assert code == 0, err
    return json.loads(out), np.load(tmp_path / "img.npy"), np.load(tmp_path / "err.npy")


def test_defines_on_the_command_line_reach_the_scene_and_agree_with_mitsuba(capsys, tmp_path):
    """``-D max_depth=2 -Dspp=N`` (both spellings): the image has the depth-2 light and N spp,
    and passes Mitsuba's criterion against Mitsuba's render with the same parameters; without
    ``-D max_depth=2`` (the scene's default, 1) it fails against that reference."""
    spp = max(2, sample_budget() // (W * H))
    ref_spp = 4 * spp
    mean, var = mitsuba_reference(DEFINED, ref_spp, params={"max_depth": "2", "spp": str(spp)})
    for defines, agrees in ((["-D", "max_depth=2", f"-Dspp={spp}"], True), ([f"-Dspp={spp}"], False)):
        out, img, err = _cli_render(capsys, tmp_path, *defines)
        assert out["spp"] == spp
        image = rgb_to_xyz(img)
        rt = render_test(image, mean, var, spp)
        mt = mean_z_test(image, xyz_stderr_bound(err), mean, np.sqrt(var / ref_spp))
        assert (rt.passed and mt.passed) == agrees, (defines, str(rt), str(mt))


@pytest.mark.parametrize("mode, target", [(["--compare", "bsdf,light"], "vrlab.render.compare.compare"),
                                          (["--gradient-domain"], "vrlab.render.render_gradient_domain")])
def test_compare_and_gradient_domain_load_the_scene_with_the_defines(capsys, monkeypatch, tmp_path, mode, target):
    """``--compare`` and ``--gradient-domain`` render the scene as ``-D`` set it (their render
    entry is replaced by a recorder: the scene it gets has the defined depth and spp)."""
    seen = []

    def record(scene, *args, **kwargs):
        seen.append(scene)
        raise KeyboardInterrupt
    monkeypatch.setattr(target, record)
    path = tmp_path / "scene.xml"
    path.write_text(DEFINED)
    run_cli(capsys, ["render", str(path), "-D", "max_depth=2", "-Dspp=3", *mode, "--workers", "1", "--no-progress"])
    scene = getattr(seen[0], "scene", seen[0])          # a render plan (gradient domain) or a scene
    assert len(seen) == 1 and scene.sensor.spp == 3 and scene.integrator.max_depth == 2


@pytest.mark.parametrize("flags, names", [
    (["-D", "spp"], ["-D", "NAME=VALUE"]),
    (["-D", "=3"], ["-D", "empty"]),
    (["-D", "1x=3"], ["-D", "1x"]),
    (["-D", "spp=1", "-D", "spp=2"], ["-D", "twice"]),
    (["-D", "foo=1"], ["-D", "foo", "not used"]),
    (["-D", "spp=abc"], ["sample_count", "from -D"]),
])
def test_a_bad_define_is_a_one_line_error_naming_it(capsys, tmp_path, flags, names):
    path = tmp_path / "scene.xml"
    path.write_text(DEFINED)
    code, _, err = run_cli(capsys, ["render", str(path), *flags, "--no-progress"])
    lines = err.strip().splitlines()
    assert code in (1, 2) and len(lines) == 1 and "Traceback" not in err, err
    for name in names:
        assert name in lines[0], (name, lines[0])


# ----------------------------------------------------------------------------- focus_distance
@pytest.mark.parametrize("camera", ["perspective", "orthographic"])
def test_focus_distance_is_accepted_and_ignored_by_a_pinhole_camera_as_in_mitsuba(camera):
    xml = scene(SHAPES["cube"], camera=camera, sensor='<float name="focus_distance" value="2.5"/>')
    assert load_scene(xml).sensor.focus_distance == 2.5
    assert_agrees_with_mitsuba(xml)


# ----------------------------------------------------------------------------- .hdr and .pfm
def _rgbe_file(path, rows: bytes, w: int, h: int, header: bytes = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n"):
    path.write_bytes(header + f"-Y {h} +X {w}\n".encode() + rows)
    return path


def test_rgbe_flat_and_run_length_encoded_pixels_have_their_closed_form_values(tmp_path):
    """value = m 2^(e - 136), 0 for e = 0 (Ward's RGBE, Mitsuba's ``rgbe_to_float``): a flat
    2 x 2 file and a run-length encoded 2 x 8 one (runs and literals in every channel)."""
    flat = _rgbe_file(tmp_path / "flat.hdr", bytes([128, 64, 0, 129, 1, 2, 3, 136, 9, 9, 9, 0, 255, 0, 128, 120]), 2, 2)
    want = np.array([[[1, 0.5, 0], [1, 2, 3]], [[0, 0, 0], [255 * 2.0 ** -16, 0, 128 * 2.0 ** -16]]])
    assert np.array_equal(read_bitmap(flat).data, want)
    w = 8
    pixels = np.array([[[10 + x, 200, (x // 2) * 30, 130 + (x > 4)] for x in range(w)],
                       [[7, 7, 7, 135]] * w], np.uint8)

    def rle(channel: np.ndarray) -> bytes:            # literals for the first half, one run for the rest
        return bytes([4, *channel[:4]]) + bytes([128 + 4, channel[4]]) if len(set(channel[4:])) == 1 else \
            bytes([8, *channel])
    rows = b"".join(bytes([2, 2, 0, w]) + b"".join(rle(row[:, c]) for c in range(4)) for row in pixels)
    got = read_bitmap(_rgbe_file(tmp_path / "rle.hdr", rows, w, 2)).data
    e = pixels[..., 3].astype(int)
    assert np.array_equal(got, pixels[..., :3] * np.ldexp(1.0, e - 136)[..., None])
    assert np.array_equal(got, np.array(mi.Bitmap(str(tmp_path / "rle.hdr"))))


@pytest.mark.parametrize("size", [(3, 5), (4, 8), (9, 37), (2, 300)])
def test_hdr_and_pfm_files_read_as_mitsuba_reads_them(tmp_path, size):
    """Files written by Mitsuba (``.hdr``: flat below 8 columns, run-length encoded from 8;
    ``.pfm``: little-endian, rows bottom to top) give mi.Bitmap's values exactly; both linear."""
    rng = np.random.default_rng(size[1])
    img = (rng.random((*size, 3)) * np.exp(rng.normal(0, 3, (*size, 1)))).astype(np.float32)
    img[:, size[1] // 3: size[1] // 2 + 1] = 0.7                  # runs
    img[0, 0] = 0
    for suffix in ("hdr", "pfm"):
        path = str(tmp_path / f"x.{suffix}")
        mi.Bitmap(img).write(path)
        b = read_bitmap(path)
        assert (b.channels, b.srgb, b.bits) == ("RGB", False, 32)
        assert np.array_equal(b.data, np.array(mi.Bitmap(path)))
    assert np.array_equal(read_bitmap(tmp_path / "x.pfm").data, img)


@pytest.mark.parametrize("kind, scale, order", [("PF", -1.0, "<f4"), ("Pf", 2.0, ">f4"), ("PF", 0.5, ">f4")])
def test_pfm_colour_and_grey_either_byte_order_bottom_row_first(tmp_path, kind, scale, order):
    c = 3 if kind == "PF" else 1
    stored = np.arange(3 * 4 * c, dtype=np.float32).reshape(3, 4, c) - 5.5     # rows bottom to top
    path = tmp_path / "x.pfm"
    path.write_bytes(f"{kind}\n4 3\n{scale}\n".encode() + stored.astype(order).tobytes())
    b = read_bitmap(path)
    assert b.channels == ("RGB" if c == 3 else "Y")
    assert np.array_equal(b.data, stored[::-1] * abs(scale))                  # top row first, times |scale|
    assert np.array_equal(b.data.reshape(3, 4, c), np.array(mi.Bitmap(str(path))).reshape(3, 4, c))


@pytest.mark.parametrize("name, content", [
    ("hdr header", b"RADIANCE\n"),
    ("hdr format", b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\x01\x01\x01\x80"),
    ("hdr orientation", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n+Y 1 +X 1\n\x01\x01\x01\x80"),
    ("hdr truncated flat", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 2\n\x01\x01\x01\x80"),
    ("hdr truncated rle", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 8\n\x02\x02\x00\x08\x88\x05"),
    ("hdr zero count", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 8\n\x02\x02\x00\x08" + b"\x00" * 40),
    ("hdr run across channels", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 8\n\x02\x02\x00\x08\x8c\x01"
                                b"\x84\x02\x88\x03\x88\x04"),
    ("pfm header", b"P6\n1 1\n-1\n" + bytes(12)),
    ("pfm scale", b"PF\n1 1\n0\n" + bytes(12)),
    ("pfm truncated", b"PF\n2 2\n-1\n" + bytes(40)),
])
def test_a_bad_or_truncated_image_is_a_value_error_naming_the_file(tmp_path, name, content):
    path = tmp_path / ("bad.pfm" if name.startswith("pfm") else "bad.hdr")
    path.write_bytes(content)
    with pytest.raises(ValueError, match=r"filename: cannot read image .*bad\.(hdr|pfm)"):
        read_bitmap(path)


def test_hdr_envmap_agrees_with_mitsuba(tmp_path):
    """An envmap from a Mitsuba-written (run-length encoded) .hdr lighting a sphere."""
    env = (np.random.default_rng(3).random((16, 32, 3)) * 0.6).astype(np.float32)
    env[3:5, 20:23] = 25.0
    mi.Bitmap(env).write(str(tmp_path / "env.hdr"))
    assert_agrees_with_mitsuba(scene(SHAPES["sphere"] + f'<emitter type="envmap"><string name="filename" value="'
                                     f'{tmp_path / "env.hdr"}"/></emitter>', lights=False))


def test_pfm_bitmap_agrees_with_mitsuba(tmp_path):
    """A diffuse floor textured by a grey, big-endian .pfm (rows bottom to top)."""
    tex = np.kron(np.random.default_rng(3).random((3, 4)), np.ones((2, 2))).astype(np.float32) * 0.9
    (tmp_path / "tex.pfm").write_bytes(b"Pf\n8 6\n1.0\n" + tex[::-1].astype(">f4").tobytes())
    assert_agrees_with_mitsuba(scene(
        '<shape type="rectangle"><transform name="to_world"><scale value="1.5"/><rotate x="1" angle="-90"/>'
        '<translate y="0.01"/></transform><bsdf type="diffuse"><texture type="bitmap" name="reflectance">'
        f'<string name="filename" value="{tmp_path / "tex.pfm"}"/><string name="filter_type" value="nearest"/>'
        '</texture></bsdf></shape>'))


# ----------------------------------------------------------------------------- volume texture
def _grid(channels: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).random((3, 4, 5, channels)).astype(np.float32)


def test_vol_files_round_trip_with_mitsubas_volume_grid(tmp_path):
    a = _grid(3)
    mi.VolumeGrid(a).write(str(tmp_path / "mi.vol"))
    data, bbox = read_vol(tmp_path / "mi.vol")
    assert np.array_equal(data, a) and np.array_equal(bbox, [[0, 0, 0], [1, 1, 1]])
    write_vol(tmp_path / "vr.vol", a[..., :1], ((-1, 0, 2), (1, 3, 4)))
    back = mi.VolumeGrid(str(tmp_path / "vr.vol"))
    assert np.array_equal(np.array(back).reshape(a.shape[:3]), a[..., 0])
    box = mi.load_dict({"type": "gridvolume", "filename": str(tmp_path / "vr.vol"), "use_grid_bbox": True}).bbox()
    assert np.allclose([list(box.min), list(box.max)], [[-1, 0, 2], [1, 3, 4]])


def _mitsuba_texture(xml: str):
    return mi.load_string(f'<texture version="3.0.0" type="volume">{xml}</texture>')


@pytest.mark.parametrize("channels", [1, 3])
@pytest.mark.parametrize("options", [
    "", '<string name="filter_type" value="nearest"/>', '<string name="wrap_mode" value="repeat"/>',
    '<string name="wrap_mode" value="mirror"/><boolean name="use_grid_bbox" value="true"/>'])
def test_volume_texture_values_agree_with_mitsuba(tmp_path, channels, options):
    """eval and eval_1 of ``<texture type="volume">`` around a ``gridvolume`` (moved, turned
    and stretched by ``to_world``), at points inside and outside its box, equal Mitsuba's to
    float32 rounding; a grid read with x and z swapped does not."""
    path = write_vol(tmp_path / "g.vol", _grid(channels), ((-0.5, 0, 0.2), (1, 1.2, 0.8)))
    xml = (f'<volume type="gridvolume" name="volume"><string name="filename" value="{path}"/>{options}'
           '<transform name="to_world"><scale x="1.5" y="0.7" z="1.1"/><rotate x="0.6" y="0.8" angle="35"/>'
           '<translate x="0.2" y="-0.1" z="0.3"/></transform></volume>')
    ours = load_scene(scene(f'<shape type="sphere"><bsdf type="diffuse"><texture type="volume" name="reflectance">'
                            f'{xml}</texture></bsdf></shape>')).shapes[-1].bsdf.reflectance
    theirs = _mitsuba_texture(xml)
    p = np.random.default_rng(1).uniform(-0.6, 2.0, (150, 3))
    si = mi.SurfaceInteraction3f()
    ref, ref1 = [], []
    for q in p:
        si.p = mi.Point3f(*q)
        ref.append(list(theirs.eval(si)))
        ref1.append(theirs.eval_1(si))
    points = SurfacePoints(np.zeros((len(p), 2)), p=p)
    assert np.allclose(ours.eval(points), ref, rtol=0, atol=2e-6)
    assert np.allclose(ours.eval_1(points), ref1, rtol=0, atol=2e-6)
    z_fastest = ours.volume.grid.reshape(5, 4, 3, channels).transpose(2, 1, 0, 3)      # a reader with z fastest
    ours.volume.grid = np.ascontiguousarray(z_fastest)
    assert not np.allclose(ours.eval(points), ref, rtol=0, atol=2e-6)


def test_constvolume_and_colours_as_volumes():
    """``constvolume`` (``value``: eval the colour, eval_1 its channel mean, as Mitsuba), and a
    ``<float>``/``<rgb>`` volume (Mitsuba's documented shorthand, a constvolume)."""
    p = SurfacePoints(np.zeros((2, 2)), p=np.array([[0.3, 0.2, 0.1], [5.0, -3, 2]]))
    si = mi.SurfaceInteraction3f()
    si.p = mi.Point3f(0.3, 0.2, 0.1)
    for inner in ('<float name="value" value="0.3"/>', '<rgb name="value" value="0.1, 0.2, 0.9"/>', ""):
        xml = f'<volume type="constvolume" name="volume">{inner}</volume>'
        theirs = _mitsuba_texture(xml)
        ours = load_scene(scene(f'<shape type="sphere"><bsdf type="diffuse"><texture type="volume" '
                                f'name="reflectance">{xml}</texture></bsdf></shape>')).shapes[-1].bsdf.reflectance
        assert np.allclose(ours.eval(p), [list(theirs.eval(si))] * 2, atol=1e-7)
        assert np.allclose(ours.eval_1(p), theirs.eval_1(si), atol=1e-7)
    shorthand = load_scene(scene('<shape type="sphere"><bsdf type="diffuse"><texture type="volume" '
                                 'name="reflectance"><rgb name="volume" value="0.1, 0.2, 0.9"/></texture></bsdf>'
                                 '</shape>')).shapes[-1].bsdf.reflectance
    assert np.allclose(shorthand.eval(p), [[0.1, 0.2, 0.9]] * 2) and np.allclose(shorthand.eval_1(p), 0.4)


@pytest.mark.parametrize("name, content, match", [
    ("magic", b"VOX\x03" + bytes(44), "not a Mitsuba .vol"),
    ("version", b"VOL\x02" + bytes(44), "version 2"),
    ("encoding", b"VOL\x03" + struct.pack("<5i", 2, 1, 1, 1, 1) + bytes(28), "encoding 2"),
    ("channels", b"VOL\x03" + struct.pack("<5i", 1, 1, 1, 1, 6) + bytes(48), "6 channels"),
    ("truncated", b"VOL\x03" + struct.pack("<5i", 1, 2, 2, 2, 1) + bytes(24 + 28), "ends early"),
])
def test_a_bad_vol_file_is_an_error_naming_the_file(tmp_path, name, content, match):
    path = tmp_path / "bad.vol"
    path.write_bytes(content)
    with pytest.raises(ValueError, match=f"filename: cannot read volume .*bad.vol.*{match}"):
        read_vol(path)
    with pytest.raises(ValueError, match=r"<string name=\"filename\">.*bad\.vol"):
        load_scene(scene(f'<shape type="sphere"><bsdf type="diffuse"><texture type="volume" name="reflectance">'
                         f'<volume type="gridvolume" name="volume"><string name="filename" value="{path}"/>'
                         '</volume></texture></bsdf></shape>'))


def test_volume_textured_sphere_agrees_with_mitsuba_and_a_turned_volume_fails(tmp_path):
    """A sphere whose reflectance is a 3-channel grid around it (``to_world`` fits the grid's
    unit cube to the sphere's box): the render passes the criterion; the grid turned 90 degrees
    about y fails against the same reference."""
    rng = np.random.default_rng(7)
    grid = np.kron(rng.random((2, 2, 2, 3)), np.ones((2, 2, 2, 1))) * 0.8 + 0.1
    path = write_vol(tmp_path / "ball.vol", grid)
    place = '<scale value="1"/><translate x="-0.5" z="-0.5"/>'
    xml = scene(f'<shape type="sphere"><point name="center" value="0, 0.5, 0"/><float name="radius" value="0.5"/>'
                f'<bsdf type="diffuse"><texture type="volume" name="reflectance"><volume type="gridvolume" '
                f'name="volume"><string name="filename" value="{path}"/><transform name="to_world">{place}'
                '</transform></volume></texture></bsdf></shape>')
    agreement = assert_agrees_with_mitsuba(xml)
    turned = xml.replace(place, '<translate x="-0.5" z="-0.5"/><rotate y="1" angle="90"/>')
    with pytest.raises(AssertionError):
        assert_agrees_with_mitsuba(turned, reference=agreement.reference)
