"""``ply``: a triangle mesh from a PLY file, ASCII or binary (Mitsuba 3 ``ply``): ``filename``,
``face_normals`` (default false), ``flip_tex_coords`` (default false), plus the common shape
parameters; ``vertex_*`` and ``face_*`` properties become mesh attributes
(:func:`vrlab.render.meshes.read_ply`)."""
from __future__ import annotations

from ..registry import register
from .mesh import Mesh

__all__ = ["PLYMesh"]


@register("shape", "ply")
class PLYMesh(Mesh):
    """A mesh from a PLY file: ``PLYMesh.from_file(path, face_normals=False, **shape)``."""

    FLIP_TEX_COORDS = False
    FORMAT = "ply"
