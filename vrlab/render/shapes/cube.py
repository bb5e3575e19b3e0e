"""``cube``: the cube [-1, 1]^3 under ``to_world`` (Mitsuba 3 ``cube``, a 12-triangle mesh with
outward winding); the ray tracer tests its six faces together by the slab test (Kay &
Kajiya 1986).  Lights sample it by area (``BoxSurface``: a face with probability
area_k / A, then uniform on it)."""
from __future__ import annotations

import numpy as np

from .. import transforms as tf
from ..registry import register
from .base import Shape, Triangles

__all__ = ["Cube", "cube_mesh"]


def cube_mesh() -> tuple[np.ndarray, np.ndarray]:
    """``(vertices (8, 3), faces (12, 3))`` of [-1, 1]^3, each face a fan of two triangles
    wound counter-clockwise seen from outside."""
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    idx = {tuple(p): i for i, p in enumerate(v.astype(int))}
    faces = []
    for axis in range(3):
        for sign in (-1, 1):
            a, b = (axis + 1) % 3, (axis + 2) % 3
            quad = []
            for s, t in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0, 0, 0]
                p[axis], p[a], p[b] = sign, s, t
                quad.append(idx[tuple(p)])
            if sign < 0:                   # (a, b, axis) is right-handed: CCW seen from +axis
                quad = quad[::-1]
            faces += [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
    return v, np.array(faces)


@register("shape", "cube")
class Cube(Shape):
    """Mitsuba's ``cube``: parameters ``to_world``, ``flip_normals``, ``bsdf``, ``emitter``."""

    def triangles(self) -> np.ndarray:
        v, f = cube_mesh()
        tri = tf.transform_points(self.to_world, v[f])
        return tri[:, ::-1] if self.flip_normals else tri

    def uv(self, p, prim):
        """Mitsuba's cube (a mesh of 24 vertices, uvs (0, 0) to (1, 1) per face): on each face an
        affine map of the two other local coordinates (read off Mitsuba's ``vertex_texcoords``)."""
        x = self.local_points(p)
        axis = np.argmax(np.abs(x), -1)
        pos = np.take_along_axis(x, axis[:, None], -1)[:, 0] > 0
        X, Y, Z = x[:, 0], x[:, 1], x[:, 2]
        # face (axis, side): (u, v), each (a + b * coordinate) / 2
        cases = [(~pos & (axis == 0), Y + 1, Z + 1), (pos & (axis == 0), Y + 1, 1 - Z),
                 (~pos & (axis == 1), Z + 1, X + 1), (pos & (axis == 1), 1 - X, 1 - Z),
                 (~pos & (axis == 2), 1 - Y, X + 1), (pos & (axis == 2), Y + 1, X + 1)]
        u = np.select([c for c, _, _ in cases], [a for _, a, _ in cases])
        v = np.select([c for c, _, _ in cases], [b for _, _, b in cases])
        return 0.5 * np.stack([u, v], -1)

    def parts(self) -> list:
        return [Triangles(self.triangles(), box=self.to_world)]

    @property
    def area(self) -> float:
        return self.surface().area

    def surface(self):
        from ...distributions import BoxSurface

        return BoxSurface.from_matrix(self.to_world)
