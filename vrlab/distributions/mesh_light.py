"""Directions towards triangle-mesh lights.

* :class:`TriangleMeshSurface` (:mod:`.mesh_surface`, re-exported here): a triangle chosen by
  area, then a point uniformly on it: p_A = 1 / A on the mesh (measure: area);
* :class:`TriangleMeshSolidAngle`: directions from reference points towards the mesh, by
  area converted to solid angle (p_w = sum over every triangle the ray crosses of
  p_A d^2 / |cos|) or by choosing a triangle and sampling its spherical triangle uniformly
  (Arvo 1995, :class:`vrlab.distributions.SphericalTriangle`); ``sample_given``, ``pdf_given``:
  towards one given triangle (the light BVH's per-triangle leaves, :mod:`vrlab.render.light_tree`).

The spherical-triangle sampler and the solid angle of a triangle live in :mod:`.triangles`.
"""
from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from .. import checks
from .._vec import dot, norm
from ..kernels import load_kernel, resolve_kernels
from .base import Distribution, as_float, as_uniforms, check_broadcast, finite_points
from .mesh_surface import TriangleMeshSurface
from .triangles import MIN_SOLID_ANGLE, _blocks, _f64, _Geom, _omega, _unit

__all__ = ["MeshLightSample", "TriangleMeshSolidAngle", "TriangleMeshSurface"]

_KERNEL = "vrlab.distributions.mesh_light_kernel"


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
    ``method``, ``selection`` in ``METHODS``, ``SELECTIONS``, ``min_solid_angle >= 0``.
    ``kernels`` ("numpy", "numba" or "auto", resolved here, see :mod:`vrlab.kernels`): "numba"
    runs ``sample_given`` and ``pdf_given`` as one compiled loop over the points
    (:mod:`vrlab.distributions.mesh_light_kernel`, the same operations; this NumPy code is its oracle).
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
        s = self.surface
        va = s.v0[k] - ref
        return va, va + s.e1[k], va + s.e2[k], s.n[k]

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
        w, y, t = self._spherical(k, np.stack([r, u[:, 1]], -1), ref)
        return w, y, t, k, ref, shape, tot

    def _spherical(self, k, u, ref):
        """``(w, y, t)``: w uniform in the spherical triangle of triangles ``k`` from ``ref``
        (or by area below ``min_solid_angle``), y = ref + t w the point on k."""
        va, vb, vc, n = self._rel(k, ref)
        w = _Geom(va, vb, vc, self.min_solid_angle).sample(u)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = dot(va, n) / dot(w, n)
        t = np.where(np.isfinite(t) & (t > 0), t, 0.0)
        return w, ref + w * t[:, None], t

    # -- one given triangle per point (the light BVH's per-triangle leaves) -----------------
    def sample_given(self, triangles: Any, u: np.ndarray) -> MeshLightSample:
        """Directions towards the given ``triangles`` (one index per point, broadcast with
        ``u (..., 2)`` and ref): by area (y uniform on triangle k, w = normalize(y - ref)) or,
        with ``method="spherical"``, uniform in k's spherical triangle.  ``pdf`` is the density
        *given* k, p_k(w) (see :meth:`pdf_given`), not the mesh's sum over hits."""
        u, ref, shape = self._flat(as_uniforms(u, 2), 2, "u")
        k = self._given(triangles, shape)
        if self.kernels == "numba":
            w, y, dist, pdf = self._compiled(k, ref, u=u)
            return MeshLightSample(*(a.reshape(shape + a.shape[1:]) for a in (w, y, dist, pdf, k)))
        if self.method == "area":
            y = self.surface.point_on(k, u)
            v = y - ref
            w, dist = _unit(v, self.surface.face_normals[k]), norm(v)
        else:
            w, y, dist = self._spherical(k, u, ref)
        pdf = self._density_given(w, ref, k)
        return MeshLightSample(*(a.reshape(shape + a.shape[1:]) for a in (w, y, dist, pdf, k)))

    def pdf_given(self, w: np.ndarray, triangles: Any) -> np.ndarray:
        """p_k(w), the density of directions towards triangle k alone, for unit-able ``w``
        that meet triangle ``k`` (not checked; t is the distance to k's plane along w):
        by area t^2 / (A_k |cos theta_k|) = 2 t^2 / |w . (e1 x e2)|; spherical 1 / Omega_k
        (the area density below ``min_solid_angle``, as in the mesh density)."""
        w, ref, shape = self._flat(w, 3, "w")
        k = self._given(triangles, shape)
        if self.kernels == "numba":
            return self._compiled(k, ref, w=_unit(w))[0].reshape(shape)
        return self._density_given(_unit(w), ref, k).reshape(shape)

    def _compiled(self, k, ref, u=None, w=None):
        """``(w, y, dist, pdf)`` of ``sample_given`` (uniforms ``u``) or ``(pdf,)`` of ``pdf_given``
        (unit ``w``) by the compiled kernels (:mod:`.mesh_light_kernel`)."""
        s, c = self.surface, np.ascontiguousarray
        args = (c(s.v0), c(s.e1), c(s.e2), c(s.n))
        ref, sph, pdf = c(ref, np.float64), self.method == "spherical", np.empty(len(k))
        if w is not None:
            load_kernel(_KERNEL, "given_pdf")(*args, k, c(w, np.float64), ref, sph, self.min_solid_angle, pdf)
            return (pdf,)
        w, y, dist = np.empty((len(k), 3)), np.empty((len(k), 3)), np.empty(len(k))
        load_kernel(_KERNEL, "given_sample")(*args, c(s.face_normals), k, c(u, np.float64), ref, sph,
                                             self.min_solid_angle, w, y, dist, pdf)
        return w, y, dist, pdf

    def _given(self, triangles, shape):
        k = np.asarray(triangles)
        if k.dtype.kind not in "iu":
            raise TypeError(f"triangles must be integer triangle indices, got {checks.describe(triangles)}")
        k = np.broadcast_to(k, shape).reshape(-1).astype(np.int64)
        if len(k) and (k.min() < 0 or k.max() >= len(self.surface.n)):
            raise ValueError(f"triangles: indices must lie in [0, {len(self.surface.n) - 1}], got {k.min()} "
                             f"to {k.max()}")
        return k

    def _density_given(self, w, ref, k):
        va, vb, vc, n = self._rel(k, ref)
        wn = np.abs(dot(w, n))
        with np.errstate(divide="ignore", invalid="ignore"):
            t = dot(va, n) / dot(w, n)
        ok = (wn > 0) & np.isfinite(t) & (t > 0)
        tt, wn = np.where(ok, t, 0.0), np.where(ok, wn, 1.0)
        p = 2.0 * tt * tt / wn
        if self.method == "spherical":
            om = _omega(va, vb, vc, n)
            sph = om >= max(self.min_solid_angle, np.finfo(float).tiny)
            p = np.where(sph, 1.0 / np.where(sph, om, 1.0), p)
        return np.where(ok, p, 0.0)

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
