"""Quadric light surfaces: ellipsoid (a mapped unit sphere, Jacobian density) and sphere,
and the ray / unit-sphere roots that every quadric (here and in the renderer) intersects with.

See ``surfaces.py`` for the shared ``Surface`` interface and the ellipsoid density
derivation, p_A(x) = 1 / (4 pi |det M| ||M^-T n_s||) (Russian lecture 4).

Ray / unit sphere: |o + t d|^2 = 1 is a t^2 + 2 b t + c = 0 with a = d.d, b = o.d,
c = o.o - 1.  The textbook roots (-b -+ sqrt(b^2 - a c)) / a cancel when |b| >> a c; the
stable pair is q = -(b + sign(b) sqrt(b^2 - a c)), t = q / a and t = c / q (the product of
the roots is c / a): Press et al., Numerical Recipes 3rd ed. 5.6; PBRT 3rd ed. 3.2.2.
An ellipsoid c + M S^2 is the unit sphere in the coordinates M^-1 (x - c), where a ray keeps
its parameter t.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .._vec import dot as _dot
from ._args import _affine4, _matrix3, _positive3, _rotation3, _sizes, _vector3
from .base import as_points, as_uniforms, positive_float
from ._sphere_chart import _sphere_from_u
from .surfaces import FOUR_PI, Surface, _INTERSECT_DOC, _sphere_to_u, _unit

if TYPE_CHECKING:
    from .solid_angle import SphereCone

__all__ = ["EllipsoidSurface", "SphereSurface", "unit_sphere_hit", "unit_sphere_hits", "unit_sphere_roots"]


# ----------------------------------------------------------------------------- ray / unit sphere

def _stable_roots(o: np.ndarray, d: np.ndarray):
    """``(hit, t1, t2)``: whether the line o + t d meets |x| = 1 (b^2 - a c >= 0) and its two
    roots q / a and c / q (q = -(b + sign(b) sqrt(b^2 - a c)); t1 twice when q = 0), unordered."""
    a = _dot(d, d)
    b = _dot(o, d)
    c = _dot(o, o) - 1.0
    disc = b * b - a * c
    hit = disc >= 0.0
    sq = np.sqrt(np.where(hit, disc, 0.0))
    q = -(b + np.where(b >= 0.0, sq, -sq))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t1 = q / a
        t2 = np.where(q != 0.0, c / np.where(q != 0.0, q, 1.0), t1)
    return hit, t1, t2


def unit_sphere_roots(o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(t_near, t_far)``, t_near <= t_far, the parameters where the line o + t d meets the
    unit sphere |x| = 1; both ``inf`` where it misses (b^2 - a c < 0, or d = 0).

    Stable roots (module docstring): q = -(b + sign(b) sqrt(b^2 - a c)), t = q / a, c / q
    (t = q / a twice when q = 0), a = d.d, b = o.d, c = o.o - 1.  ``o`` and ``d`` of shape
    (..., 3) broadcast; ``d`` need not be unit (t is in units of its length).  No argument
    checks (hot path); a non-finite root counts as a miss.  Results keep the dtype NumPy
    gives ``o`` and ``d`` (float32 stays float32).
    """
    hit, t1, t2 = _stable_roots(o, d)
    t1 = np.where(hit & np.isfinite(t1), t1, np.inf)
    t2 = np.where(hit & np.isfinite(t2), t2, np.inf)
    return np.minimum(t1, t2), np.maximum(t1, t2)


def unit_sphere_hit(o: np.ndarray, d: np.ndarray, t_min) -> np.ndarray:
    """The first hit: the smallest root t > ``t_min`` of :func:`unit_sphere_roots`, ``inf`` if
    none.  ``t_min`` is a number or an array broadcasting with the rays' leading shape.  (One
    finiteness test at the end instead of two: the renderer calls this on every candidate
    (ray, sphere) pair.)"""
    hit, t1, t2 = _stable_roots(o, d)
    lo, hi = np.minimum(t1, t2), np.maximum(t1, t2)
    t = np.where(lo > t_min, lo, np.where(hi > t_min, hi, np.inf))
    return np.where(hit & np.isfinite(t), t, np.inf)


def unit_sphere_hits(o: np.ndarray, d: np.ndarray, t_min) -> np.ndarray:
    """Every hit: the roots t > ``t_min`` of :func:`unit_sphere_roots`, shape (..., 2),
    ascending, ``inf`` for misses (a tangent ray gives its double root twice)."""
    near, far = unit_sphere_roots(o, d)
    ahead = near > t_min
    return np.stack([np.where(ahead, near, np.where(far > t_min, far, np.inf)), np.where(ahead, far, np.inf)], -1)


# ----------------------------------------------------------------------------- shapes

class EllipsoidSurface(Surface):
    """x = c + M d with d uniform on the unit sphere (measure: area, not uniform).

    p_A(x) = 1 / (4 pi |det M| ||M^-T n_s||), n_s = M^-1 (x - c): the uniform density
    1/(4 pi) divided by the area scale of M on the tangent plane (derivation in the
    module docstring; Russian lecture 4).  ``area`` is exact: 4 pi R_G(a^2 b^2, b^2 c^2,
    c^2 a^2) with a, b, c the singular values of M and R_G Carlson's symmetric elliptic
    integral (``scipy.special.elliprg``).  Normals (outward) are normalize(M^-T n_s).
    ``invert`` gives the u of the unit-sphere point.  Checked: ``center`` a finite
    3-vector, ``matrix`` a finite non-singular 3x3 matrix.
    """

    max_hits = 2

    def __init__(self, center: Any, matrix: Any):
        self.center = _vector3(center, "center")
        self.M = _matrix3(matrix, "matrix")
        self.Minv = np.linalg.inv(self.M)
        self.abs_det = float(abs(np.linalg.det(self.M)))
        self.semi_axes = np.linalg.svd(self.M, compute_uv=False)
        a, b, c = self.semi_axes
        from scipy.special import elliprg  # imported on use (startup time)

        self.area = float(FOUR_PI * elliprg(a * a * b * b, b * b * c * c, c * c * a * a))

    @classmethod
    def from_radii(cls, center: Any, radii: Any, rotation: Any = None) -> "EllipsoidSurface":
        """Ellipsoid with semi-axes ``radii`` along the columns of ``rotation`` (M = R diag(radii))."""
        r = _positive3(radii, "radii")
        _sizes(r, "radii")
        return cls(center, _rotation3(rotation) * r)

    @classmethod
    def from_matrix(cls, matrix: Any) -> "EllipsoidSurface":
        """The unit sphere at the origin under an affine 4x4 ``to_world`` ``matrix``."""
        lin, trans = _affine4(matrix, "matrix")
        return cls(trans, lin)

    def bounding_sphere(self) -> tuple[np.ndarray, float]:
        return self.center, float(self.semi_axes[0])

    def _sphere_point(self, x: np.ndarray) -> np.ndarray:
        return _unit((as_points(x, 3) - self.center) @ self.Minv.T)

    def sample(self, u: np.ndarray) -> np.ndarray:
        return self.center + _sphere_from_u(as_uniforms(u, 2)) @ self.M.T

    def pdf(self, x: np.ndarray) -> np.ndarray:
        g = self._sphere_point(x) @ self.Minv       # (M^-T n_s)^T = n_s^T M^-1
        return 1.0 / (FOUR_PI * self.abs_det * np.linalg.norm(g, axis=-1))

    def invert(self, x: np.ndarray) -> np.ndarray:
        return _sphere_to_u(self._sphere_point(x))

    def normal(self, x: np.ndarray) -> np.ndarray:
        return _unit(self._sphere_point(x) @ self.Minv)

    def intersect(self, origin: np.ndarray, direction: np.ndarray, t_min: float | None = None) -> np.ndarray:
        o, d = self._rays(origin, direction)
        return unit_sphere_hits((o - self.center) @ self.Minv.T, d @ self.Minv.T, self._t_min(t_min))

    intersect.__doc__ = _INTERSECT_DOC

    def _repr_fields(self):
        return {"center": self.center.tolist(), "matrix": np.round(self.M, 6).tolist()}


class SphereSurface(Surface):
    """Uniform points on the sphere |x - c| = r: z = 1 - 2 u1, phi = 2 pi u2, p = 1/(4 pi r^2).

    ``cone_from(ref)`` gives the (better) uniform-cone direction sampler of PBRT.
    Checked: ``center`` a finite 3-vector, ``radius`` finite > 0 (area finite).
    """

    max_hits = 2

    def __init__(self, center: Any, radius: float):
        self.center = _vector3(center, "center")
        self.radius = positive_float(radius, "radius")
        _sizes(np.array([self.radius]), "radius")
        self.area = FOUR_PI * self.radius**2

    def bounding_sphere(self) -> tuple[np.ndarray, float]:
        return self.center, self.radius

    def sample(self, u: np.ndarray) -> np.ndarray:
        return self.center + self.radius * _sphere_from_u(as_uniforms(u, 2))

    def pdf(self, x: np.ndarray) -> np.ndarray:
        x = as_points(x, 3)
        return np.full(x.shape[:-1], 1.0 / self.area)

    def invert(self, x: np.ndarray) -> np.ndarray:
        return _sphere_to_u(self.normal(x))

    def normal(self, x: np.ndarray) -> np.ndarray:
        return _unit(as_points(x, 3) - self.center)

    def intersect(self, origin: np.ndarray, direction: np.ndarray, t_min: float | None = None) -> np.ndarray:
        o, d = self._rays(origin, direction)
        return unit_sphere_hits((o - self.center) / self.radius, d / self.radius, self._t_min(t_min))

    intersect.__doc__ = _INTERSECT_DOC

    def cone_from(self, ref: np.ndarray) -> "SphereCone":
        """Directions uniform in the cone this sphere subtends from ``ref`` (batched)."""
        from .solid_angle import SphereCone
        return SphereCone(self.center, self.radius, ref)

    def _repr_fields(self):
        return {"center": self.center.tolist(), "radius": self.radius}
