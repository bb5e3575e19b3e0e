"""``serialized``: a triangle mesh from Mitsuba's compressed ``serialized`` format (Mitsuba 3
``serialized``): ``filename``, ``shape_index`` (default 0), ``face_normals`` (default
false), plus the common shape parameters (:func:`vrlab.render.meshes.read_serialized`)."""
from __future__ import annotations

from ..registry import register
from .mesh import Mesh

__all__ = ["SerializedMesh"]


@register("shape", "serialized")
class SerializedMesh(Mesh):
    """A mesh from a serialized file: ``SerializedMesh.from_file(path, shape_index=0, **shape)``."""

    FLIP_TEX_COORDS = None
    FORMAT = "serialized"

    @classmethod
    def from_props(cls, p) -> "SerializedMesh":
        index = p.int("shape_index", 0)
        if index < 0:
            raise ValueError(f"shape_index must be >= 0, got {index}")
        return cls.from_file(p.filename("filename"), face_normals=p.bool("face_normals", False),
                             shape_index=index, **cls.common(p))
