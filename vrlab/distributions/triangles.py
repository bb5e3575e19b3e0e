"""Triangle-mesh lights: points by area, Arvo's spherical triangles, directions to a mesh.

* ``TriangleMeshSurface(vertices, faces)``: triangle k with probability A_k / A (``AliasTable`` on
  u1, whose remapped uniform is reused), uniform in it by ``planar.Triangle``'s warp; p = 1 / A
  (area).  Mitsuba 3 (src/render/mesh.cpp, sample_position) does the same with a CDF on u2.
* ``SphericalTriangle(a, b, c, ref)``: directions uniform in the solid angle the triangle
  subtends from ``ref``, p = 1 / Omega (solid angle).  Arvo, "Stratified sampling of spherical
  triangles", SIGGRAPH 1995, rearranged to avoid cancellation (below).
* ``TriangleMeshSolidAngle(surface, ref, method)``: directions towards a mesh, by area or by a
  triangle then ``SphericalTriangle``; the pdf sums every triangle the ray (ref, w) crosses.
* ``triangle_solid_angle(a, b, c, ref)``: Van Oosterom & Strackee, IEEE TBME 30(2), 1983:
  tan(Omega/2) = |a.(b x c)| / (|a||b||c| + (a.b)|c| + (a.c)|b| + (b.c)|a|) with a, b, c relative
  to ref, a.(b x c) = a.((b - a) x (c - a)) (exact for far, small triangles).

Arvo step 1: C' on the arc AC with area(A, B, C') = u1 Omega.  With h = u1 Omega / 2, alpha the
angle at A, c the arc AB, k = 1 - cos c = sin^2 c / (1 + cos c) and s = 2 sin h sin(alpha - h),
the spherical law of cosines gives (our rearrangement of Arvo's q = cos b')

    tan b' = sin(c) s / (k (sin^2 alpha - 2 sin(h) cos(alpha) sin(alpha - h)) - 2 sin^2 h),

C' = cos b' A + sin b' T (T the unit tangent at A towards C).  Step 2: w on the arc B -> C' with
1 - cos theta = u2 (1 - B.C') (the area element about B is sin theta dtheta dphi).  ``invert``:
C' = the arc AC met by the great circle through B and w, u1 = Omega(A, B, C') / Omega,
u2 = |w - B|^2 / |C' - B|^2.  Below ``min_solid_angle`` (default 1e-12 sr; always for Omega = 0,
i.e. ref within 1e-12 rad of the triangle's plane) directions come from area sampling with its
exact density 2 (a.n)^2 / |w.n|^3 = d^2 / (A |cos|) (n = (b - a) x (c - a), unit w), as pbrt-v4
does below 3e-4 sr in float32; here the rearranged formulas stay exact to ~1e-14 sr (tested).
From the triangle's plane the density is 0 and w finite (the normal if ref is on the triangle).

Cost: ``hits``/``intersect`` test every ray against every triangle, elementwise in blocks of 2^18
pairs (~50 ns a pair): fine up to ~10^4 triangles and 10^5 rays; not a BVH.  Selection by solid
angle computes all F solid angles per point (O(F), ~0.15 us a pair).  Everything is float64.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .. import checks
from .._vec import dot, norm
from .base import Distribution, as_points, as_uniforms, check_broadcast, finite_points
from .planar import Triangle

__all__ = ["SphericalTriangle", "triangle_solid_angle"]

_BARY = Triangle((1.0, 0.0), (0.0, 1.0), (0.0, 0.0))   # sample(u) = barycentrics (b0, b1) of the sqrt warp
_TOL = 1e-10         # barycentric tolerance of ray-triangle hits (rounding at shared edges)
_EDGE_TOL = 1e-9     # w may lie outside an edge by this fraction of the triangle's height
_PAIRS = 1 << 18     # ray-triangle pairs per block
MIN_SOLID_ANGLE = 1e-12


def _f64(x: Any, k: int, name: str) -> np.ndarray:
    return np.asarray(as_points(x, k, name), np.float64)


def _unit(v: np.ndarray, fallback: np.ndarray | None = None) -> np.ndarray:
    """v / |v|; zero vectors become ``fallback`` (or stay zero)."""
    n = norm(v)[..., None]
    out = v / np.where(n > 0, n, 1.0)
    return out if fallback is None else np.where(n > 0, out, fallback)


def _rows(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """p_i . q_j for rows p (N, 3), q (F, 3): (N, F), elementwise (same bits for any batch)."""
    return p[:, None, 0] * q[:, 0] + p[:, None, 1] * q[:, 1] + p[:, None, 2] * q[:, 2]


def _blocks(n: int, f: int):
    step = max(1, _PAIRS // max(f, 1))
    return (slice(i, min(i + step, n)) for i in range(0, n, step))


def _omega(va: np.ndarray, vb: np.ndarray, vc: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Van Oosterom-Strackee solid angle of vertices va, vb, vc (relative to the viewpoint),
    n = (vb - va) x (vc - va); 0 where the viewpoint lies within 1e-12 rad of the plane
    (seen from va: rounding leaves ~1e-16 there, not 0)."""
    la, lb, lc = norm(va), norm(vb), norm(vc)
    triple = np.abs(dot(va, n))
    den = la * lb * lc + dot(va, vb) * lc + dot(va, vc) * lb + dot(vb, vc) * la
    return np.where(triple > 1e-12 * la * norm(n), 2.0 * np.arctan2(triple, den), 0.0)


def triangle_solid_angle(a: Any, b: Any, c: Any, ref: Any) -> np.ndarray:
    """Solid angle (sr) of the triangle (a, b, c) seen from ``ref`` (all (..., 3), broadcast):
    Van Oosterom & Strackee 1983 (see the module docstring).  E.g. (e_x, e_y, e_z) from the
    origin: pi / 2.  Checked: finite (..., 3) arrays whose leading shapes broadcast."""
    a, b, c, ref = _vertices(a, b, c, ref)
    return _omega(a - ref, b - ref, c - ref, np.cross(b - a, c - a))


def _vertices(a, b, c, ref):
    pts = [np.asarray(finite_points(v, 3, nm), np.float64) for v, nm in ((a, "a"), (b, "b"), (c, "c"), (ref, "ref"))]
    try:
        shape = np.broadcast_shapes(*(p.shape for p in pts))
    except ValueError:
        raise ValueError("a, b, c, ref: leading shapes " + ", ".join(str(p.shape) for p in pts)
                         + " do not broadcast (one triangle per reference point, or one for all)") from None
    return [np.broadcast_to(p, shape) for p in pts]


# ----------------------------------------------------------------------------- spherical triangle

class _Geom:
    """Per-point quantities of triangles (va, vb, vc relative to ref): Omega, unit A, B, C,
    the angle alpha at A, arc c = AB, the tangent at A towards C, the normal n."""

    def __init__(self, va, vb, vc, min_solid_angle):
        self.va, self.vb, self.vc = va, vb, vc
        eab, eac = vb - va, vc - va
        self.n = np.cross(eab, eac)
        self.omega = _omega(va, vb, vc, self.n)
        self.spherical = self.omega >= max(min_solid_angle, np.finfo(float).tiny)
        self.orient = np.where(self.omega > 0, np.sign(dot(va, self.n)), 0.0)   # 0: ref in the plane
        self.A, self.B = _unit(va), _unit(vb)
        tb, tc = eab - self.A * dot(eab, self.A)[..., None], eac - self.A * dot(eac, self.A)[..., None]
        self.alpha = np.arctan2(norm(np.cross(tb, tc)), dot(tb, tc))
        lb = np.where(norm(vb) > 0, norm(vb), 1.0)
        self.sin_c = norm(np.cross(self.A, eab)) / lb
        cos_c = dot(self.A, vb) / lb
        self.k = np.where(cos_c > 0, self.sin_c**2 / (1.0 + np.abs(cos_c)), 1.0 - cos_c)   # 1 - cos c
        self.T = _unit(tc)

    def inside(self, w):
        """w (unit) in the spherical triangle: on the inner side of each edge's great circle,
        within 1e-9 of the opposite vertex's distance from it (+ 1e-15: rounding)."""
        ok = self.orient != 0
        for p, q, o in ((self.va, self.vb, self.vc), (self.vb, self.vc, self.va), (self.vc, self.va, self.vb)):
            m = np.cross(p, q - p)                      # = p x q, without cancellation
            tol = _EDGE_TOL * np.abs(dot(_unit(o), m)) + 1e-15 * norm(m)
            ok = ok & (self.orient * dot(w, m) >= -tol)
        return ok

    def area_density(self, w):
        """Density in solid angle of area-sampled points of the triangle: 2 (a.n)^2 / |w.n|^3."""
        wn = np.abs(dot(w, self.n))
        an = dot(self.va, self.n)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            p = 2.0 * an * an / wn**3
        return np.where((wn > 0) & np.isfinite(p), p, 0.0)

    def sample(self, u):
        u1, u2 = u[..., 0], u[..., 1]
        h = 0.5 * u1 * self.omega
        sh, sah = np.sin(h), np.sin(self.alpha - h)
        s = 2.0 * sh * sah
        num = self.sin_c * s
        den = self.k * (np.sin(self.alpha) ** 2 - 2.0 * sh * np.cos(self.alpha) * sah) - 2.0 * sh * sh
        bp = np.arctan2(num, den)
        Cp = self.A * np.cos(bp)[..., None] + self.T * np.sin(bp)[..., None]
        d = Cp - self.B
        m = 0.5 * u2 * dot(d, d)                        # 1 - cos theta
        tang = _unit(d - self.B * dot(d, self.B)[..., None])
        w_sph = self.B * (1.0 - m)[..., None] + tang * np.sqrt(np.clip(m * (2.0 - m), 0.0, None))[..., None]
        b = _BARY.sample(u)                             # area fallback: barycentrics (b0, b1)
        y = self.va * b[..., :1] + self.vb * b[..., 1:] + self.vc * (1.0 - b[..., 0] - b[..., 1])[..., None]
        w_area = _unit(y, _unit(self.n, np.array([0.0, 0.0, 1.0])))
        return np.where(self.spherical[..., None], w_sph, w_area)

    def pdf(self, w):
        inside = self.inside(w)
        with np.errstate(divide="ignore"):
            p_sph = 1.0 / np.where(self.spherical, self.omega, 1.0)
        return np.where(inside, np.where(self.spherical, p_sph, self.area_density(w)), 0.0)

    def invert(self, w):
        C = _unit(self.vc)
        cp = _unit(np.cross(np.cross(self.B, w), np.cross(self.va, self.vc - self.va)))
        cp = np.where((dot(cp, self.A + C) < 0)[..., None], -cp, cp)
        dw, dc = w - self.B, cp - self.B
        u2 = dot(dw, dw) / np.where(dot(dc, dc) > 0, dot(dc, dc), 1.0)
        sub = _omega(self.A, self.B, cp, np.cross(self.B - self.A, cp - self.A))
        u_sph = np.stack([sub / np.where(self.spherical, self.omega, 1.0), u2], -1)
        with np.errstate(divide="ignore", invalid="ignore"):     # fallback: barycentrics of the hit
            t = dot(self.va, self.n) / dot(w, self.n)
        y = w * np.where(np.isfinite(t), t, 0.0)[..., None] - self.va
        nn = np.where(dot(self.n, self.n) > 0, dot(self.n, self.n), 1.0)
        b1 = dot(y, np.cross(self.vc - self.va, self.n)) / nn   # coefficient of (vb - va)
        b2 = dot(y, np.cross(self.n, self.vb - self.va)) / nn   # coefficient of (vc - va)
        u_area = _BARY.invert(np.stack([1.0 - b1 - b2, b1], -1))
        return np.clip(np.where(self.spherical[..., None], u_sph, u_area), 0.0, 1.0)


class SphericalTriangle(Distribution):
    """Directions from ``ref`` uniform in solid angle over the triangle (a, b, c) (Arvo 1995;
    formulas in the module docstring).  p(w) = 1 / Omega inside the spherical triangle, 0
    outside (measure: solid angle); ``solid_angle`` is Omega (Van Oosterom & Strackee 1983).
    Where Omega < ``min_solid_angle`` (default 1e-12 sr; 0 disables, except for Omega = 0)
    directions come from area sampling with its exact density (module docstring).

    ``a, b, c, ref`` are (..., 3) and broadcast (one triangle per reference point); u of
    shape (..., 2) broadcasts with their leading shape.  ``invert(w)`` undoes ``sample``.
    Checked: finite (..., 3) arrays with broadcasting leading shapes, ``min_solid_angle >= 0``.
    """

    dim_u = 2
    dim_x = 3
    measure = "solid angle"

    def __init__(self, a: Any, b: Any, c: Any, ref: Any, min_solid_angle: float = MIN_SOLID_ANGLE):
        a, b, c, self.ref = _vertices(a, b, c, ref)
        self.min_solid_angle = checks.real(min_solid_angle, "min_solid_angle", low=0.0)
        self._g = _Geom(a - self.ref, b - self.ref, c - self.ref, self.min_solid_angle)
        self.solid_angle = self._g.omega

    def _check(self, x, k, name):
        return check_broadcast(_f64(x, k, name), name, self.ref.shape[:-1], "ref")

    def sample(self, u: np.ndarray) -> np.ndarray:
        return self._g.sample(self._check(as_uniforms(u, 2), 2, "u"))

    def pdf(self, w: np.ndarray) -> np.ndarray:
        return self._g.pdf(_unit(self._check(w, 3, "w")))

    def invert(self, w: np.ndarray) -> np.ndarray:
        return self._g.invert(_unit(self._check(w, 3, "w")))

    def _repr_fields(self):
        return {"ref_shape": self.ref.shape, "min_solid_angle": self.min_solid_angle}
