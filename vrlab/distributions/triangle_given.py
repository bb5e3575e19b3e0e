"""Directions towards one given triangle per point of a triangle mesh (the light BVH's
per-triangle leaves, :mod:`vrlab.render.light_tree`): what ``TriangleMeshSolidAngle``'s
``sample_given`` and ``pdf_given`` compute, in NumPy (the oracle) or compiled.

For triangle k (rows v0, e1, e2, n = e1 x e2 of a ``TriangleMeshSurface``; |n| = 2 A_k) seen
from ref, with va = v0 - ref:

* by area: y = v0 + b1 e1 + (1 - b0 - b1) e2, (b0, b1) the square-root warp of u
  (``planar.Triangle``), w = (y - ref) / |y - ref|, dist = |y - ref|;
* spherical: w uniform in k's spherical triangle (Arvo 1995, :mod:`.triangles`; area
  sampling below ``min_solid_angle``), y = ref + t w on k's plane, t = (va . n) / (w . n);
* the density given k, in solid angle: by area t^2 / (A_k |cos theta_k|) = 2 t^2 / |w . n|,
  spherical 1 / Omega_k where Omega_k >= ``min_solid_angle`` (else the area density); 0
  unless t > 0 is finite and w . n != 0.

``kernels="numba"``: one compiled loop over the points (:mod:`.mesh_light_kernel`, the same
operations in the same order).
"""
from __future__ import annotations

import numpy as np

from .._vec import dot, norm
from ..kernels import load_kernel
from .triangles import _Geom, _omega, _unit

_KERNEL = "vrlab.distributions.mesh_light_kernel"


def relative(surface, k, ref) -> tuple:
    """``(va, vb, vc, n)``: triangles ``k``'s vertices relative to ``ref`` and n = e1 x e2."""
    va = surface.v0[k] - ref
    return va, va + surface.e1[k], va + surface.e2[k], surface.n[k]


def spherical_towards(surface, k, u, ref, min_solid_angle: float) -> tuple:
    """``(w, y, t)``: w uniform in the spherical triangle of triangles ``k`` from ``ref``
    (or by area below ``min_solid_angle``), y = ref + t w the point on k (t = 0 off k's plane)."""
    va, vb, vc, n = relative(surface, k, ref)
    w = _Geom(va, vb, vc, min_solid_angle).sample(u)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = dot(va, n) / dot(w, n)
    t = np.where(np.isfinite(t) & (t > 0), t, 0.0)
    return w, ref + w * t[:, None], t


def sample_given(surface, k, u, ref, method: str, min_solid_angle: float, kernels: str) -> tuple:
    """``(w, y, dist, pdf)`` towards triangles ``k (N,)`` from ``ref (N, 3)`` with uniforms
    ``u (N, 2)`` (float64), ``method`` "area" or "spherical", ``kernels`` "numpy" or "numba"."""
    if kernels == "numba":
        return _compiled(surface, k, ref, method, min_solid_angle, u=u)
    if method == "area":
        y = surface.point_on(k, u)
        v = y - ref
        w, dist = _unit(v, surface.face_normals[k]), norm(v)
    else:
        w, y, dist = spherical_towards(surface, k, u, ref, min_solid_angle)
    return w, y, dist, density_given(surface, w, ref, k, method, min_solid_angle, "numpy")


def density_given(surface, w, ref, k, method: str, min_solid_angle: float, kernels: str) -> np.ndarray:
    """p_k(w) of unit ``w (N, 3)`` from ``ref (N, 3)`` towards triangles ``k (N,)``."""
    if kernels == "numba":
        return _compiled(surface, k, ref, method, min_solid_angle, w=w)[0]
    va, vb, vc, n = relative(surface, k, ref)
    wn = np.abs(dot(w, n))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = dot(va, n) / dot(w, n)
    ok = (wn > 0) & np.isfinite(t) & (t > 0)
    tt, wn = np.where(ok, t, 0.0), np.where(ok, wn, 1.0)
    p = 2.0 * tt * tt / wn
    if method == "spherical":
        om = _omega(va, vb, vc, n)
        sph = om >= max(min_solid_angle, np.finfo(float).tiny)
        p = np.where(sph, 1.0 / np.where(sph, om, 1.0), p)
    return np.where(ok, p, 0.0)


def _compiled(surface, k, ref, method, min_solid_angle, u=None, w=None) -> tuple:
    """``(w, y, dist, pdf)`` for uniforms ``u``, or ``(pdf,)`` for unit ``w``, by the kernels."""
    c = np.ascontiguousarray
    tables = (c(surface.v0), c(surface.e1), c(surface.e2), c(surface.n))
    ref, sph, pdf = c(ref, np.float64), method == "spherical", np.empty(len(k))
    if w is not None:
        load_kernel(_KERNEL, "given_pdf")(*tables, k, c(w, np.float64), ref, sph, min_solid_angle, pdf)
        return (pdf,)
    w, y, dist = np.empty((len(k), 3)), np.empty((len(k), 3)), np.empty(len(k))
    load_kernel(_KERNEL, "given_sample")(*tables, c(surface.face_normals), k, c(u, np.float64), ref, sph,
                                         min_solid_angle, w, y, dist, pdf)
    return w, y, dist, pdf
