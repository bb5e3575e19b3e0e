"""A bounding-volume hierarchy of axis-aligned boxes, built and traversed with NumPy.

**Build** (top down, one level of the tree at a time, every node of the level in one
vectorised pass; 10^6 primitives in seconds): a node's primitives are put into ``BINS``
bins of their centroids along each axis, and the split between bins with the smallest
surface area heuristic cost

    C(split) = N_left A(left) + N_right A(right)   (in units of the node's traversal cost)

wins (MacDonald & Booth 1990, "Heuristics for ray tracing using space subdivision"; binned
as Wald 2007, "On fast construction of SAH-based bounding volume hierarchies").  A node
becomes a leaf when it holds at most ``leaf_size`` primitives, or at most ``MAX_LEAF`` and
no split is cheaper than testing them all (C >= N A(node)); nodes whose centroids
coincide are split at their median.

**Traversal** (Kay & Kajiya 1986's slab test for the boxes): every ray keeps its own stack
of nodes and all active rays advance one node per step, so each step is a few vectorised
operations over the rays still running.  Inner nodes push the farther child first (the
nearer one is visited first: depth first, front to back), and a node whose box starts
beyond the closest hit found so far is skipped, so a ray visits O(log P) nodes.
``occluded`` stops a ray at its first hit before ``t_max`` (shadow rays: any hit).
Leaves call a primitive test ``test(i, j) -> t`` on (ray, primitive) pairs, which the
caller supplies for its primitives (triangles, parallelograms, quadrics, disks).
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["BINS", "BVH", "LEAF_SIZE", "MAX_LEAF", "SAH_MIN"]

LEAF_SIZE = 4      # nodes with at most this many primitives are leaves
MAX_LEAF = 16      # ... and up to this many when no split pays (SAH)
BINS = 12          # centroid bins per axis for the SAH
SAH_MIN = 32       # nodes with more primitives are split by the SAH, smaller ones at their median


def _area(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Half the surface area of boxes ``(..., 3)`` (empty boxes, lo > hi: 0)."""
    e = np.maximum(hi - lo, 0.0)
    return e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0]


class BVH:
    """BVH over primitives given by their vertices ``(P, V, 3)`` (or, with
    :meth:`from_boxes`, by their bounding boxes).  ``sah_min``: nodes with more primitives
    are split by the SAH, smaller ones at their median (0: the SAH everywhere, which the
    compiled walk of :mod:`.traverse_kernel` prefers: fewer nodes and primitives per ray)."""

    def __init__(self, verts: np.ndarray, leaf_size: int = LEAF_SIZE, sah_min: int = SAH_MIN):
        verts = np.asarray(verts, float)
        self.sah_min = int(sah_min)
        self._build(verts.min(1), verts.max(1), leaf_size)

    @classmethod
    def from_boxes(cls, lo: np.ndarray, hi: np.ndarray, leaf_size: int = LEAF_SIZE, sah_min: int = SAH_MIN) -> "BVH":
        """A BVH over primitives with bounding boxes ``lo, hi (P, 3)``."""
        out = cls.__new__(cls)
        out.sah_min = int(sah_min)
        out._build(np.asarray(lo, float), np.asarray(hi, float), leaf_size)
        return out

    def _build(self, plo: np.ndarray, phi: np.ndarray, leaf_size: int) -> None:
        P = len(plo)
        cen = 0.5 * (plo + phi)
        finite = np.isfinite(np.concatenate([plo, phi], 1)).all(1)
        if not finite.all():                                   # never hit: box far out of reach
            plo, phi, cen = plo.copy(), phi.copy(), cen.copy()
            plo[~finite], phi[~finite], cen[~finite] = np.inf, -np.inf, 0.0
        pad = 1e-9 * (1.0 + np.max(np.abs(np.where(finite[:, None], plo, 0.0)), initial=0.0)
                      + np.max(np.abs(np.where(finite[:, None], phi, 0.0)), initial=0.0))
        order = np.arange(P)
        lo, hi, start, count, left, right = [], [], [], [], [], []
        # segments [b, e) of ``order``, one per node of the level; ids follow append order
        b, e, n_nodes = np.array([0]), np.array([P]), 1
        while len(b):
            size = e - b
            offs = np.concatenate([[0], np.cumsum(size)[:-1]])
            seg = np.repeat(np.arange(len(b)), size)
            pos = np.repeat(b - offs, size) + np.arange(size.sum())          # positions in ``order``
            idx = order[pos]
            nlo = np.minimum.reduceat(plo[idx], offs) if P else np.zeros((1, 3))
            nhi = np.maximum.reduceat(phi[idx], offs) if P else np.zeros((1, 3))
            lo.append(nlo - pad)
            hi.append(nhi + pad)
            split, partition = self._splits(cen[idx], plo[idx], phi[idx], seg, offs, size, nlo, nhi, leaf_size)
            inner = split >= 0                 # split: the number of primitives going left
            # reorder each inner node's primitives: left ones first (stable)
            k_in = np.flatnonzero(inner)
            kid = n_nodes + 2 * np.arange(len(k_in))
            lft, rgt = np.full(len(b), -1), np.full(len(b), -1)
            lft[k_in], rgt[k_in] = kid, kid + 1
            start.append(b)
            count.append(np.where(inner, 0, size))
            left.append(lft)
            right.append(rgt)
            if len(k_in):
                order[pos] = idx[partition]
            mid = b[k_in] + split[k_in]
            b = np.stack([b[k_in], mid], 1).reshape(-1)
            e = np.stack([mid, e[k_in]], 1).reshape(-1)
            n_nodes += 2 * len(k_in)
        self.lo, self.hi = np.concatenate(lo), np.concatenate(hi)
        self.box = np.concatenate([self.lo, self.hi], axis=1)
        self.start, self.count = np.concatenate(start), np.concatenate(count)
        self.order = order
        self.left, self.right = np.concatenate(left), np.concatenate(right)
        self.depth = len(lo)

    def _splits(self, cen, plo, phi, seg, offs, size, nlo, nhi, leaf_size) -> tuple[np.ndarray, np.ndarray]:
        """``(split, partition)``: per node of a level, the number of its primitives that go
        left (-1: a leaf), and the permutation of the level's primitives that puts each inner
        node's left ones first: binned SAH over the three axes for nodes of more than
        ``sah_min`` primitives, the median along the widest centroid axis below that (and
        where every centroid falls into one bin)."""
        S, n = len(size), len(seg)
        cmin = np.minimum.reduceat(cen, offs) if n else np.zeros((S, 3))
        cmax = np.maximum.reduceat(cen, offs) if n else np.zeros((S, 3))
        ext = cmax - cmin
        leaf = size <= max(leaf_size, 1)
        sah = ~leaf & (size > self.sah_min)
        median = ~leaf & ~sah
        goes_right = np.zeros(n, bool)
        if sah.any():
            nodes = np.flatnonzero(sah)
            rows = np.flatnonzero(sah[seg])
            cost, axis, cut, binned = self._sah(cen[rows], plo[rows], phi[rows], np.searchsorted(nodes, seg[rows]),
                                                cmin[nodes], ext[nodes], size[nodes])
            no_split = ~np.isfinite(cost)                  # every centroid in one bin: median
            pays = cost < size[nodes] * _area(nlo[nodes], nhi[nodes])
            leaf[nodes] = ~no_split & ~pays & (size[nodes] <= MAX_LEAF)
            median[nodes[no_split]] = True
            local = np.searchsorted(nodes, seg[rows])
            goes_right[rows] = binned[np.arange(len(rows)), axis[local]] > cut[local]
        med_rows = np.flatnonzero(median[seg])
        if len(med_rows):                      # rank along the widest centroid axis
            ms = seg[med_rows]
            key = cen[med_rows, np.argmax(ext, 1)[ms]]
            s = np.lexsort((key, ms))
            rank = np.empty(len(med_rows), np.int64)
            rank[s] = np.arange(len(med_rows))
            rank -= np.searchsorted(ms[s], ms, side="left")      # position within its node
            goes_right[med_rows] = rank >= size[ms] // 2
        n_left = np.bincount(seg, weights=~goes_right, minlength=S).astype(np.int64)
        return np.where(leaf, -1, n_left), np.lexsort((goes_right, seg))

    @staticmethod
    def _sah(cen, plo, phi, seg, cmin, ext, size):
        """Binned SAH of nodes ``(S,)`` with primitives ``seg``: ``(cost, axis, cut, bins)``,
        the best split (left = bins <= cut) per node and every primitive's bin per axis."""
        S = len(size)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = np.where(ext > 0, BINS / ext, 0.0)
        binned = np.clip(((cen - cmin[seg]) * inv[seg]).astype(np.int64), 0, BINS - 1)     # (n, 3)
        best_cost, best_axis, best_cut = np.full(S, np.inf), np.zeros(S, np.int64), np.zeros(S, np.int64)
        for a in range(3):
            key = seg * BINS + binned[:, a]
            cnt = np.bincount(key, minlength=S * BINS).reshape(S, BINS)
            blo, bhi = np.empty((S, BINS, 3)), np.empty((S, BINS, 3))
            for c in range(3):                             # 1-d ufunc.at: 4x faster than 2-d
                col = np.full(S * BINS, np.inf)
                np.minimum.at(col, key, np.ascontiguousarray(plo[:, c]))
                blo[..., c] = col.reshape(S, BINS)
                col = np.full(S * BINS, -np.inf)
                np.maximum.at(col, key, np.ascontiguousarray(phi[:, c]))
                bhi[..., c] = col.reshape(S, BINS)
            l_cnt = np.cumsum(cnt, 1)[:, :-1]             # split after bin k = 0 .. BINS - 2
            r_cnt = size[:, None] - l_cnt
            l_area = _area(np.minimum.accumulate(blo, 1), np.maximum.accumulate(bhi, 1))[:, :-1]
            r_area = _area(np.minimum.accumulate(blo[:, ::-1], 1)[:, ::-1],
                           np.maximum.accumulate(bhi[:, ::-1], 1)[:, ::-1])[:, 1:]
            cost = l_cnt * l_area + r_cnt * r_area
            cost[(l_cnt == 0) | (r_cnt == 0)] = np.inf
            k = np.argmin(cost, 1)
            c_best = cost[np.arange(S), k]
            better = c_best < best_cost
            best_cost[better], best_axis[better], best_cut[better] = c_best[better], a, k[better]
        return best_cost, best_axis, best_cut, binned

    # ------------------------------------------------------------------ traversal
    def _slab(self, o: np.ndarray, inv: np.ndarray, node: np.ndarray, t_min: float, tb: np.ndarray):
        """Entry distance of rays ``(o, 1/d)`` into the boxes of ``node``, inf where the ray
        misses the box within (``t_min``, ``tb``)."""
        box = self.box[node]
        with np.errstate(invalid="ignore"):
            t0 = (box[:, :3] - o) * inv
            t1 = (box[:, 3:] - o) * inv
        lo, hi = np.fmin(t0, t1), np.fmax(t0, t1)
        near = np.fmax(np.fmax(lo[:, 0], lo[:, 1]), lo[:, 2])
        far = np.fmin(np.fmin(hi[:, 0], hi[:, 1]), hi[:, 2])
        ok = (near <= far) & (far > t_min) & (near < tb)
        return np.where(ok, near, np.inf)

    def _walk(self, o: np.ndarray, d: np.ndarray, t_min: float, t_far: np.ndarray, test: Callable, any_hit: bool):
        """Depth-first traversal of every ray with its own stack of (node, entry distance):
        a popped node whose box starts beyond the closest hit so far is skipped; an inner
        node's children are slab-tested together and pushed farther first.  ``t_far`` (not
        modified) bounds the hits.  Returns ``(i, j, t, tb)`` of the improving hits found
        (closest) or, with ``any_hit``, a mask of the rays with a hit before ``t_far``."""
        n = len(o)
        inv = np.empty((n, 3))
        with np.errstate(divide="ignore"):
            np.divide(1.0, d, out=inv)
        tb = np.array(t_far, float, copy=True)
        hit_any = np.zeros(n, bool)
        depth = self.depth + 2
        stack = np.zeros((n, depth), np.int64)
        stack_t = np.zeros((n, depth))
        stack_t[:, 0] = self._slab(o, inv, np.zeros(n, np.int64), t_min, tb)
        sp = np.ones(n, np.int64)                    # the root (0) on every stack
        ray = np.flatnonzero(stack_t[:, 0] < np.inf)
        found_i, found_j, found_t = [], [], []
        while len(ray):
            top = sp[ray] - 1
            sp[ray] = top
            node, near = stack[ray, top], stack_t[ray, top]
            ok = near < tb[ray]
            cnt = self.count[node]
            leaf = ok & (cnt > 0)
            if leaf.any():
                lr, ln, lc = ray[leaf], node[leaf], cnt[leaf]
                ri = np.repeat(lr, lc)
                first = np.repeat(np.cumsum(lc) - lc, lc)
                pj = self.order[np.repeat(self.start[ln], lc) + np.arange(len(ri)) - first]
                tt = test(ri, pj)
                # closest: ties with the best so far are kept (the lowest primitive wins them)
                hit = tt < tb[ri] if any_hit else (tt <= tb[ri]) & (tt < np.inf)
                if hit.any():
                    ri, pj, tt = ri[hit], pj[hit], tt[hit]
                    if any_hit:
                        hit_any[ri] = True
                        tb[ri] = -np.inf                 # done: nothing more to look for
                    else:
                        np.minimum.at(tb, ri, tt)
                        found_i.append(ri)
                        found_j.append(pj)
                        found_t.append(tt)
            inner = ok & (cnt == 0)
            if inner.any():
                ir_, nd = ray[inner], node[inner]
                oi, ii, ti = o[ir_], inv[ir_], tb[ir_]
                lc, rc = self.left[nd], self.right[nd]
                tl, tr = self._slab(oi, ii, lc, t_min, ti), self._slab(oi, ii, rc, t_min, ti)
                swap = tr < tl                                   # the nearer child on top
                near_c, far_c = np.where(swap, rc, lc), np.where(swap, lc, rc)
                near_t, far_t = np.minimum(tl, tr), np.maximum(tl, tr)
                s = sp[ir_]
                push_far = far_t < np.inf
                stack[ir_, s], stack_t[ir_, s] = far_c, far_t     # overwritten below if not pushed
                s = s + push_far
                stack[ir_, s], stack_t[ir_, s] = near_c, near_t
                sp[ir_] = s + (near_t < np.inf)
            ray = ray[(sp[ray] > 0) & (tb[ray] > -np.inf)]
        if any_hit:
            return hit_any
        cat = (lambda parts, dt: np.concatenate(parts) if parts else np.zeros(0, dt))      # noqa: E731
        return cat(found_i, np.int64), cat(found_j, np.int64), cat(found_t, float), tb

    def closest(self, o: np.ndarray, d: np.ndarray, t_min: float, t_best: np.ndarray,
                test: Callable[[np.ndarray, np.ndarray], np.ndarray]):
        """Closest hits of rays ``o + t d`` with ``t_min < t < t_best`` (not modified):
        ``test(i, j)`` gives the exact t (inf on a miss) of ray i and primitive j.
        Returns ``(i, j, t)``: one improving hit per ray, ``i`` ascending (among equal t the
        lowest primitive)."""
        i, j, t, tb = self._walk(o, d, t_min, t_best, test, any_hit=False)
        keep = t == tb[i]
        i, j, t = i[keep], j[keep], t[keep]
        s = np.lexsort((j, i))
        i, j, t = i[s], j[s], t[s]
        first = np.ones(len(i), bool)
        np.not_equal(i[1:], i[:-1], out=first[1:])
        return i[first], j[first], t[first]

    def occluded(self, o: np.ndarray, d: np.ndarray, t_min: float, t_max: np.ndarray,
                 test: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> np.ndarray:
        """Whether each ray ``o + t d`` hits some primitive with ``t_min < t < t_max`` (any
        hit: a ray stops at the first one found)."""
        return self._walk(o, d, t_min, t_max, test, any_hit=True)
