"""Image files against Mitsuba 3's ``Bitmap``: EXR written by Mitsuba loads to ``mi.Bitmap(path)``'s
values and ``save_image``'s EXR is read back by Mitsuba unchanged; texture files (8-bit PNG
of every layout, BMP, TGA, JPEG, 16-bit PNG with each of the five PNG row filters) read to the
integers Mitsuba reads; the sRGB curve; error messages."""
from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest

from vrlab.render.image import load_image, read_bitmap, save_image, srgb_decode, srgb_encode

mi = pytest.importorskip("mitsuba")
mi.set_variant("scalar_rgb")
from PIL import Image  # noqa: E402
import OpenEXR  # noqa: E402


def png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def write_png16_filtered(path, a, interlace=0):
    """A 16-bit PNG whose row r uses filter r mod 5 (None, Sub, Up, Average, Paeth; ISO/IEC
    15948 section 9), encoded row by row here as the standard defines them."""
    a = np.asarray(a)
    h, w = a.shape[:2]
    c = 1 if a.ndim == 2 else a.shape[2]
    data = a.astype(">u2").reshape(h, -1).view(np.uint8).astype(np.int64)
    bpp, prev, rows = 2 * c, np.zeros(data.shape[1], np.int64), []
    for y in range(h):
        cur, kind = data[y], y % 5
        left = np.concatenate([np.zeros(bpp, np.int64), cur[:-bpp]])
        upleft = np.concatenate([np.zeros(bpp, np.int64), prev[:-bpp]])
        p = left + prev - upleft
        pa, pb, pc = abs(p - left), abs(p - prev), abs(p - upleft)
        paeth = np.where((pa <= pb) & (pa <= pc), left, np.where(pb <= pc, prev, upleft))
        pred = [0 * cur, left, prev, (left + prev) // 2, paeth][kind]
        rows.append(np.concatenate([[kind], (cur - pred) & 255]))
        prev = cur
    ihdr = struct.pack(">IIBBBBB", w, h, 16, {1: 0, 2: 4, 3: 2, 4: 6}[c], 0, 0, interlace)
    raw = np.concatenate(rows).astype(np.uint8).tobytes()
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + png_chunk(b"IHDR", ihdr) + png_chunk(b"IDAT", zlib.compress(raw))
                     + png_chunk(b"IEND", b""))


@pytest.mark.parametrize("layout", ["RGB", "RGB_half", "RGBA", "Y", "YA"])
def test_load_image_reads_mitsubas_exr(tmp_path, layout):
    rng = np.random.default_rng(len(layout))
    fmt = layout.removesuffix("_half")
    a = (4 * rng.random((5, 7, len(fmt))) - 1).astype(np.float32)        # negative and > 1 kept
    bitmap = mi.Bitmap(a, getattr(mi.Bitmap.PixelFormat, fmt))
    if layout.endswith("_half"):
        bitmap = bitmap.convert(component_format=mi.Struct.Type.Float16)
    bitmap.write(str(tmp_path / "x.exr"))
    theirs = np.array(mi.Bitmap(str(tmp_path / "x.exr")), dtype=np.float32).reshape(5, 7, -1)
    ours = load_image(tmp_path / "x.exr")
    expected = theirs[..., :3] if fmt.startswith("RGB") else np.repeat(theirs[..., :1], 3, axis=-1)
    assert ours.shape == (5, 7, 3)
    np.testing.assert_array_equal(ours, expected)
    b = read_bitmap(tmp_path / "x.exr")
    assert b.channels == fmt and not b.srgb and b.bits == (16 if layout.endswith("_half") else 32)
    np.testing.assert_array_equal(b.data, theirs)


def test_save_image_exr_is_mitsubas_layout(tmp_path):
    img = np.random.default_rng(1).normal(1.0, 2.0, (6, 9, 3))
    path = save_image(tmp_path / "out.exr", img)
    with OpenEXR.File(str(path), separate_channels=True) as f:
        assert sorted(f.channels()) == ["B", "G", "R"]
        assert all(c.pixels.dtype == np.float32 for c in f.channels().values())
    theirs = np.array(mi.Bitmap(str(path)))
    np.testing.assert_array_equal(theirs, img.astype(np.float32))
    np.testing.assert_array_equal(load_image(path), img.astype(np.float32))


@pytest.mark.parametrize("channels", [1, 2, 3, 4])
def test_16_bit_png_with_every_row_filter_reads_as_mitsuba(tmp_path, channels):
    rng = np.random.default_rng(channels)
    for shape in [(11, 6), (1, 4), (7, 1)]:
        a = rng.integers(0, 65536, shape + ((channels,) if channels > 1 else ()))
        write_png16_filtered(tmp_path / "x.png", a)
        theirs = np.array(mi.Bitmap(str(tmp_path / "x.png"))).reshape(shape + (channels,))
        b = read_bitmap(tmp_path / "x.png")
        assert b.channels == ["Y", "YA", "RGB", "RGBA"][channels - 1] and b.srgb and b.bits == 16
        np.testing.assert_array_equal(np.rint(b.data * 65535), theirs)


@pytest.mark.parametrize("mode", ["RGB", "RGBA", "L", "LA", "P", "1", "bmp", "tga"])
def test_8_bit_files_read_as_mitsuba(tmp_path, mode):
    rng = np.random.default_rng(3)
    a = rng.integers(0, 256, (6, 5, 4), dtype=np.uint8)
    image = {"RGB": Image.fromarray(a[..., :3]), "RGBA": Image.fromarray(a, "RGBA"),
             "L": Image.fromarray(a[..., 0], "L"), "LA": Image.fromarray(a[..., :2], "LA"),
             "P": Image.fromarray(a[..., :3]).quantize(5), "1": Image.fromarray(a[..., 0] > 128),
             "bmp": Image.fromarray(a[..., :3]), "tga": Image.fromarray(a[..., :3])}[mode]
    path = tmp_path / f"x.{mode if mode in ('bmp', 'tga') else 'png'}"
    image.save(path)
    theirs = np.array(mi.Bitmap(str(path)))
    b = read_bitmap(path)
    assert b.srgb and b.bits == 8
    np.testing.assert_array_equal(np.rint(b.data * 255).reshape(theirs.shape), theirs)


@pytest.mark.parametrize("mode", ["RGB", "L"])
def test_jpeg_reads_as_mitsuba(tmp_path, mode):
    """JPEG decoders may round the inverse DCT differently: one 8-bit step allowed."""
    a = np.random.default_rng(4).integers(0, 256, (24, 40, 3), dtype=np.uint8)
    Image.fromarray(a).convert(mode).save(tmp_path / "x.jpg", quality=90)
    theirs = np.array(mi.Bitmap(str(tmp_path / "x.jpg")), dtype=float)
    b = read_bitmap(tmp_path / "x.jpg")
    assert b.channels == {"RGB": "RGB", "L": "Y"}[mode] and b.srgb
    assert np.abs(b.data.reshape(theirs.shape) * 255 - theirs).max() <= 1 + 1e-9


def test_srgb_decode_is_the_inverse_curve():
    v = np.linspace(0, 1, 1001)
    np.testing.assert_allclose(srgb_decode(srgb_encode(v)), v, atol=1e-12)
    assert srgb_decode(0.04045) == pytest.approx(0.04045 / 12.92, rel=1e-15)
    assert srgb_decode(0.5) == pytest.approx((0.555 / 1.055) ** 2.4, rel=1e-15)
    assert srgb_decode(1.0) == pytest.approx(1.0, rel=1e-15)


def test_image_file_errors(tmp_path, raises_naming):
    with OpenEXR.File({"type": OpenEXR.scanlineimage}, {"Z": np.zeros((2, 3), np.float32)}) as f:
        f.write(str(tmp_path / "depth.exr"))
    with raises_naming(ValueError, "reference"):
        load_image(tmp_path / "depth.exr", "reference")
    with raises_naming(ValueError, "filename"):
        read_bitmap(tmp_path / "depth.exr")
    (tmp_path / "junk.exr").write_text("not an exr")
    with raises_naming(ValueError, "path"):
        load_image(tmp_path / "junk.exr")
    with pytest.raises(ValueError, match="a .png is tone mapped"):
        load_image(tmp_path / "x.png")
    write_png16_filtered(tmp_path / "laced.png", np.zeros((3, 3, 3), int), interlace=1)
    with raises_naming(ValueError, "filename"):
        read_bitmap(tmp_path / "laced.png")
    (tmp_path / "junk.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 40)
    with raises_naming(ValueError, "filename"):
        read_bitmap(tmp_path / "junk.png")
    with raises_naming(ValueError, "filename"):
        read_bitmap(tmp_path / "x.hdr")
    with raises_naming(TypeError, "filename"):
        read_bitmap(3)
