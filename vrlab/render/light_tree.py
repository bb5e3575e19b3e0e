"""``light_selection="bvh"``: pbrt-v4's light BVH picks the light per shading point.

pbrt-v4 (Pharr, Jakob & Humphreys, "Physically Based Rendering", 4th ed., section 12.6.3):
the lights with bounds go into a :class:`~vrlab.distributions.LightBVH`; the ``n_inf`` lights
at infinity (constant, envmap, directional) are picked uniformly with the total probability
p_inf = n_inf / (n_inf + 1) (1 if no bounded light has power), the tree otherwise::

    P(j | p, n) = p_inf / n_inf                       (j at infinity)
                = (1 - p_inf) P_bvh(j | p, n)         (j in the tree)

One uniform u chooses: u < p_inf picks infinite light floor(u / p_inf * n_inf), else the
tree walks down with (u - p_inf) / (1 - p_inf).  Where the tree finds no light that can
reach the point (every candidate faces away) no light is sampled (j = -1, density 0).

Per light, the bounds: a sphere its box and every direction (theta_o = pi, theta_e = pi/2);
a rectangle or disk its box (rectangle: its corners; disk: centre +- bound radius) and
its normal (theta_o = 0, theta_e = pi/2, one-sided: vrlab's area emitters emit on the
normal's side only); other shapes (cube, cylinder, ellipsoid, mesh) the box about their
bounding sphere and every direction; point and projector lights their position and every
direction; spot lights their position and pbrt-v4's cone (``emission_cone``: theta_o the beam
width, theta_e the rest of the cutoff; every direction if ``to_world`` shears or scales
unevenly).  phi is the power of ``light_selection="power"`` (the flux pi x mean radiance x
area, or the emitter's ``power``) times the emitter's ``sampling_weight``.

**Emissive triangle meshes** (``obj``, ``ply``, ``serialized``, ``mesh`` without vertex
normals; ``split`` lights) are not one leaf but one leaf per triangle: its box, its winding
normal as the cone axis (theta_o = 0, theta_e = pi/2, one-sided), phi = pi x mean radiance x A_t x
sampling_weight (zero-area triangles: phi = 0, never chosen).  The leaves are *entries*
e = 0..E-1: each unsplit bounded light has one, split light j has ``first_entry[j] + t`` for
its triangles t = 0..F_j-1 (``entry_light``, ``entry_triangle``; -1 for whole lights).  So
``sample`` returns (j, P(j, t | p, n), t) and ``pmf`` takes t.  A mesh with vertex normals
emits to the side of its interpolated shading normal (as Mitsuba judges it): its triangles'
cones hold their three vertex normals instead (theta_o > 0).
"""
from __future__ import annotations

import numpy as np

from ..distributions import LightBVH
from .lights import lambertian_flux

__all__ = ["BVHSelection"]


def _bounds(light) -> tuple:
    """(lo, hi, w, cos_o, cos_e) of one light of a :class:`~vrlab.render.light_set.LightSet`."""
    up = np.array([0.0, 0.0, 1.0])
    own = light.emitter.light_bounds()            # point, spot, projector: their position and cone
    if own is not None:
        return own
    if light.sphere is not None:
        c, r = np.asarray(light.sphere[0], float), float(light.sphere[1])
        return c - r, c + r, up, -1.0, 0.0
    shape = light.shape
    if shape is None:
        raise ValueError(f"light_selection: 'bvh' needs bounds of every light not at infinity; the "
                         f"{light.emitter.plugin_name!r} emitter gives none (light_bounds())")
    pts = shape.corners() if light.planar else None
    if pts is not None:
        return pts.min(0), pts.max(0), light.surface.normal(pts[:1])[0], 1.0, 0.0
    c, r = np.asarray(shape.center, float), float(shape.bound_radius)
    if light.planar and light.surface.unit_normal is not None:
        return c - r, c + r, np.asarray(light.surface.unit_normal, float), 1.0, 0.0
    return c - r, c + r, up, -1.0, 0.0


def _triangle_bounds(light) -> tuple:
    """(lo, hi, w, cos_o, area) of every triangle of a split mesh light (F rows): the winding
    normal and theta_o = 0, or with vertex normals the cone about their normalised sum that
    holds the three (it holds their interpolations: a cone under pi/2 is convex on the
    sphere; a wider one becomes the whole sphere)."""
    surf, shape = light.surface, light.shape
    tri = np.stack([surf.v0, surf.v0 + surf.e1, surf.v0 + surf.e2], 1)           # (F, 3, 3)
    w = np.where((surf.areas > 0)[:, None], surf.face_normals, [0.0, 0.0, 1.0])   # zero area: phi = 0
    cos_o = np.ones(len(tri))
    if shape.has_shading_normals:
        F = len(tri)
        ns = shape.shading_normals(tri.reshape(-1, 3), np.repeat(w, 3, 0), np.repeat(np.arange(F), 3))
        ns = ns.reshape(F, 3, 3)
        axis = ns.sum(1)
        length = np.linalg.norm(axis, axis=1)
        w = np.where((length > 1e-9)[:, None], axis / np.maximum(length, 1e-300)[:, None], w)
        cos_o = np.min(np.einsum("fk,fvk->fv", w, ns), axis=1) * (1 - 1e-9) - 1e-9   # rounding: slightly wider
        cos_o = np.where((cos_o > 0) & (length > 1e-9), cos_o, -1.0)
    return tri.min(1), tri.max(1), w, cos_o, surf.areas


class BVHSelection:
    """P(j, t | p, n) over the lights of a light set (see the module docstring): ``lights``
    the set's lights, ``weights (L,)`` their ``sampling_weight``, ``power (L,)`` their powers
    (pi x mean radiance x area or the emitter's power), ``split (L,)`` bool: one leaf per triangle;
    ``kernels``: the tree walk's, "numpy" (default), "numba" or "auto" (see :mod:`vrlab.kernels`)."""

    def __init__(self, lights: list, weights: np.ndarray, power: np.ndarray, split: np.ndarray | None = None, *,
                 kernels: str = "numpy"):
        L = len(lights)
        split = np.zeros(L, bool) if split is None else np.asarray(split, bool)
        inf = np.array([l.is_infinite for l in lights], bool)
        self.infinite = np.flatnonzero(inf)
        self.bounded = np.flatnonzero(~inf)
        self.split = split
        phi_light = np.maximum(weights * power, 0.0)
        rows, lights_of, tris_of = [], [], []
        for i in self.bounded:                       # a loop over lights; triangles are arrays
            if split[i]:
                lo, hi, w, cos_o, area = _triangle_bounds(lights[i])
                phi = weights[i] * lambertian_flux(lights[i].radiance, area)
                rows.append((lo, hi, w, cos_o, phi, np.zeros(len(lo))))
                lights_of.append(np.full(len(lo), i))
                tris_of.append(np.arange(len(lo)))
            else:
                lo, hi, w, cos_o, cos_e = _bounds(lights[i])
                rows.append((lo[None], hi[None], np.asarray(w, float)[None], np.array([cos_o], float),
                             np.array([phi_light[i]]), np.array([cos_e], float)))
                lights_of.append(np.array([i]))
                tris_of.append(np.array([-1]))
        cat = lambda k, shape: (np.concatenate([r[k] for r in rows]) if rows   # noqa: E731
                                else np.zeros(shape))
        lo, hi, w = cat(0, (0, 3)), cat(1, (0, 3)), cat(2, (0, 3))
        cos_o, phi, cos_e = cat(3, (0,)), cat(4, (0,)), cat(5, (0,))
        #: the light and triangle (-1: the whole light) of each entry (leaf) of the tree
        self.entry_light = np.concatenate(lights_of).astype(np.int64) if rows else np.zeros(0, np.int64)
        self.entry_triangle = np.concatenate(tris_of).astype(np.int64) if rows else np.zeros(0, np.int64)
        self.tree = LightBVH(lo, hi, w, cos_o, cos_e, phi, kernels=kernels)
        self.p_inf = self.tree.infinite_probability(len(self.infinite))
        #: each light's first entry (-1: a light at infinity)
        self.first_entry = np.full(L, -1)
        first = np.flatnonzero(np.r_[True, self.entry_light[1:] != self.entry_light[:-1]]) if rows else []
        self.first_entry[self.entry_light[first]] = first
        self.n_triangles = np.zeros(L, np.int64)
        self.n_triangles[self.bounded] = np.bincount(self.entry_light, minlength=L)[self.bounded]

    def sample(self, ref: np.ndarray, n: np.ndarray | None, u: np.ndarray) -> tuple[np.ndarray, ...]:
        """``(j, P, t)`` for points ``ref (m, 3)`` (normals ``n`` or None) and uniforms ``u (m,)``:
        the light, P(j, t | p, n) and the triangle t of a split light (-1 otherwise)."""
        u = np.asarray(u, float)
        j, pj, t = np.full(len(u), -1), np.zeros(len(u)), np.full(len(u), -1)
        k = len(self.infinite)
        at_inf = u < self.p_inf
        if at_inf.any():
            pick = np.minimum((u[at_inf] / self.p_inf * k).astype(np.int64), k - 1)
            j[at_inf], pj[at_inf] = self.infinite[pick], self.p_inf / k
        rest = np.flatnonzero(~at_inf)
        if len(rest):
            v = np.minimum((u[rest] - self.p_inf) / (1.0 - self.p_inf), np.nextafter(1.0, 0.0))
            e, pl = self.tree.sample(np.asarray(ref[rest], float), None if n is None else
                                     np.asarray(n[rest], float), v)
            ok = e >= 0
            ec = np.maximum(e, 0)
            j[rest] = np.where(ok, self.entry_light[ec], -1) if len(self.entry_light) else -1
            t[rest] = np.where(ok, self.entry_triangle[ec], -1) if len(self.entry_light) else -1
            pj[rest] = pl * (1.0 - self.p_inf)
        return j, pj, t

    def pmf(self, ref: np.ndarray, n: np.ndarray | None, j: np.ndarray, t: np.ndarray | None = None) -> np.ndarray:
        """P(j, t | p, n) at each point for light indices ``j`` (-1: 0) and triangles ``t`` of
        split lights (-1: no triangle, 0; ignored for other lights).  ``t`` None: for split
        lights the marginal P(j | p, n) = sum_t P(j, t | p, n) (O(F_j) per point)."""
        j = np.asarray(j)
        out = np.zeros(len(j))
        has = j >= 0
        jj = np.maximum(j, 0)
        inf = has & (self.first_entry[jj] < 0)
        out[inf] = self.p_inf / max(len(self.infinite), 1)
        sp = has & ~inf & self.split[jj]
        if t is None and sp.any():                   # marginals: every triangle of each row's light
            rows = np.flatnonzero(sp)
            cnt = self.n_triangles[j[rows]]
            rr = np.repeat(rows, cnt)
            tt = np.arange(len(rr)) - np.repeat(np.cumsum(cnt) - cnt, cnt)
            out[rows] = np.bincount(np.repeat(np.arange(len(rows)), cnt), minlength=len(rows),
                                    weights=self._tree_pmf(ref, n, rr, self.first_entry[j[rr]] + tt))
            has = has & ~sp
        elif sp.any():
            tc = np.asarray(t)
            has = has & (~sp | (tc >= 0))
        rows = np.flatnonzero(has & ~inf)
        if len(rows):
            e = self.first_entry[j[rows]]
            if t is not None:
                e = e + np.where(self.split[j[rows]], np.maximum(np.asarray(t)[rows], 0), 0)
            out[rows] = self._tree_pmf(ref, n, rows, e)
        return out

    def _tree_pmf(self, ref, n, rows, e):
        return (1.0 - self.p_inf) * self.tree.pmf(np.asarray(ref[rows], float),
                                                  None if n is None else np.asarray(n[rows], float), e)
