"""Triangle meshes as light surfaces, and directions towards them.

* :class:`TriangleMeshSurface`: a triangle chosen by area (an ``AliasTable``), then a point
  uniformly on it (the ``planar.Triangle`` warp): p_A = 1 / A on the mesh (measure: area);
* :class:`TriangleMeshSolidAngle`: directions from reference points towards the mesh, by
  area converted to solid angle (p_w = sum over every triangle the ray crosses of
  p_A d^2 / |cos|) or by choosing a triangle and sampling its spherical triangle uniformly
  (Arvo 1995, :class:`vrlab.distributions.SphericalTriangle`); ``sample_given``, ``pdf_given``:
  towards one given triangle (the light BVH's per-triangle leaves, :mod:`vrlab.render.light_tree`;
  computed by :mod:`.triangle_given`, compiled with ``kernels="numba"``).

The spherical-triangle sampler and the solid angle of a triangle live in :mod:`.triangles`.
"""
from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from .. import checks
from .._vec import dot, norm
from ..kernels import resolve_kernels
from .base import Distribution, as_float, as_points, as_uniforms, check_broadcast, finite_points
from .discrete import AliasTable
from .surfaces import Surface, _INTERSECT_DOC
from .triangle_given import density_given, relative, sample_given, spherical_towards
from .triangles import _BARY, _TOL, MIN_SOLID_ANGLE, _blocks, _f64, _omega, _rows, _unit

__all__ = ["MeshLightSample", "TriangleMeshSolidAngle", "TriangleMeshSurface"]


# ----------------------------------------------------------------------------- mesh surface

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
        return TriangleMeshSolidAngle(self, ref, method=method, **kw)

    def _repr_fields(self):
        return {"triangles": len(self.faces), "area": self.area}


# ----------------------------------------------------------------------------- directions to a mesh

class MeshLightSample(NamedTuple):
    """A direction towards a mesh light: unit ``w``, the sampled point ``y`` on triangle
    ``triangle``, ``dist = |y - ref|`` and the solid-angle ``pdf`` of w (every hit counted)."""

    w: np.ndarray
    y: np.ndarray
    dist: np.ndarray
    pdf: np.ndarray
    triangle: np.ndarray


class TriangleMeshSolidAngle(Distribution):
    """Directions from ``ref`` towards a ``TriangleMeshSurface`` (measure: solid angle).

    ``method="area"``: w = normalize(y - ref), y ~ the mesh by area (as ``SolidAngleFromArea``),
    p(w) = sum over the hits (t_j, k_j) of the ray (ref, w) of t_j^2 / (A |w . n_kj|).
    ``method="spherical"``: triangle k ~ P_k (u1, remapped), then w ~ ``SphericalTriangle`` of
    k (r, u2); p(w) = sum over hits of P_kj p_kj(w), p_k = 1 / Omega_k (or the area-fallback
    density 2 t^2 / |w . n_k| below ``min_solid_angle``).  ``selection="area"``: P_k = A_k / A,
    O(1) per point (the default: the renderer samples 10^5-10^6 points per pass, and near a
    large triangle, where area sampling is poor, that triangle also has a large area);
    ``selection="solid_angle"``: P_k = Omega_k / sum_j Omega_j, so p(w) = (number of hits) /
    sum_j Omega_j, uniform over the mesh's directions, at O(F) per point (small meshes).
    A closed mesh seen from outside is crossed twice by each direction: both triangles could
    have produced w, so both terms count (as in ``SolidAngleFromArea``).

    ``sample_point(u)`` -> ``MeshLightSample``; its pdf always counts the sampled triangle
    (rounding at an edge cannot drop it).  ``pdf_from_hits(w, t, triangles)``: the pdf from
    hits found by another tracer (every hit of the ray, as ``surface.hits`` gives them).
    ``ref`` (..., 3) broadcasts with u (..., 2) / w (..., 3) as in ``SolidAngleFromArea``.
    Checked: ``surface`` a ``TriangleMeshSurface`` (``TypeError``), ``ref`` finite (..., 3),
    ``method``, ``selection`` in ``METHODS``, ``SELECTIONS``, ``min_solid_angle >= 0``;
    ``kernels`` ("numpy", "numba", "auto"; resolved here): those of ``sample_given`` and
    ``pdf_given`` (:mod:`.triangle_given`).
    """

    dim_u = 2
    dim_x = 3
    measure = "solid angle"
    METHODS = ("spherical", "area")
    SELECTIONS = ("area", "solid_angle")

    def __init__(self, surface: TriangleMeshSurface, ref: Any, method: str = "spherical", selection: str = "area",
                 min_solid_angle: float = MIN_SOLID_ANGLE, *, kernels: str = "numpy"):
        self.kernels = resolve_kernels(kernels)
        if not isinstance(surface, TriangleMeshSurface):
            raise TypeError(f"surface must be a TriangleMeshSurface, got {checks.describe(surface)}")
        self.surface = surface
        self.ref = np.asarray(finite_points(ref, 3, "ref"), np.float64)
        self.method = checks.choice(method, "method", self.METHODS)
        self.selection = checks.choice(selection, "selection", self.SELECTIONS)
        self.min_solid_angle = checks.real(min_solid_angle, "min_solid_angle", low=0.0)

    def _flat(self, x, k, name):
        x = check_broadcast(_f64(x, k, name), name, self.ref.shape[:-1], "ref")
        shape = np.broadcast_shapes(x.shape[:-1], self.ref.shape[:-1])
        return (np.broadcast_to(x, shape + (k,)).reshape(-1, k),
                np.broadcast_to(self.ref, shape + (3,)).reshape(-1, 3), shape)

    def _rel(self, k, ref):
        return relative(self.surface, k, ref)

    def _totals(self, ref, u1=None):
        """sum_j Omega_j per point; with u1 also (k, r): k ~ Omega_k / sum, r the remapped u1."""
        s, F = self.surface, len(self.surface.n)
        tot, k, r = np.empty(len(ref)), np.zeros(len(ref), np.int64), np.zeros(len(ref))
        for sl in _blocks(len(ref), F):
            cdf = np.cumsum(_omega(*self._rel(slice(None), ref[sl, None, :])), 1)
            tot[sl] = cdf[:, -1]
            if u1 is not None:
                target = u1[sl] * cdf[:, -1]
                kk = np.minimum(np.sum(cdf <= target[:, None], 1), F - 1)
                lo = np.where(kk > 0, cdf[np.arange(len(kk)), np.maximum(kk - 1, 0)], 0.0)
                width = cdf[np.arange(len(kk)), kk] - lo
                k[sl] = kk
                r[sl] = np.clip((target - lo) / np.where(width > 0, width, 1.0), 0.0, np.nextafter(1.0, 0.0))
        if u1 is not None:
            none = ~(tot > 0)                           # ref in the plane of a planar mesh: density 0
            if none.any():
                k[none], r[none] = s.table.sample(u1[none], return_remapped=True)
        return tot, k, r

    def _terms(self, w, ref, t, k, tot):
        """Densities of the hits (t, k) (N, K) of unit w (N, 3) from ref (N, 3)."""
        s, hit = self.surface, k >= 0
        kc = np.maximum(k, 0)
        wn = np.abs(dot(w[:, None, :], s.n[kc]))
        tt = np.where(hit, t, 0.0)
        ok = hit & (wn > 0) & np.isfinite(tt)
        wn = np.where(ok, wn, 1.0)
        if self.method == "area":
            return np.where(ok, tt * tt * (2.0 * s.areas[kc]) / (s.area * wn), 0.0)
        om = _omega(*self._rel(kc, ref[:, None, :]))
        sph = om >= max(self.min_solid_angle, np.finfo(float).tiny)
        p = np.where(sph, 1.0 / np.where(sph, om, 1.0), 2.0 * tt * tt / wn)
        if self.selection == "area":
            P = s.areas[kc] / s.area
        else:
            P = om / np.where(tot > 0, tot, np.inf)[:, None]
        return np.where(ok, P * p, 0.0)

    def _pdf(self, w, ref, t, k, own=None, tot=None):
        """Sum of the hit densities; ``own``: the sampled triangles, counted even if rounding
        at an edge made the ray miss them; ``tot``: sum_j Omega_j if known."""
        if own is not None:
            va, _, _, n = self._rel(own, ref)
            with np.errstate(divide="ignore", invalid="ignore"):
                t_own = dot(va, n) / dot(w, n)
            new = ~np.any(k == own[:, None], 1) & np.isfinite(t_own) & (t_own > 0)
            t = np.concatenate([t, np.where(new, t_own, np.inf)[:, None]], 1)
            k = np.concatenate([k, np.where(new, own, -1)[:, None]], 1)
        if tot is None and self.method == "spherical" and self.selection == "solid_angle":
            tot = self._totals(ref)[0]
        return np.sum(self._terms(w, ref, t, k, tot), 1)

    def _sample(self, u):
        u, ref, shape = self._flat(as_uniforms(u, 2), 2, "u")
        s = self.surface
        if self.method == "area":
            y, k = s.sample_point(u)
            v = y - ref
            return _unit(v, s.face_normals[k]), y, norm(v), k, ref, shape, None
        if self.selection == "area":
            (k, r), tot = s.table.sample(u[:, 0], return_remapped=True), None
        else:
            tot, k, r = self._totals(ref, u[:, 0])
        w, y, t = spherical_towards(s, k, np.stack([r, u[:, 1]], -1), ref, self.min_solid_angle)
        return w, y, t, k, ref, shape, tot

    # -- one given triangle per point (the light BVH's per-triangle leaves) -----------------
    def sample_given(self, triangles: Any, u: np.ndarray) -> MeshLightSample:
        """Directions towards the given ``triangles`` (one index per point, broadcast with
        ``u (..., 2)`` and ref): by area (y uniform on triangle k, w = normalize(y - ref)) or,
        with ``method="spherical"``, uniform in k's spherical triangle.  ``pdf`` is the density
        *given* k, p_k(w) (see :meth:`pdf_given`), not the mesh's sum over hits."""
        u, ref, shape = self._flat(as_uniforms(u, 2), 2, "u")
        k = self._given(triangles, shape)
        w, y, dist, pdf = sample_given(self.surface, k, u, ref, self.method, self.min_solid_angle, self.kernels)
        return MeshLightSample(*(a.reshape(shape + a.shape[1:]) for a in (w, y, dist, pdf, k)))

    def pdf_given(self, w: np.ndarray, triangles: Any) -> np.ndarray:
        """p_k(w), the density of directions towards triangle k alone, for unit-able ``w``
        that meet triangle ``k`` (not checked; t is the distance to k's plane along w):
        by area t^2 / (A_k |cos theta_k|) = 2 t^2 / |w . (e1 x e2)|; spherical 1 / Omega_k
        (the area density below ``min_solid_angle``, as in the mesh density)."""
        w, ref, shape = self._flat(w, 3, "w")
        return density_given(self.surface, _unit(w), ref, self._given(triangles, shape), self.method,
                             self.min_solid_angle, self.kernels).reshape(shape)

    def _given(self, triangles, shape):
        k = np.asarray(triangles)
        if k.dtype.kind not in "iu":
            raise TypeError(f"triangles must be integer triangle indices, got {checks.describe(triangles)}")
        k = np.broadcast_to(k, shape).reshape(-1).astype(np.int64)
        if len(k) and (k.min() < 0 or k.max() >= len(self.surface.n)):
            raise ValueError(f"triangles: indices must lie in [0, {len(self.surface.n) - 1}], got {k.min()} "
                             f"to {k.max()}")
        return k

    def sample(self, u: np.ndarray) -> np.ndarray:
        w, *_, shape, _ = self._sample(u)
        return w.reshape(shape + (3,))

    def sample_point(self, u: np.ndarray) -> MeshLightSample:
        """``MeshLightSample(w, y, dist, pdf, triangle)`` (see the class docstring)."""
        w, y, dist, k, ref, shape, tot = self._sample(u)
        pdf = self._pdf(w, ref, *self.surface.hits(ref, w), own=k, tot=tot)
        return MeshLightSample(w.reshape(shape + (3,)), y.reshape(shape + (3,)), dist.reshape(shape),
                               pdf.reshape(shape), k.reshape(shape))

    def sample_pdf(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s = self.sample_point(u)
        return s.w, s.pdf

    def pdf(self, w: np.ndarray) -> np.ndarray:
        w, ref, shape = self._flat(w, 3, "w")
        w = _unit(w)
        return self._pdf(w, ref, *self.surface.hits(ref, w)).reshape(shape)

    def pdf_from_hits(self, w: np.ndarray, t: np.ndarray, triangles: np.ndarray) -> np.ndarray:
        """p(w) from every hit of the rays (ref, w), found by another tracer: distances t (..., K)
        along unit w and triangle indices (..., K) (-1: none), as ``surface.hits`` gives them."""
        w, ref, shape = self._flat(w, 3, "w")
        t = np.asarray(as_float(t, "t"), np.float64)
        t = np.broadcast_to(t, shape + t.shape[-1:]).reshape(len(w), -1)
        k = np.broadcast_to(np.asarray(triangles), shape + t.shape[-1:]).reshape(t.shape).astype(np.int64)
        return self._pdf(_unit(w), ref, t, k).reshape(shape)

    def pdf_at(self, y: np.ndarray, w: np.ndarray) -> np.ndarray:
        """p(w) for a mesh that the ray (ref, w) meets once, at the known point ``y``."""
        y = _f64(y, 3, "y")
        k = self.surface.locate(y)
        wu = _unit(_f64(w, 3, "w"))
        t = dot(y - self.ref, wu)
        return self.pdf_from_hits(wu, t[..., None], k[..., None])

    def _repr_fields(self):
        return {"surface": self.surface, "ref_shape": self.ref.shape, "method": self.method,
                "selection": self.selection}
