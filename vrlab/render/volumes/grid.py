"""``gridvolume``: values on a 3D grid of cells (Mitsuba 3 ``gridvolume``, src/volumes/grid.cpp,
with Dr.Jit's 3D texture lookup, include/drjit/texture.h).

File (Mitsuba's binary ``.vol``, little-endian, as Mitsuba 0.6 wrote it): bytes 'V', 'O', 'L',
the version 3 (one byte), int32 encoding (1: float32, the only one), int32 xres, yres, zres,
int32 channels (1 or 3 are read here; Mitsuba also stores 6, which only media read), six
float32 of a bounding box (xmin, ymin, zmin, xmax, ymax, zmax), then xres yres zres channels
float32 values in the order data[((z yres + y) xres + x) channels + c] (x fastest).

Lookup at a world point p: q = to_world^-1 p in the unit cube [0, 1]^3 (the file's bounding
box is ignored unless ``use_grid_bbox``, which maps the box to the unit cube first:
q = (to_world^-1 p - min) / (max - min)).  Cells are centred, as a bitmap's texels: cell
(i, j, k) covers [i / X, (i + 1) / X] x ... with its value at its centre; so

* ``trilinear`` (default): x = q_x X - 1/2 (likewise y, z), i = floor(x), fx = x - i, and
  the value is the trilinear blend of the 8 cells (i or i + 1, j or j + 1, k or k + 1) with
  weights (1 - fx or fx)(1 - fy or fy)(1 - fz or fz);
* ``nearest``: cell (floor(q_x X), floor(q_y Y), floor(q_z Z));
* every index is wrapped by ``wrap_mode``: ``clamp`` (default: outside the cube the
  nearest face's values), ``repeat`` or ``mirror`` (:func:`vrlab.render.textures.bitmap.wrap_index`).

``raw`` (no colour conversion) changes nothing in the RGB variants; ``accel`` (CUDA
hardware interpolation) and ``max_value`` (a medium's majorant) are accepted and have no
effect on a texture lookup.  Values are used as stored (float64 here; Mitsuba computes in
float32).
"""
from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

import numpy as np

from ... import checks
from ..textures.base import LUMINANCE
from ..textures.bitmap import WRAP_MODES, wrap_index
from ..registry import register
from .base import Volume

__all__ = ["FILTER_TYPES", "GridVolume", "read_vol", "write_vol"]

FILTER_TYPES = ("trilinear", "nearest")
_BIG = float(2 ** 52)


def read_vol(path: str | Path, name: str = "filename") -> tuple[np.ndarray, np.ndarray]:
    """``(data (Z, Y, X, C) float32, bbox (2, 3))`` of a Mitsuba ``.vol`` file (format in the
    module docstring).  ``ValueError`` naming ``name`` and the file for a missing file, a bad
    header, another encoding, a channel count other than 1 or 3, or too little data."""
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"{name}: no such file {str(p)!r}")
    raw = p.read_bytes()
    where = f"{name}: cannot read volume {str(p)!r}"
    if len(raw) < 48 or raw[:3] != b"VOL":
        raise ValueError(f"{where}: not a Mitsuba .vol file (no 'VOL' header of 48 bytes)")
    if raw[3] != 3:
        raise ValueError(f"{where}: version {raw[3]}; only version 3 is read (as in Mitsuba 3)")
    encoding, xres, yres, zres, channels = struct.unpack("<5i", raw[4:24])
    if encoding != 1:
        raise ValueError(f"{where}: encoding {encoding}; only 1 (float32) is read (as in Mitsuba 3)")
    if min(xres, yres, zres) < 1:
        raise ValueError(f"{where}: grid size {xres} x {yres} x {zres}")
    if channels not in (1, 3):
        raise ValueError(f"{where}: {channels} channels; a volume texture reads 1 or 3")
    bbox = np.frombuffer(raw, "<f4", 6, 24).astype(float).reshape(2, 3)
    n = xres * yres * zres * channels
    if len(raw) - 48 < 4 * n:
        raise ValueError(f"{where}: the file ends early: {len(raw) - 48} bytes of data for "
                         f"{xres} x {yres} x {zres} x {channels} floats")
    data = np.frombuffer(raw, "<f4", n, 48).reshape(zres, yres, xres, channels)
    return data.astype(np.float32), bbox


def write_vol(path: str | Path, data: Any, bbox: Any = ((0, 0, 0), (1, 1, 1))) -> Path:
    """Write ``data`` ``(Z, Y, X)`` or ``(Z, Y, X, C)`` (C = 1 or 3) as a ``.vol`` file with
    bounding box ``bbox`` ``(2, 3)``; returns the path."""
    a = checks.finite_array(data, "data")
    if a.ndim == 3:
        a = a[..., None]
    if a.ndim != 4 or a.shape[3] not in (1, 3) or min(a.shape[:3]) < 1:
        raise ValueError(f"data must have shape (Z, Y, X) or (Z, Y, X, C), C = 1 or 3, got {a.shape}")
    box = checks.finite_array(bbox, "bbox")
    if box.shape != (2, 3):
        raise ValueError(f"bbox must be (min, max) of shape (2, 3), got {box.shape}")
    z, y, x, c = a.shape
    head = b"VOL" + bytes([3]) + struct.pack("<5i", 1, x, y, z, c) + box.astype("<f4").tobytes()
    p = Path(path)
    p.write_bytes(head + a.astype("<f4").tobytes())
    return p


@register("volume", "gridvolume")
class GridVolume(Volume):
    """A grid of values (see the module docstring): ``filename`` (a ``.vol`` file) or ``data``
    (an array ``(Z, Y, X)`` or ``(Z, Y, X, C)``, C = 1 or 3, x fastest as in the file),
    exactly one; ``filter_type`` ``"trilinear"`` (default) or ``"nearest"``; ``wrap_mode``
    ``"clamp"`` (default), ``"repeat"`` or ``"mirror"``; ``to_world``; ``use_grid_bbox``
    (default False); ``raw``, ``accel``, ``max_value``: no effect here."""

    def __init__(self, filename: str | Path | None = None, *, data: Any = None, filter_type: str = "trilinear",
                 wrap_mode: str = "clamp", to_world: Any = None, use_grid_bbox: bool = False, raw: bool = False,
                 accel: bool = True, max_value: float | None = None):
        super().__init__(to_world)
        self.filter_type = checks.choice(filter_type, "filter_type", FILTER_TYPES)
        self.wrap_mode = checks.choice(wrap_mode, "wrap_mode", WRAP_MODES)
        self.raw, self.accel = checks.flag(raw, "raw"), checks.flag(accel, "accel")
        self.use_grid_bbox = checks.flag(use_grid_bbox, "use_grid_bbox")
        self.max_value = None if max_value is None else checks.real(max_value, "max_value")
        if (filename is None) == (data is None):
            raise ValueError("filename: give either filename (a .vol file) or data (an array), not "
                             + ("both" if filename is not None else "neither"))
        self.filename = None if filename is None else Path(filename)
        if data is not None:
            grid = checks.finite_array(data, "data")
            grid = grid[..., None] if grid.ndim == 3 else grid
            if grid.ndim != 4 or grid.shape[3] not in (1, 3) or min(grid.shape[:3]) < 1:
                raise ValueError(f"data must have shape (Z, Y, X) or (Z, Y, X, C), C = 1 or 3, got {grid.shape}")
            self.bbox = np.array([[0.0, 0, 0], [1, 1, 1]])
        else:
            grid, self.bbox = read_vol(filename, "filename")
        if self.use_grid_bbox and not (self.bbox[1] > self.bbox[0]).all():
            raise ValueError(f"use_grid_bbox: the grid's bounding box {self.bbox.tolist()} is empty")
        self.grid = np.ascontiguousarray(grid, dtype=float)

    @classmethod
    def from_props(cls, p) -> "GridVolume":
        return cls(p.filename("filename"), filter_type=p.string("filter_type", "trilinear", FILTER_TYPES),
                   wrap_mode=p.string("wrap_mode", "clamp", WRAP_MODES), to_world=p.transform("to_world"),
                   use_grid_bbox=p.bool("use_grid_bbox", False), raw=p.bool("raw", False),
                   accel=p.bool("accel", True),
                   max_value=p.float("max_value") if p.has("max_value") else None)

    @property
    def resolution(self) -> tuple[int, int, int]:
        """``(X, Y, Z)``: cells along x, y and z."""
        z, y, x, _ = self.grid.shape
        return x, y, z

    @property
    def channels(self) -> int:
        """1 or 3."""
        return self.grid.shape[3]

    def unit(self, p: Any) -> np.ndarray:
        """``(N, 3)``: world points ``p`` in the grid's unit cube (to_world^-1, then the file's
        bounding box with ``use_grid_bbox``)."""
        q = self.local(p)
        if self.use_grid_bbox:
            q = (q - self.bbox[0]) / (self.bbox[1] - self.bbox[0])
        return q

    def lookup(self, p: Any) -> np.ndarray:
        """The interpolated values ``(N, C)`` at world points ``p`` (module docstring)."""
        q = self.unit(p)
        res = np.array(self.resolution, float)
        g, mode = self.grid, self.wrap_mode
        if self.filter_type == "nearest":
            k = np.floor(np.clip(q * res, -_BIG, _BIG)).astype(np.int64)
            idx = [wrap_index(k[:, a], int(res[a]), mode) for a in range(3)]
            return g[idx[2], idx[1], idx[0]]
        pos = np.clip(q * res - 0.5, -_BIG, _BIG)
        k0 = np.floor(pos)
        f = pos - k0
        k0 = k0.astype(np.int64)
        lo = [wrap_index(k0[:, a], int(res[a]), mode) for a in range(3)]
        hi = [wrap_index(k0[:, a] + 1, int(res[a]), mode) for a in range(3)]
        out = np.zeros((len(q), g.shape[3]))
        for cz in (0, 1):                      # the 8 corners, each vectorised over the points
            wz = f[:, 2:3] if cz else 1 - f[:, 2:3]
            z = hi[2] if cz else lo[2]
            for cy in (0, 1):
                wy = f[:, 1:2] if cy else 1 - f[:, 1:2]
                y = hi[1] if cy else lo[1]
                out += wz * wy * ((1 - f[:, :1]) * g[z, y, lo[0]] + f[:, :1] * g[z, y, hi[0]])
        return out

    def eval(self, p: Any) -> np.ndarray:
        """RGB ``(N, 3)`` (one channel repeated into three)."""
        v = self.lookup(p)
        return np.repeat(v, 3, axis=1) if v.shape[1] == 1 else v

    def eval_1(self, p: Any) -> np.ndarray:
        """``(N,)``: the value (one channel) or its luminance (three)."""
        v = self.lookup(p)
        return v[:, 0] if v.shape[1] == 1 else v @ LUMINANCE

    def mean(self) -> np.ndarray:
        """The mean cell value ``(3,)``."""
        m = self.grid.mean(axis=(0, 1, 2))
        return np.repeat(m, 3) if m.size == 1 else m

    def __repr__(self) -> str:
        src = f"filename={str(self.filename)!r}" if self.filename is not None else "data=..."
        x, y, z = self.resolution
        return (f"GridVolume({src}, {x}x{y}x{z}x{self.channels}, filter_type={self.filter_type!r}, "
                f"wrap_mode={self.wrap_mode!r})")
