"""Planar warps: disk, triangle, rectangle.  Measure: area (points of shape (..., 2)).

* ``Disk(method="polar")``: r = R sqrt(u1), phi = 2 pi u2 (the sqrt undoes the r dr
  of the area element); ``method="concentric"``: Shirley & Chiu (1997), "A Low
  Distortion Map Between Disk and Square", which keeps strata compact.
  p = 1 / (pi R^2).
* ``Triangle(a, b, c)``: barycentrics b0 = 1 - sqrt(u1), b1 = u2 sqrt(u1)
  (Turk 1990, Graphics Gems), x = b0 a + b1 b + (1 - b0 - b1) c, p = 1 / area.
* ``Rectangle(xlim, ylim)``: uniform, p = 1 / area.

Constructors check their arguments (finite numbers, radius > 0, a known ``method``,
non-degenerate shapes); ``sample``/``pdf``/``invert`` check only the array shapes.
"""
from __future__ import annotations

import numpy as np

from .. import checks
from .base import Distribution, as_float, as_points, as_uniforms, finite_points, positive_float
from .interval import as_bounds


def concentric_disk(u: np.ndarray) -> np.ndarray:
    """Shirley–Chiu concentric map of [0,1)^2 to the unit disk (area preserving up to pi/4).
    ``u`` of shape (..., 2) (values not checked)."""
    u = as_uniforms(u, 2)
    a = 2.0 * u[..., 0] - 1.0
    b = 2.0 * u[..., 1] - 1.0
    first = np.abs(a) > np.abs(b)
    r = np.where(first, a, b)
    safe_a = np.where(a == 0, 1.0, a)
    safe_b = np.where(b == 0, 1.0, b)
    phi = np.where(first, (np.pi / 4) * (b / safe_a), np.pi / 2 - (np.pi / 4) * (a / safe_b))
    phi = np.where((a == 0) & (b == 0), 0.0, phi)
    return np.stack([r * np.cos(phi), r * np.sin(phi)], axis=-1)


def concentric_disk_inverse(d: np.ndarray) -> np.ndarray:
    """Inverse of ``concentric_disk``: unit-disk points ``d`` (..., 2) to [0,1)^2."""
    d = as_points(d, 2, "d")
    x, y = d[..., 0], d[..., 1]
    r = np.hypot(x, y)
    phi = np.arctan2(y, x)  # (-pi, pi]
    # bring phi to [-pi/4, 7pi/4) and find the wedge: |a| > |b| wedges are around 0 and pi
    phi = np.where(phi < -np.pi / 4, phi + 2 * np.pi, phi)
    a = np.empty_like(r)
    b = np.empty_like(r)
    w0 = phi < np.pi / 4                     # a = r > 0, phi = pi/4 * b/a
    w1 = (phi >= np.pi / 4) & (phi < 3 * np.pi / 4)    # b = r > 0, phi = pi/2 - pi/4 a/b
    w2 = (phi >= 3 * np.pi / 4) & (phi < 5 * np.pi / 4)  # a = -r, phi = pi + pi/4 b/a
    w3 = phi >= 5 * np.pi / 4                # b = -r, phi = 3pi/2 - pi/4 a/b
    a[w0], b[w0] = r[w0], r[w0] * phi[w0] / (np.pi / 4)
    b[w1], a[w1] = r[w1], r[w1] * (np.pi / 2 - phi[w1]) / (np.pi / 4)
    a[w2], b[w2] = -r[w2], -r[w2] * (phi[w2] - np.pi) / (np.pi / 4)
    b[w3], a[w3] = -r[w3], -r[w3] * (3 * np.pi / 2 - phi[w3]) / (np.pi / 4)
    return np.stack([(a + 1.0) / 2.0, (b + 1.0) / 2.0], -1)


def _vertex(v, name: str) -> np.ndarray:
    """A finite 2D or 3D point as float64."""
    p = np.array(as_float(v, name), dtype=np.float64)
    if p.shape not in ((2,), (3,)):
        raise ValueError(f"{name}: a vertex must be a 2D or 3D point, got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{name} must be finite, got {p.tolist()}")
    return p


class Disk(Distribution):
    """Uniform points on the disk of radius ``radius`` about ``center``; p = 1/(pi R^2) (area).

    Checked: ``radius`` finite > 0, ``center`` finite of shape (..., 2), ``method`` one of
    ``METHODS``."""

    dim_u = 2
    dim_x = 2
    measure = "area"
    METHODS = ("concentric", "polar")

    def __init__(self, radius: float = 1.0, center=(0.0, 0.0), method: str = "concentric"):
        self.method = checks.choice(method, "method", self.METHODS)
        self.radius = positive_float(radius, "radius")
        with np.errstate(over="ignore"):
            area = np.pi * np.square(np.float64(self.radius))
        if not np.isfinite(area):
            raise ValueError(f"radius: the disk's area overflows, got {self.radius:g}")
        self.center = finite_points(center, 2, "center")

    def sample(self, u):
        u = as_uniforms(u, 2)
        if self.method == "concentric":
            d = concentric_disk(u)
        else:
            r = np.sqrt(u[..., 0])
            phi = 2 * np.pi * u[..., 1]
            d = np.stack([r * np.cos(phi), r * np.sin(phi)], -1)
        return self.center + self.radius * d

    def pdf(self, x):
        d = (as_points(x, 2) - self.center) / self.radius
        inside = np.sum(d * d, -1) <= 1.0
        return np.where(inside, 1.0 / (np.pi * self.radius**2), 0.0)

    def invert(self, x):
        d = (as_points(x, 2) - self.center) / self.radius
        if self.method == "concentric":
            return concentric_disk_inverse(d)
        u2 = np.mod(np.arctan2(d[..., 1], d[..., 0]) / (2 * np.pi), 1.0)
        return np.stack([np.sum(d * d, -1), u2], -1)

    def _repr_fields(self):
        return {"radius": self.radius, "method": self.method}


class Triangle(Distribution):
    """Uniform points in the triangle (a, b, c) (2D or 3D vertices); p = 1/area (area).

    Barycentrics from the square-root warp: b0 = 1 - sqrt(u1), b1 = u2 sqrt(u1).
    Checked: ``a``, ``b``, ``c`` finite points of one size (2 or 3), not collinear.
    """

    dim_u = 2
    measure = "area"

    def __init__(self, a, b, c):
        verts = [_vertex(v, name) for v, name in ((a, "a"), (b, "b"), (c, "c"))]
        if len({v.shape for v in verts}) > 1:
            raise ValueError(f"a, b, c: vertices must have the same size, got {[v.shape[0] for v in verts]}")
        self.v = np.stack(verts)
        self.dim_x = self.v.shape[1]
        e1, e2 = self.v[0] - self.v[2], self.v[1] - self.v[2]
        with np.errstate(over="ignore", invalid="ignore"):
            if self.dim_x == 2:
                self.area = 0.5 * abs(e1[0] * e2[1] - e1[1] * e2[0])
            else:
                self.area = 0.5 * float(np.linalg.norm(np.cross(e1, e2)))
        if not np.isfinite(self.area):
            raise ValueError("a, b, c: the triangle's area overflows")
        if not self.area > 0:
            raise ValueError("a, b, c: vertices are collinear (zero area)")
        # solve x - c = b0 e1 + b1 e2 by least squares (exact for points in the plane)
        self._pinv = np.linalg.pinv(np.stack([e1, e2], 1))

    def _bary(self, x):
        return (as_points(x, self.dim_x) - self.v[2]) @ self._pinv.T

    def sample(self, u):
        u = as_uniforms(u, 2)
        su = np.sqrt(u[..., 0])
        b0 = 1.0 - su
        b1 = u[..., 1] * su
        return b0[..., None] * self.v[0] + b1[..., None] * self.v[1] + (1.0 - b0 - b1)[..., None] * self.v[2]

    def pdf(self, x):
        b = self._bary(x)
        tol = 1e-12
        inside = (b[..., 0] >= -tol) & (b[..., 1] >= -tol) & (b[..., 0] + b[..., 1] <= 1 + tol)
        return np.where(inside, 1.0 / self.area, 0.0)

    def invert(self, x):
        b = self._bary(x)
        su = 1.0 - b[..., 0]
        return np.stack([su * su, np.where(su > 0, b[..., 1] / np.where(su > 0, su, 1.0), 0.0)], -1)


class Rectangle(Distribution):
    """Uniform points in [x0, x1] x [y0, y1]; p = 1 / area (area).

    Checked: ``xlim`` and ``ylim`` are finite pairs (lo, hi) with lo < hi."""

    dim_u = 2
    dim_x = 2
    measure = "area"

    def __init__(self, xlim=(0.0, 1.0), ylim=(0.0, 1.0)):
        b = np.concatenate([as_bounds(lim, name) for lim, name in ((xlim, "xlim"), (ylim, "ylim"))])
        if b.shape != (2, 2):
            raise ValueError(f"xlim, ylim: each must be one pair (lo, hi), got {xlim!r}, {ylim!r}")
        self.lo, self.hi = b[:, 0], b[:, 1]
        self.area = float(np.prod(self.hi - self.lo))
        if not (np.isfinite(self.area) and self.area > 0):
            raise ValueError(f"xlim, ylim: the area {self.area} is not a finite number > 0")

    def sample(self, u):
        return self.lo + (self.hi - self.lo) * as_uniforms(u, 2)

    def pdf(self, x):
        x = as_points(x, 2)
        inside = np.all((x >= self.lo) & (x <= self.hi), -1)
        return np.where(inside, 1.0 / self.area, 0.0)

    def invert(self, x):
        return (as_points(x, 2) - self.lo) / (self.hi - self.lo)
