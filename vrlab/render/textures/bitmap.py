"""``bitmap``: an image texture (Mitsuba 3 ``bitmap``, src/textures/bitmap.cpp, with Dr.Jit's
texture lookup, include/drjit/texture_impl.h).

Loading (Mitsuba 3 convention, RGB variants):

* the file is read as Mitsuba's ``Bitmap`` reads it (:func:`vrlab.render.image.read_bitmap`):
  row 0 is the top row of the image, and no row is flipped;
* grey (Y) images stay one channel; RGB stays RGB; alpha is dropped (values unchanged:
  not divided or multiplied by alpha); a palette is expanded to RGB;
* integer images (PNG, JPEG, BMP, TGA; 8 or 16 bits) are normalised to [0, 1]
  (value / 255 or / 65535) and, unless ``raw``, decoded from sRGB with the exact
  curve (v <= 0.04045: v / 12.92, else ((v + 0.055) / 1.055)^2.4), whatever the file's
  gAMA/iCCP chunks say.  ``raw`` keeps the normalised values (normal maps, masks);
* EXR is linear: ``raw`` changes nothing;
* the texels are kept in float64.  Mitsuba's default ``format="auto"`` stores 16-bit
  images in half precision (``fp16``; values differ from the exact ones by up to 2^-11
  relative); ``format="fp16"`` reproduces that rounding, ``"auto"`` and ``"variant"``
  keep full precision (Mitsuba's ``"variant"``);
* the value is used as it is whatever the texture is used for: in the RGB variants
  Mitsuba neither clamps a reflectance to [0, 1] (it only warns) nor converts an
  emitter's radiance, so the texture needs no ``kind``.

Lookup at uv (after ``to_uv``: uv' = A uv + t, see :func:`.base.uv_transform`), for an
image of W x H texels, texel (i, j) = column i, row j, covering
[i / W, (i + 1) / W] x [j / H, (j + 1) / H] with its centre at ((i + 1/2) / W, (j + 1/2) / H);
u runs along the columns (left to right) and v along the rows (top to bottom):

* ``nearest``: texel (floor(u W), floor(v H)), wrapped;
* ``bilinear`` (default): x = u W - 1/2, y = v H - 1/2, i = floor(x), j = floor(y),
  fx = x - i, fy = y - j; value = (1 - fy) [(1 - fx) T(i, j) + fx T(i + 1, j)]
  + fy [(1 - fx) T(i, j + 1) + fx T(i + 1, j + 1)], each index wrapped;
* wrap of an index k on n texels: ``repeat`` k mod n; ``clamp`` min(max(k, 0), n - 1);
  ``mirror`` m = k mod 2n, then m if m < n else 2n - 1 - m (so texel -1 is texel 0).

Images narrower or lower than 2 texels are used as they are (Mitsuba upsamples them to
2 with a tent filter, which copies the single row or column: the same values).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ... import checks
from ..image import read_bitmap, srgb_decode
from ..registry import register
from .base import LUMINANCE, Texture, apply_uv, surface_points, uv_transform

__all__ = ["BitmapTexture", "FILTER_TYPES", "FORMATS", "WRAP_MODES", "wrap_index"]

FILTER_TYPES = ("bilinear", "nearest")
WRAP_MODES = ("repeat", "mirror", "clamp")
FORMATS = ("auto", "variant", "fp16")
_BIG = float(2 ** 52)        # |texel coordinate| bound before the integer cast (beyond it uv has no fraction)


def wrap_index(k: np.ndarray, n: int, mode: str) -> np.ndarray:
    """Integer texel indices ``k`` wrapped onto [0, n) (Dr.Jit's ``tex_wrap``,
    include/drjit/texture_impl.h): ``repeat`` k mod n, ``clamp`` clip(k, 0, n - 1),
    ``mirror`` m = k mod 2n then m if m < n else 2n - 1 - m."""
    if mode == "repeat":
        return np.mod(k, n)
    if mode == "clamp":
        return np.clip(k, 0, n - 1)
    m = np.mod(k, 2 * n)
    return np.where(m < n, m, 2 * n - 1 - m)


@register("texture", "bitmap")
class BitmapTexture(Texture):
    """An image texture (see the module docstring for the conventions).

    ``filename``: a PNG, JPEG, BMP, TGA or EXR file; or ``data``: an ``(H, W)``,
    ``(H, W, 1)`` or ``(H, W, 3)`` array of linear values used as they are (Mitsuba's
    ``data`` tensor); exactly one of the two.  ``filter_type``: ``"bilinear"`` (default)
    or ``"nearest"``; ``wrap_mode``: ``"repeat"`` (default), ``"mirror"`` or ``"clamp"``;
    ``raw``: keep sRGB-encoded values as they are (default False); ``to_uv``: a 3 x 3 or
    4 x 4 matrix applied to uv (default identity); ``format``: ``"auto"`` (default),
    ``"variant"`` or ``"fp16"`` (texels rounded to half precision, as Mitsuba stores them).
    """

    def __init__(self, filename: str | Path | None = None, *, data: Any = None, filter_type: str = "bilinear",
                 wrap_mode: str = "repeat", raw: bool = False, to_uv: Any = None, format: str = "auto"):
        self.filter_type = checks.choice(filter_type, "filter_type", FILTER_TYPES)
        self.wrap_mode = checks.choice(wrap_mode, "wrap_mode", WRAP_MODES)
        self.raw = checks.flag(raw, "raw")
        self.format = checks.choice(format, "format", FORMATS)
        self.to_uv = None if to_uv is None else checks.finite_array(to_uv, "to_uv")
        uv_transform(self.to_uv)                       # checks the shape
        if (filename is None) == (data is None):
            raise ValueError("filename: give either filename (an image file) or data (an array), not "
                             + ("both" if filename is not None else "neither"))
        self.filename = None
        if data is not None:
            texels = checks.finite_array(data, "data")
            if texels.ndim == 2:
                texels = texels[..., None]
            if texels.ndim != 3 or texels.shape[2] not in (1, 3) or texels.shape[0] < 1 or texels.shape[1] < 1:
                raise ValueError(f"data must have shape (H, W), (H, W, 1) or (H, W, 3), got {texels.shape}")
        else:
            bitmap = read_bitmap(filename, "filename")
            self.filename = Path(filename)
            texels = bitmap.data[..., :1] if bitmap.channels.startswith("Y") else bitmap.data[..., :3]
            if bitmap.srgb and not self.raw:
                texels = srgb_decode(texels)
        if self.format == "fp16":
            texels = texels.astype(np.float32).astype(np.float16)
        self.texels = np.ascontiguousarray(texels, dtype=float)

    @classmethod
    def from_props(cls, p) -> "BitmapTexture":
        p.bool("accel", True)      # Mitsuba's CUDA hardware-interpolation switch: no effect here
        return cls(p.filename("filename"), filter_type=p.string("filter_type", "bilinear", FILTER_TYPES),
                   wrap_mode=p.string("wrap_mode", "repeat", WRAP_MODES), raw=p.bool("raw", False),
                   to_uv=p.transform("to_uv"), format=p.string("format", "auto", FORMATS))

    def validate(self) -> None:
        """Check ``filter_type``, ``wrap_mode`` and the texels again after a change in place."""
        checks.choice(self.filter_type, "filter_type", FILTER_TYPES)
        checks.choice(self.wrap_mode, "wrap_mode", WRAP_MODES)
        t = checks.finite_array(self.texels, "texels", ndim=3)
        if t.shape[2] not in (1, 3) or t.shape[0] < 1 or t.shape[1] < 1:
            raise ValueError(f"texels must have shape (H, W, 1) or (H, W, 3), got {t.shape}")

    @property
    def resolution(self) -> tuple[int, int]:
        """``(W, H)``: texels along u and along v."""
        return self.texels.shape[1], self.texels.shape[0]

    @property
    def channels(self) -> int:
        """1 (grey) or 3 (RGB)."""
        return self.texels.shape[2]

    def lookup(self, uv: np.ndarray) -> np.ndarray:
        """The interpolated texels ``(N, C)`` at texture coordinates ``uv`` ``(N, 2)`` before
        ``to_uv`` (formulas in the module docstring)."""
        uv = apply_uv(uv_transform(self.to_uv), uv)
        h, w, _ = self.texels.shape
        res = np.array([w, h], float)
        if self.filter_type == "nearest":
            k = np.floor(np.clip(uv * res, -_BIG, _BIG)).astype(np.int64)
            return self.texels[wrap_index(k[:, 1], h, self.wrap_mode), wrap_index(k[:, 0], w, self.wrap_mode)]
        x0, x1, y0, y1, fx, fy = self._corners(uv)
        t = self.texels
        return (1 - fy) * ((1 - fx) * t[y0, x0] + fx * t[y0, x1]) + fy * ((1 - fx) * t[y1, x0] + fx * t[y1, x1])

    def _corners(self, uv: np.ndarray) -> tuple:
        """Bilinear lookup at uv (after ``to_uv``): the wrapped texel columns x0, x1, rows y0, y1
        and the fractions fx, fy ``(N, 1)``."""
        h, w, _ = self.texels.shape
        pos = np.clip(uv * np.array([w, h], float) - 0.5, -_BIG, _BIG)
        k0 = np.floor(pos)
        f = pos - k0
        k0 = k0.astype(np.int64)
        x0, x1 = (wrap_index(k0[:, 0] + d, w, self.wrap_mode) for d in (0, 1))
        y0, y1 = (wrap_index(k0[:, 1] + d, h, self.wrap_mode) for d in (0, 1))
        return x0, x1, y0, y1, f[:, :1], f[:, 1:]

    def lookup_grad(self, uv: np.ndarray) -> np.ndarray:
        """d(texels)/d(uv) ``(N, C, 2)`` at ``uv`` before ``to_uv``: 0 for ``nearest``; for
        ``bilinear`` the derivative of the interpolant in x and y times (W, H), mapped back
        through uv' = A uv + t (d/duv = A^T d/duv').  Equal to Mitsuba 3.9.1's
        ``eval_1_grad`` (to 2e-5) without ``to_uv`` or with scales and translations; for a
        rotated ``to_uv`` Mitsuba's value is not the derivative (measured: off by up to 1 for a
        90-degree turn), and vrlab keeps the derivative."""
        affine = uv_transform(self.to_uv)
        uv2 = apply_uv(affine, uv)
        h, w, c = self.texels.shape
        if self.filter_type == "nearest":
            return np.zeros((len(uv), c, 2))
        x0, x1, y0, y1, fx, fy = self._corners(uv2)
        t = self.texels
        d_dx = (1 - fy) * (t[y0, x1] - t[y0, x0]) + fy * (t[y1, x1] - t[y1, x0])
        d_dy = (1 - fx) * (t[y1, x0] - t[y0, x0]) + fx * (t[y1, x1] - t[y0, x1])
        grad = np.stack([d_dx * w, d_dy * h], -1)                  # (N, C, 2) w.r.t. uv'
        return grad @ affine[:, :2]                                 # A^T applied to each gradient row

    def eval_1_grad(self, si: Any) -> np.ndarray:
        """``(N, 2)``: the uv gradient of :meth:`eval_1` (see :meth:`lookup_grad`)."""
        g = self.lookup_grad(surface_points(si).uv)
        return g[:, 0] if g.shape[1] == 1 else np.einsum("c,ncd->nd", LUMINANCE, g)

    def eval(self, si: Any) -> np.ndarray:
        """RGB ``(N, 3)`` at ``si`` (a grey image repeated into the three channels)."""
        v = self.lookup(surface_points(si).uv)
        return np.repeat(v, 3, axis=1) if v.shape[1] == 1 else v

    def eval_1(self, si: Any) -> np.ndarray:
        """``(N,)``: the value of a grey image, the luminance (``LUMINANCE``) of an RGB one."""
        v = self.lookup(surface_points(si).uv)
        return v[:, 0] if v.shape[1] == 1 else v @ LUMINANCE

    def mean(self) -> np.ndarray:
        """The mean texel ``(3,)`` (equal to the average of the bilinear or nearest
        interpolant over [0, 1]^2 for every wrap mode, ``to_uv`` aside)."""
        m = self.texels.mean(axis=(0, 1))
        return np.repeat(m, 3) if m.size == 1 else m

    def mean_1(self) -> float:
        """Mitsuba's ``mean()``: the mean luminance of the texels (RGB), the mean value (grey)."""
        m = self.texels.mean(axis=(0, 1))
        return float(m[0] if m.size == 1 else m @ LUMINANCE)

    def __repr__(self) -> str:
        src = f"filename={str(self.filename)!r}" if self.filename is not None else "data=..."
        w, h = self.resolution
        return (f"BitmapTexture({src}, {w}x{h}x{self.channels}, filter_type={self.filter_type!r}, "
                f"wrap_mode={self.wrap_mode!r}, raw={self.raw}, format={self.format!r})")
