"""Primitive groups of :class:`~vrlab.render.accel.geometry.SceneGeometry` (see its module
docstring): planar primitives (parallelograms and triangles, with the slab test for
cubes) and quadrics, each with a float32 all-pairs pass (:mod:`.dense`) and its float64
or float32 finish, and a conservative cull for many quadrics; every group also has the exact
float64 test of (ray, primitive) pairs that the scene's BVH (:mod:`.scene_bvh`) calls.  Disks
are :mod:`.disks`."""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..._vec import dot as _dot
from ..._vec import norm, scale
from ...distributions.quadrics import unit_sphere_hit
from .dense import DensePlanar, closest_quadrics
from .flat import PARA, QUADRIC, SPHERE, TRI

__all__ = ["DENSE_QUADRICS", "Planar", "Quadrics", "affine_boxes", "unit", "unit_sphere_hit"]

# (ray, primitive) pairs per culling block: cache sized (the (N, 11) @ (11, P) products of the
# quadric cull take as much CPU time as with OPENBLAS_NUM_THREADS=1: 0.814 against 0.827 us per
# many_lights sample; half the block size costs 15 % more in per-block overhead)
_QUADRIC_ELEMS = 1 << 15
DENSE_QUADRICS = 16           # up to this many quadrics are tested all-pairs in float32
_TOL_DISC = 1e-12             # culling slack of sphere discriminants, relative


def _take64(a: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The rows ``rows`` of ``a`` as float64 (the float64 finish of float32 rays)."""
    return np.take(a, rows, axis=0).astype(np.float64, copy=False)


def unit(v: np.ndarray) -> np.ndarray:
    """Unit vectors along the rows of ``v`` (zero rows stay zero)."""
    n = norm(v)
    return scale(v, 1.0 / np.where(n > 0, n, 1.0))


def _box_faces(v0, e1, e2, shape, boxes: dict) -> list:
    """For each cube (shape index -> ``to_world``) whose six faces are parallelograms of
    this group: ``(face indices by code 2 k + (side > 0), M^-1, c)`` for the slab test."""
    out = []
    for k, m in boxes.items():
        rows = np.flatnonzero(shape == k)
        lin, c = m[:3, :3], m[:3, 3]
        if len(rows) != 6 or abs(np.linalg.det(lin)) < 1e-300:
            continue
        minv = np.linalg.inv(lin)
        x = (v0[rows] + 0.5 * (e1[rows] + e2[rows]) - c) @ minv.T        # face centres, local
        axis = np.argmax(np.abs(x), -1)
        code = 2 * axis + (x[np.arange(6), axis] > 0)
        if sorted(code.tolist()) == list(range(6)):
            faces = np.empty(6, np.int64)
            faces[code] = rows
            out.append((faces, minv, c))
    return out


class Planar:
    """Parallelograms (``para=True``) or triangles ``v0 + s e1 + u e2`` with their
    normals and shape indices; see the module docstring for the formulas."""

    def __init__(self, v0, e1, e2, normal, shape, para: bool, boxes: dict | None = None, local=None,
                 dense: bool = True):
        m = np.cross(e1, e2)
        m2 = np.sum(m * m, -1)
        keep = m2 > 0                                  # degenerate ones are never hit
        v0, e1, e2, m, m2 = v0[keep], e1[keep], e2[keep], m[keep], m2[keep]
        #: each primitive's index within its shape (a mesh's triangle index)
        self.local = (np.zeros(len(shape), np.int64) if local is None else np.asarray(local, np.int64))[keep]
        self.para = para
        self.v0, self.e1, self.e2 = v0, e1, e2
        self.normal, self.shape = normal[keep], shape[keep]
        self.normal32 = self.normal.astype(np.float32)
        self.n = m / np.sqrt(m2)[:, None]
        self.a1 = np.cross(e2, m) / m2[:, None]
        self.a2 = np.cross(m, e1) / m2[:, None]
        self.packed = np.concatenate([v0, self.n, self.a1, self.a2], axis=1)
        # the float32 all-pairs kernel (``dense``), else exact tests only (the scene's BVH)
        self.kernel = None if not dense else \
            DensePlanar(self.n, self.a1, self.a2, v0, para, _box_faces(v0, e1, e2, self.shape, boxes or {}))
        self.shape_ext = self.shape if self.kernel is None else \
            np.concatenate([self.shape, self.shape[self.kernel.box_faces[:, 0]]])   # + boxes

    def __len__(self) -> int:
        return len(self.v0)

    def dense(self, O: np.ndarray, D: np.ndarray, t_min: float, index: bool = True):
        """float32 ``(t, j)`` of every ray against every primitive (:mod:`.dense`)."""
        return self.kernel.closest(O, D, t_min, index)

    def finish(self, o, d, t_min, rows, j, t32, t, shape, normal, prim=None):
        """float64 plane t, shape and normal of the rays ``rows`` whose closest hit is
        primitive ``j`` by the float32 pass (the in/out decision is that pass's); with
        ``prim``, the primitive's index within its shape too."""
        j = self.kernel.faces(o, d, rows, t32, j)
        q = np.take(self.packed, j, axis=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            tt = -_dot(_take64(o, rows) - q[:, :3], q[:, 3:6]) / _dot(_take64(d, rows), q[:, 3:6])
        ok = np.isfinite(tt) & (tt > t_min)
        if not ok.all():
            rows, j, tt = rows[ok], j[ok], tt[ok]
        t[rows], shape[rows] = tt, np.take(self.shape, j)
        normal[rows] = np.take(self.normal, j, axis=0)
        if prim is not None:
            prim[rows] = np.take(self.local, j)

    def shape_of(self, j: np.ndarray) -> np.ndarray:
        """Shape index of the dense pass's primitives ``j`` (box winners included)."""
        return np.take(self.shape_ext, j)

    def finish32(self, o, d, t_min, rows, j, t32, t, shape, normal, prim=None):
        """``finish`` for float32 rays: the float32 pass's t and the primitive's normal."""
        j = self.kernel.faces(o, d, rows, t32, j)
        if len(rows) == len(t):                        # every ray: no scatter
            rows = slice(None)
        t[rows], shape[rows] = t32, np.take(self.shape, j)
        normal[rows] = np.take(self.normal32, j, axis=0)
        if prim is not None:
            prim[rows] = np.take(self.local, j)

    # -- the pair interface of the scene's BVH (:mod:`.scene_bvh`), shared by every group ------
    def boxes(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounding boxes ``(lo, hi)`` of the primitives: the boxes of their corners."""
        corners = [self.v0, self.v0 + self.e1, self.v0 + self.e2] + ([self.v0 + self.e1 + self.e2] if self.para
                                                                     else [])
        c = np.stack(corners, 1)
        return c.min(1), c.max(1)

    def hit_info(self, j: np.ndarray, plane: bool):
        """``(v0 and unit plane normal (N, 6) or None, normal, shape, index in the shape)`` of
        primitives ``j`` (Embree's hits, :mod:`.embree`)."""
        return (self.packed[j, :6] if plane else None), self.normal[j], self.shape[j], self.local[j]

    def normals(self, o, d, rows, j, t) -> np.ndarray:
        """Normals of the hits ``(rays rows, primitives j, t)``: the primitives' own."""
        return self.normal[j]

    def prims(self, j) -> np.ndarray:
        """Each primitive's index within its shape (a mesh's triangle)."""
        return self.local[j]

    def kernel_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """``(kind codes, rows (P, 16))`` of the compiled traversal (:mod:`.flat`): ``v0, n, a1, a2``,
        the normal."""
        rows = np.zeros((len(self), 16))
        rows[:, :12], rows[:, 12:15] = self.packed, self.normal
        return np.full(len(self), PARA if self.para else TRI, np.int64), rows

    def exact(self, o, d, t_min, i, j):
        """Exact t (inf on a miss) of the pairs ``(ray i, primitive j)``."""
        q = self.packed[j]                         # [v0, n, a1, a2]
        oc = o[i] - q[:, :3]
        dd, n = d[i], q[:, 3:6]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = _dot(oc, n)
            t /= _dot(dd, n)
            np.negative(t, out=t)
            oc += t[:, None] * dd                 # hit point - v0
            s, u = _dot(oc, q[:, 6:9]), _dot(oc, q[:, 9:])
            ok = (t > t_min) & (np.minimum(s, u) >= 0.0)
            ok &= (np.maximum(s, u) <= 1.0) if self.para else (s + u <= 1.0)
        ok &= np.isfinite(t)
        return np.where(ok, t, np.inf)


class Quadrics:
    """Ellipsoids ``x = c + M s``, ``|s| = 1``, culled with their bounding spheres
    (a BVH of their boxes was about 2x slower for the 128 small spheres of many_lights)."""

    def __init__(self, quad):
        self.shape = np.array([q[0] for q in quad], int)
        self.c = np.array([q[1] for q in quad], float).reshape(-1, 3)
        self.minv = np.array([q[2] for q in quad], float).reshape(-1, 3, 3)
        self.sign = np.array([q[3] for q in quad], float)
        m = np.linalg.inv(self.minv)
        r = np.linalg.norm(m, ord=2, axis=(1, 2))                # bounding sphere radius
        cx, cy, cz = self.c.T                                    # the cull's sphere features (closest)
        self.w_disc = np.stack([np.ones_like(r), cx, cy, cz, cx * cx, cy * cy, cz * cz, cx * cy, cx * cz, cy * cz,
                                r * r - np.sum(self.c * self.c, -1)])
        self.cmax = float(np.max(np.linalg.norm(self.c, axis=-1) + r, initial=0.0))
        # float32 all-pairs data (.dense): spheres in world space, else unit-sphere frames
        self.c32 = self.c.astype(np.float32)
        gram = np.einsum("kab,kac->kbc", m, m)                   # M^T M = r^2 I for spheres
        spheres = np.allclose(gram, (r * r)[:, None, None] * np.eye(3), rtol=1e-12, atol=0)
        self.minv32 = None if spheres else self.minv.astype(np.float32)
        self.radius = r if spheres else None
        self.inv_r32 = (self.sign / r).astype(np.float32)       # sign / r (spheres' finish32)
        self.r2_32 = (r * r if spheres else np.ones_like(r)).astype(np.float32)[:, None]
        self.use_dense = len(r) <= DENSE_QUADRICS

    def __len__(self) -> int:
        return len(self.shape)

    def _local(self, o, d, i, j):
        """Pair rays in the unit-sphere frames: ``M^-1 (o - c)``, ``M^-1 d``, and ``M^-1``."""
        minv = np.take(self.minv, j, axis=0)
        oc = _take64(o, i) - np.take(self.c, j, axis=0)
        dd = _take64(d, i)
        ol = minv[:, :, 0] * oc[:, 0:1] + minv[:, :, 1] * oc[:, 1:2] + minv[:, :, 2] * oc[:, 2:3]
        dl = minv[:, :, 0] * dd[:, 0:1] + minv[:, :, 1] * dd[:, 1:2] + minv[:, :, 2] * dd[:, 2:3]
        return ol, dl, minv

    def _normal(self, ol, dl, minv, j, tt):
        x = ol + tt[:, None] * dl                                        # unit-sphere point
        n = x[:, 0:1] * minv[:, 0] + x[:, 1:2] * minv[:, 1] + x[:, 2:3] * minv[:, 2]   # M^-T x
        return self.sign[j, None] * unit(n)

    # -- the pair interface (see ``Planar``) -------------------------------------------------
    def boxes(self) -> tuple[np.ndarray, np.ndarray]:
        """Exact boxes of the ellipsoids: c_i +- sqrt(sum_j M_ij^2)."""
        return affine_boxes(self.c, np.linalg.inv(self.minv))

    def exact(self, o, d, t_min, i, j):
        """Exact t (inf on a miss) of the pairs ``(ray i, quadric j)``: the stable roots in the
        unit-sphere frame (for spheres (o - c) / r and d / r: a rotation leaves the roots)."""
        if self.radius is not None:
            inv_r = 1.0 / np.take(self.radius, j)[:, None]
            return unit_sphere_hit((_take64(o, i) - np.take(self.c, j, axis=0)) * inv_r, _take64(d, i) * inv_r, t_min)
        return unit_sphere_hit(*self._local(o, d, i, j)[:2], t_min)

    def normals(self, o, d, rows, j, t) -> np.ndarray:
        """Normals of the hits ``(rays rows, quadrics j, t)``: sign M^-T of the unit-sphere point
        (spheres: sign (o + t d - c) / |...|)."""
        if self.radius is not None:
            x = _take64(o, rows) - np.take(self.c, j, axis=0)
            x += scale(_take64(d, rows), t)
            return scale(unit(x), np.take(self.sign, j))
        return self._normal(*self._local(o, d, rows, j), j, t)

    def prims(self, j) -> np.ndarray:
        return np.zeros(len(j), np.int64)

    def kernel_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """``(kind codes, rows (P, 16))`` of the compiled traversal (:mod:`.flat`): ``c, 1 / r``
        for a group of spheres (the test ``exact`` takes), else ``c, M^-1``; the normals' sign."""
        rows = np.zeros((len(self), 16))
        rows[:, 15] = self.sign
        rows[:, :3] = self.c
        if self.radius is not None:
            rows[:, 3] = 1.0 / self.radius
            return np.full(len(self), SPHERE, np.int64), rows
        rows[:, 3:12] = self.minv.reshape(-1, 9)
        return np.full(len(self), QUADRIC, np.int64), rows

    def _fold(self, o, d, t_min, i, j, tt, t, shape, normal, prim=None):
        _update(t, shape, normal, i, tt, lambda w: self.shape[j[w]],
                lambda w: self.normals(o, d, i[w], j[w], tt[w]), prim, lambda w: 0)

    def dense(self, O: np.ndarray, D: np.ndarray, t_min: float, index: bool = True):
        """float32 ``(t, j)`` of every ray against every quadric (:mod:`.dense`)."""
        return closest_quadrics(self.c32, self.minv32, self.r2_32, O[:3], D, t_min, index)

    def finish(self, o, d, t_min, rows, j, t32, t, shape, normal, prim=None):
        """float64 t (stable roots; the float32 t where a grazing ray misses in float64),
        shape and normal of the rays ``rows`` whose closest hit is quadric ``j`` (``prim``: 0)."""
        if prim is not None:
            prim[rows] = 0
        if self.radius is not None:
            return self._finish_spheres(o, d, t_min, rows, j, t, shape, normal)
        ol, dl, minv = self._local(o, d, rows, j)
        tt = unit_sphere_hit(ol, dl, t_min)
        tt = np.where(np.isfinite(tt), tt, t32.astype(np.float64))
        ok = tt > t_min
        if not ok.all():
            rows, j, tt, ol, dl, minv = rows[ok], j[ok], tt[ok], ol[ok], dl[ok], minv[ok]
        t[rows], shape[rows], normal[rows] = tt, self.shape[j], self._normal(ol, dl, minv, j, tt)

    def shape_of(self, j: np.ndarray) -> np.ndarray:
        """Shape index of the dense pass's quadrics ``j``."""
        return np.take(self.shape, j)

    def finish32(self, o, d, t_min, rows, j, t32, t, shape, normal, prim=None):
        """``finish`` for float32 rays: spheres keep the float32 pass's t, normal = sign
        (o + t d - c) / r in float32; ellipsoids take the float64 ``finish``."""
        if prim is not None:
            prim[rows] = 0
        if self.radius is None:
            return self.finish(o, d, t_min, rows, j, t32, t, shape, normal)
        x = np.take(o, rows, axis=0)
        x += scale(np.take(d, rows, axis=0), t32)
        x -= np.take(self.c32, j, axis=0)
        t[rows], shape[rows], normal[rows] = t32, np.take(self.shape, j), scale(x, np.take(self.inv_r32, j))

    def _finish_spheres(self, o, d, t_min, rows, j, t, shape, normal):
        """``finish`` for spheres, in world space: b = (o - c).d / |d|^2, l = o - c - b d,
        t = -b -/+ sqrt((r^2 - |l|^2) / |d|^2) (clamped at 0: the float32 pass said hit),
        normal = sign (o + t d - c) / r."""
        oc = _take64(o, rows) - np.take(self.c, j, axis=0)
        dd = _take64(d, rows)
        r = np.take(self.radius, j)
        inva = 1.0 / _dot(dd, dd)
        b = _dot(oc, dd) * inva
        lv = oc - scale(dd, b)
        sq = np.sqrt(np.maximum(r * r - _dot(lv, lv), 0.0) * inva)
        t1 = -b - sq
        tt = np.where(t1 > t_min, t1, sq - b)
        ok = tt > t_min
        if not ok.all():
            rows, j, tt, oc, dd, r = rows[ok], j[ok], tt[ok], oc[ok], dd[ok], r[ok]
        oc += scale(dd, tt)
        t[rows], shape[rows], normal[rows] = tt, np.take(self.shape, j), scale(oc, np.take(self.sign, j) / r)

    def closest(self, o, d, t_min, t, shape, normal, prim=None):
        """Update the closest hits of a block of rays in place.  The cull: a ray meets a
        bounding sphere (c, r) where disc/4 = (d.(o - c))^2 - a (|o - c|^2 - r^2) >= 0 (a = d.d),
        expanded into 11 ray features times 11 sphere features (``w_disc``: 1, c, the products
        c_i c_j, r^2 - |c|^2), so that one matrix product gives every pair's discriminant; its
        float64 rounding is far inside the slack ``tol`` (relative 1e-12 of a (|o| + |c|)^2)."""
        o, d = o.astype(np.float64, copy=False), d.astype(np.float64, copy=False)
        a, oo, do = _dot(d, d), _dot(o, o), _dot(o, d)
        tol = -_TOL_DISC * a * (np.sqrt(oo) + self.cmax) ** 2
        feat = np.empty((len(o), 11))
        feat[:, 0] = do * do - a * oo
        np.multiply(o, 2 * a[:, None], out=feat[:, 1:4])
        feat[:, 1:4] -= (2 * do)[:, None] * d
        np.multiply(d, d, out=feat[:, 4:7])
        feat[:, 7] = 2 * d[:, 0] * d[:, 1]
        feat[:, 8] = 2 * d[:, 0] * d[:, 2]
        feat[:, 9] = 2 * d[:, 1] * d[:, 2]
        feat[:, 10] = a
        ii, jj = [], []
        for r, sl in _blocks(len(o), len(self), _QUADRIC_ELEMS):
            disc = feat[r] @ self.w_disc[:, sl]
            i, j = _nonzero(disc >= tol[r, None])
            ii.append(i + r.start)
            jj.append(j + sl.start)
        i, j = _pairs(ii, jj)
        self._fold(o, d, t_min, i, j, self.exact(o, d, t_min, i, j), t, shape, normal, prim)


def affine_boxes(c: np.ndarray, m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Boxes of c + M s over the unit ball of s (M ``(P, 3, k)``): c +- the row norms of M."""
    half = np.sqrt(np.sum(m * m, -1))
    return c - half, c + half


def _blocks(n_rays: int, n_prims: int, elems: int):
    """(ray slice, primitive slice) blocks of about ``elems`` pairs (cache sized)."""
    pb = min(n_prims, elems // 64)
    rb = max(64, elems // max(pb, 1))
    for a in range(0, n_rays, rb):
        for b in range(0, n_prims, pb):
            yield slice(a, min(a + rb, n_rays)), slice(b, min(b + pb, n_prims))


def _nonzero(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.nonzero`` of a C-contiguous 2-d mask (4x faster via the flat indices)."""
    return np.divmod(np.flatnonzero(mask), mask.shape[1])


def _pairs(ii: list, jj: list) -> tuple[np.ndarray, np.ndarray]:
    """Concatenated (ray, primitive) pairs of all blocks, sorted by ray, then primitive."""
    i, j = np.concatenate(ii), np.concatenate(jj)
    if len(i) > 1 and np.any(i[1:] < i[:-1]):
        s = np.lexsort((j, i))
        i, j = i[s], j[s]
    return i, j


def _firsts(i: np.ndarray) -> np.ndarray:
    """Mask of the first element of each run of equal values in ``i``."""
    f = np.empty(len(i), bool)
    f[:1] = True
    np.not_equal(i[1:], i[:-1], out=f[1:])
    return f


def _update(t, shape, normal, i, tt, shape_of: Callable, normal_of: Callable, prim=None,
            prim_of: Callable | None = None) -> None:
    """Fold pair hits ``(ray i, t tt)`` (``i`` ascending) into the closest hits; a tie
    keeps the earlier hit (the first pair, or the hit already stored)."""
    w = np.flatnonzero(tt < t[i])
    if not len(w):
        return
    iw, tw = i[w], tt[w]
    starts = np.flatnonzero(_firsts(iw))
    best = np.minimum.reduceat(tw, starts)
    win = np.flatnonzero(tw == np.repeat(best, np.diff(np.append(starts, len(iw)))))
    win = win[_firsts(iw[win])]                                # first of ties
    rows = iw[win]
    t[rows] = tw[win]
    shape[rows] = shape_of(w[win])
    normal[rows] = normal_of(w[win])
    if prim is not None:
        prim[rows] = prim_of(w[win])
