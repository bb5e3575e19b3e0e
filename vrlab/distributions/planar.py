"""Planar warps: disk, triangle, rectangle.  Measure: area (points of shape (..., 2)).

* ``Disk(method="polar")``: r = R sqrt(u1), phi = 2 pi u2 (the sqrt undoes the r dr
  of the area element); ``method="concentric"``: Shirley & Chiu (1997), "A Low
  Distortion Map Between Disk and Square", which keeps strata compact.
  p = 1 / (pi R^2).
* ``Triangle(a, b, c)``: barycentrics b0 = 1 - sqrt(u1), b1 = u2 sqrt(u1)
  (Turk 1990, Graphics Gems), x = b0 a + b1 b + (1 - b0 - b1) c, p = 1 / area.
* ``Rectangle(xlim, ylim)``: uniform, p = 1 / area.
"""
from __future__ import annotations

import numpy as np

from .base import Distribution, as_points, as_uniforms, positive_float


def concentric_disk(u: np.ndarray) -> np.ndarray:
    """Shirley–Chiu concentric map of [0,1)^2 to the unit disk (area preserving up to pi/4)."""
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
    """Inverse of ``concentric_disk``: unit-disk points to [0,1)^2."""
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


class Disk(Distribution):
    """Uniform points on the disk of radius ``radius`` about ``center``; p = 1/(pi R^2) (area)."""

    dim_u = 2
    dim_x = 2
    measure = "area"
    METHODS = ("concentric", "polar")

    def __init__(self, radius: float = 1.0, center=(0.0, 0.0), method: str = "concentric"):
        if method not in self.METHODS:
            raise ValueError(f"method must be one of {self.METHODS}, got {method!r}")
        self.radius = positive_float(radius, "radius")
        self.center = as_points(center, 2, "center")
        self.method = method

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
    """

    dim_u = 2
    measure = "area"

    def __init__(self, a, b, c):
        self.v = np.stack([np.asarray(a, float), np.asarray(b, float), np.asarray(c, float)])
        if self.v.ndim != 2 or self.v.shape[1] not in (2, 3):
            raise ValueError(f"vertices must be 2D or 3D points of equal size, got shape {self.v.shape}")
        self.dim_x = self.v.shape[1]
        e1, e2 = self.v[0] - self.v[2], self.v[1] - self.v[2]
        if self.dim_x == 2:
            self.area = 0.5 * abs(e1[0] * e2[1] - e1[1] * e2[0])
        else:
            self.area = 0.5 * float(np.linalg.norm(np.cross(e1, e2)))
        if not self.area > 0:
            raise ValueError("triangle: vertices are collinear (zero area)")
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
    """Uniform points in [x0, x1] x [y0, y1]; p = 1 / area (area)."""

    dim_u = 2
    dim_x = 2
    measure = "area"

    def __init__(self, xlim=(0.0, 1.0), ylim=(0.0, 1.0)):
        b = np.array([xlim, ylim], dtype=float)
        if b.shape != (2, 2) or not np.all(b[:, 1] > b[:, 0]) or not np.all(np.isfinite(b)):
            raise ValueError(f"xlim, ylim must be finite (lo, hi) with lo < hi, got {xlim}, {ylim}")
        self.lo, self.hi = b[:, 0], b[:, 1]
        self.area = float(np.prod(self.hi - self.lo))

    def sample(self, u):
        return self.lo + (self.hi - self.lo) * as_uniforms(u, 2)

    def pdf(self, x):
        x = as_points(x, 2)
        inside = np.all((x >= self.lo) & (x <= self.hi), -1)
        return np.where(inside, 1.0 / self.area, 0.0)

    def invert(self, x):
        return (as_points(x, 2) - self.lo) / (self.hi - self.lo)
