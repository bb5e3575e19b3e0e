"""Compiled light-BVH walk (Numba): ``LightBVH(..., kernels="numba")`` sample and pmf.

The NumPy walk of :mod:`vrlab.distributions.light_bvh` (its oracle) moves every point one
tree level per step; here each point walks from the root to its leaf in one serial loop
(a loop over points, ``@njit(cache=True)``, no prange: vrlab's parallelism is its worker
processes).  At an inner node the two children's importances I_0, I_1 (pbrt-v4's
``LightBounds::Importance``, see :mod:`vrlab.distributions.light_bounds`) give
``p0 = I_0 / (I_0 + I_1)``; ``sample`` goes right when ``u >= p0`` and rescales
``u <- (u - [right] p0) / P_c`` (below 1), ``pmf`` follows the light's trail bits; the
probability is the product of the ``P_c``; both children at 0 is a dead end (no light).

:func:`_importance` does the operations of ``light_bounds.importance_prepared`` in the same
order (no fused multiply-adds: Numba does not contract without fastmath; ``error_model="numpy"``
drops the division-by-zero checks, no divisor here can be 0), so the walks
agree with the NumPy ones to the last bit on the test machine; the tests still only ask
for the same light (ties aside) and pmf within 1e-6 relative.

Node table (``LightBVH._table`` transposed, one row per node): ``pc (3), w (3), r2,
cos_o, sin_o, cos_e, phi``; ``two (M,)`` bool; ``first (M,)`` the left child (the right is
``first + 1``), ``light (M,)`` the leaf's light or -1.  Points ``p (N, 3)``, unit normals
``n (N, 3)`` with ``has_n (N,)`` (False: the point has no normal).
"""
from __future__ import annotations

import math

from numba import njit

__all__ = ["bvh_sample", "bvh_pmf", "SIGNATURES", "COMPILE_SECONDS"]

_TABLE = "float64[:, ::1], boolean[::1], int64[::1], int64[::1], float64[:, ::1], float64[:, ::1], boolean[::1]"
#: the signatures vrlab.kernels.load_kernels compiles
SIGNATURES = {
    "bvh_sample": [f"void({_TABLE}, float64[::1], float64, int64[::1], float64[::1])"],
    "bvh_pmf": [f"void({_TABLE}, boolean[:, ::1], int64[::1], float64, float64[::1])"],
}
#: cold compile time (seconds, measured on the development machine), for the notice
COMPILE_SECONDS = 1.0

_ONE_MINUS_EPS = 1.0 - 2.0 ** -53       # the largest float below 1


@njit(cache=True, error_model="numpy")
def _sin(c):
    return math.sqrt(max(1.0 - c * c, 0.0))


@njit(cache=True, error_model="numpy")
def _importance(t, two, k, p, n, has_n, i, floor2):
    """pbrt-v4's importance of node ``k`` (row of the table ``t``) at point ``i`` (phi > 0)."""
    rx = p[i, 0] - t[k, 0]
    ry = p[i, 1] - t[k, 1]
    rz = p[i, 2] - t[k, 2]
    dist2 = rx * rx
    dist2 += ry * ry
    dist2 += rz * rz
    r2 = t[k, 6]
    d2 = max(max(dist2, r2), floor2)
    if dist2 > 0:
        inv = 1.0 / math.sqrt(dist2)
        rx *= inv
        ry *= inv
        rz *= inv
    else:                                   # p at the box centre: wi is any unit vector
        rx, ry, rz = t[k, 3], t[k, 4], t[k, 5]
    cos_w = t[k, 3] * rx
    cos_w += t[k, 4] * ry
    cos_w += t[k, 5] * rz
    if two[k]:
        cos_w = abs(cos_w)
    sin_w = _sin(cos_w)
    if dist2 < r2:                          # inside the bounding sphere: theta_b = pi
        cos_b = -1.0
    else:
        cos_b = math.sqrt(max(1.0 - r2 / d2, 0.0))
    sin_b = _sin(cos_b)
    cos_o, sin_o = t[k, 7], t[k, 8]
    if cos_w > cos_o:                       # theta_w (-) theta_o
        cos_x, sin_x = 1.0, 0.0
    else:
        cos_x = cos_w * cos_o + sin_w * sin_o
        sin_x = sin_w * cos_o - cos_w * sin_o
    cos_p = 1.0 if cos_x > cos_b else cos_x * cos_b + sin_x * sin_b     # ... (-) theta_b
    imp = t[k, 10] * cos_p
    imp /= d2
    if has_n[i]:
        cos_i = abs(rx * n[i, 0] + ry * n[i, 1] + rz * n[i, 2])
        imp *= 1.0 if cos_i > cos_b else cos_i * cos_b + _sin(cos_i) * sin_b
    if not cos_p > t[k, 9]:                 # beyond theta_e
        return 0.0
    return max(imp, 0.0)


@njit(cache=True, error_model="numpy")
def bvh_sample(t, two, first, light, p, n, has_n, u, floor2, j_out, pmf_out):
    """For each point i: the light ``j_out[i]`` (-1: a dead end) and its probability ``pmf_out[i]``,
    walking down with the uniform ``u[i]``.  The root must be an inner node."""
    for i in range(len(u)):
        node, ui, prob = 0, u[i], 1.0
        j_out[i], pmf_out[i] = -1, 0.0
        while True:
            c = first[node]
            i0 = _importance(t, two, c, p, n, has_n, i, floor2)
            i1 = _importance(t, two, c + 1, p, n, has_n, i, floor2)
            total = i0 + i1
            if not total > 0:
                break
            p0 = i0 / total
            if ui >= p0:
                pc = 1.0 - p0
                ui = min((ui - p0) / (pc if pc > 0 else 1.0), _ONE_MINUS_EPS)
                node = c + 1
            else:
                pc = p0
                ui = min(ui / (pc if pc > 0 else 1.0), _ONE_MINUS_EPS)
                node = c
            prob = prob * pc
            if light[node] >= 0:
                j_out[i], pmf_out[i] = light[node], prob
                break


@njit(cache=True, error_model="numpy")
def bvh_pmf(t, two, first, light, p, n, has_n, trail, jj, floor2, out):
    """For each point i: the probability that the walk reaches light ``jj[i]`` (whose leaf is
    below the root, an inner node), following its ``trail`` bits."""
    for i in range(len(jj)):
        node, d, prob = 0, 0, 1.0
        out[i] = 0.0
        while True:
            c = first[node]
            i0 = _importance(t, two, c, p, n, has_n, i, floor2)
            i1 = _importance(t, two, c + 1, p, n, has_n, i, floor2)
            total = i0 + i1
            p0 = i0 / total if total > 0 else 0.0
            if trail[jj[i], d]:
                prob = prob * (1.0 - p0) * (1.0 if i1 > 0 else 0.0)
                node = c + 1
            else:
                prob = prob * p0 * (1.0 if i0 > 0 else 0.0)
                node = c
            d += 1
            if light[node] >= 0:
                out[i] = prob
                break
            if not prob > 0:
                break
