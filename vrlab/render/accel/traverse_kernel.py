"""Compiled ray queries through the scene BVH (Numba): closest hit and any hit, every kind.

The NumPy walk of :mod:`vrlab.render.accel.bvh` (its oracle) moves every active ray one node
per step; here each ray walks the tree in one serial loop (a loop over rays,
``@njit(cache=True)``, no prange: vrlab's parallelism is its worker processes), over the
arrays of :class:`~vrlab.render.accel.flat.FlatBVH`.  The walk is the same: a stack of
(node, entry distance), a popped node whose box starts at or beyond the closest hit so far
is skipped, an inner node's two children are slab-tested (Kay & Kajiya 1986) and the nearer
one is visited next, the farther one stacked (a tie: the left child first); a box counts
where ``near <= far``, ``far > t_min`` and ``near < t_best``.  The slab distances take 1 /
1e-300 for a zero direction component where NumPy has inf (its fmin/fmax then skip the NaN
of a ray in a box's face plane): the boxes are padded beyond every primitive, so such
differences only change which nodes are visited, never the hits.  At a leaf each primitive is tested exactly in
float64 with the formulas of the NumPy pair tests, in the same order of operations:

* planar (:class:`~vrlab.render.accel.groups.Planar`): ``t = -((o - v0).n) / (d.n)``,
  ``s, u = (o + t d - v0).a1, .a2``; inside where ``s, u >= 0`` and ``s, u <= 1``
  (parallelogram) or ``s + u <= 1`` (triangle);
* quadrics: the ray in the unit-sphere frame (``(o - c) / r, d / r`` for spheres, ``M^-1 (o
  - c), M^-1 d`` for ellipsoids), then the stable roots of
  :func:`vrlab.distributions.quadrics.unit_sphere_hit` (q = -(b + sign(b) sqrt(b^2 - a c)),
  t = q / a and c / q), the smaller root above ``t_min``, else the larger;
* disks (:class:`~vrlab.render.accel.disks.Disks`): the ray in the disk frame,
  ``t = -o_z / d_z``, inside where ``x^2 + y^2 <= 1``;
* tubes (cylinders, :class:`~vrlab.render.accel.tubes.Tubes`): the ray in the tube frame,
  the stable roots of ``(o_x + t d_x)^2 + (o_y + t d_y)^2 = 1`` of
  :func:`vrlab.distributions.cylinder.tube_hits`, the first above ``t_min`` with
  ``0 <= z <= 1``.

Every test requires ``t > t_min`` and a finite t.  Closest hits keep the NumPy rule for ties:
among equal t the lowest global primitive wins, and a hit equal to the incoming ``t`` (a
planar hit of Embree) does not replace it.  ``closest`` writes the improved t, the global
primitive (-1: no improvement) and the hit's unit normal, with the formulas and the order of
operations of the groups' ``normals``; :class:`~vrlab.render.accel.scene_bvh.Accel` takes the
shape and the primitive within it from tables.  ``occluded`` stops a ray at its first hit
with ``t < t_max``.  As in NumPy, a NaN root or plane distance is a miss.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .flat import DISK, PARA, QUADRIC, SPHERE, TRI, TUBE

__all__ = ["closest", "occluded", "SIGNATURES", "COMPILE_SECONDS"]

_TREE = "float64[:, ::1], float64[:, ::1], int64[:, ::1], int64[::1], int64[::1], float64[:, ::1], int64[::1], int64"
#: the signatures vrlab.kernels.load_kernels compiles
SIGNATURES = {
    "closest": [f"void({_TREE}, float64[:, ::1], float64[:, ::1], float64, float64[::1], int64[::1], boolean, "
                "float64[:, ::1])"],
    "occluded": [f"void({_TREE}, float64[:, ::1], float64[:, ::1], float64, float64[::1], boolean[::1])"],
}
#: cold compile time (seconds, measured on the development machine), for the notice
COMPILE_SECONDS = 5.0


@njit(cache=True, error_model="numpy")
def _fmin(a, b):
    return a if a < b else b


@njit(cache=True, error_model="numpy")
def _fmax(a, b):
    return a if a > b else b


@njit(cache=True, error_model="numpy")
def _inv(x):
    """1 / x, and 1e300 for x = 0 (no inf: no (box - o) * inf = NaN in the slab test)."""
    return 1.0 / (x if x != 0.0 else 1e-300)


@njit(cache=True, error_model="numpy", inline="always")
def _slab(box, row, k, ox, oy, oz, ix, iy, iz, t_min, tb):
    """Entry distance of the ray (origin o, 1 / d) into the box ``box[row, k:k + 6]`` (lo, hi),
    inf where it misses the box within (t_min, tb)."""
    t0, t1 = (box[row, k] - ox) * ix, (box[row, k + 3] - ox) * ix
    near, far = _fmin(t0, t1), _fmax(t0, t1)
    t0, t1 = (box[row, k + 1] - oy) * iy, (box[row, k + 4] - oy) * iy
    near, far = _fmax(near, _fmin(t0, t1)), _fmin(far, _fmax(t0, t1))
    t0, t1 = (box[row, k + 2] - oz) * iz, (box[row, k + 5] - oz) * iz
    near, far = _fmax(near, _fmin(t0, t1)), _fmin(far, _fmax(t0, t1))
    return near if (near <= far) & (far > t_min) & (near < tb) else np.inf


@njit(cache=True, error_model="numpy")
def _sphere_roots(ox, oy, oz, dx, dy, dz, t_min):
    """The first root t > t_min of |o + t d| = 1 (inf if none): ``unit_sphere_hit``."""
    a = dx * dx
    a += dy * dy
    a += dz * dz
    b = ox * dx
    b += oy * dy
    b += oz * dz
    c = ox * ox
    c += oy * oy
    c += oz * oz
    c = c - 1.0
    disc = b * b - a * c
    hit = disc >= 0.0
    sq = math.sqrt(disc if hit else 0.0)
    q = -(b + (sq if b >= 0.0 else -sq))
    t1 = q / a
    t2 = c / (q if q != 0.0 else 1.0) if q != 0.0 else t1
    lo, hi = (t1, t2) if t1 < t2 else (t2, t1)
    t = lo if lo > t_min else (hi if hi > t_min else np.inf)
    # selects, no early exits; a NaN root (NumPy's minimum/maximum propagate it) is a miss
    return t if hit & (t < np.inf) & (t1 == t1) & (t2 == t2) else np.inf


@njit(cache=True, error_model="numpy")
def _tube_z(t, oz, dz, t_min):
    """t if it is a valid root of the tube (finite, beyond t_min, 0 <= z <= 1), else inf."""
    z = oz + (t if math.isfinite(t) else 0.0) * dz
    return t if math.isfinite(t) and t > t_min and z >= 0.0 and z <= 1.0 else np.inf


@njit(cache=True, error_model="numpy")
def _tube_roots(ox, oy, oz, dx, dy, dz, t_min):
    """The first root t > t_min of the unit tube with 0 <= z <= 1 (inf if none): ``tube_hits``."""
    a = dx * dx + dy * dy
    b = ox * dx + oy * dy
    c = ox * ox + oy * oy - 1.0
    disc = b * b - a * c
    if not (disc >= 0.0 and a > 0.0):
        return np.inf
    sq = math.sqrt(disc)
    q = -(b + (sq if b >= 0.0 else -sq))
    t1 = q / a
    t2 = c / q if q != 0.0 else t1
    return min(_tube_z(t1, oz, dz, t_min), _tube_z(t2, oz, dz, t_min))


@njit(cache=True, error_model="numpy")
def _row(q, r, a, x, y, z):
    """Row a of M^-1 (row r of ``q``: c, M^-1 row-major) times (x, y, z)."""
    return q[r, 3 + 3 * a] * x + q[r, 4 + 3 * a] * y + q[r, 5 + 3 * a] * z


@njit(cache=True, error_model="numpy")
def _frame(q, r, o, d, i):
    """The ray i in the frame ``M^-1 (x - c)``: ``(o_x, o_y, o_z, d_x, d_y, d_z)``."""
    cx, cy, cz = o[i, 0] - q[r, 0], o[i, 1] - q[r, 1], o[i, 2] - q[r, 2]
    dx, dy, dz = d[i, 0], d[i, 1], d[i, 2]
    return (_row(q, r, 0, cx, cy, cz), _row(q, r, 1, cx, cy, cz), _row(q, r, 2, cx, cy, cz),
            _row(q, r, 0, dx, dy, dz), _row(q, r, 1, dx, dy, dz), _row(q, r, 2, dx, dy, dz))


@njit(cache=True, error_model="numpy", inline="always")
def _hit(kind, q, r, o, d, i, t_min):
    """Exact t (inf on a miss) of ray i and the primitive of row r."""
    k = kind[r]
    if k == PARA or k == TRI:
        ox, oy, oz = o[i, 0] - q[r, 0], o[i, 1] - q[r, 1], o[i, 2] - q[r, 2]
        t = ox * q[r, 3]
        t += oy * q[r, 4]
        t += oz * q[r, 5]
        dn = d[i, 0] * q[r, 3]
        dn += d[i, 1] * q[r, 4]
        dn += d[i, 2] * q[r, 5]
        t /= dn
        t = -t
        ox += t * d[i, 0]
        oy += t * d[i, 1]
        oz += t * d[i, 2]
        s = ox * q[r, 6]
        s += oy * q[r, 7]
        s += oz * q[r, 8]
        u = ox * q[r, 9]
        u += oy * q[r, 10]
        u += oz * q[r, 11]
        # one combined test (no early exits: a mispredicted branch costs more than the arithmetic)
        inside = (s <= 1.0) & (u <= 1.0) if k == PARA else s + u <= 1.0
        return t if (t > t_min) & (t < np.inf) & (s >= 0.0) & (u >= 0.0) & inside else np.inf
    if k == SPHERE:
        inv_r = q[r, 3]
        return _sphere_roots((o[i, 0] - q[r, 0]) * inv_r, (o[i, 1] - q[r, 1]) * inv_r, (o[i, 2] - q[r, 2]) * inv_r,
                             d[i, 0] * inv_r, d[i, 1] * inv_r, d[i, 2] * inv_r, t_min)
    if k == QUADRIC:
        ox, oy, oz, dx, dy, dz = _frame(q, r, o, d, i)
        return _sphere_roots(ox, oy, oz, dx, dy, dz, t_min)
    if k == DISK:
        ox, oy, oz, dx, dy, dz = _frame(q, r, o, d, i)
        t = -oz / dz
        x, y = ox + t * dx, oy + t * dy
        if math.isfinite(t) and t > t_min and x * x + y * y <= 1.0:
            return t
        return np.inf
    if k == TUBE:
        ox, oy, oz, dx, dy, dz = _frame(q, r, o, d, i)
        return _tube_roots(ox, oy, oz, dx, dy, dz, t_min)
    return np.inf


@njit(cache=True, error_model="numpy")
def _unit(x, y, z, sign, out, i):
    """``out[i] = sign * (v * (1 / |v|))`` (``vrlab._vec``'s unit and scale, in their order)."""
    n = x * x
    n += y * y
    n += z * z
    n = math.sqrt(n)
    inv = 1.0 / (n if n > 0 else 1.0)
    out[i, 0], out[i, 1], out[i, 2] = x * inv * sign, y * inv * sign, z * inv * sign


@njit(cache=True, error_model="numpy")
def _normal(kind, q, r, o, d, i, t, out):
    """The unit normal of the hit of ray i at t on the primitive of row r, as the groups'
    ``normals``: the stored normal (planar, disks), sign (o + t d - c) / |..| (spheres),
    sign M^-T x / |..| with x = M^-1 (o - c) + t M^-1 d (ellipsoids; tubes: x_z = 0)."""
    k = kind[r]
    if k == SPHERE:
        _unit((o[i, 0] - q[r, 0]) + d[i, 0] * t, (o[i, 1] - q[r, 1]) + d[i, 1] * t,
              (o[i, 2] - q[r, 2]) + d[i, 2] * t, q[r, 15], out, i)
    elif k == QUADRIC:
        ox, oy, oz, dx, dy, dz = _frame(q, r, o, d, i)
        x, y, z = ox + t * dx, oy + t * dy, oz + t * dz
        _unit(x * q[r, 3] + y * q[r, 6] + z * q[r, 9], x * q[r, 4] + y * q[r, 7] + z * q[r, 10],
              x * q[r, 5] + y * q[r, 8] + z * q[r, 11], q[r, 15], out, i)
    elif k == TUBE:
        ox, oy, oz, dx, dy, dz = _frame(q, r, o, d, i)
        x, y = ox + t * dx, oy + t * dy
        _unit(x * q[r, 3] + y * q[r, 6], x * q[r, 4] + y * q[r, 7], x * q[r, 5] + y * q[r, 8], q[r, 15], out, i)
    else:
        out[i, 0], out[i, 1], out[i, 2] = q[r, 12], q[r, 13], q[r, 14]


@njit(cache=True, error_model="numpy")
def _walk(root, kids, child, count, kind, prim, gid, depth, o, d, t_min, tb, j_out, any_hit, want_normal,
          normal):
    """Each ray's depth-first walk (module docstring).  Closest: ``tb[i]`` lowered to the closest
    t, ``j_out[i]`` its global primitive (-1: none below the incoming tb) and, with
    ``want_normal``, ``normal[i]`` its unit normal.  Any hit: ``tb[i]`` set to -inf at the first
    hit below it."""
    stack = np.empty(depth + 2, np.int64)
    stack_t = np.empty(depth + 2)
    for i in range(o.shape[0]):
        ox, oy, oz = o[i, 0], o[i, 1], o[i, 2]
        ix, iy, iz = _inv(d[i, 0]), _inv(d[i, 1]), _inv(d[i, 2])
        best, best_r, tbi = -1, -1, tb[i]
        near = _slab(root, 0, 0, ox, oy, oz, ix, iy, iz, t_min, tbi)
        sp = 0
        if near < np.inf:
            stack[0], stack_t[0], sp = 0, near, 1
        node = -1                                          # -1: pop the next node
        while sp > 0 or node >= 0:
            if node < 0:
                sp -= 1
                node = stack[sp]
                if not stack_t[sp] < tbi:
                    node = -1
                    continue
            n = count[node]
            if n > 0:
                first = child[node, 0]
                for r in range(first, first + n):
                    t = _hit(kind, prim, r, o, d, i, t_min)
                    if t < tbi:
                        if any_hit:
                            tbi = -np.inf
                            break
                        tbi, best, best_r = t, gid[r], r
                    elif (t == tbi) & (best >= 0) & (gid[r] < best):
                        best, best_r = gid[r], r   # a tie: the lowest primitive
                if any_hit and tbi == -np.inf:
                    break
                node = -1
                continue
            tl = _slab(kids, node, 0, ox, oy, oz, ix, iy, iz, t_min, tbi)
            tr = _slab(kids, node, 6, ox, oy, oz, ix, iy, iz, t_min, tbi)
            near_c, far_c = child[node, 0], child[node, 1]
            near_t, far_t = tl, tr
            if tr < tl:                                    # the nearer child on top
                near_c, far_c, near_t, far_t = far_c, near_c, tr, tl
            if far_t < np.inf:
                stack[sp], stack_t[sp] = far_c, far_t
                sp += 1
            node = near_c if near_t < np.inf else -1          # the nearer child next (not stacked)
        tb[i], j_out[i] = tbi, best
        if want_normal and best >= 0:
            _normal(kind, prim, best_r, o, d, i, tbi, normal)


@njit(cache=True, error_model="numpy")
def closest(root, kids, child, count, kind, prim, gid, depth, o, d, t_min, t, j_out, want_normal, normal):
    """Closest hits with ``t_min < t < t[i]`` (in place: ``t`` lowered, ``j_out`` the global
    primitive or -1 where no hit beats the incoming t, with ``want_normal`` ``normal`` the
    hit's unit normal there)."""
    _walk(root, kids, child, count, kind, prim, gid, depth, o, d, t_min, t, j_out, False, want_normal, normal)


@njit(cache=True, error_model="numpy")
def occluded(root, kids, child, count, kind, prim, gid, depth, o, d, t_min, t_max, hit):
    """``hit[i]``: whether ray i hits a primitive with ``t_min < t < t_max[i]`` (any hit)."""
    tb = t_max.copy()
    j = np.empty(o.shape[0], np.int64)
    _walk(root, kids, child, count, kind, prim, gid, depth, o, d, t_min, tb, j, True, False, np.empty((0, 3)))
    for i in range(o.shape[0]):
        hit[i] = tb[i] == -np.inf
