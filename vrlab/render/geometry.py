"""Scene geometry as arrays, and vectorised closest-hit ray intersection.

``SceneGeometry(scene)`` collects every shape of a :class:`~vrlab.render.Scene` into
primitive groups:

* planar primitives ``x = v0 + s e1 + u e2``: parallelograms (``s, u`` in [0, 1]; a
  rectangle, each cube face and every pair of mesh triangles that forms one) and the
  remaining mesh triangles (``s, u >= 0``, ``s + u <= 1``; ``obj``).  The hit is the
  plane hit ``t = (v0 - o).n / d.n`` and ``s = (x - v0).a1``, ``u = (x - v0).a2`` with
  the dual basis ``a1 = (e2 x m)/|m|^2``, ``a2 = (m x e1)/|m|^2``, ``m = e1 x e2``
  (the same hits as Moller & Trumbore 1997, "Fast, minimum storage ray/triangle
  intersection");
* quadrics (``sphere``, ``ellipsoid``): the unit sphere under an affine map
  x = c + M s, intersected in the unit-sphere frame;
* disks: the unit disk in z = 0 under an affine map.

``intersect(origin, direction)`` (rays ``(N, 3)``, directions need not be unit; t is in
units of their length) returns :class:`Hits` with the closest ``t > t_min`` per ray,
the index of the shape hit (into ``scene.shapes``; -1 for a miss), the hit point and
the unit geometric normal, which follows Mitsuba: ``M^-T`` of the object normal for
analytic shapes (rectangle, disk, sphere, ellipsoid), the winding ``e1 x e2`` for
meshes (cube, obj), outward for closed shapes, and reversed by ``flip_normals``.

Groups of up to a few dozen primitives (every built-in scene) are tested *all pairs* in
float32 (:mod:`vrlab.render.dense`: one contiguous row of rays per primitive, about 2.5x
NumPy's float64 rate), which picks the closest primitive of each ray; then t, the
point and the normal of that primitive are recomputed in float64, except for float32
rays (the renderer's), which keep the float32 t and get float32 points and normals.  Hit/miss decisions
are therefore float32-accurate, as in Mitsuba's scalar variants: rays should start at
least about 1e-5 (1 + |o|) off a surface (the renderer offsets them by that much), and
rays within float32 rounding of an edge or of a second surface may pick either.
Larger groups keep exact float64 decisions: ``obj`` meshes of at least 64 triangles
use a BVH (:mod:`vrlab.render.bvh`), and more than 16 quadrics (many_lights' 128
spheres) a conservative cull of all (ray, quadric) pairs with thin matrix products
``[d, d.o] @ W`` (the discriminant of each bounding sphere, with a tolerance that only
admits extra pairs) followed by the stable quadratic roots of the candidate pairs.
Among equal ``t`` (coincident surfaces; in the float32 pass, t equal to about 1e-5
relative) the first group (parallelograms, triangles, quadrics, disks) and then the
lowest primitive wins.  Loops run over
primitive groups and blocks, never over single rays.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from .._vec import dot as _dot
from .._vec import norm, scale
from .bvh import BVH
from .dense import closest_planes, closest_quadrics, plane_rows
from .scene import Scene

__all__ = ["DEFAULT_RAY_CHUNK", "Hits", "SceneGeometry"]

DEFAULT_RAY_CHUNK = 1 << 15   # rays per block
# (ray, primitive) pairs per culling block: cache sized, and small enough (N k P <= 2^18
# for an (N, k) @ (k, P) product) that OpenBLAS stays single-threaded (much faster here)
_QUADRIC_ELEMS = 1 << 15
DENSE_QUADRICS = 16           # up to this many quadrics are tested all-pairs in float32
_BVH_MIN_PRIMS = 64           # planar groups at least this big are traversed with a BVH
_TOL_DISC = 1e-12             # culling slack of sphere discriminants, relative


class Hits(NamedTuple):
    """Closest hits: ``t (N,)`` (inf on a miss), ``shape (N,)`` int (-1 on a miss),
    ``p (N, 3)`` hit points and ``n (N, 3)`` unit geometric normals (0 on a miss)."""

    t: np.ndarray
    shape: np.ndarray
    p: np.ndarray
    n: np.ndarray


def _take64(a: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The rows ``rows`` of ``a`` as float64 (the float64 finish of float32 rays)."""
    return np.take(a, rows, axis=0).astype(np.float64, copy=False)


def _unit(v: np.ndarray) -> np.ndarray:
    n = norm(v)
    return scale(v, 1.0 / np.where(n > 0, n, 1.0))


def _parallelograms(tri: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Split triangles ``(T, 3, 3)`` into parallelograms ``(corner, e1, e2)`` made of
    consecutive pairs ``(p0, p1, p2), (p0, p2, y)`` or ``(y, p0, p2)`` with ``y = p0 + p2 - p1``
    (fan-triangulated quads, also reversed), and the indices of the triangles left over.
    Returns ``(para (Q, 4, 3): corner, e1, e2, winding normal of the first triangle), rest``."""
    a, b = tri[:-1], tri[1:]
    p0, p1, p2 = a[:, 0], a[:, 1], a[:, 2]

    def near(x, y):
        return np.all(np.abs(x - y) <= tol, axis=-1)

    fan = near(b[:, 0], p0) & near(b[:, 1], p2)
    rev = near(b[:, 1], p0) & near(b[:, 2], p2)
    y = np.where(fan[:, None], b[:, 2], b[:, 0])
    ok = (fan | rev) & near(y, p0 + p2 - p1)
    used = np.zeros(len(tri), bool)
    first = []
    for k in np.flatnonzero(ok):       # greedy, non-overlapping pairs
        if not used[k]:
            used[k] = used[k + 1] = True
            first.append(k)
    first = np.array(first, int)
    p0, p1, p2 = tri[first, 0], tri[first, 1], tri[first, 2]
    n = _unit(np.cross(p1 - p0, p2 - p0))
    para = np.stack([p1, p0 - p1, p2 - p1, n], axis=1) if len(first) else np.zeros((0, 4, 3))
    return para, np.flatnonzero(~used)


class _Planar:
    """Parallelograms (``para=True``) or triangles ``v0 + s e1 + u e2`` with their
    normals and shape indices; see the module docstring for the formulas."""

    def __init__(self, v0, e1, e2, normal, shape, para: bool):
        m = np.cross(e1, e2)
        m2 = np.sum(m * m, -1)
        keep = m2 > 0                                  # degenerate ones are never hit
        v0, e1, e2, m, m2 = v0[keep], e1[keep], e2[keep], m[keep], m2[keep]
        self.para = para
        self.v0, self.e1, self.e2 = v0, e1, e2
        self.normal, self.shape = normal[keep], shape[keep]
        self.normal32 = self.normal.astype(np.float32)
        self.n = m / np.sqrt(m2)[:, None]
        self.a1 = np.cross(e2, m) / m2[:, None]
        self.a2 = np.cross(m, e1) / m2[:, None]
        self.packed = np.concatenate([v0, self.n, self.a1, self.a2], axis=1)
        self.rows32 = plane_rows(self.n, self.a1, self.a2, v0, para)      # float32 (.dense)
        p = len(v0)
        self.bvh = BVH(np.stack([v0, v0 + e1, v0 + e2] + ([v0 + e1 + e2] if para else []),
                                axis=1)) if p >= _BVH_MIN_PRIMS else None

    def __len__(self) -> int:
        return len(self.v0)

    def dense(self, O: np.ndarray, D: np.ndarray, t_min: float):
        """float32 ``(t, j)`` of every ray against every primitive (:mod:`.dense`)."""
        return closest_planes(*self.rows32, self.para, O, D, t_min)

    def finish(self, o, d, t_min, rows, j, t32, t, shape, normal):
        """float64 plane t, shape and normal of the rays ``rows`` whose closest hit is
        primitive ``j`` by the float32 pass (the in/out decision is that pass's)."""
        q = np.take(self.packed, j, axis=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            tt = -_dot(_take64(o, rows) - q[:, :3], q[:, 3:6]) / _dot(_take64(d, rows), q[:, 3:6])
        ok = np.isfinite(tt) & (tt > t_min)
        if not ok.all():
            rows, j, tt = rows[ok], j[ok], tt[ok]
        t[rows], shape[rows] = tt, np.take(self.shape, j)
        normal[rows] = np.take(self.normal, j, axis=0)

    def finish32(self, o, d, t_min, rows, j, t32, t, shape, normal):
        """``finish`` for float32 rays: the float32 pass's t and the primitive's normal."""
        t[rows], shape[rows] = t32, np.take(self.shape, j)
        normal[rows] = np.take(self.normal32, j, axis=0)

    def exact(self, rays, t_min, i, j):
        """Exact t (inf on a miss) of the pairs ``(i, j)``; ``rays = [o, d]`` ``(N, 6)``."""
        r, q = rays[i], self.packed[j]            # [o, d], [v0, n, a1, a2]
        oc = r[:, :3] - q[:, :3]
        dd, n = r[:, 3:], q[:, 3:6]
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

    def closest(self, o, d, t_min, t, shape, normal):
        """Update the closest hits ``t, shape, normal`` of a block of rays in place (BVH)."""
        rays = np.concatenate([o, d], axis=1)

        def test(i, j):
            return self.exact(rays, t_min, i, j)
        i, j, tt = self.bvh.closest(o, d, t_min, t, test)
        _update(t, shape, normal, i, tt, lambda w: self.shape[j[w]], lambda w: self.normal[j[w]])


class _Quadrics:
    """Ellipsoids ``x = c + M s``, ``|s| = 1``, culled with their bounding spheres
    (a BVH of their boxes was about 2x slower for the 128 small spheres of many_lights)."""

    def __init__(self, quad):
        self.shape = np.array([q[0] for q in quad], int)
        self.c = np.array([q[1] for q in quad], float).reshape(-1, 3)
        self.minv = np.array([q[2] for q in quad], float).reshape(-1, 3, 3)
        self.sign = np.array([q[3] for q in quad], float)
        m = np.linalg.inv(self.minv)
        r = np.linalg.norm(m, ord=2, axis=(1, 2))                # bounding sphere radius
        self.w_b = np.concatenate([-self.c.T, np.ones((1, len(r)))])
        self.w_c = np.concatenate([-2.0 * self.c.T, np.ones((1, len(r))),
                                   [np.sum(self.c * self.c, -1) - r * r]])
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
        return self.sign[j, None] * _unit(n)

    def _fold(self, o, d, t_min, i, j, tt, t, shape, normal):
        def nrm(w):
            return self._normal(*self._local(o, d, i[w], j[w]), j[w], tt[w])
        _update(t, shape, normal, i, tt, lambda w: self.shape[j[w]], nrm)

    def dense(self, O: np.ndarray, D: np.ndarray, t_min: float):
        """float32 ``(t, j)`` of every ray against every quadric (:mod:`.dense`)."""
        return closest_quadrics(self.c32, self.minv32, self.r2_32, O[:3], D, t_min)

    def finish(self, o, d, t_min, rows, j, t32, t, shape, normal):
        """float64 t (stable roots; the float32 t where a grazing ray misses in float64),
        shape and normal of the rays ``rows`` whose closest hit is quadric ``j``."""
        if self.radius is not None:
            return self._finish_spheres(o, d, t_min, rows, j, t, shape, normal)
        ol, dl, minv = self._local(o, d, rows, j)
        tt = _unit_sphere_hit(ol, dl, t_min)
        tt = np.where(np.isfinite(tt), tt, t32.astype(np.float64))
        ok = tt > t_min
        if not ok.all():
            rows, j, tt, ol, dl, minv = rows[ok], j[ok], tt[ok], ol[ok], dl[ok], minv[ok]
        t[rows], shape[rows], normal[rows] = tt, self.shape[j], self._normal(ol, dl, minv, j, tt)

    def finish32(self, o, d, t_min, rows, j, t32, t, shape, normal):
        """``finish`` for float32 rays: spheres keep the float32 pass's t, normal = sign
        (o + t d - c) / r in float32; ellipsoids take the float64 ``finish``."""
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

    def closest(self, o, d, t_min, t, shape, normal):
        """Update the closest hits of a block of rays in place."""
        a, oo = _dot(d, d), _dot(o, o)
        tol = -_TOL_DISC * a * (np.sqrt(oo) + self.cmax) ** 2
        ao = np.empty((len(o), 5))                        # a [o, |o|^2, 1]
        np.multiply(o, a[:, None], out=ao[:, :3])
        ao[:, 3] = a * oo
        ao[:, 4] = a
        do = np.empty((len(o), 4))                        # [d, d.o]
        do[:, :3] = d
        do[:, 3] = _dot(o, d)
        ii, jj = [], []
        for r, sl in _blocks(len(o), len(self), _QUADRIC_ELEMS):
            b = do[r] @ self.w_b[:, sl]                   # b = d.(o - c)
            b *= b
            b -= ao[r] @ self.w_c[:, sl]                  # - a (|o - c|^2 - r^2): discriminant / 4
            i, j = _nonzero(b >= tol[r, None])
            ii.append(i + r.start)
            jj.append(j + sl.start)
        i, j = _pairs(ii, jj)
        tt = _unit_sphere_hit(*self._local(o, d, i, j)[:2], t_min)
        self._fold(o, d, t_min, i, j, tt, t, shape, normal)


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


def _update(t, shape, normal, i, tt, shape_of: Callable, normal_of: Callable) -> None:
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


class SceneGeometry:
    """All shapes of ``scene`` as arrays of primitives (see the module docstring)."""

    def __init__(self, scene: Scene):
        para, tris, quad, disk, pts = [], [], [], [], [np.zeros(3)]
        self._n_tri = 0
        for k, s in enumerate(scene.shapes):
            pts.append(s.center)
            if s.type in ("rectangle", "cube", "obj"):
                t = s.triangles()
                self._n_tri += len(t)
                pts.append(t.reshape(-1, 3))
                if s.type == "rectangle":      # analytic in Mitsuba: normal M^-T z (mirrors too)
                    corner, e1, e2, n = s.rectangle()
                    para.append((np.array([[corner, e1, e2, n]]), k))
                    continue
                tol = 1e-12 * (1.0 + np.max(np.abs(t)))
                pg, rest = _parallelograms(t, tol)
                para.append((pg, k))
                t = t[rest]
                tris.append((np.stack([t[:, 0], t[:, 1] - t[:, 0], t[:, 2] - t[:, 0],
                                       _unit(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]))],
                                      axis=1), k))
            elif s.type in ("sphere", "ellipsoid"):
                c, m = s.ellipsoid()
                quad.append((k, c, np.linalg.inv(m), -1.0 if s.flip_normals else 1.0))
            elif s.type == "disk":
                c, m = s.center, s.to_world[:3, :3]
                disk.append((k, c, np.linalg.inv(m), s.disk()[3]))
            else:  # pragma: no cover - the loader rejects other types
                raise ValueError(f"shape type {s.type!r} is not supported by the renderer")
        self.planar = []
        for group, is_para in ((para, True), (tris, False)):
            arr = np.concatenate([g for g, _ in group] or [np.zeros((0, 4, 3))])
            if len(arr):
                ids = np.concatenate([np.full(len(g), k) for g, k in group])
                self.planar.append(_Planar(arr[:, 0], arr[:, 1], arr[:, 2], arr[:, 3], ids, is_para))
        self.quadrics = _Quadrics(quad) if quad else None
        self.disks = disk
        pts = np.vstack(pts)
        radii = [np.linalg.norm(np.linalg.inv(q[2]), 2) for q in quad + disk]
        #: a length scale of the scene (for ray offsets)
        self.scale = float(np.max(np.abs(pts)) + max(radii, default=0.0))

    @property
    def n_triangles(self) -> int:
        """Number of triangles of the mesh shapes (rectangle 2, cube 12, obj)."""
        return self._n_tri

    # ------------------------------------------------------------------ intersection
    def intersect(self, origin: np.ndarray, direction: np.ndarray, t_min: float = 0.0,
                  chunk: int = DEFAULT_RAY_CHUNK) -> Hits:
        """Closest hits with ``t > t_min`` of the rays ``origin + t direction`` (``(N, 3)``).

        float32 rays give float32 points and normals (t is float64 either way; it and the
        normal are computed in float64 from the float32 ray), anything else float64."""
        if not t_min >= 0:
            raise ValueError(f"t_min must be >= 0, got {t_min!r}")
        o, d = np.asarray(origin), np.asarray(direction)
        dt = np.float32 if o.dtype == d.dtype == np.float32 else np.float64
        o, d = np.broadcast_arrays(o.astype(dt, copy=False).reshape(-1, 3), d.astype(dt, copy=False).reshape(-1, 3))
        n_rays = len(d)
        t = np.full(n_rays, np.inf)
        shape = np.full(n_rays, -1, dtype=np.int64)
        normal = np.zeros((n_rays, 3), dt)
        for a in range(0, n_rays, chunk):
            sl = slice(a, min(a + chunk, n_rays))
            self._closest(np.ascontiguousarray(o[sl]), np.ascontiguousarray(d[sl]), t_min,
                          t[sl], shape[sl], normal[sl])
        hit = shape >= 0
        p = o + scale(d, np.where(hit, t, 0.0).astype(dt, copy=False))
        if not hit.all():
            p[~hit] = 0.0
        return Hits(t, shape, p, normal)

    def _closest(self, o, d, t_min, t, shape, normal):
        """Update ``t``, ``shape``, ``normal`` (views of one chunk) in place."""
        dense = [g for g in self.planar if g.bvh is None]
        if self.quadrics is not None and self.quadrics.use_dense:
            dense.append(self.quadrics)
        if dense:                      # float32 all pairs: the winner, then its float64 hit
            o4 = np.ones((4, len(o)), np.float32)             # [o; 1] and d as float32 rows
            o4[:3] = o.T
            rows32 = (o4, np.ascontiguousarray(d.T, dtype=np.float32))
            for k, g in enumerate(dense):
                tg, jg = g.dense(*rows32, t_min)
                if k == 0:
                    best, prim, group = tg, jg, np.where(tg < np.inf, 0, -1)
                else:                                 # strict: the earlier group keeps ties
                    closer = tg < best
                    best, prim, group = np.where(closer, tg, best), np.where(closer, jg, prim), np.where(closer, k, group)
            for k, g in enumerate(dense):
                r = np.flatnonzero(group == k)
                if len(r) and o.dtype == np.float32:       # float32 rays: float32 hits
                    g.finish32(o, d, t_min, r, prim[r], best[r], t, shape, normal)
                elif len(r):
                    g.finish(o, d, t_min, r, prim[r], best[r], t, shape, normal)
        exact = [g for g in self.planar if g.bvh is not None]
        if self.quadrics is not None and not self.quadrics.use_dense:
            exact.append(self.quadrics)
        if exact or self.disks:        # float64 decisions: float64 rays
            o, d = o.astype(np.float64, copy=False), d.astype(np.float64, copy=False)
        for g in exact:
            g.closest(o, d, t_min, t, shape, normal)
        for k, c, minv, n in self.disks:
            ol, dl = (o - c) @ minv.T, d @ minv.T
            with np.errstate(divide="ignore", invalid="ignore"):
                tt = -ol[:, 2] / dl[:, 2]
            ok = np.isfinite(tt) & (tt > t_min)
            x = ol[:, :2] + np.where(ok, tt, 0.0)[:, None] * dl[:, :2]
            ok &= np.sum(x * x, -1) <= 1.0
            better = ok & (tt < t)
            t[better] = tt[better]
            shape[better] = k
            normal[better] = n


def _unit_sphere_hit(o: np.ndarray, d: np.ndarray, t_min: float) -> np.ndarray:
    """Smallest t > t_min with |o + t d| = 1, inf if none (stable quadratic roots)."""
    a = _dot(d, d)
    b = _dot(o, d)
    c = _dot(o, o) - 1.0
    disc = b * b - a * c
    hit = disc >= 0.0
    sq = np.sqrt(np.where(hit, disc, 0.0))
    q = -(b + np.where(b >= 0.0, sq, -sq))
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = q / a
        t2 = np.where(q != 0.0, c / np.where(q != 0.0, q, 1.0), t1)
    lo, hi = np.minimum(t1, t2), np.maximum(t1, t2)
    t = np.where(lo > t_min, lo, np.where(hi > t_min, hi, np.inf))
    return np.where(hit & np.isfinite(t), t, np.inf)
