"""``rectangle``: the square [-1, 1]^2 in the plane z = 0 with normal +z, under ``to_world``
(Mitsuba 3 ``rectangle``).  Sampled by area (``RectangleSurface``); the unoccluded
integral of cos over it from a point above it has Lambert's polygon closed form,
I = 1/2 |sum_k theta_k n . unit(v_k x v_k+1)| (Lambert 1760; Arvo 1995, "Applications of
irradiance tensors"), where v_k are the unit directions to the corners and theta_k the
angles between consecutive ones.
"""
from __future__ import annotations

import numpy as np

from ...distributions import RectangleSurface
from .. import transforms as tf
from ..registry import register
from .base import Parallelograms, Shape

__all__ = ["Rectangle"]


@register("shape", "rectangle")
class Rectangle(Shape):
    """Mitsuba's ``rectangle``: parameters ``to_world``, ``flip_normals``, ``bsdf``, ``emitter``."""

    def corners(self) -> np.ndarray:
        """World corners ``(4, 3)`` in order (-1,-1), (1,-1), (1,1), (-1,1)."""
        return tf.transform_points(self.to_world, np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float))

    def rectangle(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(corner, edge1, edge2, unit normal); points = corner + s edge1 + t edge2, s, t in [0, 1]."""
        c = self.corners()
        return c[0], c[1] - c[0], c[3] - c[0], self.normal_z()

    def uv(self, p, prim):
        """Mitsuba's rectangle: uv = ((x + 1) / 2, (y + 1) / 2) of the local point."""
        x = self.local_points(p)
        return 0.5 * x[:, :2] + 0.5

    def parts(self) -> list:
        corner, e1, e2, n = self.rectangle()
        return [Parallelograms(np.array([[corner, e1, e2, n]]))]

    def triangles(self) -> np.ndarray:
        c = self.corners()
        tri = c[np.array([[0, 1, 2], [0, 2, 3]])]
        return tri[:, ::-1] if self.flip_normals else tri

    @property
    def area(self) -> float:
        _, e1, e2, _ = self.rectangle()
        return float(np.linalg.norm(np.cross(e1, e2)))

    @property
    def bound_radius(self) -> float:
        return float(np.max(np.linalg.norm(self.corners() - self.center, axis=-1)))

    def surface(self) -> RectangleSurface:
        return RectangleSurface.from_matrix(self.to_world, self.flip_normals)

    def surface32(self) -> RectangleSurface:
        s = self.surface()
        return RectangleSurface(*(np.float32(a) for a in (s.corner, s.edge1, s.edge2)))

    def cos_integral(self, ref: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        corners = self.corners()
        v = corners[None] - ref[:, None]                      # (m, 4, 3)
        above = np.all(np.einsum("mkc,mc->mk", v, n) > 0, -1)
        front = np.sum((ref - corners[0]) * self.normal_z(), -1) > 0
        valid = above & front
        v = v / np.linalg.norm(v, axis=-1, keepdims=True)
        w = np.roll(v, -1, axis=1)
        theta = np.arccos(np.clip(np.sum(v * w, -1), -1.0, 1.0))
        c = np.cross(v, w)
        c /= np.maximum(np.linalg.norm(c, axis=-1, keepdims=True), 1e-300)
        integral = 0.5 * np.abs(np.sum(theta * np.einsum("mkc,mc->mk", c, n), -1))
        return np.where(valid, integral, 0.0), valid
