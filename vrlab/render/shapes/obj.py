"""``obj``: a triangle mesh from a Wavefront OBJ file (Mitsuba 3 ``obj``): ``filename``,
``face_normals`` (default false: smooth shading with the file's vertex normals, or
Mitsuba's angle-weighted ones), ``flip_tex_coords`` (default true), plus the common shape
parameters; read by :func:`vrlab.render.meshes.read_obj` (polygons fan-triangulated,
negative indices, one vertex per distinct corner as in Mitsuba)."""
from __future__ import annotations

from ..registry import register
from .mesh import Mesh

__all__ = ["OBJMesh"]


@register("shape", "obj")
class OBJMesh(Mesh):
    """A mesh from an OBJ file: ``OBJMesh.from_file(path, face_normals=False, **shape)``."""

    FLIP_TEX_COORDS = True
    FORMAT = "obj"
