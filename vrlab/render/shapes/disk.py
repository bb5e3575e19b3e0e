"""``disk``: the unit disk in the plane z = 0 with normal +z, under ``to_world`` (Mitsuba 3
``disk``); an affine map keeps uniform area sampling uniform, so lights sample it with
:class:`vrlab.distributions.DiskSurface`."""
from __future__ import annotations

import numpy as np

from ..registry import register
from .base import DiskPart, Shape

__all__ = ["Disk"]


@register("shape", "disk")
class Disk(Shape):
    """Mitsuba's ``disk``: parameters ``to_world``, ``flip_normals``, ``bsdf``, ``emitter``."""

    def disk(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(center, axis1, axis2, unit normal); points = center + r cos t axis1 + r sin t axis2."""
        m = self.to_world
        return self.center, m[:3, 0].copy(), m[:3, 1].copy(), self.normal_z()

    def uv(self, p, prim):
        """Mitsuba's disk: uv = (r, phi / 2 pi) of the local point, phi in [0, 2 pi)."""
        x = self.local_points(p)
        v = np.arctan2(x[:, 1], x[:, 0]) / (2 * np.pi)
        return np.stack([np.hypot(x[:, 0], x[:, 1]), np.where(v < 0, v + 1.0, v)], -1)

    def parts(self) -> list:
        return [DiskPart(self.center, self.to_world[:3, :3].copy(), self.normal_z())]

    @property
    def area(self) -> float:
        _, a1, a2, _ = self.disk()
        return float(np.pi * np.linalg.norm(np.cross(a1, a2)))

    @property
    def bound_radius(self) -> float:
        _, a1, a2, _ = self.disk()
        return float(max(np.linalg.norm(a1), np.linalg.norm(a2)))

    def surface(self):
        from ...distributions import DiskSurface

        return DiskSurface.from_matrix(self.to_world, self.flip_normals, method="polar")
