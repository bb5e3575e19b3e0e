"""Light surfaces: points sampled on a shape (measure: area) and the directions they induce.

Every surface maps ``u`` of shape ``(..., 2)`` to points ``(..., 3)`` and reports the
density per unit area, ``pdf(x)``.  ``pdf`` assumes ``x`` lies on the surface (it is
*not* zero off it; points off the surface are treated as their projection).  All
surfaces share ``area``, ``normal(x)``, ``intersect(origin, direction)`` (every hit,
not just the first) and ``solid_angle_from(ref)``.  Sources: Russian lecture 4
("light surface sampling"), Shirley, Wang & Zimmerman, "Monte Carlo techniques for
direct lighting calculations" (TOG 1996), Arvo, "Stratified sampling of spherical
triangles" (1995), Pharr, Jakob & Humphreys, PBRT 3rd ed. 14.2.

* ``RectangleSurface(corner, edge1, edge2)``: x = corner + u1 e1 + u2 e2, p = 1/|e1 x e2|.
* ``DiskSurface(center, axis1, axis2)``: x = c + p a1 + q a2 with (p, q) uniform on the unit
  disk (``planar.Disk``); a linear map scales every area by |a1 x a2|, so x is uniform by
  area, p = 1 / (pi |a1 x a2|).
* ``BoxSurface(center, half_extents, rotation)``: pick a face with probability
  area_k / A (u1 is remapped through the 6-face CDF and reused), uniform on it;
  p = 1/A.  ``BoxSurface.from_matrix`` gives any parallelepiped (Mitsuba ``cube``).
* ``SphereSurface(center, r)``: p = 1/(4 pi r^2).
* ``EllipsoidSurface(center, M)``: x = c + M d with d uniform on the unit sphere.  This
  is *not* uniform by area.  A linear map scales the area element at a point with unit
  normal N by |det M| ||M^-T N||: a thin prism on the tangent patch with one edge N has
  volume dA; after the map its volume is |det M| dA, its base is the image patch dA',
  and its height is (M N) . n' with n' = M^-T N / ||M^-T N||, i.e. 1 / ||M^-T N||.
  Hence (lecture 4)

      p_A(x) = 1 / (4 pi |det M| ||M^-T n_s||),   n_s = M^-1 (x - c) (on the unit sphere).

  For M = diag(a, b, c) and n_s = (1, 0, 0) this is 1 / (4 pi b c).
``EllipsoidSurface`` and ``SphereSurface`` live in ``quadrics.py``.  Directions towards
these surfaces (``solid_angle_from``, ``cone_from``) live in
``solid_angle.py``.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .. import checks
from ._args import _affine4, _matrix3, _positive3, _rotation3, _sizes, _vector3
from .base import Distribution, as_points, as_uniforms
from .frames import to_local, to_world  # noqa: F401
from .planar import Disk

if TYPE_CHECKING:
    from .solid_angle import SolidAngleFromArea

from ._sphere_chart import (FOUR_PI, TWO_PI, _T_EPS, _finish_hits, _sphere_from_u, _sphere_to_u,  # noqa: F401
                            _unit)


def _plane_hit(o: np.ndarray, d: np.ndarray, point: np.ndarray, n: np.ndarray, dual: np.ndarray,
               t_min: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t, ok, local)`` for rays o + t d and the plane through ``point`` with normal ``n``:
    t = ((point - o) . n) / (d . n), ``ok`` where t is finite and > t_min, and the hit's
    plane coordinates (o + t d - point) @ ``dual`` (dual (3, 2): pseudo-inverse of the edges)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((point - o) @ n) / (d @ n)
    ok = np.isfinite(t) & (t > t_min)
    return t, ok, (o + np.where(ok, t, 0.0)[..., None] * d - point) @ dual


# ----------------------------------------------------------------------------- base

class Surface(Distribution):
    """A sampled light surface.  Measure of ``pdf``: area.

    Subclasses provide ``sample``, ``pdf`` (points assumed on the surface), ``area``,
    ``normal(x)`` (unit, outward for closed shapes), ``intersect`` and ``max_hits`` (K).
    """

    dim_u = 2
    dim_x = 3
    measure = "area"
    max_hits: int = 1
    area: float
    #: the unit normal of a planar surface (3,), None for curved ones
    unit_normal: np.ndarray | None = None

    def normal(self, x: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError  # abstract

    def intersect(self, origin: np.ndarray, direction: np.ndarray,
                  t_min: float | None = None) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError  # abstract

    def bounding_sphere(self) -> tuple[np.ndarray, float]:  # pragma: no cover - interface
        """``(center, radius)`` of a sphere containing the surface."""
        raise NotImplementedError  # abstract

    def _t_min(self, t_min: float | None) -> float:
        if t_min is not None:
            return checks.real(t_min, "t_min", finite=False)
        if not hasattr(self, "_t_eps"):
            self._t_eps = _T_EPS * self.bounding_sphere()[1]
        return self._t_eps

    def solid_angle_from(self, ref: np.ndarray) -> "SolidAngleFromArea":
        """Directions from ``ref`` towards area samples of this surface (solid angle pdf)."""
        from .solid_angle import SolidAngleFromArea
        return SolidAngleFromArea(self, ref)

    def _rays(self, origin: np.ndarray, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return as_points(origin, 3, "origin"), as_points(direction, 3, "direction")


_INTERSECT_DOC = """All hits of the rays ``origin + t direction`` with t > t_min.

        ``origin`` and ``direction`` (shape (..., 3), broadcast; direction need not be
        unit, t is in units of its length) give ``t`` of shape (..., K), ascending,
        ``inf`` for misses.  ``t_min`` (a real, not NaN) defaults to 1e-9 x the bounding
        radius.  Only shapes are checked (hot path).
        """


# ----------------------------------------------------------------------------- rectangle

class RectangleSurface(Surface):
    """Uniform points on the parallelogram corner + s e1 + t e2, (s, t) in [0, 1)^2.

    p = 1 / |e1 x e2| (area); normal = normalize(e1 x e2); ``invert`` gives (s, t).
    ``RectangleSurface.from_matrix(M)``: Mitsuba's ``rectangle`` ([-1, 1]^2 in the xy
    plane, normal +z) under the 4x4 ``to_world`` matrix ``M``.
    Checked: finite 3-vectors, non-zero and non-parallel edges.
    """

    max_hits = 1

    def __init__(self, corner: Any, edge1: Any, edge2: Any):
        self.corner = _vector3(corner, "corner")
        self.edge1 = _vector3(edge1, "edge1")
        self.edge2 = _vector3(edge2, "edge2")
        with np.errstate(over="ignore"):
            l1, l2 = np.linalg.norm(self.edge1), np.linalg.norm(self.edge2)
        if l1 == 0:
            raise ValueError("edge1: must be non-zero")
        if l2 == 0:
            raise ValueError("edge2: must be non-zero")
        _sizes(np.array([l1]), "edge1")
        _sizes(np.array([l2]), "edge2")
        cross = np.cross(self.edge1, self.edge2)
        self.area = float(np.linalg.norm(cross))
        if self.area <= 1e-12 * l1 * l2:
            raise ValueError("edge1, edge2: must not be parallel (degenerate rectangle)")
        self.unit_normal = cross / self.area
        self._edges = np.stack([self.edge1, self.edge2])   # (2, 3)
        self._dual = np.linalg.pinv(self._edges)           # (3, 2): (x - corner) @ dual = (s, t)

    @classmethod
    def from_matrix(cls, matrix: Any, flip_normals: bool = False) -> "RectangleSurface":
        """Mitsuba ``rectangle`` under the affine 4x4 ``to_world`` ``matrix``.

        Corners M (+-1, +-1, 0); the normal is Mitsuba's, M^-T (0, 0, 1) (flipped with
        ``flip_normals``): when det of the linear part is negative the edges are swapped
        so that normalize(e1 x e2) still equals it.
        """
        lin, trans = _affine4(matrix, "matrix")
        if not isinstance(flip_normals, (bool, np.bool_)):
            raise TypeError(f"flip_normals must be True or False, got {flip_normals!r}")
        corner = lin @ np.array([-1.0, -1.0, 0.0]) + trans
        e1, e2 = lin @ np.array([2.0, 0.0, 0.0]), lin @ np.array([0.0, 2.0, 0.0])
        flip = (np.linalg.det(lin) < 0) != bool(flip_normals)
        return cls(corner, e2, e1) if flip else cls(corner, e1, e2)

    @property
    def center(self) -> np.ndarray:
        return self.corner + 0.5 * (self.edge1 + self.edge2)

    def bounding_sphere(self) -> tuple[np.ndarray, float]:
        r = 0.5 * max(np.linalg.norm(self.edge1 + self.edge2), np.linalg.norm(self.edge1 - self.edge2))
        return self.center, float(r)

    def sample(self, u: np.ndarray) -> np.ndarray:
        u = as_uniforms(u, 2)
        return u @ self._edges + self.corner          # corner + u1 e1 + u2 e2

    def pdf(self, x: np.ndarray) -> np.ndarray:
        x = as_points(x, 3)
        return np.full(x.shape[:-1], 1.0 / self.area)

    def invert(self, x: np.ndarray) -> np.ndarray:
        return (as_points(x, 3) - self.corner) @ self._dual

    def normal(self, x: np.ndarray) -> np.ndarray:
        x = as_points(x, 3)
        return np.broadcast_to(self.unit_normal, x.shape).copy()

    def intersect(self, origin: np.ndarray, direction: np.ndarray, t_min: float | None = None) -> np.ndarray:
        o, d = self._rays(origin, direction)
        t, ok, st = _plane_hit(o, d, self.corner, self.unit_normal, self._dual, self._t_min(t_min))
        ok &= np.all((st >= 0.0) & (st <= 1.0), -1)
        return np.where(ok, t, np.inf)[..., None]

    intersect.__doc__ = _INTERSECT_DOC

    def _repr_fields(self):
        return {"corner": self.corner.tolist(), "edge1": self.edge1.tolist(), "edge2": self.edge2.tolist()}


# ----------------------------------------------------------------------------- disk

class DiskSurface(Surface):
    """Uniform points on the (elliptic) disk c + r cos(t) a1 + r sin(t) a2, r <= 1.

    x = c + p a1 + q a2 with (p, q) = ``planar.Disk(1, method=method).sample(u)``: the affine
    image of the unit disk, uniform by area (the map scales every area by |a1 x a2|), so
    p = 1 / area with area = pi |a1 x a2| (area measure).  normal = normalize(a1 x a2);
    ``invert`` gives the u of (p, q).  ``method``: ``"concentric"`` (Shirley & Chiu 1997;
    Mitsuba 3's ``disk`` shape, src/shapes/disk.cpp ``sample_position``) or ``"polar"``.
    ``DiskSurface.from_matrix(M)``: Mitsuba's ``disk`` (the unit disk in the xy plane)
    under the 4x4 ``to_world`` ``M``: c = M (0, 0, 0), a1 = M e_x, a2 = M e_y, so that
    ``sample(u)`` is Mitsuba's ``sample_position(u).p``, and Mitsuba's normal M^-T e_z
    (negated with ``flip_normals``).  Checked: finite 3-vectors, non-zero and non-parallel
    axes, ``method`` one of ``METHODS``.
    """

    max_hits = 1
    METHODS = Disk.METHODS

    def __init__(self, center: Any, axis1: Any, axis2: Any, method: str = "concentric"):
        self.center = _vector3(center, "center")
        self.axis1 = _vector3(axis1, "axis1")
        self.axis2 = _vector3(axis2, "axis2")
        self.disk = Disk(1.0, method=method)
        self.method = self.disk.method
        with np.errstate(over="ignore"):
            l1, l2 = np.linalg.norm(self.axis1), np.linalg.norm(self.axis2)
        for length, name in ((l1, "axis1"), (l2, "axis2")):
            if length == 0:
                raise ValueError(f"{name}: must be non-zero")
            _sizes(np.array([length]), name)
        cross = np.cross(self.axis1, self.axis2)
        norm = float(np.linalg.norm(cross))
        if norm <= 1e-12 * l1 * l2:
            raise ValueError("axis1, axis2: must not be parallel (degenerate disk)")
        self.area = float(np.pi * norm)
        self.unit_normal = cross / norm
        self._axes = np.stack([self.axis1, self.axis2])     # (2, 3)
        self._dual = np.linalg.pinv(self._axes)             # (3, 2): (x - c) @ dual = (p, q)

    @classmethod
    def from_matrix(cls, matrix: Any, flip_normals: bool = False, method: str = "concentric") -> "DiskSurface":
        """Mitsuba ``disk`` under the affine 4x4 ``to_world`` ``matrix`` (see the class docstring)."""
        lin, trans = _affine4(matrix, "matrix")
        flip_normals = checks.flag(flip_normals, "flip_normals")
        self = cls(trans, lin[:, 0], lin[:, 1], method)
        if (np.linalg.det(lin) < 0) != flip_normals:       # M^-T e_z = (M e_x x M e_y) / det M
            self.unit_normal = -self.unit_normal
        return self

    def bounding_sphere(self) -> tuple[np.ndarray, float]:
        """The centre and the semi-major axis (largest singular value of [a1 a2])."""
        return self.center, float(np.linalg.svd(self._axes, compute_uv=False)[0])

    def sample(self, u: np.ndarray) -> np.ndarray:
        return self.disk.sample(u) @ self._axes + self.center

    def pdf(self, x: np.ndarray) -> np.ndarray:
        x = as_points(x, 3)
        return np.full(x.shape[:-1], 1.0 / self.area)

    def invert(self, x: np.ndarray) -> np.ndarray:
        return self.disk.invert((as_points(x, 3) - self.center) @ self._dual)

    def normal(self, x: np.ndarray) -> np.ndarray:
        x = as_points(x, 3)
        return np.broadcast_to(self.unit_normal, x.shape).copy()

    def intersect(self, origin: np.ndarray, direction: np.ndarray, t_min: float | None = None) -> np.ndarray:
        o, d = self._rays(origin, direction)
        t, ok, pq = _plane_hit(o, d, self.center, self.unit_normal, self._dual, self._t_min(t_min))
        ok &= np.sum(pq * pq, -1) <= 1.0
        return np.where(ok, t, np.inf)[..., None]

    intersect.__doc__ = _INTERSECT_DOC

    def _repr_fields(self):
        return {"center": self.center.tolist(), "axis1": self.axis1.tolist(), "axis2": self.axis2.tolist(),
                "method": self.method}


# ----------------------------------------------------------------------------- box

class BoxSurface(Surface):
    """Uniform points on the surface of a box (parallelepiped); p = 1 / total area.

    The box is c + L q for q in [-1, 1]^3 with L = rotation @ diag(half_extents)
    (``from_matrix`` accepts any affine map of Mitsuba's ``cube``, i.e. any
    parallelepiped).  Face k = 2 axis + (0 for the -side, 1 for +) has area
    4 |L e_i x L e_j|.  Sampling (lecture 4): u1 picks the face through the CDF of face
    areas and is remapped to u1' = (u1 - F_{k-1}) / P_k, then (u1', u2) is uniform on the
    face.  Normals are outward.  ``invert`` undoes ``sample``.  Checked: ``center`` a
    finite 3-vector, ``half_extents`` 3 finite numbers > 0 (or one), ``rotation`` orthogonal.
    """

    max_hits = 2

    def __init__(self, center: Any, half_extents: Any, rotation: Any = None):
        h = _positive3(half_extents, "half_extents")
        _sizes(h, "half_extents")
        R = _rotation3(rotation)
        self.half_extents = h
        self.rotation = R
        self._setup(_vector3(center, "center"), R * h)

    @classmethod
    def from_matrix(cls, matrix: Any) -> "BoxSurface":
        """Mitsuba's ``cube`` ([-1, 1]^3) under the affine 4x4 ``to_world`` ``matrix``."""
        lin, trans = _affine4(matrix, "matrix")
        lin = _matrix3(lin, "matrix")
        self = cls.__new__(cls)
        self.half_extents = np.linalg.norm(lin, axis=0)
        self.rotation = None
        self._setup(trans, lin)
        return self

    def _setup(self, center: np.ndarray, L: np.ndarray) -> None:
        self.center = center
        self.L = L
        self.Linv = np.linalg.inv(L)
        corners, e1s, e2s, normals, areas = [], [], [], [], []
        for axis in range(3):
            i, j = [a for a in range(3) if a != axis]
            for sign in (-1.0, 1.0):
                corners.append(center + L @ (sign * np.eye(3)[axis] - np.eye(3)[i] - np.eye(3)[j]))
                e1s.append(2.0 * L[:, i])
                e2s.append(2.0 * L[:, j])
                n = sign * self.Linv[axis]           # L^-T e_axis: outward face normal
                normals.append(n / np.linalg.norm(n))
                areas.append(np.linalg.norm(np.cross(e1s[-1], e2s[-1])))
        self._corner = np.array(corners)            # (6, 3)
        self._e1, self._e2 = np.array(e1s), np.array(e2s)
        self._normals = np.array(normals)
        self.face_areas = np.array(areas)
        self.area = float(self.face_areas.sum())
        self.face_probs = self.face_areas / self.area
        cdf = np.cumsum(self.face_probs)
        cdf[-1] = 1.0
        self._cdf = cdf
        self._cdf_lo = np.concatenate([[0.0], cdf[:-1]])
        # (6, 3, 2): (x - corner_k) @ dual_k = (s, t) on face k
        self._dual = np.stack([np.linalg.pinv(np.stack([a, b])) for a, b in zip(self._e1, self._e2)])

    def bounding_sphere(self) -> tuple[np.ndarray, float]:
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)
        return self.center, float(np.max(np.linalg.norm(signs @ self.L.T, axis=-1)))

    def face(self, x: np.ndarray) -> np.ndarray:
        """Index 2 axis + (q_axis > 0) of the face holding each surface point."""
        q = (as_points(x, 3) - self.center) @ self.Linv.T
        axis = np.argmax(np.abs(q), axis=-1)
        side = np.take_along_axis(q, axis[..., None], -1)[..., 0] > 0
        return 2 * axis + side

    def sample(self, u: np.ndarray) -> np.ndarray:
        u = as_uniforms(u, 2)
        k = np.minimum(np.searchsorted(self._cdf, u[..., 0], side="right"), 5)
        s = np.clip((u[..., 0] - self._cdf_lo[k]) / self.face_probs[k], 0.0, 1.0)
        return self._corner[k] + s[..., None] * self._e1[k] + u[..., 1:2] * self._e2[k]

    def pdf(self, x: np.ndarray) -> np.ndarray:
        x = as_points(x, 3)
        return np.full(x.shape[:-1], 1.0 / self.area)

    def invert(self, x: np.ndarray) -> np.ndarray:
        x = as_points(x, 3)
        k = self.face(x)
        st = np.einsum("...i,...ij->...j", x - self._corner[k], self._dual[k])
        return np.stack([self._cdf_lo[k] + st[..., 0] * self.face_probs[k], st[..., 1]], -1)

    def normal(self, x: np.ndarray) -> np.ndarray:
        return self._normals[self.face(x)]

    def intersect(self, origin: np.ndarray, direction: np.ndarray, t_min: float | None = None) -> np.ndarray:
        o, d = self._rays(origin, direction)
        o = (o - self.center) @ self.Linv.T          # unit-cube coordinates, same t
        d = d @ self.Linv.T
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / d
            t1, t2 = (-1.0 - o) * inv, (1.0 - o) * inv
        near = np.max(np.minimum(t1, t2), axis=-1)
        far = np.min(np.maximum(t1, t2), axis=-1)
        hit = near <= far                            # NaN (ray in a face plane) is a miss
        t = np.stack([near, far], -1)
        return _finish_hits(t, hit[..., None] & (t > self._t_min(t_min)))

    intersect.__doc__ = _INTERSECT_DOC

    def _repr_fields(self):
        return {"center": self.center.tolist(), "half_extents": np.round(self.half_extents, 6).tolist()}
