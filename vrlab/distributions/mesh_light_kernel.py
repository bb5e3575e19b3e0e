"""Compiled emitter sampling towards given mesh triangles (Numba): ``TriangleMeshSolidAngle``
``sample_given`` and ``pdf_given`` with ``kernels="numba"`` (:mod:`.triangle_given`).

The NumPy code of :mod:`vrlab.distributions.triangle_given` and :mod:`vrlab.distributions.triangles`
(its oracle) works on whole arrays; here one serial loop over the points (``@njit(cache=True)``,
no prange: vrlab's parallelism is its worker processes) does, per point i with triangle
k = ``k[i]`` (rows ``v0, e1, e2`` and ``n = e1 x e2`` of the mesh's tables) and uniforms u:

* by area: barycentrics of the square-root warp b0 = 1 - sqrt(u1), b1 = u2 sqrt(u1) (Turk
  1990; ``planar.Triangle``), y = v0 + b1 e1 + (1 - b0 - b1) e2, w = (y - ref) / |y - ref|;
* spherical: Arvo 1995 in the rearranged form of :mod:`vrlab.distributions.triangles`
  (C' on the arc AC from tan b', then w on the arc B -> C' with 1 - cos theta = u2 (1 - B.C')),
  area sampling below ``min_solid_angle``; y = ref + t w on k's plane, t = (va . n) / (w . n);
* the density given k: by area t^2 / (A_k |cos theta_k|) = 2 t^2 / |w . n|, spherical
  1 / Omega_k (Van Oosterom & Strackee 1983) where Omega_k >= ``min_solid_angle``; 0 unless
  t > 0 is finite and w . n != 0.

Each step does the NumPy code's floating-point operations in its order (``error_model="numpy"``:
a division by 0 gives inf/NaN as NumPy does, and Numba does not contract multiply-adds
without fastmath), so the area path gives the same bits; sin, cos and atan2 come from the
C library here and may differ from NumPy's in the last place (the spherical path: the tests
ask 1e-12 relative).
"""
from __future__ import annotations

import math

from numba import njit

__all__ = ["given_sample", "given_pdf", "SIGNATURES", "COMPILE_SECONDS"]

_MESH = "float64[:, ::1], float64[:, ::1], float64[:, ::1], float64[:, ::1]"
#: the signatures vrlab.kernels.load_kernels compiles
SIGNATURES = {
    "given_sample": [f"void({_MESH}, float64[:, ::1], int64[::1], float64[:, ::1], float64[:, ::1], boolean, "
                     "float64, float64[:, ::1], float64[:, ::1], float64[::1], float64[::1])"],
    "given_pdf": [f"void({_MESH}, int64[::1], float64[:, ::1], float64[:, ::1], boolean, float64, float64[::1])"],
}
#: cold compile time (seconds, measured on the development machine), for the notice
COMPILE_SECONDS = 2.0

_TINY = 2.2250738585072014e-308          # np.finfo(float).tiny


@njit(cache=True, error_model="numpy")
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True, error_model="numpy")
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True, error_model="numpy")
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit(cache=True, error_model="numpy")
def _mul(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


@njit(cache=True, error_model="numpy")
def _norm(a):
    return math.sqrt(_dot(a, a))


@njit(cache=True, error_model="numpy")
def _unit(a, fallback):
    """a / |a|, or ``fallback`` for a zero vector (``triangles._unit``)."""
    n = _norm(a)
    if not n > 0:
        return fallback
    return (a[0] / n, a[1] / n, a[2] / n)


@njit(cache=True, error_model="numpy")
def _omega(va, vb, vc, n):
    """Van Oosterom-Strackee solid angle (``triangles._omega``), 0 within 1e-12 rad of the plane."""
    la, lb, lc = _norm(va), _norm(vb), _norm(vc)
    triple = abs(_dot(va, n))
    den = la * lb * lc + _dot(va, vb) * lc + _dot(va, vc) * lb + _dot(vb, vc) * la
    return 2.0 * math.atan2(triple, den) if triple > 1e-12 * la * _norm(n) else 0.0


@njit(cache=True, error_model="numpy")
def _row(a, k):
    return (a[k, 0], a[k, 1], a[k, 2])


@njit(cache=True, error_model="numpy")
def _density(va, e1, e2, n, w, spherical, floor):
    """p_k(w) (``TriangleMeshSolidAngle._density_given``); ``floor`` = max(min_solid_angle, tiny)."""
    wn = abs(_dot(w, n))
    t = _dot(va, n) / _dot(w, n)
    if not (wn > 0 and math.isfinite(t) and t > 0):
        return 0.0
    if spherical:
        om = _omega(va, (va[0] + e1[0], va[1] + e1[1], va[2] + e1[2]),
                    (va[0] + e2[0], va[1] + e2[1], va[2] + e2[2]), n)
        if om >= floor:
            return 1.0 / om
    return 2.0 * t * t / wn


@njit(cache=True, error_model="numpy")
def _arvo(va, vb, vc, u1, u2, floor):
    """A direction of the spherical triangle (va, vb, vc) (``triangles._Geom.sample``)."""
    eab, eac = _sub(vb, va), _sub(vc, va)
    n = _cross(eab, eac)
    su = math.sqrt(u1)
    omega = _omega(va, vb, vc, n)
    if not omega >= floor:                              # area fallback
        b0 = 1.0 - su
        b1 = u2 * su
        b2 = 1.0 - b0 - b1
        y = (va[0] * b0 + vb[0] * b1 + vc[0] * b2, va[1] * b0 + vb[1] * b1 + vc[1] * b2,
             va[2] * b0 + vb[2] * b1 + vc[2] * b2)
        return _unit(y, _unit(n, (0.0, 0.0, 1.0)))
    zero = (0.0, 0.0, 0.0)
    A, B = _unit(va, zero), _unit(vb, zero)
    tb, tc = _sub(eab, _mul(A, _dot(eab, A))), _sub(eac, _mul(A, _dot(eac, A)))
    alpha = math.atan2(_norm(_cross(tb, tc)), _dot(tb, tc))
    lb = _norm(vb)
    lb = lb if lb > 0 else 1.0
    sin_c = _norm(_cross(A, eab)) / lb
    cos_c = _dot(A, vb) / lb
    kk = sin_c * sin_c / (1.0 + abs(cos_c)) if cos_c > 0 else 1.0 - cos_c
    T = _unit(tc, zero)
    h = 0.5 * u1 * omega
    sh, sah = math.sin(h), math.sin(alpha - h)
    s = 2.0 * sh * sah
    sa = math.sin(alpha)
    den = kk * (sa * sa - 2.0 * sh * math.cos(alpha) * sah) - 2.0 * sh * sh
    bp = math.atan2(sin_c * s, den)
    cb, sb = math.cos(bp), math.sin(bp)
    d = (A[0] * cb + T[0] * sb - B[0], A[1] * cb + T[1] * sb - B[1], A[2] * cb + T[2] * sb - B[2])
    m = 0.5 * u2 * _dot(d, d)                          # 1 - cos theta
    tang = _unit(_sub(d, _mul(B, _dot(d, B))), zero)
    r = math.sqrt(max(m * (2.0 - m), 0.0))
    return (B[0] * (1.0 - m) + tang[0] * r, B[1] * (1.0 - m) + tang[1] * r, B[2] * (1.0 - m) + tang[2] * r)


@njit(cache=True, error_model="numpy")
def given_sample(v0, e1, e2, n, face_normals, k, u, ref, spherical, min_solid_angle, w_out, y_out, dist_out,
                 pdf_out):
    """For each point i: w, y, dist and p_k(w) of a direction towards triangle ``k[i]`` from
    ``ref[i]`` with uniforms ``u[i]`` (area or ``spherical``; see the module docstring)."""
    floor = max(min_solid_angle, _TINY)
    for i in range(len(k)):
        kk = k[i]
        p = _row(ref, i)
        va, a, b, nk = _sub(_row(v0, kk), p), _row(e1, kk), _row(e2, kk), _row(n, kk)
        if spherical:
            w = _arvo(va, (va[0] + a[0], va[1] + a[1], va[2] + a[2]), (va[0] + b[0], va[1] + b[1], va[2] + b[2]),
                      u[i, 0], u[i, 1], floor)
            t = _dot(va, nk) / _dot(w, nk)
            t = t if math.isfinite(t) and t > 0 else 0.0
            y = (p[0] + w[0] * t, p[1] + w[1] * t, p[2] + w[2] * t)
            dist = t
        else:
            su = math.sqrt(u[i, 0])
            b0 = 1.0 - su
            b1 = u[i, 1] * su
            b2 = 1.0 - b0 - b1
            y = (v0[kk, 0] + a[0] * b1 + b[0] * b2, v0[kk, 1] + a[1] * b1 + b[1] * b2,
                 v0[kk, 2] + a[2] * b1 + b[2] * b2)
            v = _sub(y, p)
            dist = _norm(v)
            w = _unit(v, _row(face_normals, kk))
        for c in range(3):
            w_out[i, c], y_out[i, c] = w[c], y[c]
        dist_out[i] = dist
        pdf_out[i] = _density(va, a, b, nk, w, spherical, floor)


@njit(cache=True, error_model="numpy")
def given_pdf(v0, e1, e2, n, k, w, ref, spherical, min_solid_angle, out):
    """For each point i: p_k(w[i]) of unit ``w[i]`` from ``ref[i]`` towards triangle ``k[i]``."""
    floor = max(min_solid_angle, _TINY)
    for i in range(len(k)):
        kk = k[i]
        va = _sub(_row(v0, kk), _row(ref, i))
        out[i] = _density(va, _row(e1, kk), _row(e2, kk), _row(n, kk), _row(w, i), spherical, floor)
