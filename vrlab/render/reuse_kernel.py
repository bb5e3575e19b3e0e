"""Compiled reconnection of the renderer's spatial reuse (Numba): ``BlockPixels.shift``'s
Jacobian and ``BlockPixels._points``' directions and facing with kernels "numba"
(:mod:`vrlab.render.reuse`, vrlab issue 31).

Per row r, the light point y_r of light j_r reconnected from camera row s_r to camera row d_r:

    J = G_d(y) / G_s(y)  (0 where G_s is not > 0),
    G_b(y) = |n_y . (y - p_b)| / |y - p_b|^3   (= |cos theta_y| / |y - p_b|^2),

with G_b = 0 where there is no light (j < 0) or no shading point (group < 0), G_b = 1 for
lights that are not shapes (delta lights, lights at infinity: the shift is the identity in
their measure) and 0 where y = p_b.  The light's normal n_y comes in (``LightSet.point_normals``,
the emitters' own code).  The same operations in the same order as the NumPy code of
``BlockPixels._G`` (its oracle): the dot products summed x + y, then + z (``vrlab._vec.dot``),
``d2 * sqrt(d2)`` as the denominator.
"""
from __future__ import annotations

import math

from numba import njit

__all__ = ["reconnection_jacobian", "reconnect", "SIGNATURES", "COMPILE_SECONDS"]

#: the signatures vrlab.kernels.load_kernels compiles
SIGNATURES = {"reconnection_jacobian": ["void(float64[:, ::1], int64[::1], float64[:, ::1], boolean[::1], "
                                        "float64[:, ::1], int64[::1], int64[::1], int64[::1], float64[::1])"],
              "reconnect": ["void(float64[:, ::1], int64[::1], float32[:, ::1], float64[:, ::1], boolean[::1], "
                            "boolean[::1], float64, float32[:, ::1], int64[::1], boolean[::1], float32[:, ::1])"]}
#: cold compile time (seconds, measured on the development machine), for the notice
COMPILE_SECONDS = 1.0


@njit(cache=True, error_model="numpy")
def reconnection_jacobian(y, j, normals, is_emitter, p, group, src, dst, out):
    """``out[r]`` = G_dst(y_r) / G_src(y_r) for light points ``y (R, 3)`` of lights ``j (R,)``
    with normals ``normals (R, 3)``, camera rows ``src``, ``dst (R,)`` of shading points
    ``p (rows, 3)`` and BSDF groups ``group (rows,)``; ``is_emitter (L,)``: not a shape light.
    (One loop body, no helper taking the arrays: a call per row passing arrays costs more than
    the arithmetic.)"""
    for r in range(len(out)):
        gs = gd = 0.0
        for side in range(2):
            row = src[r] if side == 0 else dst[r]
            g = 0.0
            if j[r] >= 0 and group[row] >= 0:
                if is_emitter[j[r]]:
                    g = 1.0
                else:
                    v0, v1, v2 = y[r, 0] - p[row, 0], y[r, 1] - p[row, 1], y[r, 2] - p[row, 2]
                    d2 = v0 * v0
                    d2 += v1 * v1
                    d2 += v2 * v2
                    c = normals[r, 0] * v0
                    c += normals[r, 1] * v1
                    c += normals[r, 2] * v2
                    g = abs(c) / (d2 * math.sqrt(d2)) if d2 > 0.0 else 0.0
            if side == 0:
                gs = g
            else:
                gd = g
        out[r] = gd / gs if gs > 0.0 else 0.0


@njit(cache=True, error_model="numpy")
def reconnect(y, j, p, normals, is_infinite, is_emitter, far, w, j_out, front, y_out):
    """Shading points ``p (R, 3)`` (float32) reconnected to light points ``y (R, 3)`` of lights
    ``j`` (``BlockPixels._points``): v = y - p (y itself, a direction, for a light at
    infinity), valid where j >= 0 and |v| > 0; ``w`` = v / |v| in float32 ((0, 0, 1) where not
    valid), ``j_out`` = j (-1 where not valid), ``front``: valid and the light emits towards p
    (not a shape, or (p - y) . n_y > 0 with its ``normals``), ``y_out`` the light's point in
    float32 (p + far w for a light at infinity).  The NumPy code's operations, in its order."""
    for r in range(len(j)):
        jj = max(j[r], 0)
        inf = is_infinite[jj]
        p0, p1, p2 = float(p[r, 0]), float(p[r, 1]), float(p[r, 2])
        if inf:
            v0, v1, v2 = y[r, 0], y[r, 1], y[r, 2]
        else:
            v0, v1, v2 = y[r, 0] - p0, y[r, 1] - p1, y[r, 2] - p2
        d2 = v0 * v0
        d2 += v1 * v1
        d2 += v2 * v2
        dist = math.sqrt(d2)
        valid = j[r] >= 0 and dist > 0.0
        if valid:
            w0, w1, w2 = v0 / dist, v1 / dist, v2 / dist
        else:
            w0, w1, w2 = 0.0, 0.0, 1.0
        w[r, 0], w[r, 1], w[r, 2] = w0, w1, w2
        j_out[r] = j[r] if valid else -1
        facing = False
        if valid:
            if is_emitter[jj]:
                facing = True
            else:
                c = (p0 - y[r, 0]) * normals[r, 0]
                c += (p1 - y[r, 1]) * normals[r, 1]
                c += (p2 - y[r, 2]) * normals[r, 2]
                facing = c > 0.0
        front[r] = facing
        if inf:
            y_out[r, 0], y_out[r, 1], y_out[r, 2] = p0 + far * w0, p1 + far * w1, p2 + far * w2
        else:
            y_out[r, 0], y_out[r, 1], y_out[r, 2] = y[r, 0], y[r, 1], y[r, 2]
