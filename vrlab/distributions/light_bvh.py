"""pbrt-v4's light BVH: a discrete distribution over lights conditional on a shading point.

Pharr, Jakob & Humphreys, "Physically Based Rendering", 4th ed. (pbrt-v4), section 12.6.3,
``BVHLightSampler``; our own NumPy (no code copied).  Each light is given by its *light
bounds* (:mod:`vrlab.distributions.light_bounds`): box, cone of normals (theta_o), emission
spread (theta_e), power phi, two-sidedness.  A binary tree over the lights (one light per
leaf; lights with phi = 0 are left out and never selected) stores in each node the union
of its lights' bounds.

**Sampling** ``j ~ P(. | p, n)`` with one uniform u per point: from the root, at each
interior node take the importances I_0, I_1 of the two children at (p, n) (see
``light_bounds.importance``), go to child c with probability P_c = I_c / (I_0 + I_1) and
rescale ``u <- (u - [c = 1] P_0) / P_c`` (kept below 1), so the one uniform drives every
level; at the leaf, ``P(j | p, n) = prod P_c`` along the path.  If both children have
importance 0 (no light below can reach p) the point gets no light (j = -1, pmf 0); so
the pmf sums to 1 over the lights minus the mass of such dead ends.  All points walk down
together, one tree level per NumPy step.  ``pmf(p, n, j)`` walks the same path, read from
each light's stored bit trail (child 0 or 1 at each depth).

**One light**: the root is a leaf.  As pbrt-v4's ``Sample``, it is returned with pmf 1
where its importance is > 0, else no light; pbrt's ``PDF`` returns 1 everywhere, ours
returns the probability ``sample`` realises (0 where the importance is 0), so the two agree.

**Build** (top-down, one NumPy pass per tree level over all nodes of that level): the
binned split of pbrt-v4: the centroids of a node's lights are binned into 12 buckets per
axis; every split between buckets (11 per axis) is scored by the surface area orientation
heuristic ``cost(lights below) + cost(lights above)`` (``light_bounds.split_cost``), bucket
bounds by a segmented tree reduction, below/above unions by a scan over the 12 buckets.
The cheapest split with cost > 0 and both sides non-empty wins.  Unlike pbrt (which splits
the light *list* in the middle, in input order) a node without such a split (coincident
centroids, all-zero costs as for point lights on a line) is split at the median along its
widest centroid axis.  Node bounds are the unions of their children's, bottom-up.

**Lights at infinity** (environment, directional) have no bounds and are not in the tree.
As pbrt-v4, the caller picks one of the ``n_inf`` of them (uniformly) with probability
``p_inf = n_inf / (n_inf + 1)`` (``n_inf / n_inf = 1`` for an empty tree) and the tree with
``1 - p_inf``, remapping u to ``(u - p_inf) / (1 - p_inf)``: see :meth:`LightBVH.infinite_probability`.
"""
from __future__ import annotations

import numpy as np

from .. import checks
from .light_bounds import Bounds, empty_bounds, importance, split_cost, union

__all__ = ["LightBVH"]

N_BUCKETS = 12
_ONE_MINUS_EPS = np.nextafter(1.0, 0.0)


def _segments(key: np.ndarray):
    """``(order, starts, rank)``: a stable sort of ``key``, the first sorted position of
    each run of equal keys and each sorted item's rank within its run."""
    order = np.argsort(key, kind="stable")
    k = key[order]
    new = np.ones(len(k), bool)
    new[1:] = k[1:] != k[:-1]
    starts = np.flatnonzero(new)
    run = np.cumsum(new) - 1
    rank = np.arange(len(k)) - starts[run]
    return order, starts, rank, run


def _segment_union(b: Bounds, key: np.ndarray) -> tuple[np.ndarray, Bounds]:
    """``(keys, unions)``: the union of the records with each distinct ``key``, by a
    pairwise tree reduction (log2 of the longest run of NumPy steps)."""
    order, starts, rank, run = _segments(key)
    acc = b.take(order)
    size = np.diff(np.append(starts, len(order)))[run]
    s = 1
    while s < (size.max() if len(size) else 0):
        i = np.flatnonzero((rank % (2 * s) == 0) & (rank + s < size))
        acc.put(i, union(acc.take(i), acc.take(i + s)))
        s *= 2
    return key[order][starts], acc.take(starts)


def _split_sides(b: Bounds, group: np.ndarray, n_groups: int) -> np.ndarray:
    """For lights ``b`` in nodes ``group`` (0..n_groups-1, each with >= 2 lights): True for
    the lights that go to child 1 (see the module docstring: binned SAOH, median fallback)."""
    G, B = n_groups, N_BUCKETS
    c = (b.lo + b.hi) / 2
    cmin = np.full((G, 3), np.inf)
    cmax = np.full((G, 3), -np.inf)
    np.minimum.at(cmin, group, c)
    np.maximum.at(cmax, group, c)
    bmin = np.full((G, 3), np.inf)
    bmax = np.full((G, 3), -np.inf)
    np.minimum.at(bmin, group, b.lo)
    np.maximum.at(bmax, group, b.hi)
    ext = cmax - cmin
    with np.errstate(invalid="ignore", divide="ignore"):
        bucket = np.minimum((B * (c - cmin[group]) / ext[group]).astype(np.int64, copy=False), B - 1)
    bucket = np.where(ext[group] > 0, np.clip(bucket, 0, B - 1), 0)              # (K, 3)
    # bucket bounds for every (axis, node, bucket) at once
    K = len(group)
    key = ((np.arange(3)[:, None] * G + group[None, :]) * B + bucket.T).ravel()
    keys, ub = _segment_union(b.take(np.tile(np.arange(K), 3)), key)
    buckets = empty_bounds(3 * G * B)
    buckets.put(keys, ub)
    buckets = Bounds(*(f.reshape((3 * G, B) + f.shape[1:]) for f in buckets))
    col = lambda i: Bounds(*(f[:, i] for f in buckets))               # noqa: E731
    below = [col(0)]
    for i in range(1, B - 1):
        below.append(union(below[-1], col(i)))
    above = [col(B - 1)]
    for i in range(B - 2, 0, -1):
        above.append(union(above[-1], col(i)))
    above = above[::-1]                                   # above[i]: buckets i+1 .. B-1
    diag = bmax - bmin                                    # (G, 3)
    with np.errstate(divide="ignore", invalid="ignore"):
        kr = (diag.max(axis=1)[None, :] / diag.T).ravel()  # (3 G,)
    cost = np.empty((3 * G, B - 1))
    for i in range(B - 1):
        lo_, hi_ = below[i], above[i]
        ok = (lo_.phi > 0) & (hi_.phi > 0)
        with np.errstate(invalid="ignore"):
            cost[:, i] = np.where(ok, split_cost(lo_, kr) + split_cost(hi_, kr), np.inf)
    cost = np.where(np.isfinite(cost) & (cost > 0) & (ext.T.ravel() > 0)[:, None], cost, np.inf)
    cost = cost.reshape(3, G, B - 1).transpose(1, 0, 2).reshape(G, -1)
    best = np.argmin(cost, axis=1)
    sah = np.isfinite(cost[np.arange(G), best])
    axis, at = best // (B - 1), best % (B - 1)
    side = bucket[np.arange(K), axis[group]] > at[group]
    # median along the widest centroid axis where no split scored
    med = ~sah[group]
    if med.any():
        wide = np.argmax(ext, axis=1)
        coord = c[np.arange(K), wide[group]]
        order = np.lexsort((np.arange(K), coord, group))
        _, _, rank, _ = _segments(group[order])
        count = np.bincount(group, minlength=G)
        upper = np.empty(K, bool)
        upper[order] = rank >= count[group[order]] // 2
        side = np.where(med, upper, side)
    return side


def _rescale(u: np.ndarray, p0: np.ndarray, right: np.ndarray) -> np.ndarray:
    """The uniform left after choosing child 0 (u < p0) or 1: (u - [right] p0) / P_c, below 1."""
    pc = np.where(right, 1.0 - p0, p0)
    return np.minimum(np.where(right, u - p0, u) / np.where(pc > 0, pc, 1.0), _ONE_MINUS_EPS)


class LightBVH:
    """pbrt-v4's light BVH over ``L`` lights (see the module docstring).

    ``lo, hi (L, 3)``: each light's box; ``w (L, 3)``: its principal emission direction
    (normalised here); ``cos_theta_o, cos_theta_e (L,)`` in [-1, 1]; ``phi (L,)`` >= 0 the
    power; ``two_sided (L,)`` bool (default all False).  Attributes: ``nodes`` (a
    ``light_bounds.Bounds`` with one row per node, root 0), ``children (M, 2)`` (-1 at
    leaves), ``light (M,)`` (the leaf's light, -1 inside), ``leaf (L,)`` (each light's
    node, -1 if phi = 0), ``depth (L,)`` and ``trail (L, D)`` (child taken at each depth).
    """

    def __init__(self, lo, hi, w, cos_theta_o, cos_theta_e, phi, two_sided=None):
        lo = checks.finite_array(lo, "lo", ndim=2, last=3)
        L = len(lo)
        hi = _rows(hi, "hi", L, 3)
        w = _rows(w, "w", L, 3)
        cos_o, cos_e, phi = (_rows(v, name, L) for v, name in
                             ((cos_theta_o, "cos_theta_o"), (cos_theta_e, "cos_theta_e"), (phi, "phi")))
        if np.any(hi < lo):
            i = int(np.argwhere(hi < lo)[0, 0])
            raise ValueError(f"hi must be >= lo in every coordinate; light {i} has lo {lo[i]}, hi {hi[i]}")
        length = np.linalg.norm(w, axis=1)
        if np.any(length < 1e-12):
            raise ValueError(f"w: light {int(np.argmax(length < 1e-12))} has a zero direction; w must be unit "
                             "vectors (any direction for lights emitting all around)")
        for v, name in ((cos_o, "cos_theta_o"), (cos_e, "cos_theta_e")):
            if np.any(np.abs(v) > 1):
                raise ValueError(f"{name} must lie in [-1, 1], got {v[np.abs(v) > 1][0]}")
        if np.any(phi < 0):
            raise ValueError(f"phi must be >= 0 (a power), got {phi[phi < 0][0]}")
        if two_sided is None:
            two = np.zeros(L, bool)
        else:
            two = np.asarray(two_sided)
            if two.dtype != bool or two.shape != (L,):
                raise TypeError(f"two_sided must be a boolean array of shape ({L},), got "
                                f"{checks.describe(two_sided)} of dtype {two.dtype} and shape {two.shape}")
        self.n_lights = L
        self.bounds = Bounds(lo, hi, w / length[:, None], cos_o, cos_e, phi, two)
        scene = np.concatenate([lo, hi]) if L else np.zeros((1, 3))
        self.floor2 = float(max((1e-12 * np.linalg.norm(scene.max(0) - scene.min(0))) ** 2, 1e-300))
        self._build(np.flatnonzero(phi > 0))

    def _build(self, ids: np.ndarray) -> None:
        L = self.n_lights
        self.leaf, self.depth = np.full(L, -1), np.zeros(L, np.int64)
        trails = []
        node_of = np.zeros(len(ids), np.int64)             # every light starts at the root
        children, lights, count = [], [], 1
        level_nodes = [np.zeros(1, np.int64)]
        b = self.bounds.take(ids)
        while len(ids):
            nodes, first, sizes = np.unique(node_of, return_index=True, return_counts=True)
            done = sizes[np.searchsorted(nodes, node_of)] == 1
            leaf_nodes = node_of[done]
            self.leaf[ids[done]] = leaf_nodes
            lights.append(np.column_stack([leaf_nodes, ids[done]]))
            ids, node_of, b = ids[~done], node_of[~done], b.take(~done)
            if not len(ids):
                break
            split, group = np.unique(node_of, return_inverse=True)
            side = _split_sides(b, group, len(split))
            kids = count + 2 * np.arange(len(split))
            children.append(np.column_stack([split, kids, kids + 1]))
            count += 2 * len(split)
            node_of = kids[group] + side
            trails.append(np.column_stack([ids, side]))
            level_nodes.append(np.concatenate([kids, kids + 1]))
        self._assemble(count, children, lights, trails, level_nodes)

    def _assemble(self, count, children, lights, trails, level_nodes) -> None:
        self.children = np.full((count, 2), -1)
        for c in children:
            self.children[c[:, 0]] = c[:, 1:]
        self.light = np.full(count, -1)
        for pairs in lights:
            self.light[pairs[:, 0]] = pairs[:, 1]
        self.trail = np.zeros((self.n_lights, max(len(trails), 1)), bool)
        for d, t in enumerate(trails):
            self.trail[t[:, 0], d] = t[:, 1]
            self.depth[t[:, 0]] += 1
        self.nodes = empty_bounds(count)
        is_leaf = self.light >= 0
        self.nodes.put(np.flatnonzero(is_leaf), self.bounds.take(self.light[is_leaf]))
        for level in reversed(level_nodes):            # children before parents
            inner = level[self.children[level, 0] >= 0]
            if len(inner):
                c = self.children[inner]
                self.nodes.put(inner, union(self.nodes.take(c[:, 0]), self.nodes.take(c[:, 1])))
        self.empty = not is_leaf.any()

    # -- queries -----------------------------------------------------------------------------
    def infinite_probability(self, n_infinite) -> float:
        """pbrt-v4's probability of picking a light at infinity: n_inf / (n_inf + 1), or 1
        (given any) when the tree is empty; 0 without lights at infinity."""
        k = checks.integer(n_infinite, "n_infinite", low=0)
        return k / (k + (0 if self.empty else 1)) if k else 0.0

    def importance(self, p, n=None) -> np.ndarray:
        """``(N, L)``: every light's own importance at the points (pbrt's exhaustive sampler
        weighs lights by these; 0 for lights with phi = 0)."""
        p, n = self._points(p, n)
        N, L = len(p), self.n_lights
        rows = np.repeat(np.arange(N), L)
        return importance(self.bounds.take(np.tile(np.arange(L), N)), p[rows], n[rows],
                          self.floor2).reshape(N, L)

    def sample(self, p, n, u) -> tuple[np.ndarray, np.ndarray]:
        """``(j, pmf)``: a light index per point (-1: none can reach it) and P(j | p, n)."""
        p, n = self._points(p, n)
        u = checks.finite_array(u, "u", ndim=1)
        if len(u) != len(p):
            raise ValueError(f"u must have one uniform per point: shape ({len(p)},), got {u.shape}")
        if np.any((u < 0) | (u >= 1)):
            raise ValueError(f"u: uniforms must lie in [0, 1), got {u[(u < 0) | (u >= 1)][0]}")
        N = len(p)
        j, pmf = np.full(N, -1), np.zeros(N)
        if self.empty or N == 0:
            return j, pmf
        if self.light[0] >= 0:                           # a single light: the root is a leaf
            ok = importance(self.nodes.take(np.zeros(N, np.int64)), p, n, self.floor2) > 0
            return np.where(ok, self.light[0], -1), ok.astype(float)
        rows, node, u, prob = np.arange(N), np.zeros(N, np.int64), u.astype(float), np.ones(N)
        while len(rows):
            c = self.children[node]
            imp = importance(self.nodes.take(c.T.ravel()), np.tile(p[rows], (2, 1)), np.tile(n[rows], (2, 1)),
                             self.floor2).reshape(2, -1)
            total = imp[0] + imp[1]
            alive = total > 0
            p0 = np.where(alive, imp[0] / np.where(alive, total, 1.0), 0.0)
            right = u >= p0
            pc = np.where(right, 1.0 - p0, p0)
            u = _rescale(u, p0, right)
            prob = prob * pc
            node = c[np.arange(len(rows)), right.astype(np.int64)]
            leaf = alive & (self.light[node] >= 0)
            j[rows[leaf]], pmf[rows[leaf]] = self.light[node[leaf]], prob[leaf]
            keep = alive & ~leaf
            rows, node, u, prob = rows[keep], node[keep], u[keep], prob[keep]
        return j, pmf

    def pmf(self, p, n, j) -> np.ndarray:
        """P(j | p, n) per point for light indices ``j (N,)`` (-1 or a light with phi = 0:
        0), the probability that :meth:`sample` returns j there."""
        p, n = self._points(p, n)
        j = np.asarray(j)
        if j.shape != (len(p),) or not (np.issubdtype(j.dtype, np.integer) or len(j) == 0):
            raise ValueError(f"j must be an integer array of shape ({len(p)},), got {checks.describe(j)}")
        j = j.astype(np.int64)
        if np.any((j < -1) | (j >= self.n_lights)):
            bad = j[(j < -1) | (j >= self.n_lights)][0]
            raise ValueError(f"j must be a light index in [-1, {self.n_lights - 1}], got {bad}")
        out = np.zeros(len(p))
        has = j >= 0
        has[has] = self.leaf[j[has]] >= 0
        rows = np.flatnonzero(has)
        if self.light[0] >= 0 and len(rows):              # a single light
            out[rows] = importance(self.nodes.take(np.zeros(len(rows), np.int64)), p[rows], n[rows], self.floor2) > 0
            return out
        jj, node, prob, d = j[rows], np.zeros(len(rows), np.int64), np.ones(len(rows)), 0
        while len(rows):
            c = self.children[node]
            imp = importance(self.nodes.take(c.T.ravel()), np.tile(p[rows], (2, 1)), np.tile(n[rows], (2, 1)),
                             self.floor2).reshape(2, -1)
            total = imp[0] + imp[1]
            bit = self.trail[jj, d]
            mine = np.where(bit, imp[1], imp[0])
            alive = total > 0
            p0 = np.where(alive, imp[0] / np.where(alive, total, 1.0), 0.0)
            prob = prob * np.where(bit, 1.0 - p0, p0) * (mine > 0)
            node = c[np.arange(len(rows)), bit.astype(np.int64)]
            d += 1
            leaf = self.light[node] >= 0
            out[rows[leaf]] = prob[leaf]
            keep = ~leaf & (prob > 0)
            rows, jj, node, prob = rows[keep], jj[keep], node[keep], prob[keep]
        return out

    def _points(self, p, n):
        p = checks.finite_array(p, "p", ndim=2, last=3)
        if n is None:
            return p, np.zeros_like(p)
        n = checks.finite_array(n, "n", ndim=2, last=3)
        if n.shape != p.shape:
            raise ValueError(f"n must have the shape of p, {p.shape}, got {n.shape}")
        length = np.linalg.norm(n, axis=1)
        return p, n / np.where(length > 0, length, 1.0)[:, None]


def _rows(value, name: str, L: int, last: int | None = None) -> np.ndarray:
    a = checks.finite_array(value, name, ndim=1 if last is None else 2, last=last)
    if len(a) != L:
        raise ValueError(f"{name} must have one row per light ({L}, as lo), got shape {a.shape}")
    return a
