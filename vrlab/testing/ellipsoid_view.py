"""A chart of the directions from a point that hit an ellipsoid light (its solid angle).

Shared by the chi-square tests of the light-surface samplers (``tests/test_surfaces.py``)
and the light-surfaces experiment (:mod:`vrlab.experiments.light_surfaces`), which
integrates solid-angle densities over it.
"""
from __future__ import annotations

import numpy as np

from ..distributions.frames import to_local, to_world
from ..distributions.charts import Chart

__all__ = ["EllipsoidViewChart"]


class EllipsoidViewChart(Chart):
    """Directions from ``ref`` that hit the ellipsoid c + M S^2 (covers exactly that set).

    Ray ref + t w meets the ellipsoid iff ref' + t M^-1 w meets the unit sphere,
    ref' = M^-1 (ref - c).  So w = normalize(M w') for w' in the cone the unit sphere
    subtends from ref' (axis a, 1 - cos_max = omc), with dw = |det M| / |M w'|^3 dw'.
    Parameters: 1 - w'.a = omc s (2 - s), phi = 2 pi t; the silhouette is s = 1 and the
    Jacobian 4 pi omc (1 - s) cancels the 1/sqrt singularity of the solid-angle pdf there.
    """

    p, dim_x = 2, 3

    def __init__(self, center, M, ref):
        self.M = np.asarray(M, float)
        self.Minv = np.linalg.inv(self.M)
        self.det = abs(np.linalg.det(self.M))
        o = (np.asarray(ref, float) - center) @ self.Minv.T
        d = np.linalg.norm(o)
        if not d > 1:
            raise ValueError("ref: the point must lie outside the ellipsoid")
        self.axis = -o / d
        self.omc = 1.0 - np.sqrt(1.0 - 1.0 / d**2)

    def _wp(self, s):
        omz = self.omc * s[..., 0] * (2.0 - s[..., 0])
        sin = np.sqrt(omz * (2.0 - omz))
        phi = 2 * np.pi * s[..., 1]
        return to_world(np.stack([sin * np.cos(phi), sin * np.sin(phi), 1.0 - omz], -1), self.axis)

    def from_param(self, s):
        w = self._wp(s) @ self.M.T
        return w / np.linalg.norm(w, axis=-1, keepdims=True)

    def to_param(self, w):
        wp = np.asarray(w, float) @ self.Minv.T
        wp = wp / np.linalg.norm(wp, axis=-1, keepdims=True)
        local = to_local(wp, self.axis)
        omz = 0.5 * np.sum((wp - self.axis) ** 2, -1)
        s = 1.0 - np.sqrt(np.clip(1.0 - omz / self.omc, 0.0, None))
        t = np.mod(np.arctan2(local[..., 1], local[..., 0]) / (2 * np.pi), 1.0)
        return np.stack([s, t], -1)

    def jacobian(self, s):
        norm = np.linalg.norm(self._wp(s) @ self.M.T, axis=-1)
        return 4 * np.pi * self.omc * (1.0 - s[..., 0]) * self.det / norm**3
