"""Compiled reconnection Jacobian of the renderer's spatial reuse (Numba):
``BlockPixels.shift`` with kernels "numba" (:mod:`vrlab.render.reuse`, vrlab issue 31).

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

__all__ = ["reconnection_jacobian", "SIGNATURES", "COMPILE_SECONDS"]

#: the signatures vrlab.kernels.load_kernels compiles
SIGNATURES = {"reconnection_jacobian": ["void(float64[:, ::1], int64[::1], float64[:, ::1], boolean[::1], "
                                        "float64[:, ::1], int64[::1], int64[::1], int64[::1], float64[::1])"]}
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
