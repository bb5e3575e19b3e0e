"""All-pairs float32 ray intersection kernels for small primitive groups (the hot path).

For a few primitives (the built-in scenes have 2-18 planar ones and up to a few
quadrics) testing every (primitive, ray) pair is faster in NumPy than culling, if the
arrays are laid out ``(primitives, rays)`` so that every ufunc runs over a long
contiguous row, and in float32 (about 2.5x the float64 element rate on the 2-core test
machine).  Rays come as rows: origins ``O`` (``(4, N)`` with a row of ones for planes,
``(3, N)`` for quadrics) and directions ``D (3, N)``.  Each kernel returns the
smallest float32 ``t > t_min`` per ray (inf on a miss) and the index of the primitive;
:class:`~vrlab.render.accel.geometry.SceneGeometry` recomputes t in float64 for the winner.

* planes ``x = v0 + s e1 + u e2``: with the unit normal n and the dual basis a1, a2 of
  (e1, e2), ``t = (n.v0 - n.o) / n.d``, ``s = a1.o - a1.v0 + t a1.d``, ``u`` likewise
  (two small matrix products give every row); a hit needs s, u in [0, 1]
  (parallelograms, tested as max(|s - 1/2|, |u - 1/2|) <= 1/2) or s, u >= 0, s + u <= 1
  (triangles);
* spheres: b = (o - c).d / |d|^2, l = (o - c) - b d (the point of closest approach),
  disc = r^2 - |l|^2 and t = -b -/+ sqrt(disc / |d|^2).  The perpendicular form keeps
  small, far spheres accurate in float32 (Haines et al., "Precision improvements for
  ray/sphere intersection", Ray Tracing Gems, 2019);
* ellipsoids ``|M^-1 (x - c)| = 1``: the sphere formula (r = 1) in the unit-sphere frame
  ``M^-1 (o - c)``, ``M^-1 d``.

Rays are processed in blocks of about ``ELEMS`` pairs so that the temporaries stay in
the cache.  Values are computed per pair; only the BLAS products could in principle round
differently for different block widths, and they only feed the float32 choice of the
primitive (the tests compare different chunkings bit for bit).  A NaN t (0/0: a ray
lying in a plane) counts as a miss: the int32 view of x86's default NaN is negative and
would otherwise win the packed minimum.
"""
from __future__ import annotations

import numpy as np

from ..._vec import scale

__all__ = ["ELEMS", "DensePlanar", "box_rows", "closest_boxes", "closest_planes", "closest_quadrics", "plane_rows"]

ELEMS = 1 << 16          # (primitive, ray) pairs per block (float32: 256 KB temporaries)
F32 = np.float32
BIG = np.array(0x7F000000, np.int32).view(F32)[()]   # 1.7e38 = "no hit" in the kernels
                                                     # (low mantissa bits 0: see _pick)


def _rows(w: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``w (K, k) @ x (k, n)`` as ``(K, n)`` (BLAS: about 4x faster than broadcast
    multiply-adds; only the float32 winner depends on it, t is recomputed in float64)."""
    return w @ x


def _pick(t: np.ndarray, index: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """Smallest t per column of ``t (P, n)`` (float32, >= 0, misses = ``BIG``) and its row.

    The row index is packed into the low ``bits = ceil(log2 P)`` mantissa bits (the
    int32 view of non-negative floats is monotonic), so one ``minimum.reduce`` finds
    both; ``argmin`` over axis 0 is about 15x slower.  Candidates within a relative
    2^(bits - 23) of each other are ordered by row, and the winner's t is recomputed in
    float64 afterwards, so this only decides near-ties.  ``t`` is overwritten.  Without
    ``index`` (distance queries) the row is not needed: ``(t, None)``."""
    if not index:
        m = np.minimum.reduce(t, axis=0)
        return np.where(m < BIG, m, F32(np.inf)), None
    bits = (len(t) - 1).bit_length()
    key = t.view(np.int32)
    if bits:
        mask = np.int32((1 << bits) - 1)
        key &= ~mask
        key |= np.arange(len(t), dtype=np.int32)[:, None]
    m = np.minimum.reduce(key, axis=0)
    j = (m & ((1 << bits) - 1)).astype(np.int64)
    best = (m & ~np.int32((1 << bits) - 1)).view(F32)
    return np.where(best < BIG, best, F32(np.inf)), j


def _miss(t: np.ndarray, bad: np.ndarray) -> np.ndarray:
    """``t`` with the entries ``bad`` (and NaN) raised to ``BIG``, in place (``fmax`` with a
    0 / ``BIG`` array is several times faster than ``putmask`` or ``where``)."""
    return np.fmax(t, bad * BIG, out=t)


def _blocks(n: int, rows: int):
    step = max(256, ELEMS // max(rows, 1))
    for a in range(0, n, step):
        yield slice(a, min(a + step, n))


def plane_rows(n: np.ndarray, a1: np.ndarray, a2: np.ndarray, v0: np.ndarray, para: bool):
    """float32 ``(wo (3P, 4), wd (3P, 3))`` for :func:`closest_planes`: ``wo @ [o; 1]`` gives
    the rows ``n.v0 - n.o``, ``a1.o - a1.v0 - h`` and ``a2.o - a2.v0 - h`` (h = 1/2 for
    parallelograms, so s and u come out centred, else 0) and ``wd @ d`` gives n.d, a1.d, a2.d."""
    h = 0.5 if para else 0.0
    c = np.concatenate([np.sum(n * v0, -1), -np.sum(a1 * v0, -1) - h, -np.sum(a2 * v0, -1) - h])
    wd = np.concatenate([n, a1, a2])
    wo = np.concatenate([np.concatenate([-n, a1, a2]), c[:, None]], axis=1)
    return wo.astype(F32), wd.astype(F32)


def closest_planes(wo: np.ndarray, wd: np.ndarray, para: bool, O: np.ndarray, D: np.ndarray,
                   t_min: float, index: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """``(t, j)`` of P planar primitives (``wo``, ``wd`` from :func:`plane_rows`) for rays
    ``O (4, N)`` (origins with a row of ones) and ``D (3, N)``; parallelograms if ``para``
    (hit: |s - 1/2|, |u - 1/2| <= 1/2) else triangles (s, u >= 0, s + u <= 1); j is None
    without ``index``."""
    n = O.shape[1]
    p = len(wd) // 3
    t_out, j_out = np.empty(n, F32), np.empty(n, np.int64) if index else None
    with np.errstate(divide="ignore", invalid="ignore"):
        for b in _blocks(n, 3 * p):
            ow = _rows(wo, O[:, b])
            dw = _rows(wd, D[:, b])
            t = ow[:p]
            t /= dw[:p]
            s, u = dw[p:2 * p], dw[2 * p:]
            s *= t
            s += ow[p:2 * p]
            u *= t
            u += ow[2 * p:]
            ok = t > t_min                             # NaN (0/0: a ray inside the plane) is a miss
            if para:
                np.abs(s, out=s)
                np.abs(u, out=u)
                ok &= np.maximum(s, u, out=s) <= 0.5
            else:
                ok &= np.minimum(s, u, out=ow[p:2 * p]) >= 0
                s += u
                ok &= s <= 1
            t_out[b], jb = _pick(np.where(ok, t, BIG), index)
            if index:
                j_out[b] = jb
    return t_out, j_out


def _sphere_roots(ox, oy, oz, dx, dy, dz, r2, t_min):
    """Smallest root t > t_min of |o + t d|^2 = r2 (rows of pairs; the o rows are reused)."""
    a = dx * dx
    a += dy * dy
    a += dz * dz
    inva = 1.0 / a
    b = ox * dx
    b += oy * dy
    b += oz * dz
    b *= inva                                  # b / a
    ox -= b * dx
    oy -= b * dy
    oz -= b * dz                               # l = o - (b/a) d
    ox *= ox
    oy *= oy
    oz *= oz
    ox += oy
    ox += oz
    disc = np.subtract(r2, ox, out=ox)         # r^2 - |l|^2 = disc / a
    miss = disc < 0
    np.maximum(disc, 0, out=disc)
    disc *= inva
    sq = np.sqrt(disc, out=disc)
    t = np.negative(b, out=b)
    t -= sq                                    # t1 = -b - sq; where t1 <= t_min: t2 = t1 + 2 sq
    sq += sq
    sq *= t <= t_min
    t += sq
    miss |= ~(t > t_min)                       # NaN is a miss too
    return _miss(t, miss)


def closest_quadrics(c: np.ndarray, minv: np.ndarray | None, r2: np.ndarray, O: np.ndarray,
                     D: np.ndarray, t_min: float, index: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """``(t, j)`` of Q quadrics, float32: centres ``c (Q, 3)``; spheres (``minv`` None,
    squared radii ``r2 (Q, 1)``) or ellipsoids (``minv (Q, 3, 3)``, ``r2`` = 1)."""
    n = O.shape[1]
    q = len(c)
    t_out, j_out = np.empty(n, F32), np.empty(n, np.int64)
    with np.errstate(divide="ignore", invalid="ignore"):
        for b in _blocks(n, 3 * q):
            o, d = O[:, b], D[:, b]
            oc = [o[k] - c[:, k:k + 1] for k in range(3)]               # (Q, n) each
            if minv is None:
                dd = [d[0], d[1], d[2]]
            else:
                oc = [minv[:, k, 0:1] * oc[0] + minv[:, k, 1:2] * oc[1] + minv[:, k, 2:3] * oc[2]
                      for k in range(3)]
                dd = [minv[:, k, 0:1] * d[0] + minv[:, k, 1:2] * d[1] + minv[:, k, 2:3] * d[2]
                      for k in range(3)]
            t_out[b], jb = _pick(_sphere_roots(*oc, *dd, r2, t_min), index)
            if index:
                j_out[b] = jb
    return t_out, j_out if index else None


def box_rows(minv: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """float32 ``(wo (3B, 4), wd (3B, 3))`` for :func:`closest_boxes`: ``wo @ [o; 1]`` gives
    the rows of ``M^-1 (o - c)`` and ``wd @ d`` those of ``M^-1 d`` (box b is
    ``|M_b^-1 (x - c_b)|_inf <= 1``, Mitsuba's ``cube`` under its ``to_world``)."""
    wd = minv.reshape(-1, 3)
    wo = np.concatenate([wd, -np.einsum("bkj,bj->bk", minv, c).reshape(-1, 1)], axis=1)
    return wo.astype(F32), wd.astype(F32)


def closest_boxes(wo: np.ndarray, wd: np.ndarray, O: np.ndarray, D: np.ndarray,
                  t_min: float, index: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """``(t, j)`` of B boxes by the slab test (Kay & Kajiya 1986) in each box's frame:
    per axis k, t1,2 = (-+1 - o_k) / d_k; t_near = max_k min(t1, t2), t_far = min_k
    max(t1, t2); a hit needs t_near <= t_far, t = t_near if it is > t_min (from outside)
    else t_far (from inside).  fmin/fmax drop the NaN of 0 * inf (a ray parallel to a
    slab, on its boundary); NaN t is a miss."""
    n = O.shape[1]
    nb = len(wd) // 3
    t_out, j_out = np.empty(n, F32), np.empty(n, np.int64)
    with np.errstate(divide="ignore", invalid="ignore"):
        for b in _blocks(n, 3 * nb):
            ol = _rows(wo, O[:, b])
            inv = np.divide(1.0, _rows(wd, D[:, b]))
            t1 = np.subtract(-1.0, ol)
            t1 *= inv
            t2 = np.subtract(1.0, ol, out=ol)
            t2 *= inv
            tn = np.fmin(t1, t2, out=inv).reshape(nb, 3, -1)
            tf = np.fmax(t1, t2, out=t2).reshape(nb, 3, -1)
            near = np.fmax(np.fmax(tn[:, 0], tn[:, 1]), tn[:, 2])
            far = np.fmin(np.fmin(tf[:, 0], tf[:, 1]), tf[:, 2])
            t = np.where(near > t_min, near, far)
            bad = t > t_min
            np.logical_not(bad, out=bad)
            bad |= near > far
            t_out[b], jb = _pick(_miss(t, bad), index)
            if index:
                j_out[b] = jb
    return t_out, j_out if index else None


class DensePlanar:
    """float32 all-pairs test of a planar group (:class:`~vrlab.render.accel.groups.Planar`):
    plane rows of its primitives, except the six faces of each box (``boxes``: a list of
    ``(face primitive indices (6,) by face code 2 k + (side > 0), M^-1, c)``), which one slab
    test replaces (a third of the rows and of the work).  ``closest`` returns ``(t, j)``
    with j the group's primitive, or ``n_prims + b`` for box b, whose face
    :meth:`faces` finds for the winners only; a plane wins a tie against a box."""

    def __init__(self, n, a1, a2, v0, para: bool, boxes=()):
        self.para, self.n_prims = para, len(v0)
        in_box = np.concatenate([f for f, _, _ in boxes] or [np.zeros(0, np.int64)])
        self.plane_ids = np.setdiff1d(np.arange(len(v0)), in_box)
        ids = self.plane_ids
        self.rows = plane_rows(n[ids], a1[ids], a2[ids], v0[ids], para) if len(ids) else None
        self.box_faces = np.array([f for f, _, _ in boxes], np.int64).reshape(-1, 6)
        self.box_minv = np.array([m for _, m, _ in boxes], float).reshape(-1, 3, 3)
        self.box_c = np.array([c for _, _, c in boxes], float).reshape(-1, 3)
        self.box_rows = box_rows(self.box_minv, self.box_c) if boxes else None

    def closest(self, O: np.ndarray, D: np.ndarray, t_min: float,
                index: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        if self.rows is not None:
            t, j = closest_planes(*self.rows, self.para, O, D, t_min, index)
            j = self.plane_ids[j] if index else None
        else:
            t, j = np.full(O.shape[1], np.inf, F32), np.zeros(O.shape[1], np.int64)
        if self.box_rows is not None:
            tb, jb = closest_boxes(*self.box_rows, O, D, t_min, index)
            if not index:
                return np.minimum(t, tb), None
            closer = tb < t
            t, j = np.where(closer, tb, t), np.where(closer, self.n_prims + jb, j)
        return t, j

    def faces(self, o: np.ndarray, d: np.ndarray, rows: np.ndarray, t: np.ndarray, j: np.ndarray) -> np.ndarray:
        """``j`` (of the rays ``rows`` of ``o``, ``d``, hit at ``t``) with each box winner
        ``n_prims + b`` replaced by the face of box b that the ray meets: the face code
        2 k + (x_k > 0) of the largest |x_k| of the local hit point x = M^-1 (o + t d - c)."""
        if self.box_rows is None:
            return j
        j = j.copy()
        for b in range(len(self.box_c)):                # a few boxes: one product each
            box = np.flatnonzero(j == self.n_prims + b)
            if not len(box):
                continue
            r = rows[box]
            x = np.take(o, r, axis=0) + scale(np.take(d, r, axis=0), t[box]) - self.box_c[b]
            x = x @ self.box_minv[b].T
            a = np.abs(x)
            x0, x1 = a[:, 0] >= a[:, 1], a[:, 0] >= a[:, 2]
            x1x2 = a[:, 1] >= a[:, 2]
            axis = np.where(x0 & x1, 0, np.where(~x0 & x1x2, 1, 2))
            side = np.where(axis == 0, x[:, 0], np.where(axis == 1, x[:, 1], x[:, 2])) > 0
            j[box] = self.box_faces[b][2 * axis + side]
        return j
