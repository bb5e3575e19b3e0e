"""Triangle meshes as light surfaces: :class:`TriangleMeshSurface`, a triangle chosen by area
(an ``AliasTable``), then a point uniformly on it (the ``planar.Triangle`` warp): p_A = 1 / A
on the mesh (measure: area).  Directions towards it: :mod:`vrlab.distributions.mesh_light`.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .. import checks
from .._vec import dot, norm
from .base import as_points, as_uniforms
from .discrete import AliasTable
from .surfaces import Surface, _INTERSECT_DOC
from .triangles import _BARY, _TOL, _blocks, _f64, _rows, _unit

__all__ = ["TriangleMeshSurface"]


class TriangleMeshSurface(Surface):
    """Uniform points on a triangle mesh by area: p = 1 / A (area), A = sum of A_k.

    ``sample_point(u) -> (x, k)``: triangle k ~ A_k / A through an ``AliasTable`` on u1, whose
    remapped uniform r and u2 give x = b0 v0 + b1 v1 + (1 - b0 - b1) v2 with (b0, b1) =
    ``planar.Triangle``'s warp of (r, u2).  ``normal_of(k)``: the winding normal
    normalize((v1 - v0) x (v2 - v0)) (zero for zero-area triangles, which are never sampled);
    ``normal(x)``: that of ``locate(x)``, the triangle nearest x (by plane distance plus
    distance outside the triangle's edges; O(F) per point).  ``normals`` (V, 3): optional
    vertex (shading) normals, kept as ``vertex_normals``; sampling ignores them.
    ``intersect`` returns every hit (K = the most hits of any ray in the call, <= max_hits =
    F; see the module docstring for the cost).  Checked: ``vertices`` finite (V, 3), ``faces``
    integers (F, 3) in [0, V), F >= 1, some triangle of positive area, ``normals`` finite (V, 3).
    """

    def __init__(self, vertices: Any, faces: Any, normals: Any = None):
        v = checks.finite_array(vertices, "vertices", ndim=2, last=3)
        f = np.asarray(faces)
        if f.dtype.kind not in "iu":
            raise TypeError(f"faces must be an integer array (F, 3), got {checks.describe(faces)}")
        if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
            raise ValueError(f"faces must have shape (F, 3) with F >= 1, got {f.shape}")
        if f.min() < 0 or f.max() >= len(v):
            raise ValueError(f"faces: vertex indices must lie in [0, {len(v) - 1}], got {f.min()} to {f.max()}")
        self.vertices, self.faces = v, f.astype(np.int64)
        self.vertex_normals = None if normals is None else checks.finite_array(normals, "normals", ndim=2, last=3)
        if self.vertex_normals is not None and len(self.vertex_normals) != len(v):
            raise ValueError(f"normals: expected one per vertex ({len(v)}), got {len(self.vertex_normals)}")
        tri = v[self.faces]
        self.v0, self.e1, self.e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        self.n = np.cross(self.e1, self.e2)                       # |n| = 2 A_k
        twice = norm(self.n)
        self.areas = 0.5 * twice
        self.area = float(np.sum(np.sort(self.areas)))
        if not (self.area > 0 and np.isfinite(self.area)):
            raise ValueError("faces: every triangle of the mesh has zero area (or the area overflows)")
        self.table = AliasTable(self.areas)
        self.max_hits = len(f)
        self.face_normals = _unit(self.n)
        used = v[np.unique(self.faces)]
        self._center = 0.5 * (used.min(0) + used.max(0))
        self._radius = float(np.max(norm(used - self._center)))
        nn = np.where(twice > 0, twice * twice, np.inf)[:, None]
        self._p0 = self.v0 - self._center                       # coordinates about the centre
        self._g1, self._g2 = np.cross(self.e2, self.n) / nn, np.cross(self.n, self.e1) / nn   # (x - v0).g = b
        self._c = (dot(self._p0, self.n), dot(self._p0, self._g1), dot(self._p0, self._g2))
        self._size = np.where(twice > 0, np.sqrt(twice), np.inf)

    @classmethod
    def from_triangles(cls, triangles: Any) -> "TriangleMeshSurface":
        """A mesh of separate triangles ``(F, 3, 3)`` (e.g. ``vrlab.render`` ``Mesh.triangles()``)."""
        t = checks.finite_array(triangles, "triangles", ndim=3)
        if t.shape[1:] != (3, 3):
            raise ValueError(f"triangles must have shape (F, 3, 3), got {t.shape}")
        return cls(t.reshape(-1, 3), np.arange(3 * len(t)).reshape(-1, 3))

    def bounding_sphere(self) -> tuple[np.ndarray, float]:
        return self._center, self._radius

    def sample_point(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(x, k)``: points (..., 3) and their triangle indices (...)."""
        u = _f64(as_uniforms(u, 2), 2, "u")
        k, r = self.table.sample(u[..., 0], return_remapped=True)
        return self.point_on(k, np.stack([r, u[..., 1]], -1)), k

    def point_on(self, k: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Uniform points on the given triangles ``k (...)`` from uniforms ``u (..., 2)``:
        x = b0 v0 + b1 v1 + (1 - b0 - b1) v2, (b0, b1) = ``planar.Triangle``'s warp of u."""
        b = _BARY.sample(u)
        return self.v0[k] + self.e1[k] * b[..., 1:] + self.e2[k] * (1.0 - b[..., 0] - b[..., 1])[..., None]

    def sample(self, u: np.ndarray) -> np.ndarray:
        return self.sample_point(u)[0]

    def pdf(self, x: np.ndarray) -> np.ndarray:
        return np.full(as_points(x, 3).shape[:-1], 1.0 / self.area)

    def normal_of(self, k: Any) -> np.ndarray:
        """Unit winding normals of triangles ``k`` (integer array): (..., 3)."""
        return self.face_normals[np.asarray(k)]

    def locate(self, x: np.ndarray) -> np.ndarray:
        """Index of the triangle nearest each point (..., 3): argmin |plane distance| + size x
        (amount outside the barycentric range); zero-area triangles are skipped."""
        x = _f64(x, 3, "x")
        flat = x.reshape(-1, 3) - self._center
        out = np.empty(len(flat), np.int64)
        nhat = self.face_normals
        for sl in _blocks(len(flat), len(self.n)):
            p = flat[sl]
            h = np.abs(_rows(p, nhat) - dot(self._p0, nhat))
            b1, b2 = _rows(p, self._g1) - self._c[1], _rows(p, self._g2) - self._c[2]
            off = np.maximum(np.maximum(-b1, -b2), np.maximum(b1 + b2 - 1.0, 0.0))
            out[sl] = np.argmin(h + self._size * off, axis=1)
        return out.reshape(x.shape[:-1])

    def normal(self, x: np.ndarray) -> np.ndarray:
        return self.face_normals[self.locate(x)]

    def hits(self, origin: np.ndarray, direction: np.ndarray, t_min: float | None = None):
        """``(t, k)`` of every hit of the rays: t (..., K) ascending (inf padding), k the
        triangle index (-1 padding).  Barycentric tolerance 1e-10 (a ray through a shared edge
        may count both triangles)."""
        o, d = self._rays(origin, direction)
        shape = np.broadcast_shapes(o.shape, d.shape)
        o = np.broadcast_to(np.asarray(o, np.float64), shape).reshape(-1, 3) - self._center
        d = np.broadcast_to(np.asarray(d, np.float64), shape).reshape(-1, 3)
        t_min = self._t_min(t_min)
        ts, ks = [np.full((0, 1), np.inf)], [np.full((0, 1), -1)]
        for sl in _blocks(len(o), len(self.n)):
            oo, dd = o[sl], d[sl]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (self._c[0] - _rows(oo, self.n)) / _rows(dd, self.n)
            tt = np.where(np.isfinite(t), t, 0.0)
            b1 = _rows(oo, self._g1) - self._c[1] + tt * _rows(dd, self._g1)
            b2 = _rows(oo, self._g2) - self._c[2] + tt * _rows(dd, self._g2)
            t = np.where((t > t_min) & (b1 >= -_TOL) & (b2 >= -_TOL) & (b1 + b2 <= 1.0 + _TOL), t, np.inf)
            kk = max(int(np.isfinite(t).sum(1).max(initial=0)), 1)
            idx = np.argpartition(t, kk - 1, 1)[:, :kk]             # the kk nearest, then sorted
            idx = np.take_along_axis(idx, np.argsort(np.take_along_axis(t, idx, 1), 1), 1)
            ts.append(np.take_along_axis(t, idx, 1))
            ks.append(np.where(np.isfinite(ts[-1]), idx, -1))
        K = max(a.shape[1] for a in ts)
        t = np.concatenate([np.pad(a, ((0, 0), (0, K - a.shape[1])), constant_values=np.inf) for a in ts])
        k = np.concatenate([np.pad(a, ((0, 0), (0, K - a.shape[1])), constant_values=-1) for a in ks])
        return t.reshape(shape[:-1] + (K,)), k.reshape(shape[:-1] + (K,))

    def intersect(self, origin: np.ndarray, direction: np.ndarray, t_min: float | None = None) -> np.ndarray:
        return self.hits(origin, direction, t_min)[0]

    intersect.__doc__ = _INTERSECT_DOC

    def solid_angle_from(self, ref: np.ndarray, method: str = "area", **kw) -> "TriangleMeshSolidAngle":
        """Directions from ``ref`` towards the mesh (``TriangleMeshSolidAngle``; by default by
        area, the same samples and density as ``SolidAngleFromArea(self, ref)``, faster)."""
        from .mesh_light import TriangleMeshSolidAngle

        return TriangleMeshSolidAngle(self, ref, method=method, **kw)

    def _repr_fields(self):
        return {"triangles": len(self.faces), "area": self.area}
