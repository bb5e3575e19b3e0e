"""The scene's triangles pooled into one indexed set, built with array operations over all of
them at once (no Python loop over meshes, parts or triangles; the loop over shapes only
collects references).

:func:`pool_triangles` takes the triangle parts of every shape (meshes as
:class:`~vrlab.render.shapes.base.IndexedTriangles`: world vertices and faces; cubes and other
:class:`~vrlab.render.shapes.base.Triangles` as three vertices per triangle) and returns a
:class:`TrianglePool`:

* every vertex of every part in one ``(V, 3)`` float64 array and every face in one ``(T, 3)``
  integer array (int32 below 2**31 vertices) of indices into it, in shape order; a triangle's
  shape and its index within the shape follow from the parts' first triangles
  (``searchsorted``), not from per-triangle arrays;
* the parallelograms found among consecutive triangles of the parts that allow it
  (``merge``): pairs ``(p0, p1, p2), (p0, p2, y)`` or ``(y, p0, p2)`` with ``y = p0 + p2 - p1``
  within ``1e-12 (1 + max |x|)`` of the part, taken greedily from the first (in a run of
  consecutive pairable positions k, k + 1, ... the even offsets: what the one-by-one greedy
  scan takes), as ``(corner p1, e1 = p0 - p1, e2 = p2 - p1, unit normal of the first
  triangle)`` with the first triangle's index;
* the triangles left (``ids``, global indices, or None for all), without those of zero area
  (``|e1 x e2| = 0``, never hit).

:class:`IndexedPlanar` is the pool's triangles as a planar group of the scene's BVH when
Embree traces them (:mod:`.embree`): it keeps nothing per triangle beyond the pool's indices
and computes a hit's normal, plane, shape and triangle index for the hits only, with the
operations :class:`~vrlab.render.accel.groups.Planar` uses for its tables (the same bits).
:meth:`IndexedPlanar.planar` gives the full :class:`Planar` group (the all-pairs kernels and
the NumPy BVH need its per-triangle tables).
"""
from __future__ import annotations

import numpy as np

from .groups import Planar, unit

__all__ = ["IndexedPlanar", "TrianglePool", "greedy_pairs", "pool_triangles"]

_BLOCK = 1 << 14              # triangles per block of the zero-area test (cache sized)


def greedy_pairs(ok: np.ndarray) -> np.ndarray:
    """Positions k taken by a greedy scan of ``ok`` (pair k joins items k, k + 1) that skips a
    pair overlapping the one taken before: in each run of consecutive True, the even offsets."""
    idx = np.flatnonzero(ok)
    if not len(idx):
        return idx
    new_run = np.ones(len(idx), bool)
    new_run[1:] = idx[1:] != idx[:-1] + 1
    run_start = idx[new_run][np.cumsum(new_run) - 1]
    return idx[(idx - run_start) % 2 == 0]


class TrianglePool:
    """The pooled triangles (see the module docstring): ``vertices``, ``faces`` (all triangles),
    ``start`` (first triangle of each part, and the total), ``part_shape``, ``ids`` (the
    triangle group's triangles, None for all) and the parallelograms ``para (Q, 4, 3)``,
    ``para_shape``, ``para_local``, ``para_part``."""

    def __init__(self, vertices, faces, start, part_shape, ids, para, para_shape, para_local, para_part):
        self.vertices, self.faces, self.start, self.part_shape = vertices, faces, start, part_shape
        self.ids = ids
        self.para, self.para_shape, self.para_local, self.para_part = para, para_shape, para_local, para_part

    @property
    def n_group(self) -> int:
        """Triangles of the triangle group (after pairing, before the zero-area test)."""
        return len(self.faces) if self.ids is None else len(self.ids)

    def locate(self, gid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(shape, index within the shape)`` of global triangles ``gid``."""
        part = np.searchsorted(self.start, gid, side="right") - 1
        return self.part_shape[part], gid - self.start[part]

    def corners(self, gid) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(p0, p1, p2)`` of global triangles ``gid`` (float64 world)."""
        f = np.take(self.faces, gid, axis=0)
        v = self.vertices
        return np.take(v, f[:, 0], axis=0), np.take(v, f[:, 1], axis=0), np.take(v, f[:, 2], axis=0)

    def drop_degenerate(self) -> None:
        """Remove the triangles of zero area (``|m|^2 = 0``, ``m = (p1 - p0) x (p2 - p0)``, as
        :class:`Planar` tests it) from the group, in cache-sized blocks."""
        n = self.n_group
        bad = []
        for a in range(0, n, _BLOCK):
            gid = np.arange(a, min(a + _BLOCK, n)) if self.ids is None else self.ids[a:a + _BLOCK]
            p0, e1, e2 = self.corners(gid)
            e1 -= p0
            e2 -= p0
            m2 = np.square(e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1])
            m2 += np.square(e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2])
            m2 += np.square(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
            if not m2.all():
                bad.append(np.flatnonzero(m2 == 0) + a)
        if bad:
            keep = np.ones(n, bool)
            keep[np.concatenate(bad)] = False
            self.ids = (np.flatnonzero(keep) if self.ids is None else self.ids[keep]).astype(self.faces.dtype)

    def group_ids(self) -> np.ndarray:
        return np.arange(len(self.faces)) if self.ids is None else self.ids


def pool_triangles(parts: list, order: np.ndarray | None = None) -> TrianglePool:
    """Pool ``parts``: a list of ``(shape index, vertices (V, 3) world, faces (T, 3), merge)``
    (see the module docstring; ``order``: each part's position among all the scene's parts,
    which orders the parallelograms)."""
    shape = np.array([p[0] for p in parts], np.int64)
    vcount = np.array([len(p[1]) for p in parts], np.int64)
    fcount = np.array([len(p[2]) for p in parts], np.int64)
    itype = np.int32 if vcount.sum() < 2 ** 31 - 1 else np.int64
    vertices = np.concatenate([p[1] for p in parts]).astype(np.float64, copy=False)
    faces = np.concatenate([p[2] for p in parts], dtype=itype, casting="same_kind")
    start = np.concatenate([[0], np.cumsum(fcount)])
    voff = np.concatenate([[0], np.cumsum(vcount)[:-1]]).astype(itype)
    if np.any(voff[1:]):
        faces += np.repeat(voff, fcount)[:, None]
    merge = np.array([bool(p[3]) for p in parts])
    para, para_shape, para_local, para_part = np.zeros((0, 4, 3)), np.zeros(0, np.int64), np.zeros(0, np.int64), \
        np.zeros(0, np.int64)
    ids = None
    if merge.any():
        part_of = np.repeat(np.arange(len(parts)), np.where(merge, fcount, 0))
        m_idx = np.flatnonzero(np.repeat(merge, fcount)) if not merge.all() else np.arange(start[-1])
        tri = vertices[faces[m_idx]]                                   # (Tm, 3, 3)
        tmax = np.abs(tri).max(axis=(1, 2))
        first_of_part = np.flatnonzero(np.r_[True, part_of[1:] != part_of[:-1]])
        tol = 1e-12 * (1.0 + np.maximum.reduceat(tmax, first_of_part))
        tol = np.repeat(tol, np.diff(np.r_[first_of_part, len(part_of)]))[:-1]
        a, b = tri[:-1], tri[1:]
        p0, p1, p2 = a[:, 0], a[:, 1], a[:, 2]

        def near(x, y):
            return np.all(np.abs(x - y) <= tol[:, None], axis=-1)

        fan = near(b[:, 0], p0) & near(b[:, 1], p2)
        rev = near(b[:, 1], p0) & near(b[:, 2], p2)
        y = np.where(fan[:, None], b[:, 2], b[:, 0])
        ok = (fan | rev) & near(y, p0 + p2 - p1) & (part_of[1:] == part_of[:-1])
        first = greedy_pairs(ok)
        if len(first):
            p0, p1, p2 = tri[first, 0], tri[first, 1], tri[first, 2]
            n = unit(np.cross(p1 - p0, p2 - p0))
            para = np.stack([p1, p0 - p1, p2 - p1, n], axis=1)
            gid = m_idx[first]
            para_part = part_of[first]
            para_shape, para_local = shape[para_part], gid - start[para_part]
            keep = np.ones(len(faces), bool)
            keep[gid] = keep[gid + 1] = False
            ids = np.flatnonzero(keep).astype(itype)
    pool = TrianglePool(vertices, faces, start, shape, ids, para, para_shape, para_local,
                        para_part if order is None else np.asarray(order)[para_part])
    return pool


class IndexedPlanar:
    """The pool's triangle group as a planar group traced by Embree (see the module docstring)."""

    para = False

    def __init__(self, pool: TrianglePool):
        self.pool = pool
        self.ids = pool.ids

    def __len__(self) -> int:
        return self.pool.n_group

    def _gid(self, j: np.ndarray) -> np.ndarray:
        return j if self.ids is None else self.ids[j]

    def embree_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """``(vertices (V, 3) float32, indices (T, 3) int32)`` of the group for Embree."""
        f = self.pool.faces if self.ids is None else self.pool.faces[self.ids]
        return self.pool.vertices.astype(np.float32), np.ascontiguousarray(f, dtype=np.int32)

    def hit_info(self, j: np.ndarray, plane: bool):
        """``(v0 and unit plane normal (N, 6) or None, normal (N, 3), shape, index in the shape)``
        of primitives ``j``: as :class:`Planar`'s tables, ``n = m / |m|``, ``normal = unit(m)``,
        ``m = e1 x e2``."""
        gid = self._gid(j)
        p0, p1, p2 = self.pool.corners(gid)
        m = np.cross(p1 - p0, p2 - p0)
        shape, local = self.pool.locate(gid)
        q = None
        if plane:
            q = np.concatenate([p0, m / np.sqrt(np.sum(m * m, -1))[:, None]], axis=1)
        return q, unit(m), shape, local

    def planar(self, dense: bool = False, boxes: dict | None = None) -> Planar:
        """The full :class:`Planar` group of these triangles (per-triangle tables)."""
        gid = self.pool.group_ids()
        p0, p1, p2 = self.pool.corners(gid)
        e1, e2 = p1 - p0, p2 - p0
        shape, local = self.pool.locate(gid)
        return Planar(p0, e1, e2, unit(np.cross(e1, e2)), shape, False, boxes, local, dense=dense)
