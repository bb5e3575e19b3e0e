"""Uniform points on an open cylinder (Mitsuba 3's ``cylinder`` shape), as a light surface.

The cylinder is the image of the unit tube {(cos phi, sin phi, z): z in [0, 1]} under
x = origin + M s, where M has orthogonal columns a1, a2 (|a1| = |a2| = r, the radius) and
a3 (the axis, |a3| = h, the length).  Such a map keeps area ratios, so uniform (u1, u2)
-> (z = u1, phi = 2 pi u2) is uniform by area:

    p_A = 1 / (2 pi r h)      (measure: area).

The outward normal at s is M^-T (cos phi, sin phi, 0), normalised (a1 cos phi + a2 sin
phi over r).  A ray meets the tube at most twice: in the local frame, the roots of
(o_x + t d_x)^2 + (o_y + t d_y)^2 = 1 with 0 <= z <= 1 (the caps are open, as in Mitsuba).
Source: the cylinder of PBRT (Pharr, Jakob & Humphreys, 3rd ed., 3.3 and 14.2).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .._vec import matvec3
from ._args import _vector3
from .base import as_points, as_uniforms
from .surfaces import TWO_PI, Surface, _finish_hits

__all__ = ["CylinderSurface", "tube_hits"]


def tube_hits(o: np.ndarray, d: np.ndarray, t_min: float) -> np.ndarray:
    """Both t > t_min (ascending, inf for none) of local rays ``o + t d`` with the unit tube
    x^2 + y^2 = 1, 0 <= z <= 1; ``(..., 2)``.  Stable roots: q = -(b + sign(b) sqrt(disc))."""
    a = d[..., 0] ** 2 + d[..., 1] ** 2
    b = o[..., 0] * d[..., 0] + o[..., 1] * d[..., 1]
    c = o[..., 0] ** 2 + o[..., 1] ** 2 - 1.0
    disc = b * b - a * c
    ok = (disc >= 0) & (a > 0)
    sq = np.sqrt(np.where(ok, disc, 0.0))
    q = -(b + np.where(b >= 0, sq, -sq))
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = np.where(ok, q / np.where(ok, a, 1.0), np.inf)
        t2 = np.where(ok & (q != 0), c / np.where(q != 0, q, 1.0), t1)
    t = np.stack([t1, t2], -1)
    z = o[..., None, 2] + np.where(np.isfinite(t), t, 0.0) * d[..., None, 2]
    valid = ok[..., None] & np.isfinite(t) & (t > t_min) & (z >= 0.0) & (z <= 1.0)
    return _finish_hits(t, valid)


class CylinderSurface(Surface):
    """Uniform points on the open cylinder origin + a1 cos phi + a2 sin phi + z a3 (see the
    module docstring).  ``from_matrix(M)``: the unit tube under a 4x4 ``to_world``.
    ``flip``: inward normals.  Checked: finite vectors, a1, a2, a3 orthogonal, |a1| = |a2|."""

    max_hits = 2

    def __init__(self, origin: Any, a1: Any, a2: Any, a3: Any, flip: bool = False):
        self.origin = _vector3(origin, "origin")
        m = np.stack([_vector3(a1, "a1"), _vector3(a2, "a2"), _vector3(a3, "a3")], axis=1)
        r, h = np.linalg.norm(m[:, 0]), np.linalg.norm(m[:, 2])
        g = m.T @ m
        scale = max(r, h)
        if not (r > 0 and h > 0) or np.abs(g - np.diag(np.diag(g))).max() > 1e-9 * scale * scale \
                or abs(np.linalg.norm(m[:, 1]) - r) > 1e-9 * r:
            raise ValueError("a1: the axes a1, a2 (the radius) and a3 (the length) must be non-zero and orthogonal, "
                             "with |a1| = |a2|")
        self.matrix, self.radius, self.length = m, float(r), float(h)
        self.minv = np.linalg.inv(m)
        self.sign = -1.0 if flip else 1.0
        self.area = float(TWO_PI * r * h)

    @classmethod
    def from_matrix(cls, matrix: Any, flip: bool = False) -> "CylinderSurface":
        m = np.asarray(matrix, float)
        return cls(m[:3, 3], m[:3, 0], m[:3, 1], m[:3, 2], flip)

    def bounding_sphere(self) -> tuple[np.ndarray, float]:
        return self.origin + 0.5 * self.matrix[:, 2], float(np.hypot(self.radius, 0.5 * self.length))

    def local(self, x: np.ndarray) -> np.ndarray:
        """Local tube coordinates M^-1 (x - origin)."""
        return matvec3(self.minv, np.asarray(x, float) - self.origin)

    def sample(self, u: np.ndarray) -> np.ndarray:
        u = as_uniforms(u, 2)
        phi = TWO_PI * u[..., 1]
        s = np.stack([np.cos(phi), np.sin(phi), u[..., 0]], -1)
        return self.origin + s @ self.matrix.T

    def pdf(self, x: np.ndarray) -> np.ndarray:
        return np.full(as_points(x, 3, "x").shape[:-1], 1.0 / self.area)

    def invert(self, x: np.ndarray) -> np.ndarray:
        s = self.local(as_points(x, 3, "x"))
        u2 = np.arctan2(s[..., 1], s[..., 0]) / TWO_PI
        u2 = np.where(u2 < 0, u2 + 1.0, u2)
        return np.stack([s[..., 2], np.where(u2 >= 1.0, 0.0, u2)], -1)

    def normal(self, x: np.ndarray) -> np.ndarray:
        s = self.local(as_points(x, 3, "x"))
        s[..., 2] = 0.0
        n = s @ self.minv                      # M^-T s as rows
        return self.sign * n / np.linalg.norm(n, axis=-1, keepdims=True)

    def intersect(self, origin, direction, t_min=None):
        o, d = self._rays(origin, direction)
        return tube_hits(self.local(o), matvec3(self.minv, d), self._t_min(t_min))

    def _repr_fields(self):
        return {"radius": self.radius, "length": self.length}
