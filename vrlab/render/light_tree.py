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
bounding sphere and every direction; point, spot and projector lights their position and
every direction (a spot's cone is not used: conservative).  phi is the power of
``light_selection="power"`` (mean radiance x area, or the emitter's ``power``) times the
emitter's ``sampling_weight``.
"""
from __future__ import annotations

import numpy as np

from ..distributions import LightBVH

__all__ = ["BVHSelection"]


def _bounds(light) -> tuple:
    """(lo, hi, w, cos_o) of one light of a :class:`~vrlab.render.lights.LightSet`."""
    up = np.array([0.0, 0.0, 1.0])
    if getattr(light, "emitter", None) is not None and not hasattr(light, "shape"):    # point, spot, projector
        pos = np.asarray(light.emitter.position, float)
        return pos, pos, up, -1.0
    if light.sphere is not None:
        c, r = np.asarray(light.sphere[0], float), float(light.sphere[1])
        return c - r, c + r, up, -1.0
    shape = light.shape
    if light.planar and hasattr(shape, "corners"):
        pts = shape.corners()
        return pts.min(0), pts.max(0), light.surface.normal(pts[:1])[0], 1.0
    c, r = np.asarray(shape.center, float), float(shape.bound_radius)
    if light.planar and hasattr(light.surface, "unit_normal"):
        return c - r, c + r, np.asarray(light.surface.unit_normal, float), 1.0
    return c - r, c + r, up, -1.0


class BVHSelection:
    """P(j | p, n) over the lights of a light set (see the module docstring): ``lights`` the
    set's lights, ``power (L,)`` their selection weights (power x sampling_weight)."""

    def __init__(self, lights: list, power: np.ndarray):
        inf = np.array([getattr(l, "is_infinite", False) for l in lights], bool)
        self.infinite = np.flatnonzero(inf)
        self.bounded = np.flatnonzero(~inf)
        rows = [_bounds(lights[i]) for i in self.bounded]
        lo = np.array([r[0] for r in rows]).reshape(-1, 3)
        hi = np.array([r[1] for r in rows]).reshape(-1, 3)
        w = np.array([r[2] for r in rows]).reshape(-1, 3)
        cos_o = np.array([r[3] for r in rows], float)
        self.tree = LightBVH(lo, hi, w, cos_o, np.zeros(len(rows)), np.maximum(power[self.bounded], 0.0))
        self.p_inf = self.tree.infinite_probability(len(self.infinite))
        self.local = np.full(len(lights), -1)
        self.local[self.bounded] = np.arange(len(self.bounded))

    def sample(self, ref: np.ndarray, n: np.ndarray | None, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(j, P_j)`` for points ``ref (m, 3)`` (normals ``n`` or None) and uniforms ``u (m,)``."""
        u = np.asarray(u, float)
        j, pj = np.full(len(u), -1), np.zeros(len(u))
        k = len(self.infinite)
        at_inf = u < self.p_inf
        if at_inf.any():
            pick = np.minimum((u[at_inf] / self.p_inf * k).astype(np.int64), k - 1)
            j[at_inf], pj[at_inf] = self.infinite[pick], self.p_inf / k
        rest = np.flatnonzero(~at_inf)
        if len(rest):
            v = np.minimum((u[rest] - self.p_inf) / (1.0 - self.p_inf), np.nextafter(1.0, 0.0))
            jl, pl = self.tree.sample(np.asarray(ref[rest], float), None if n is None else
                                      np.asarray(n[rest], float), v)
            j[rest] = np.where(jl >= 0, self.bounded[np.maximum(jl, 0)] if len(self.bounded) else -1, -1)
            pj[rest] = pl * (1.0 - self.p_inf)
        return j, pj

    def pmf(self, ref: np.ndarray, n: np.ndarray | None, j: np.ndarray) -> np.ndarray:
        """P_j at each point for light indices ``j`` (-1: 0)."""
        j = np.asarray(j)
        out = np.zeros(len(j))
        has = j >= 0
        jj = np.maximum(j, 0)
        inf = has & (self.local[jj] < 0)
        out[inf] = self.p_inf / max(len(self.infinite), 1)
        rows = np.flatnonzero(has & ~inf)
        if len(rows):
            out[rows] = (1.0 - self.p_inf) * self.tree.pmf(
                np.asarray(ref[rows], float), None if n is None else np.asarray(n[rows], float), self.local[j[rows]])
        return out
