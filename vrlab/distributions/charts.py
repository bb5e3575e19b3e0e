"""Charts: parameterisations of sampling domains by the unit square (or interval).

They live in the warps layer because two higher layers use them: the chi-square harness
(:mod:`vrlab.testing`, which re-exports every name) and the quadrature of predicted
variances (:func:`vrlab.integrands.mc_variance`).

A chart maps parameters ``s`` in [0, 1)^p to points ``x`` of a domain and back, and
gives ``jacobian(s)``: the domain measure (length, area, solid angle) per unit of
parameter volume.  The chi-square harness histograms ``to_param(x)`` on a regular
grid and integrates ``pdf(from_param(s)) * jacobian(s)`` over each cell, so one
harness serves intervals, boxes, disks, spheres, caps and light surfaces.

Constructors check their arguments (finite numbers, positive sizes, non-degenerate
shapes; errors name the argument).  ``to_param(x)`` checks that ``x`` holds real numbers of
shape ``(..., dim_x)`` (NaN rows are allowed: the harness counts them as off the chart);
``from_param`` and ``jacobian`` are the harness's inner loop and take its grid unchecked.
"""
from __future__ import annotations

import numpy as np

from .. import checks
from .base import as_points

#: Relative size below which a shape counts as degenerate (sine of the angle between edges).
DEGENERATE = 1e-9


def _points(x, k: int) -> np.ndarray:
    """``x`` as points ``(..., k)``: ``TypeError`` naming ``x`` unless it holds real numbers."""
    a = np.asarray(x)
    if a.dtype.kind not in "biuf":
        raise TypeError(f"x must be an array of real numbers, got {checks.describe(x)}")
    return as_points(a, k)


def _vector(value, name: str, size: int | tuple[int, ...]) -> np.ndarray:
    """A finite float vector of length ``size`` (or one of the lengths in a tuple)."""
    sizes = (size,) if isinstance(size, int) else size
    v = checks.finite_array(value, name)
    if v.ndim != 1 or len(v) not in sizes:
        want = " or ".join(str(k) for k in sizes)
        raise ValueError(f"{name} must be a vector of {want} numbers, got shape {v.shape}")
    return v


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
    """Axis-aligned box ``[(a1, b1), ...]`` (1 or 2 dims), x = a + (b - a) s.

    ``bounds``: finite numbers, one or two pairs ``(a, b)`` with ``a < b``.
    """

    def __init__(self, bounds):
        b = checks.finite_array(bounds, "bounds")
        if b.size not in (2, 4) or b.ndim > 2 or (b.ndim == 2 and b.shape[1] != 2):
            raise ValueError(f"bounds must be [(a, b)] or [(a1, b1), (a2, b2)] (a chart has 1 or 2 "
                             f"parameters), got shape {b.shape}")
        b = b.reshape(-1, 2)
        if not np.all(b[:, 1] > b[:, 0]):
            raise ValueError(f"bounds must satisfy a < b, got {b.tolist()}")
        self.lo, self.hi = b[:, 0], b[:, 1]
        self.p = self.dim_x = len(b)

    def to_param(self, x):
        return (_points(x, self.dim_x) - self.lo) / (self.hi - self.lo)

    def from_param(self, s):
        return self.lo + (self.hi - self.lo) * s

    def jacobian(self, s):
        return np.full(s.shape[:-1], np.prod(self.hi - self.lo))


def IntervalChart(a: float, b: float) -> BoxChart:
    """The interval [a, b] (points of shape (..., 1)); ``a < b`` finite."""
    a, b = checks.real(a, "a"), checks.real(b, "b")
    if not b > a:
        raise ValueError(f"a, b: need a < b, got a = {a:g}, b = {b:g}")
    return BoxChart([(a, b)])


class HalfLineChart(Chart):
    """[0, inf) with x = -scale * log(1 - s), so cells are equal-mass for Exp(1/scale); ``scale > 0``."""

    def __init__(self, scale: float = 1.0):
        self.scale = checks.real(scale, "scale", low=0.0, low_open=True)

    def to_param(self, x):
        return -np.expm1(-_points(x, 1) / self.scale)

    def from_param(self, s):
        return -self.scale * np.log1p(-s)

    def jacobian(self, s):
        return self.scale / (1.0 - s[..., 0])


class DiskChart(Chart):
    """Disk of radius R about c with s = (r/R)^2, t = phi / 2pi (equal-area cells).

    ``radius > 0``; ``center``: 2 finite numbers.
    """

    p = dim_x = 2

    def __init__(self, radius: float = 1.0, center=(0.0, 0.0)):
        self.radius = checks.real(radius, "radius", low=0.0, low_open=True)
        self.center = _vector(center, "center", 2)

    def to_param(self, x):
        d = _points(x, 2) - self.center
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
    ``to_param`` finds the barycentrics by cross products with the normal n = (a - c) x (b - c)
    (b0 = ((x - c) x (b - c)) . n / |n|^2, b1 = ((a - c) x (x - c)) . n / |n|^2; a 2D triangle
    in the plane z = 0), elementwise: no BLAS, so no rounding that depends on the CPU's BLAS
    kernel, and no Gram matrix, whose squared condition number misplaced points of thin
    triangles (height 1e-6: bins off by ~1e-4).  At vertex a the square collapses and t is
    undefined: within ``VERTEX_TOL`` of it (1 - s <= VERTEX_TOL), where rounding of order
    1e-16 in the barycentrics makes t = b1 / (1 - s) meaningless, t is clipped to [0, 1].
    ``a, b, c``: finite 2D or 3D points of one dimension, not collinear (``ValueError``).
    """

    p = 2
    VERTEX_TOL = 1e-9

    def __init__(self, a, b, c):
        va = _vector(a, "a", (2, 3))
        vb, vc = _vector(b, "b", len(va)), _vector(c, "c", len(va))
        self.v = np.stack([va, vb, vc])
        self.dim_x = self.v.shape[1]
        e = np.stack([self.v[0] - self.v[2], self.v[1] - self.v[2]])
        self.e = e
        self._e3 = e3 = np.pad(e, ((0, 0), (0, 3 - self.dim_x)))       # 2D: the plane z = 0
        self._n = np.cross(e3[0], e3[1])
        self._n2 = float(self._n @ self._n)
        if not self._n2 > DEGENERATE**2 * float(e3[0] @ e3[0]) * float(e3[1] @ e3[1]):
            raise ValueError("a, b, c: the triangle is degenerate (zero area: coincident or collinear vertices)")
        self.area = 0.5 * float(np.sqrt(self._n2))

    def to_param(self, x):
        d = _points(x, self.dim_x) - self.v[2]
        if self.dim_x == 2:
            d = np.concatenate([d, np.zeros(d.shape[:-1] + (1,))], -1)
        b0 = np.sum(np.cross(d, self._e3[1]) * self._n, -1) / self._n2
        b1 = np.sum(np.cross(self._e3[0], d) * self._n, -1) / self._n2
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
    Checked: ``z_min`` in [-1, 1), ``power > 0``.
    """

    p, dim_x = 2, 3

    def __init__(self, z_min: float = 0.0, power: float = 1.0):
        self.z_min = checks.real(z_min, "z_min", low=-1.0, high=1.0, high_open=True)
        self.power = checks.real(power, "power", low=0.0, low_open=True)

    def to_param(self, x):
        w = _points(x, 3)
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
    """Planar parallelogram in 3D: x = corner + s e1 + t e2, area element |e1 x e2|.

    ``corner``, ``edge1``, ``edge2``: 3 finite numbers each; the edges must span an area.
    """

    p, dim_x = 2, 3

    def __init__(self, corner, edge1, edge2):
        self.corner = _vector(corner, "corner", 3)
        self.e = np.stack([_vector(edge1, "edge1", 3), _vector(edge2, "edge2", 3)])
        self.area = float(np.linalg.norm(np.cross(self.e[0], self.e[1])))
        if not self.area > DEGENERATE * np.linalg.norm(self.e[0]) * np.linalg.norm(self.e[1]):
            raise ValueError("edge1, edge2: the parallelogram is degenerate (an edge is zero or the edges are "
                             "parallel)")
        self.normal = np.cross(self.e[0], self.e[1]) / self.area
        self._dual = np.linalg.pinv(self.e)  # (3, 2): x @ dual gives (s, t)

    def to_param(self, x):
        return (_points(x, 3) - self.corner) @ self._dual

    def from_param(self, s):
        return self.corner + s @ self.e

    def jacobian(self, s):
        return np.full(s.shape[:-1], self.area)

    def contains(self, x, tol: float = 1e-9):
        d = _points(x, 3) - self.corner
        s = d @ self._dual
        off = np.abs(d @ self.normal)
        scale = np.sqrt(self.area)
        return (off <= tol * scale) & np.all((s >= -tol) & (s <= 1 + tol), -1)


class EllipsoidChart(Chart):
    """Ellipsoid x = c + M d, d on the unit sphere (chart of ``SphereChart``).

    Area element: dA = |det M| * ||M^-T d|| * d(omega) (the Jacobian of a linear map
    restricted to the tangent plane of the unit sphere, normal d).  ``center``: 3 finite
    numbers; ``matrix``: a finite non-singular 3x3 matrix.
    """

    p, dim_x = 2, 3

    def __init__(self, center, matrix):
        self.center = _vector(center, "center", 3)
        self.M = _matrix3(matrix, "matrix")
        self.Minv = np.linalg.inv(self.M)
        self.det = abs(np.linalg.det(self.M))
        self.sphere = SphereChart()

    def to_param(self, x):
        d = (_points(x, 3) - self.center) @ self.Minv.T
        d = d / np.linalg.norm(d, axis=-1, keepdims=True)
        return self.sphere.to_param(d)

    def from_param(self, s):
        return self.center + self.sphere.from_param(s) @ self.M.T

    def jacobian(self, s):
        d = self.sphere.from_param(s)
        return self.sphere.jacobian(s) * self.det * np.linalg.norm(d @ self.Minv, axis=-1)


def _matrix3(value, name: str) -> np.ndarray:
    """A finite, non-singular 3x3 matrix."""
    m = checks.finite_array(value, name)
    if m.shape != (3, 3):
        raise ValueError(f"{name} must be a 3x3 matrix, got shape {m.shape}")
    if not abs(np.linalg.det(m)) > DEGENERATE * np.prod(np.linalg.norm(m, axis=1)):
        raise ValueError(f"{name} must be non-singular (a degenerate 3x3 matrix was given)")
    return m


class AtlasChart(Chart):
    """Several 2-parameter charts side by side: chart k owns s in [k/K, (k+1)/K).

    Charts must provide ``contains(x)``; a point goes to the first chart containing it
    (points on shared edges have measure zero).  ``charts``: a non-empty list of such
    charts, all with the same point dimension.
    """

    p = 2

    def __init__(self, charts):
        if isinstance(charts, (str, Chart)) or not hasattr(charts, "__iter__"):
            raise TypeError(f"charts must be a list of charts, got {checks.describe(charts)}")
        self.charts = list(charts)
        if not self.charts:
            raise ValueError("charts: give at least one chart")
        for k, c in enumerate(self.charts):
            if not callable(getattr(c, "contains", None)) or getattr(c, "p", None) != 2:
                raise TypeError(f"charts[{k}]: needs a 2-parameter chart with contains(x) "
                                f"(e.g. ParallelogramChart), got {checks.describe(c)}")
        dims = {c.dim_x for c in self.charts}
        if len(dims) > 1:
            raise ValueError(f"charts: all charts must have the same point dimension, got {sorted(dims)}")
        self.dim_x = self.charts[0].dim_x

    def to_param(self, x):
        x = _points(x, self.dim_x)
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
    """The six faces of an oriented box as an atlas of parallelograms.

    ``center``: 3 numbers; ``half_extents``: one or 3 positive numbers; ``rotation``: a
    non-singular 3x3 matrix (default identity).
    """
    c = _vector(center, "center", 3)
    h = checks.finite_array(half_extents, "half_extents")
    if h.ndim > 1 or h.size not in (1, 3):
        raise ValueError(f"half_extents must be one number or 3 numbers, got shape {h.shape}")
    if not np.all(h > 0):
        raise ValueError(f"half_extents must be > 0, got {h.tolist()}")
    h = h * np.ones(3)
    R = np.eye(3) if rotation is None else _matrix3(rotation, "rotation")
    charts = []
    for axis in range(3):
        i, j = [a for a in range(3) if a != axis]
        for sign in (-1.0, 1.0):
            corner = c + R @ (sign * h[axis] * np.eye(3)[axis] - h[i] * np.eye(3)[i] - h[j] * np.eye(3)[j])
            charts.append(ParallelogramChart(corner, R @ (2 * h[i] * np.eye(3)[i]), R @ (2 * h[j] * np.eye(3)[j])))
    return AtlasChart(charts)
