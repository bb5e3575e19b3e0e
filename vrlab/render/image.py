"""Images: saving and loading linear renders, tone mapping for PNG, and error metrics.

* ``.npy``: the linear float32 (H, W, 3) image, unchanged (NaN kept: the standard error
  of a 1-spp render is NaN).
* ``auto_exposure(img)``: the scale that maps the log-average luminance exp(mean log(1e-4
  + Y)) (Y the luminance of :mod:`vrlab.colour`) to the mid-grey key 0.18 (Reinhard
  et al. 2002, "Photographic tone reproduction"), lowered where needed so that the
  brightest 3% of the pixels at most reach white: directly seen lights clip, the lit
  scene does not.  Figures
  that compare images use one exposure for all of them.
* ``.png``: clamp to [0, 1] after an exposure scale, then the sRGB transfer curve
  (IEC 61966-2-1: 12.92 v for v <= 0.0031308, else 1.055 v^(1/2.4) - 0.055), rounded to
  8 bits (round(255 v));
  NaN or infinite pixels are an error (they have no colour).
* ``.exr``: through the ``OpenEXR`` package, as Mitsuba 3 writes and reads it (src/core/
  bitmap.cpp): :func:`save_image` writes float32 channels ``R``, ``G``, ``B`` (ZIP
  compression); :func:`load_image` reads ``R``, ``G``, ``B`` (``A`` and other channels
  ignored) or a grey ``Y`` (repeated into the three channels), half or float, with the
  values of ``mi.Bitmap(path)``.
* :func:`read_bitmap` reads a texture file the way Mitsuba 3's ``Bitmap`` does (PNG,
  JPEG, BMP, TGA through Pillow, 16-bit PNG decoded here, EXR, Radiance HDR and PFM), and
  :func:`srgb_decode` is the sRGB transfer curve's inverse.
* ``rel_mse(img, ref) = mean((img - ref)^2 / (ref^2 + 0.01))`` (relative MSE as used in
  rendering papers, e.g. Rousselle et al. 2011).

Checked: the path's type, suffix and folder (``save_image``) or existence
(``load_image``), the image's shape ``(H, W, 3)`` with H, W >= 1 and real values,
``exposure`` finite and > 0 or ``"auto"``; errors name the argument.

``save_image(path, img, exposure=...)`` keeps ``exposure=1.0`` as its default (a PNG
shows the linear values unscaled, so e.g. standard-error images of several renders are
comparable); ``exposure="auto"`` uses ``auto_exposure(img)``.  ``vrlab render -o x.png``
defaults to ``--exposure auto`` and reports the exposure it used.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from .. import checks
from ..colour import luminance

__all__ = ["BITMAP_SUFFIXES", "Bitmap", "auto_exposure", "load_image", "read_bitmap", "rel_mse", "save_image",
           "srgb_decode", "srgb_encode"]

SUFFIXES = (".npy", ".png", ".exr")


def _image(value: Any, name: str, finite: bool) -> np.ndarray:
    """``value`` as a float array ``(H, W, 3)``, H, W >= 1 (finite if ``finite``)."""
    if finite:
        a = checks.finite_array(value, name)
    else:
        try:
            a = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise TypeError(f"{name} must be an array of real numbers, got {type(value).__name__}") from None
    if a.ndim != 3 or a.shape[-1] != 3 or a.size == 0:
        raise ValueError(f"{name}: expected an image of shape (H, W, 3) with H, W >= 1, got {a.shape}")
    return a


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """Linear values to sRGB-encoded values in [0, 1] (clamped to [0, 1] first; NaN is an error)."""
    v = np.asarray(linear)
    if v.dtype.kind not in "fiub":
        raise TypeError(f"linear must be an array of real numbers, got dtype {v.dtype}")
    if np.isnan(v).any():
        raise ValueError("linear: the image has NaN values (no colour to encode)")
    v = np.clip(v.astype(float, copy=False), 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)


def auto_exposure(img: np.ndarray, key: float = 0.18, clip: float = 0.03) -> float:
    """min(key / exp(mean log(1e-4 + Y)), 1 / (the (1 - clip) quantile of Y)) over the finite
    pixels' luminance Y (see the module docstring); 1.0 for an image without light."""
    img = _image(img, "img", False)
    key = checks.real(key, "key", low=0.0, low_open=True)
    clip = checks.real(clip, "clip", low=0.0, high=1.0)
    lum = luminance(img)
    lum = np.maximum(lum[np.isfinite(lum)], 0.0)
    if lum.size == 0 or not np.any(lum > 0):
        return 1.0
    scale = key / float(np.exp(np.mean(np.log(1e-4 + lum))))
    top = float(np.quantile(lum, 1.0 - clip))
    return min(scale, 1.0 / top) if top > 0 else scale


def rel_mse(img: np.ndarray, ref: np.ndarray) -> float:
    """mean((img - ref)^2 / (ref^2 + 0.01)) over all pixels and channels of two finite
    images of the same shape ``(H, W, 3)``."""
    img, ref = _image(img, "img", True), _image(ref, "ref", True)
    if img.shape != ref.shape:
        raise ValueError(f"ref: shape {ref.shape} of the reference differs from the image's {img.shape}")
    from ..metrics import rel_mse as _rel_mse     # the one relMSE (vrlab.metrics)

    return _rel_mse(img, ref)


def save_image(path: str | Path, img: np.ndarray, exposure: float | str = 1.0) -> Path:
    """Save a linear (H, W, 3) image as .npy, .png (sRGB of clamp(exposure x img)) or .exr;
    returns the path.  ``exposure``: a number > 0 (default 1.0) or ``"auto"``
    (:func:`auto_exposure` of ``img``); used by .png only.

    ``ValueError`` for another suffix, a folder that does not exist, a wrong shape, NaN or
    infinite pixels in a PNG, or ``exposure`` not finite and > 0 (``TypeError``: a string
    other than ``"auto"``)."""
    path = checks.file_path(path, "path", SUFFIXES)
    img = _image(img, "img", False).astype(np.float32)
    if isinstance(exposure, str):
        if exposure != "auto":
            raise TypeError(f"exposure must be 'auto' or a number > 0, got {exposure!r}")
    else:
        exposure = checks.real(exposure, "exposure", low=0, low_open=True)
    suffix = path.suffix.lower()
    if suffix == ".npy":
        np.save(path, img)
    elif suffix == ".png":
        bad = ~np.isfinite(img)
        if bad.any():
            i, j, c = (int(k) for k in np.argwhere(bad)[0])
            raise ValueError(f"img: pixel ({i}, {j}) channel {c} is {img[i, j, c]} ({int(bad.sum())} "
                             "non-finite values); a PNG cannot hold it, save as .npy")
        import matplotlib.image

        if exposure == "auto":
            exposure = auto_exposure(img)
        with np.errstate(over="ignore"):
            encoded = srgb_encode(img.astype(float) * exposure)
        # rounded to 8 bits (a plain cast would truncate: 1.055 - 0.055 = 0.99999... -> 254, never white)
        matplotlib.image.imsave(path, np.rint(encoded * 255).astype(np.uint8))
    else:
        try:
            import OpenEXR  # type: ignore[import-not-found]
        except ImportError:
            raise ValueError("path: writing .exr needs the OpenEXR package (pip install OpenEXR); "
                             "use .npy for the linear image") from None
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        with OpenEXR.File(header, {"RGB": img}) as f:
            f.write(str(path))
    return path


def load_image(path: str | Path, name: str = "path") -> np.ndarray:
    """A linear (H, W, 3) float image from ``.npy`` or ``.exr`` (channels R, G, B, or a grey
    Y repeated three times; see the module docstring), e.g. a reference for
    :func:`rel_mse`.  ``ValueError`` naming ``name`` if the file is missing, unreadable,
    not (H, W, 3) or not finite."""
    p = checks.file_path(path, name, SUFFIXES, write=False)
    if p.suffix.lower() == ".png":
        raise ValueError(f"{name}: a .png is tone mapped; load a linear .npy or .exr image")
    if not p.is_file():
        raise ValueError(f"{name}: no such file {str(p)!r}")
    if p.suffix.lower() == ".npy":
        try:
            data = np.load(p, allow_pickle=False)
        except Exception as exc:  # noqa: BLE001 - any unreadable file
            raise ValueError(f"{name}: cannot read image {str(p)!r}: {exc}") from None
    else:
        data, channels, _ = _read_exr(p, name)
        data = data[..., :3] if channels.startswith("RGB") else np.repeat(data[..., :1], 3, axis=-1)
    return _image(data, name, True)


# -- texture files (Mitsuba 3's Bitmap reader, src/core/bitmap.cpp) ---------------------------

BITMAP_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tga", ".exr", ".hdr", ".pfm")


class Bitmap(NamedTuple):
    """A texture file's pixels as Mitsuba 3's ``Bitmap`` holds them (rows top to bottom).

    ``data``: ``(H, W, C)`` float64; integer formats are normalised, value / (2^bits - 1),
    and not yet decoded from sRGB; EXR values as stored.  ``channels``: ``"Y"``, ``"YA"``,
    ``"RGB"`` or ``"RGBA"`` (C = 1, 2, 3, 4; alpha straight, not premultiplied, as PNG
    stores it).  ``srgb``: whether the values are sRGB-encoded (Mitsuba 3 treats every PNG,
    JPEG, BMP and TGA so, whatever gAMA/iCCP chunks say; EXR is linear).  ``bits``: 8 or
    16 (integers), 16 (half) or 32 (float) for EXR.
    """

    data: np.ndarray
    channels: str
    srgb: bool
    bits: int


def srgb_decode(encoded: Any) -> np.ndarray:
    """The inverse sRGB transfer curve (IEC 61966-2-1), as Mitsuba 3 decodes 8/16-bit
    images: v / 12.92 for v <= 0.04045, else ((v + 0.055) / 1.055)^2.4."""
    v = np.asarray(encoded, dtype=float)
    return np.where(v <= 0.04045, v / 12.92, np.power((np.maximum(v, 0.04045) + 0.055) / 1.055, 2.4))


def read_bitmap(path: str | Path, name: str = "filename") -> Bitmap:
    """The pixels of a texture file (:class:`Bitmap`), read as Mitsuba 3 does: PNG (1 to 16
    bits; palette expanded to RGB, a tRNS key to alpha), JPEG, BMP and TGA through Pillow,
    16-bit PNG decoded here (Pillow keeps 8 of the 16 bits of colour PNGs), EXR through
    ``OpenEXR`` (channels R, G, B [A] or Y [A]), Radiance ``.hdr`` and ``.pfm``
    (:mod:`vrlab.render.image_hdr`; linear, 32-bit float).  ``ValueError`` naming ``name`` for a
    missing file, another suffix, or a pixel layout Mitsuba refuses (CMYK, ...)."""
    p = checks.file_path(path, name, BITMAP_SUFFIXES, write=False)
    if not p.is_file():
        raise ValueError(f"{name}: no such file {str(p)!r}")
    if p.suffix.lower() == ".exr":
        data, channels, bits = _read_exr(p, name)
        return Bitmap(data.astype(float), channels, False, bits)
    if p.suffix.lower() in (".hdr", ".pfm"):              # linear float formats (vrlab.render.image_hdr)
        from .image_hdr import read_pfm, read_rgbe

        data, channels = (read_rgbe(p, name), "RGB") if p.suffix.lower() == ".hdr" else read_pfm(p, name)
        return Bitmap(data.astype(float), channels, False, 32)
    with open(p, "rb") as fh:
        head = fh.read(33)
    if head[:8] == b"\x89PNG\r\n\x1a\n" and len(head) == 33 and head[24] == 16:
        data, channels = _read_png16(p, name)
        return Bitmap(data / 65535.0, channels, True, 16)
    from PIL import Image

    try:
        with Image.open(p) as im:
            im.load()
            mode = im.mode
            if mode in ("1", "P", "PA"):
                im = im.convert("L" if mode == "1" else "RGB")
                mode = im.mode
            layout = {"L": "Y", "LA": "YA", "RGB": "RGB", "RGBA": "RGBA"}.get(mode)
            if layout is None:
                raise ValueError(f"{name}: {str(p)!r} has pixel mode {mode!r}; supported: grey, grey + alpha, "
                                 "RGB, RGBA, palette (8 bits per channel) or 16-bit PNG")
            data = np.asarray(im, dtype=np.uint8)
    except ValueError:
        raise
    except Exception as exc:  # noqa: BLE001 - any unreadable file
        raise ValueError(f"{name}: cannot read image {str(p)!r}: {exc}") from None
    data = data.reshape(data.shape[0], data.shape[1], len(layout))
    return Bitmap(data / 255.0, layout, True, 8)


def _read_exr(p: Path, name: str) -> tuple[np.ndarray, str, int]:
    """``(data (H, W, C) float32, channels, bits)`` of an EXR file's first part: channels
    R, G, B (and A), else Y (and A), as Mitsuba 3's Bitmap picks them."""
    try:
        import OpenEXR  # type: ignore[import-not-found]
    except ImportError:
        raise ValueError(f"{name}: reading .exr needs the OpenEXR package (pip install OpenEXR)") from None
    try:
        with OpenEXR.File(str(p), separate_channels=True) as f:
            found = {k: np.asarray(v.pixels) for k, v in f.channels().items()}
    except Exception as exc:  # noqa: BLE001 - any unreadable file
        raise ValueError(f"{name}: cannot read image {str(p)!r}: {exc}") from None
    for layout in ("RGBA", "RGB", "YA", "Y"):
        keys = list(layout)                                     # one-letter channel names
        if all(k in found for k in keys) and not ({"RY", "BY"} & set(found)):
            planes = [found[k] for k in keys]
            if any(a.shape != planes[0].shape or a.ndim != 2 for a in planes):
                raise ValueError(f"{name}: the channels {', '.join(keys)} of {str(p)!r} differ in size "
                                 "(subsampled channels are not supported)")
            bits = 16 if all(a.dtype == np.float16 for a in planes) else 32
            return np.stack(planes, axis=-1).astype(np.float32), layout, bits
    raise ValueError(f"{name}: {str(p)!r} has the channels {', '.join(sorted(found)) or 'none'}; "
                     "expected R, G, B (and A) or Y (and A)")


_PNG_CHANNELS = {0: "Y", 2: "RGB", 4: "YA", 6: "RGBA"}


def _read_png16(p: Path, name: str) -> tuple[np.ndarray, str]:
    """``(data (H, W, C) uint16, channels)`` of a non-interlaced 16-bit PNG (ISO/IEC 15948:
    zlib stream of IDAT chunks, one filter byte per row).  The row filters are undone on
    anti-diagonals of pixels (each pixel needs its left, upper and upper-left neighbours
    only), so the loop runs over H + W - 1 diagonals, each step vectorised."""
    import struct
    import zlib

    raw = p.read_bytes()
    width, height, _, color, _, _, interlace = struct.unpack(">IIBBBBB", raw[16:29])
    if color not in _PNG_CHANNELS or interlace != 0:
        raise ValueError(f"{name}: {str(p)!r} is a {'interlaced ' if interlace else ''}16-bit PNG of colour "
                         f"type {color}; supported 16-bit PNG: non-interlaced grey, grey + alpha, RGB, RGBA")
    channels = _PNG_CHANNELS[color]
    bpp = 2 * len(channels)
    idat, pos = [], 8
    while pos + 8 <= len(raw):
        length, kind = struct.unpack(">I4s", raw[pos:pos + 8])
        if kind == b"IDAT":
            idat.append(raw[pos + 8:pos + 8 + length])
        elif kind == b"IEND":
            break
        pos += 12 + length
    try:
        rows = np.frombuffer(zlib.decompress(b"".join(idat)), np.uint8)
        rows = rows[:height * (1 + width * bpp)].reshape(height, 1 + width * bpp)
    except (zlib.error, ValueError) as exc:
        raise ValueError(f"{name}: cannot read image {str(p)!r}: corrupt PNG data ({exc})") from None
    kinds = rows[:, 0].astype(np.int64)
    if kinds.max(initial=0) > 4:
        raise ValueError(f"{name}: cannot read image {str(p)!r}: unknown PNG row filter {kinds.max()}")
    filt = rows[:, 1:].reshape(height, width, bpp).astype(np.int64)
    out = np.zeros((height + 1, width + 1, bpp), np.int64)     # a zero row above and column left
    for k in range(height + width - 1):
        r = np.arange(max(0, k - width + 1), min(height, k + 1))
        x = k - r
        a, b, c = out[r + 1, x], out[r, x + 1], out[r, x]      # left, up, up-left
        t = kinds[r, None]
        est = a + b - c                                         # Paeth predictor
        pa, pb, pc = np.abs(est - a), np.abs(est - b), np.abs(est - c)
        paeth = np.where((pa <= pb) & (pa <= pc), a, np.where(pb <= pc, b, c))
        pred = np.select([t == 1, t == 2, t == 3, t == 4], [a, b, (a + b) // 2, paeth], 0)
        out[r + 1, x + 1] = (filt[r, x] + pred) & 255
    pix = out[1:, 1:].reshape(height, width, len(channels), 2)
    return (pix[..., 0] * 256 + pix[..., 1]).astype(np.uint16), channels
