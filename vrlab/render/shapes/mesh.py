"""The base of triangle-mesh shapes (``obj``, ``ply``, ``serialized``; Mitsuba 3's ``Mesh``).

A mesh holds object-space ``vertices (V, 3)`` and ``faces (F, 3)`` (indices), optional
per-vertex ``normals`` and ``uvs``, and named vertex/face attributes; ``to_world`` maps
it to the world.  Geometric normals follow the winding (``e1 x e2``), flipped by
``flip_normals``; ``face_normals=True`` drops the vertex normals (flat shading).
Checked: vertices finite and within the float32 range in the world, faces integer
indices of existing vertices, at least one triangle of non-zero area.  The mesh keeps its
arrays once: its world vertices are the vertex array itself under the identity (else one
transformed copy, cached), the ray tracer gets them indexed
(:class:`~vrlab.render.shapes.base.IndexedTriangles`), and barycentrics are computed for the
hit faces only (no per-face tables).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ..._vec import cross, dot, matvec3, norm, scale
from .. import transforms as tf
from ..scene_checks import MAX_COORD
from .base import IndexedTriangles, Shape, check_world_points

__all__ = ["Mesh", "check_mesh"]


def check_mesh(vertices: Any, faces: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(vertices (V, 3) float, faces (T, 3) int64)`` of a triangle mesh, checked."""
    if vertices is None or faces is None:
        raise ValueError("vertices: a mesh needs vertices (V, 3) and faces (T, 3)")
    v = checks.finite_array(vertices, "vertices", ndim=2, last=3)
    if np.abs(v).max(initial=0.0) > MAX_COORD:
        raise ValueError(f"vertices must lie within +-{MAX_COORD:g}, got {np.abs(v).max():g}")
    f = np.asarray(faces)
    if f.dtype.kind not in "iu" or f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(f"faces must be an integer array (T, 3), got {f.dtype} {f.shape}")
    if len(f) == 0:
        raise ValueError("faces: the mesh has no faces")
    if f.min() < 0 or f.max() >= len(v):
        raise ValueError(f"faces: vertex indices must lie in [0, {len(v) - 1}], got {f.min()} to {f.max()}")
    for rows in (slice(0, 64), slice(None)):     # a non-degenerate triangle is almost always among the first
        tri = v[f[rows]]
        if np.any(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])):
            break
    else:
        raise ValueError("faces: every triangle of the mesh has zero area")
    return v, f.astype(np.int64)


class Mesh(Shape):
    """A triangle mesh (see the module docstring); ``filename`` is where it was read from.

    As Mitsuba, a mesh without vertex normals read from a file gets its angle-weighted
    vertex normals (smooth shading) unless ``face_normals``: :meth:`from_file`."""

    has_barycentrics = True
    #: Mitsuba's default ``flip_tex_coords`` of the file format (None: no such parameter)
    FLIP_TEX_COORDS: bool | None = False
    FORMAT = ""

    @classmethod
    def from_file(cls, path, *, face_normals: bool = False, flip_tex_coords: bool | None = None,
                  shape_index: int = 0, **common) -> "Mesh":
        """A mesh read from ``path`` (:func:`vrlab.render.meshes.read_mesh`), shaded as Mitsuba
        shades it: its vertex normals, Mitsuba's angle-weighted ones where the file has none,
        or flat with ``face_normals``."""
        from ..meshes import read_mesh

        flip = cls.FLIP_TEX_COORDS if flip_tex_coords is None else flip_tex_coords
        try:
            data = read_mesh(path, format=cls.FORMAT or None, face_normals=face_normals,
                             flip_tex_coords=bool(flip), shape_index=shape_index)
        except (OSError, ValueError) as exc:
            raise ValueError(f"filename: cannot read the {cls.FORMAT or 'mesh'} file: {exc}") from None
        if data.normals is None and not face_normals:
            data = data.with_vertex_normals()
        return cls(vertices=data.vertices, faces=data.faces, normals=data.normals, uvs=data.uvs,
                   face_normals=face_normals, filename=str(path), vertex_attributes=data.vertex_attributes,
                   face_attributes=data.face_attributes, **common)

    @classmethod
    def from_props(cls, p) -> "Mesh":
        kw = {}
        if cls.FLIP_TEX_COORDS is not None:
            kw["flip_tex_coords"] = p.bool("flip_tex_coords", cls.FLIP_TEX_COORDS)
        return cls.from_file(p.filename("filename"), face_normals=p.bool("face_normals", False),
                             **kw, **cls.common(p))

    def __init__(self, *, vertices: Any, faces: Any, normals: Any = None, uvs: Any = None,
                 face_normals: bool = False, filename: str | None = None,
                 vertex_attributes: dict | None = None, face_attributes: dict | None = None, **common):
        super().__init__(**common)
        self.vertices, self.faces = check_mesh(vertices, faces)
        self.face_normals = checks.flag(face_normals, "face_normals")
        self.normals = None if normals is None or self.face_normals else \
            checks.finite_array(normals, "normals", ndim=2, last=3)
        if self.normals is not None and len(self.normals) != len(self.vertices):
            raise ValueError(f"normals: expected one per vertex ({len(self.vertices)}), got {len(self.normals)}")
        self.uvs = None if uvs is None else checks.finite_array(uvs, "uvs", ndim=2, last=2)
        if self.uvs is not None and len(self.uvs) != len(self.vertices):
            raise ValueError(f"uvs: expected one per vertex ({len(self.vertices)}), got {len(self.uvs)}")
        self.vertex_attributes = dict(vertex_attributes or {})
        self.face_attributes = dict(face_attributes or {})
        self.filename = filename
        check_world_points(self.vertices, self.to_world)

    def validate(self) -> None:
        super().validate()
        self._light_surface = self._faces_cache = self._world_cache = None
        self.vertices, self.faces = check_mesh(self.vertices, self.faces)
        check_world_points(self.vertices, self.to_world)

    @property
    def params(self) -> dict:
        """``{"vertices", "faces", "filename"}`` (the mesh data)."""
        return {"vertices": self.vertices, "faces": self.faces, "filename": self.filename}

    def world_vertices(self) -> np.ndarray:
        """``(V, 3)`` float64 world positions of the vertices, ``to_world`` applied row by row
        (elementwise multiply-adds: a gather of them has the bits of transforming the gathered
        rows); the vertex array itself for the identity; computed once per transform and array."""
        key = (self.to_world, self.vertices)
        c = getattr(self, "_world_cache", None)
        if c is None or any(a is not b for a, b in zip(c[0], key)):
            m = self.to_world
            w = self.vertices if np.array_equal(m, np.eye(4)) else matvec3(m[:3, :3], self.vertices) + m[:3, 3]
            c = self._world_cache = (key, w)
        return c[1]

    def world_faces(self) -> np.ndarray:
        """``faces`` in outward winding (reversed by ``flip_normals``)."""
        return self.faces[:, ::-1] if self.flip_normals else self.faces

    def triangles(self) -> np.ndarray:
        return self.world_vertices()[self.world_faces()]

    def parts(self) -> list:
        # a hit's triangle and barycentrics are needed for smooth normals and textures: no pairs
        needs = self.has_shading_normals or bool(self.bsdf.textures) or \
            (self.emitter is not None and self.emitter.texture is not None)
        return [IndexedTriangles(self.world_vertices(), self.world_faces(), merge=not needs)]

    @property
    def has_shading_normals(self) -> bool:
        return self.normals is not None

    def _world_faces(self, prim: np.ndarray) -> tuple:
        """``(v0, d1, d2, m2)`` of the faces ``prim`` in world space, computed for those faces
        only (no per-face table is kept: a mesh of millions of faces is hit in a few of them
        per block): the first vertex, the dual basis of the edges (e2 x m, m x e1 with
        m = e1 x e2) and |m|^2.  The vertices are transformed as one row each
        (:meth:`world_vertices`), so these have the bits of a table over every face."""
        v = self.world_vertices()[self.faces[prim]]                                   # (N, 3, 3)
        v0 = np.ascontiguousarray(v[:, 0])
        e1, e2 = v[:, 1] - v0, v[:, 2] - v0
        n = cross(e1, e2)
        return v0, cross(e2, n), cross(n, e1), dot(n, n)

    def _normal_map(self) -> np.ndarray:
        """to_world^-T (3 x 3), for normals."""
        key = self.to_world
        c = getattr(self, "_faces_cache", None)
        if c is None or c[0] is not key:
            c = self._faces_cache = (key, np.linalg.inv(key[:3, :3]).T)
        return c[1]

    def barycentrics(self, p: np.ndarray, prim: np.ndarray) -> np.ndarray:
        """``(b1, b2)`` of world points ``p`` on triangles ``prim``: p = v0 + b1 (v1 - v0) +
        b2 (v2 - v0) (object-space vertex order; the dual basis of the edges)."""
        v0, d1, d2, m2 = self._world_faces(np.asarray(prim))
        x = np.asarray(p, float) - v0
        out = np.empty((len(x), 2))
        np.divide(dot(x, d1), m2, out=out[:, 0])
        np.divide(dot(x, d2), m2, out=out[:, 1])
        return out

    def uv(self, p, prim):
        """The vertex uvs interpolated with the barycentrics; without uvs, Mitsuba's (b1, b2)."""
        b = self.barycentrics(p, prim)
        if self.uvs is None:
            return b
        t = self.uvs[self.faces[prim]]
        return (1.0 - b[:, :1] - b[:, 1:]) * t[:, 0] + b[:, :1] * t[:, 1] + b[:, 1:] * t[:, 2]

    def shading_normals(self, p: np.ndarray, n: np.ndarray, prim: np.ndarray) -> np.ndarray:
        """Mitsuba's smooth shading: the vertex normals interpolated with the barycentrics,
        N = (1 - b1 - b2) N0 + b1 N1 + b2 N2, mapped by to_world^-T and normalised (negated by
        ``flip_normals``)."""
        if self.normals is None:
            return n
        b = self.barycentrics(p, prim)
        f = self.faces[prim]
        b1, b2 = b[:, 0], b[:, 1]
        b0 = 1.0 - b1
        b0 -= b2
        ns = scale(self.normals[f[:, 0]], b0)
        ns += scale(self.normals[f[:, 1]], b1)
        ns += scale(self.normals[f[:, 2]], b2)
        ns = matvec3(self._normal_map(), ns)                                     # M^-T ns
        length = np.maximum(norm(ns), 1e-300)
        for k in range(3):
            ns[:, k] /= length
        return (-ns if self.flip_normals else ns).astype(np.asarray(n).dtype, copy=False)

    @property
    def center(self) -> np.ndarray:
        return tf.transform_points(self.to_world, self.vertices.mean(0))

    @property
    def bound_radius(self) -> float:
        w = self.world_vertices()
        return float(np.max(np.linalg.norm(w - self.center, axis=-1)))

    def surface(self):
        """The mesh as a light surface: a triangle by area, then uniform in it
        (:class:`vrlab.distributions.TriangleMeshSurface`; built once)."""
        if getattr(self, "_light_surface", None) is None:
            from ...distributions import TriangleMeshSurface

            self._light_surface = TriangleMeshSurface.from_triangles(self.triangles())
        return self._light_surface

    @property
    def area(self) -> float:
        t = self.triangles()
        return float(0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=-1).sum())
