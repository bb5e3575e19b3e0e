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
each light's stored bit trail (child 0 or 1 at each depth).  Both read the children's
prepared bounds (``light_bounds.prepare``: centre, radius, sines, one table row per node) with
``light_bounds.importance_prepared``, the same operations as ``importance``; consecutive
rows at the same point (RIS candidates) are walked in order of u and share the importances
of the nodes they pass together, with unchanged values.  The build is in ``light_bvh_build``.

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

**Kernels**: ``kernels="numba"`` walks each point down in one compiled serial loop
(:mod:`vrlab.distributions.light_bvh_kernel`, the same operations per point, so the same
lights and probabilities); "numpy" (the default for now) is the walk above, the reference;
"auto" is numba where it can be imported (see :mod:`vrlab.kernels`).
"""
from __future__ import annotations

import numpy as np

from .. import checks
from .._vec import dot
from ..kernels import load_kernel, resolve_kernels
from .light_bounds import Bounds, Prepared, empty_bounds, importance, importance_prepared, prepare, union
from .light_bvh_build import split_sides

__all__ = ["LightBVH"]

_ONE_MINUS_EPS = np.nextafter(1.0, 0.0)


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
    ``kernels``: "numpy" (default), "numba" or "auto", the walk of ``sample`` and ``pmf``
    (resolved here; attribute ``kernels`` is "numpy" or "numba").
    """

    def __init__(self, lo, hi, w, cos_theta_o, cos_theta_e, phi, two_sided=None, *, kernels="numpy"):
        self.kernels = resolve_kernels(kernels)
        self._ktree = None
        lo = checks.finite_array(lo, "lo", ndim=2, last=3)
        L = len(lo)
        hi = _rows(hi, "hi", L, 3)
        w = _rows(w, "w", L, 3)
        cos_o, cos_e, phi = (_rows(v, name, L) for v, name in
                             ((cos_theta_o, "cos_theta_o"), (cos_theta_e, "cos_theta_e"), (phi, "phi")))
        for v, name in ((lo, "lo"), (hi, "hi")):
            _coordinates(v, name)
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
            side = split_sides(b, group, len(split))
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
        with np.errstate(invalid="ignore"):              # an empty tree's root: an inverted box
            t = prepare(self.nodes)
        #: per node, what the walk reads (rows pc, w, r2, cos_o, sin_o, cos_e, phi; see ``light_bounds.prepare``)
        self._table = np.concatenate([t.pc, t.w, np.stack([t.r2, t.cos_o, t.sin_o, t.cos_e, t.phi])])
        self._two = t.two
        self._first = np.ascontiguousarray(self.children[:, 0])
        D = self.trail.shape[1]
        #: each light's leaf position from the left (tree order; None for trees deeper than 62)
        self._inorder = (self.trail.astype(np.int64) << np.arange(D - 1, -1, -1)).sum(1) if D <= 62 else None

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
        if self.kernels == "numba":
            j = np.full(N, -1, np.int64)
            p, n = np.ascontiguousarray(p, float), np.ascontiguousarray(n, float)
            self._compiled("bvh_sample")(*self._kernel_tree(), p, n, dot(n, n) > 0, u.astype(float), self.floor2,
                                         j, pmf)
            return j, pmf
        pts, pt = _columns(p, n)
        rows, u = np.arange(N), u.astype(float)
        if len(pts[0][0]) < N:                           # repeated points: u ascending per point
            rows = np.lexsort((u, pt))
            pt, u = pt[rows], u[rows]
        node, prob = np.zeros(N, np.int64), np.ones(N)
        while len(rows):
            imp = self._children_importance(node, pt, pts)
            total = imp[0] + imp[1]
            alive = total > 0
            p0 = np.where(alive, imp[0] / np.where(alive, total, 1.0), 0.0)
            right = u >= p0
            pc = np.where(right, 1.0 - p0, p0)
            u = _rescale(u, p0, right)
            prob = prob * pc
            node = self._first[node] + right            # the children of a node are consecutive
            leaf = alive & (self.light[node] >= 0)
            j[rows[leaf]], pmf[rows[leaf]] = self.light[node[leaf]], prob[leaf]
            keep = alive & ~leaf
            if not keep.all():
                rows, node, u, prob, pt = rows[keep], node[keep], u[keep], prob[keep], pt[keep]
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
        if not len(rows):
            return out
        if self.kernels == "numba":
            pr, nr, res = np.ascontiguousarray(p[rows], float), np.ascontiguousarray(n[rows], float), np.zeros(len(rows))
            self._compiled("bvh_pmf")(*self._kernel_tree(), pr, nr, dot(nr, nr) > 0, self.trail, j[rows],
                                      self.floor2, res)
            out[rows] = res
            return out
        pts, pt = _columns(p[rows], n[rows])
        jj = j[rows]
        if len(pts[0][0]) < len(rows) and self._inorder is not None:    # repeated points: lights in tree order
            order = np.lexsort((self._inorder[jj], pt))
            rows, jj, pt = rows[order], jj[order], pt[order]
        node, prob, d = np.zeros(len(rows), np.int64), np.ones(len(rows)), 0
        while len(rows):
            imp = self._children_importance(node, pt, pts)
            total = imp[0] + imp[1]
            bit = self.trail[jj, d]
            mine = np.where(bit, imp[1], imp[0])
            alive = total > 0
            p0 = np.where(alive, imp[0] / np.where(alive, total, 1.0), 0.0)
            prob = prob * np.where(bit, 1.0 - p0, p0) * (mine > 0)
            node = self._first[node] + bit
            d += 1
            leaf = self.light[node] >= 0
            out[rows[leaf]] = prob[leaf]
            keep = ~leaf & (prob > 0)
            if not keep.all():
                rows, jj, node, prob, pt = rows[keep], jj[keep], node[keep], prob[keep], pt[keep]
        return out

    def _children_importance(self, node: np.ndarray, pt: np.ndarray, pts: tuple) -> np.ndarray:
        """``(2, m)``: the importances of both children of the inner nodes ``node (m,)`` at the
        points ``pt (m,)`` (columns of ``pts``, see :func:`_columns`).  Consecutive rows at the
        same point and node (candidates of one point that took the same path) share one
        evaluation: the values do not change, as every element is computed alone."""
        head = None
        if len(pts[0][0]) < len(pt) and len(pt) > 1:
            head = np.empty(len(pt), bool)
            head[0] = True
            np.not_equal(node[1:], node[:-1], out=head[1:])
            head[1:] |= pt[1:] != pt[:-1]
            if head.all():
                head = None
            else:
                at = np.flatnonzero(head)
                node, pt = node[at], pt[at]
        (P, N, has_n) = pts
        kids = self._first[node] + _PAIR                     # (2, m)
        g = np.take(self._table, kids, axis=1)              # (11, 2, m): pc, w, r2, cos_o, sin_o, cos_e, phi
        t = Prepared(g[0:3], g[3:6], g[6], g[7], g[8], g[9], g[10], None if self._two is None else self._two[kids])
        imp = importance_prepared(t, np.take(P, pt, axis=1), None if N is None else np.take(N, pt, axis=1),
                                  self.floor2, None if has_n is None else has_n[pt], positive=True)
        return imp if head is None else imp[:, np.cumsum(head) - 1]

    def _kernel_tree(self) -> tuple:
        """``(table (M, 11), two (M,), first, light)`` as the compiled walk reads them."""
        if self._ktree is None:
            two = np.zeros(len(self.light), bool) if self._two is None else self._two
            self._ktree = (np.ascontiguousarray(self._table.T), np.ascontiguousarray(two, bool),
                           np.ascontiguousarray(self._first, np.int64), np.ascontiguousarray(self.light, np.int64))
        return self._ktree

    @staticmethod
    def _compiled(name: str):
        return load_kernel("vrlab.distributions.light_bvh_kernel", name)

    def _points(self, p, n):
        p = _coordinates(checks.finite_array(p, "p", ndim=2, last=3), "p")
        if n is None:
            return p, np.zeros_like(p)
        n = checks.finite_array(n, "n", ndim=2, last=3)
        if n.shape != p.shape:
            raise ValueError(f"n must have the shape of p, {p.shape}, got {n.shape}")
        length = np.linalg.norm(n, axis=1)
        return p, n / np.where(length > 0, length, 1.0)[:, None]


_PAIR = np.array([[0], [1]])
#: largest coordinate magnitude: squared distances and box areas stay finite in float64
MAX_COORDINATE = 1e100


def _coordinates(a: np.ndarray, name: str) -> np.ndarray:
    if a.size and np.max(np.abs(a)) > MAX_COORDINATE:
        raise ValueError(f"{name}: coordinates must be at most {MAX_COORDINATE:g} in magnitude (squared distances "
                         f"overflow beyond), got {a.flat[np.argmax(np.abs(a))]:g}")
    return a


def _columns(p: np.ndarray, n: np.ndarray) -> tuple[tuple, np.ndarray]:
    """``((P, N, has_n), pt)``: the distinct points as columns for the walk, ``P (3, U)``, unit
    normals ``N (3, U)`` (None: no point has one), ``has_n (U,)`` (None: all have one), and
    each row's point ``pt``.  Only runs of equal consecutive rows (bit for bit, p and n: the
    candidates of one shading point) are merged, and only when they are common."""
    P, Nn = np.ascontiguousarray(p.T), np.ascontiguousarray(n.T)
    pt = np.arange(len(p))
    if len(p) > 1:
        bits = np.concatenate([P, Nn]).view(np.int64)
        same = np.all(bits[:, 1:] == bits[:, :-1], axis=0)
        if 4 * np.count_nonzero(same) >= len(p):
            new = np.concatenate([[True], ~same])
            pt = np.cumsum(new) - 1
            at = np.flatnonzero(new)
            P, Nn = P[:, at], Nn[:, at]
    has_n = dot(Nn.T, Nn.T) > 0 if len(p) else np.zeros(0, bool)
    if not has_n.any():
        return (P, None, None), pt
    return (P, Nn, None if has_n.all() else has_n), pt


def _rows(value, name: str, L: int, last: int | None = None) -> np.ndarray:
    a = checks.finite_array(value, name, ndim=1 if last is None else 2, last=last)
    if len(a) != L:
        raise ValueError(f"{name} must have one row per light ({L}, as lo), got shape {a.shape}")
    return a
