"""``ellipsoid`` (vrlab's own element, not a Mitsuba plugin): ``center`` and ``radii``, the unit
sphere under ``to_world @ T(center) @ S(radii)``.  Lights sample it with
``EllipsoidSurface`` (x = c + M d, d uniform on the unit sphere; not uniform by area, its
density p_A = 1 / (4 pi |det M| |M^-T n_s|) is exact)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from .. import transforms as tf
from ..registry import register
from .base import Quadric, Shape, shape_matrix

__all__ = ["Ellipsoid"]


@register("shape", "ellipsoid")
class Ellipsoid(Shape):
    """``center`` (3,), ``radii`` (3,) all > 0, and the common shape parameters."""

    def __init__(self, *, center: Any = (0.0, 0.0, 0.0), radii: Any = (1.0, 1.0, 1.0), **common):
        super().__init__(**common)
        c = checks.finite_array(center, "center").reshape(-1)
        r = checks.finite_array(radii, "radii").reshape(-1)
        if c.shape != (3,):
            raise ValueError(f"center must be 3 numbers, got {center!r}")
        if r.shape != (3,) or np.any(r <= 0):
            raise ValueError(f"radii must be 3 numbers > 0, got {radii!r}")
        self.to_world = self.to_world @ tf.translate(c) @ tf.scale(r)
        self.to_world = shape_matrix(self.to_world)

    @classmethod
    def from_props(cls, p) -> Ellipsoid:
        return cls(center=p.point("center", (0, 0, 0)), radii=p.vector("radii", (1, 1, 1)), **cls.common(p))

    def ellipsoid(self) -> tuple[np.ndarray, np.ndarray]:
        """(center, 3x3 linear map) with world points = center + A @ unit-sphere points."""
        return self.center, self.to_world[:3, :3].copy()

    def uv(self, p, prim):
        """Mitsuba's sphere: uv = (phi / 2 pi, theta / pi) of the local direction (on the unit
        sphere the shape is mapped from), phi in [0, 2 pi)."""
        x = self.local_points(p)
        phi = np.arctan2(x[:, 1], x[:, 0])
        phi = np.where(phi < 0, phi + 2 * np.pi, phi)
        theta = np.arccos(np.clip(x[:, 2] / np.maximum(np.linalg.norm(x, axis=-1), 1e-300), -1.0, 1.0))
        return np.stack([phi / (2 * np.pi), theta / np.pi], -1)

    def parts(self) -> list:
        return [Quadric(self.center, self.to_world[:3, :3].copy(), -1.0 if self.flip_normals else 1.0)]

    @property
    def bound_radius(self) -> float:
        return float(np.linalg.norm(self.to_world[:3, :3], 2))

    @property
    def area(self) -> float:
        return self.surface().area

    def surface(self):
        from ...distributions import EllipsoidSurface

        return EllipsoidSurface.from_matrix(self.to_world)
