"""A bounding-volume hierarchy of axis-aligned boxes, traversed as a wavefront.

Built top-down by splitting the primitives at the median centroid along the widest
axis; nodes are tested with the slab test (Kay & Kajiya 1986, "Ray tracing complex
scenes").  Traversal keeps an array of (ray, node) pairs and advances all of them one
level per step, so the work is NumPy-vectorised over rays and nodes; pairs whose box
lies beyond the closest hit found so far are dropped.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["BVH"]

LEAF_SIZE = 4


class BVH:
    """BVH over primitives given by their vertices ``(P, V, 3)``."""

    def __init__(self, verts: np.ndarray, leaf_size: int = LEAF_SIZE):
        verts = np.asarray(verts, float)
        plo, phi = verts.min(1), verts.max(1)
        cen = 0.5 * (plo + phi)
        pad = 1e-9 * (1.0 + np.max(np.abs(verts), initial=0.0))
        order = np.arange(len(verts))
        lo, hi, left, start, count = [], [], [], [], []
        stack = [(0, len(verts))]              # depth first: a left child follows its parent
        while stack:
            b, e = stack.pop()
            k = len(lo)
            idx = order[b:e]
            lo.append(plo[idx].min(0) - pad)
            hi.append(phi[idx].max(0) + pad)
            if e - b <= leaf_size:
                left.append(-1)
                start.append(b)
                count.append(e - b)
                continue
            left.append(k + 1)
            start.append(b)
            count.append(0)
            c = cen[idx]
            axis = int(np.argmax(c.max(0) - c.min(0)))
            mid = (e - b) // 2
            order[b:e] = idx[np.argpartition(c[:, axis], mid)]
            stack.append((b + mid, e))             # right subtree after the left one
            stack.append((b, b + mid))
        self.lo, self.hi = np.array(lo), np.array(hi)
        self.box = np.concatenate([self.lo, self.hi], axis=1)
        self.start, self.count = np.array(start), np.array(count)
        self.order = order
        self.left = np.array(left)
        self.right = self._rights()

    def _rights(self) -> np.ndarray:
        """Right children: depth-first order puts a node's right subtree after its left."""
        n = len(self.lo)
        right = np.full(n, -1)
        size = np.ones(n, int)
        for k in range(n - 1, -1, -1):           # subtree sizes, children after parents
            if self.count[k] == 0:
                right[k] = self.left[k] + size[self.left[k]]
                size[k] = 1 + size[self.left[k]] + size[right[k]]
        return right

    def closest(self, o: np.ndarray, d: np.ndarray, t_min: float, t_best: np.ndarray,
                test: Callable[[np.ndarray, np.ndarray], np.ndarray]):
        """Closest hits of rays ``o + t d`` with ``t_min < t < t_best`` (not modified):
        ``test(i, j)`` gives the exact t (inf on a miss) of ray i and primitive j.
        Returns ``(i, j, t)``: one improving hit per ray, ``i`` ascending."""
        oi = np.empty((len(o), 6))                   # [o, 1 / d]
        oi[:, :3] = o
        with np.errstate(divide="ignore"):
            np.divide(1.0, d, out=oi[:, 3:])
        tb = t_best.copy()
        ray = np.arange(len(o))
        node = np.zeros(len(o), int)
        found_i, found_j, found_t = [], [], []
        while len(ray):
            r, box = oi[ray], self.box[node]
            with np.errstate(invalid="ignore"):
                t0 = (box[:, :3] - r[:, :3]) * r[:, 3:]
                t1 = (box[:, 3:] - r[:, :3]) * r[:, 3:]
            lo, hi = np.fmin(t0, t1), np.fmax(t0, t1)
            near = np.fmax(np.fmax(lo[:, 0], lo[:, 1]), lo[:, 2])
            far = np.fmin(np.fmin(hi[:, 0], hi[:, 1]), hi[:, 2])
            ok = (near <= far) & (far > t_min) & (near <= tb[ray])
            ray, node = ray[ok], node[ok]
            leaf = self.count[node] > 0
            if leaf.any():
                lr, ln = ray[leaf], node[leaf]
                cnt = self.count[ln]
                ri = np.repeat(lr, cnt)
                first = np.repeat(np.cumsum(cnt) - cnt, cnt)
                pj = self.order[np.repeat(self.start[ln], cnt) + np.arange(len(ri)) - first]
                tt = test(ri, pj)
                hit = tt < tb[ri]
                ri, pj, tt = ri[hit], pj[hit], tt[hit]
                np.minimum.at(tb, ri, tt)
                found_i.append(ri)
                found_j.append(pj)
                found_t.append(tt)
            inner = ~leaf
            ray = np.concatenate([ray[inner], ray[inner]])
            node = np.concatenate([self.left[node[inner]], self.right[node[inner]]])
        if not found_i:
            return np.zeros(0, int), np.zeros(0, int), np.zeros(0)
        i, j, t = np.concatenate(found_i), np.concatenate(found_j), np.concatenate(found_t)
        keep = t == tb[i]
        i, j, t = i[keep], j[keep], t[keep]
        s = np.lexsort((j, i))
        i, j, t = i[s], j[s], t[s]
        first = np.ones(len(i), bool)
        np.not_equal(i[1:], i[:-1], out=first[1:])
        return i[first], j[first], t[first]
