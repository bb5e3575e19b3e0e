"""Triangle mesh files as Mitsuba 3 reads them: OBJ, PLY and Mitsuba's ``serialized``.

``read_obj``, ``read_ply`` and ``read_serialized`` return a :class:`MeshData` whose
``vertices``, ``faces``, ``normals`` and ``uvs`` equal (up to float32 rounding) the
``vertex_positions``, ``faces``, ``vertex_normals`` and ``vertex_texcoords`` that
Mitsuba 3's ``obj``, ``ply`` and ``serialized`` shapes build from the same file (no
``to_world`` applied).  The Mitsuba shape parameters that change the data are keywords
of every reader: ``face_normals`` (flat shading: ``normals=None``) and
``flip_tex_coords`` (uv ``(u, 1 - v)``; Mitsuba's default is True for OBJ, False for PLY;
the serialized plugin has none).  When a file has no normals ``normals`` is ``None``;
:meth:`MeshData.with_vertex_normals` / :func:`vertex_normals` compute Mitsuba's
angle-weighted ones.  ``read_mesh`` picks the reader from the file extension.
"""
from __future__ import annotations

import os

from .data import MeshData, vertex_normals
from ..._lazy import lazy_attributes

__all__ = ["MeshData", "read_mesh", "read_obj", "read_ply", "read_serialized",
           "vertex_normals", "write_ply", "write_serialized", "FORMATS"]

#: Mesh formats by file extension, with Mitsuba's default ``flip_tex_coords``.
FORMATS = {"obj": True, "ply": False, "serialized": False}


def read_mesh(path: str | os.PathLike, *, format: str | None = None,
              face_normals: bool = False, flip_tex_coords: bool | None = None,
              shape_index: int = 0) -> MeshData:
    """Read a mesh file with the reader of its format (Mitsuba 3 shapes ``obj``, ``ply``,
    ``serialized``), chosen by ``format`` or else by the file extension.

    ``flip_tex_coords=None`` takes Mitsuba's default of the format (:data:`FORMATS`);
    ``shape_index`` is for serialized files only.  ``ValueError`` for an unknown format
    or extension (naming the file), and whatever the reader raises.
    """
    from .data import check_path
    p = check_path(path)
    fmt = format if format is not None else os.path.splitext(p)[1][1:].lower()
    if fmt not in FORMATS:
        known = ", ".join(sorted(FORMATS))
        if format is not None:
            raise ValueError(f"format must be one of {known}, got {format!r}")
        raise ValueError(f"path: {p!r} has no known mesh extension "
                         f"(.{', .'.join(sorted(FORMATS))}); pass format= one of {known}")
    flip = FORMATS[fmt] if flip_tex_coords is None else flip_tex_coords
    if fmt == "serialized":
        from .serialized import read_serialized

        return read_serialized(p, shape_index, face_normals=face_normals, flip_tex_coords=flip)
    if shape_index != 0:
        raise ValueError(f"shape_index applies to serialized files only, got {shape_index!r} "
                         f"for {p!r}")
    from .obj import read_obj
    from .ply import read_ply

    reader = read_obj if fmt == "obj" else read_ply
    return reader(p, face_normals=face_normals, flip_tex_coords=flip)


# the readers are imported on first use (start-up time of scenes without meshes)
__getattr__, __dir__ = lazy_attributes(__name__, {"read_obj": "obj", "read_ply": "ply", "write_ply": "ply_write",
                                                  "read_serialized": "serialized",
                                                  "write_serialized": "serialized"}, __all__)
