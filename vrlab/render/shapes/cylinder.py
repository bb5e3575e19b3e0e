"""``cylinder`` (Mitsuba 3): an open tube (no caps) from ``p0`` (default (0, 0, 0)) to ``p1``
(default (0, 0, 1)) of ``radius`` (default 1), under ``to_world``; normals point outwards
(``flip_normals`` turns them in).  The tube {(cos phi, sin phi, z): 0 <= z <= 1} is mapped
by to_world @ T(p0) @ R @ S(r, r, |p1 - p0|), R turning +z to p1 - p0; the result must
keep the cross-section circular (to_world a similarity on it).  The ray tracer intersects
its :class:`~vrlab.render.shapes.base.TubePart` (the roots of the tube in its local frame,
:func:`vrlab.distributions.cylinder.tube_hits`; in the scene's BVH with the other
primitives); lights sample it uniformly by area (:class:`vrlab.distributions.CylinderSurface`)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ...distributions.cylinder import CylinderSurface
from ...distributions.frames import Frame
from .. import transforms as tf
from ..registry import register
from .base import Shape, TubePart, shape_matrix

__all__ = ["Cylinder"]


@register("shape", "cylinder")
class Cylinder(Shape):
    """``Cylinder(p0=(0, 0, 0), p1=(0, 0, 1), radius=1, **shape)`` (see the module docstring)."""

    def __init__(self, *, p0: Any = (0.0, 0.0, 0.0), p1: Any = (0.0, 0.0, 1.0), radius: float = 1.0, **common):
        super().__init__(**common)
        a = checks.finite_array(p0, "p0").reshape(-1)
        b = checks.finite_array(p1, "p1").reshape(-1)
        if a.shape != (3,) or b.shape != (3,):
            raise ValueError(f"p0: p0 and p1 must be 3 numbers each, got {p0!r}, {p1!r}")
        r = checks.real(radius, "radius", low=0, low_open=True)
        axis = b - a
        h = float(np.linalg.norm(axis))
        if not h > 0:
            raise ValueError(f"p1 must differ from p0, got p0 = p1 = {a.tolist()}")
        frame = Frame(axis / h)
        rot = np.eye(4)
        rot[:3, :3] = np.stack([frame.t, frame.b, frame.n], axis=1)
        self.to_world = shape_matrix(self.to_world @ tf.translate(a) @ rot @ tf.scale(np.array([r, r, h])))
        self._make_surface()

    def _make_surface(self) -> None:
        try:
            self._surface = CylinderSurface.from_matrix(self.to_world, self.flip_normals)
        except ValueError:
            raise ValueError("to_world: a cylinder's cross-section must stay a circle (no shear or non-uniform "
                             "scale across its axis; Mitsuba warns about such transforms too)") from None

    @classmethod
    def from_props(cls, p) -> "Cylinder":
        return cls(p0=p.point("p0", (0, 0, 0)), p1=p.point("p1", (0, 0, 1)), radius=p.float("radius", 1.0),
                   **cls.common(p))

    def validate(self) -> None:
        super().validate()
        self._make_surface()

    def uv(self, p, prim):
        """Mitsuba's cylinder: uv = (phi / 2 pi, z) of the local point, phi in [0, 2 pi)."""
        x = self._surface.local(p)
        phi = np.arctan2(x[:, 1], x[:, 0]) / (2 * np.pi)
        return np.stack([np.where(phi < 0, phi + 1.0, phi), x[:, 2]], -1)

    def parts(self) -> list:
        s = self._surface
        return [TubePart(s.origin, s.matrix, s.sign)]

    @property
    def center(self) -> np.ndarray:
        return self._surface.bounding_sphere()[0]

    @property
    def bound_radius(self) -> float:
        return self._surface.bounding_sphere()[1]

    @property
    def area(self) -> float:
        return self._surface.area

    def surface(self) -> CylinderSurface:
        return self._surface
