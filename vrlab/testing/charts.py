"""Charts: parameterisations of sampling domains by the unit square (or interval).

A chart maps parameters ``s`` in [0, 1)^p to points ``x`` of a domain and back, and
gives ``jacobian(s)``: the domain measure (length, area, solid angle) per unit of
parameter volume.  The chi-square harness histograms ``to_param(x)`` on a regular
grid and integrates ``pdf(from_param(s)) * jacobian(s)`` over each cell, so one
harness serves intervals, boxes, disks, spheres, caps and light surfaces.
"""
from __future__ import annotations

import numpy as np

from ..distributions.base import as_points


class Chart:
    """Interface: ``p`` parameter dimensions, ``dim_x`` point dimensions."""

    p: int = 1
    dim_x: int = 1

    def to_param(self, x: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError  # abstract

    def from_param(self, s: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError  # abstract

    def jacobian(self, s: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError  # abstract


class BoxChart(Chart):
    """Axis-aligned box ``[(a1, b1), ...]`` (1 or 2 dims), x = a + (b - a) s."""

    def __init__(self, bounds):
        b = np.asarray(bounds, dtype=float).reshape(-1, 2)
        if not np.all(b[:, 1] > b[:, 0]):
            raise ValueError(f"bounds must satisfy a < b, got {bounds}")
        self.lo, self.hi = b[:, 0], b[:, 1]
        self.p = self.dim_x = len(b)

    def to_param(self, x):
        return (as_points(x, self.dim_x) - self.lo) / (self.hi - self.lo)

    def from_param(self, s):
        return self.lo + (self.hi - self.lo) * s

    def jacobian(self, s):
        return np.full(s.shape[:-1], np.prod(self.hi - self.lo))


def IntervalChart(a: float, b: float) -> BoxChart:
    """The interval [a, b] (points of shape (..., 1))."""
    return BoxChart([(a, b)])


class HalfLineChart(Chart):
    """[0, inf) with x = -scale * log(1 - s), so cells are equal-mass for Exp(1/scale)."""

    def __init__(self, scale: float = 1.0):
        self.scale = float(scale)

    def to_param(self, x):
        return -np.expm1(-as_points(x, 1) / self.scale)

    def from_param(self, s):
        return -self.scale * np.log1p(-s)

    def jacobian(self, s):
        return self.scale / (1.0 - s[..., 0])


class DiskChart(Chart):
    """Disk of radius R about c with s = (r/R)^2, t = phi / 2pi (equal-area cells)."""

    p = dim_x = 2

    def __init__(self, radius: float = 1.0, center=(0.0, 0.0)):
        self.radius = float(radius)
        self.center = np.asarray(center, dtype=float)

    def to_param(self, x):
        d = as_points(x, 2) - self.center
        r2 = np.sum(d * d, -1) / self.radius**2
        t = np.mod(np.arctan2(d[..., 1], d[..., 0]) / (2 * np.pi), 1.0)
        return np.stack([r2, t], -1)

    def from_param(self, s):
        r = self.radius * np.sqrt(s[..., 0])
        phi = 2 * np.pi * s[..., 1]
        return self.center + np.stack([r * np.cos(phi), r * np.sin(phi)], -1)

    def jacobian(self, s):
        return np.full(s.shape[:-1], np.pi * self.radius**2)


class TriangleChart(Chart):
    """Triangle (a, b, c) with barycentrics (s, t (1 - s)): x = c + s (a - c) + t (1 - s) (b - c).

    A "collapsed square" (not the sqrt warp the sampler uses); area element 2 A (1 - s).
    ``to_param`` solves the 2x2 Gram system elementwise (no BLAS, so no rounding that
    depends on the CPU's BLAS kernel).  At vertex a the square collapses and t is
    undefined: within ``VERTEX_TOL`` of it (1 - s <= VERTEX_TOL), where rounding of order
    1e-16 in the barycentrics makes t = b1 / (1 - s) meaningless, t is clipped to [0, 1].
    """

    p = 2
    VERTEX_TOL = 1e-9

    def __init__(self, a, b, c):
        self.v = np.stack([np.asarray(a, float), np.asarray(b, float), np.asarray(c, float)])
        self.dim_x = self.v.shape[1]
        e = np.stack([self.v[0] - self.v[2], self.v[1] - self.v[2]])
        self.e = e
        self._gram = (float(e[0] @ e[0]), float(e[0] @ e[1]), float(e[1] @ e[1]))
        g00, g01, g11 = self._gram
        self._det = g00 * g11 - g01 * g01
        if not self._det > 0:
            raise ValueError("a, b, c: the triangle is degenerate (zero area)")
        self.area = 0.5 * float(np.sqrt(self._det))

    def to_param(self, x):
        d = as_points(x, self.dim_x) - self.v[2]
        r0 = sum(d[..., k] * self.e[0, k] for k in range(self.dim_x))
        r1 = sum(d[..., k] * self.e[1, k] for k in range(self.dim_x))
        g00, g01, g11 = self._gram
        b0 = (g11 * r0 - g01 * r1) / self._det
        b1 = (g00 * r1 - g01 * r0) / self._det
        rest = 1.0 - b0
        t = b1 / np.where(rest > 0, rest, 1.0)
        t = np.where(rest > self.VERTEX_TOL, t, np.clip(np.where(rest > 0, t, 0.0), 0.0, 1.0))
        return np.stack([b0, t], -1)

    def from_param(self, s):
        b0 = s[..., 0]
        b1 = s[..., 1] * (1.0 - b0)
        return self.v[2] + b0[..., None] * self.e[0] + b1[..., None] * self.e[1]

    def jacobian(self, s):
        return 2.0 * self.area * (1.0 - s[..., 0])


class CapChart(Chart):
    """Spherical cap z >= z_min about +z: 1 - z = (1 - z_min) s^power, phi = 2 pi t.

    ``z_min = -1`` is the whole sphere, ``0`` the hemisphere; ``power = 2`` makes
    ``s`` roughly proportional to the polar angle, which resolves peaked lobes.
    Jacobian (solid angle per unit parameter area): 2 pi (1 - z_min) power s^(power-1).
    """

    p, dim_x = 2, 3

    def __init__(self, z_min: float = 0.0, power: float = 1.0):
        if not -1.0 <= z_min < 1.0:
            raise ValueError(f"z_min must be in [-1, 1), got {z_min}")
        self.z_min, self.power = float(z_min), float(power)

    def to_param(self, x):
        w = as_points(x, 3)
        h = np.clip((1.0 - w[..., 2]) / (1.0 - self.z_min), 0.0, None)
        t = np.mod(np.arctan2(w[..., 1], w[..., 0]) / (2 * np.pi), 1.0)
        return np.stack([h ** (1.0 / self.power), t], -1)

    def from_param(self, s):
        z = 1.0 - (1.0 - self.z_min) * s[..., 0] ** self.power
        r = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
        phi = 2 * np.pi * s[..., 1]
        return np.stack([r * np.cos(phi), r * np.sin(phi), z], -1)

    def jacobian(self, s):
        return 2 * np.pi * (1.0 - self.z_min) * self.power * s[..., 0] ** (self.power - 1.0)


def SphereChart(power: float = 1.0) -> CapChart:
    """The unit sphere (solid angle 4 pi)."""
    return CapChart(-1.0, power)


def HemisphereChart(power: float = 1.0) -> CapChart:
    """The upper unit hemisphere z >= 0 (solid angle 2 pi)."""
    return CapChart(0.0, power)


class ParallelogramChart(Chart):
    """Planar parallelogram in 3D: x = corner + s e1 + t e2, area element |e1 x e2|."""

    p, dim_x = 2, 3

    def __init__(self, corner, edge1, edge2):
        self.corner = np.asarray(corner, dtype=float)
        self.e = np.stack([np.asarray(edge1, float), np.asarray(edge2, float)])
        self.area = float(np.linalg.norm(np.cross(self.e[0], self.e[1])))
        if self.area == 0:
            raise ValueError("edges must not be parallel")
        self.normal = np.cross(self.e[0], self.e[1]) / self.area
        self._dual = np.linalg.pinv(self.e)  # (3, 2): x @ dual gives (s, t)

    def to_param(self, x):
        return (as_points(x, 3) - self.corner) @ self._dual

    def from_param(self, s):
        return self.corner + s @ self.e

    def jacobian(self, s):
        return np.full(s.shape[:-1], self.area)

    def contains(self, x, tol: float = 1e-9):
        d = as_points(x, 3) - self.corner
        s = d @ self._dual
        off = np.abs(d @ self.normal)
        scale = np.sqrt(self.area)
        return (off <= tol * scale) & np.all((s >= -tol) & (s <= 1 + tol), -1)


class EllipsoidChart(Chart):
    """Ellipsoid x = c + M d, d on the unit sphere (chart of ``SphereChart``).

    Area element: dA = |det M| * ||M^-T d|| * d(omega) (the Jacobian of a linear map
    restricted to the tangent plane of the unit sphere, normal d).
    """

    p, dim_x = 2, 3

    def __init__(self, center, matrix):
        self.center = np.asarray(center, dtype=float)
        self.M = np.asarray(matrix, dtype=float)
        self.Minv = np.linalg.inv(self.M)
        self.det = abs(np.linalg.det(self.M))
        self.sphere = SphereChart()

    def to_param(self, x):
        d = (as_points(x, 3) - self.center) @ self.Minv.T
        d = d / np.linalg.norm(d, axis=-1, keepdims=True)
        return self.sphere.to_param(d)

    def from_param(self, s):
        return self.center + self.sphere.from_param(s) @ self.M.T

    def jacobian(self, s):
        d = self.sphere.from_param(s)
        return self.sphere.jacobian(s) * self.det * np.linalg.norm(d @ self.Minv, axis=-1)


class AtlasChart(Chart):
    """Several 2-parameter charts side by side: chart k owns s in [k/K, (k+1)/K).

    Charts must provide ``contains(x)``; a point goes to the first chart containing it
    (points on shared edges have measure zero).
    """

    p = 2

    def __init__(self, charts):
        self.charts = list(charts)
        self.dim_x = self.charts[0].dim_x

    def to_param(self, x):
        x = as_points(x, self.dim_x)
        K = len(self.charts)
        out = np.full(x.shape[:-1] + (2,), np.nan)
        todo = np.ones(x.shape[:-1], bool)
        for k, c in enumerate(self.charts):
            m = todo & c.contains(x)
            s = c.to_param(x[m])
            out[m] = np.stack([(k + np.clip(s[:, 0], 0, 1 - 1e-12)) / K, s[:, 1]], -1)
            todo &= ~m
        return out  # points on no chart stay NaN and are reported outside the domain

    def _split(self, s):
        K = len(self.charts)
        k = np.minimum((s[..., 0] * K).astype(int), K - 1)
        local = np.stack([s[..., 0] * K - k, s[..., 1]], -1)
        return k, local

    def from_param(self, s):
        k, local = self._split(s)
        out = np.empty(s.shape[:-1] + (self.dim_x,))
        for i, c in enumerate(self.charts):
            m = k == i
            out[m] = c.from_param(local[m])
        return out

    def jacobian(self, s):
        k, local = self._split(s)
        out = np.empty(s.shape[:-1])
        for i, c in enumerate(self.charts):
            m = k == i
            out[m] = c.jacobian(local[m]) * len(self.charts)
        return out


def box_surface_chart(center, half_extents, rotation=None) -> AtlasChart:
    """The six faces of an oriented box as an atlas of parallelograms."""
    c = np.asarray(center, float)
    h = np.asarray(half_extents, float) * np.ones(3)
    R = np.eye(3) if rotation is None else np.asarray(rotation, float)
    charts = []
    for axis in range(3):
        i, j = [a for a in range(3) if a != axis]
        for sign in (-1.0, 1.0):
            corner = c + R @ (sign * h[axis] * np.eye(3)[axis] - h[i] * np.eye(3)[i] - h[j] * np.eye(3)[j])
            charts.append(ParallelogramChart(corner, R @ (2 * h[i] * np.eye(3)[i]), R @ (2 * h[j] * np.eye(3)[j])))
    return AtlasChart(charts)
