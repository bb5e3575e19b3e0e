"""Mitsuba's ``serialized`` mesh format: reader and writer.

Format (Mitsuba 3 convention, src/shapes/serialized.cpp and its documentation), all
little endian.  A file is a sequence of shapes, each an uncompressed header -- ``uint16``
magic ``0x041C``, ``uint16`` version (3 or 4) -- followed by one zlib stream holding:
``uint32`` flags (``0x0001`` vertex normals, ``0x0002`` uvs, ``0x0008`` vertex colors,
``0x0010`` face normals, ``0x1000`` single / ``0x2000`` double precision); in version 4
only, the shape's name as a NUL-terminated UTF-8 string; ``uint64`` vertex count ``V``;
``uint64`` triangle count ``F``; positions ``V x 3``; normals ``V x 3``; uvs ``V x 2``;
colors ``V x 3`` (each only if flagged, in the flagged precision); faces ``F x 3`` as
``uint32`` (``uint64`` when ``V > 0xFFFFFFFF``).  The file ends with a dictionary: the
byte offset of every shape (``uint64`` in version 4, ``uint32`` in version 3) and the
``uint32`` number of shapes.
"""
from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Sequence

import numpy as np

from .data import MeshData, check_flag, check_path, read_bytes, unit_normals

__all__ = ["read_serialized", "write_serialized"]

MAGIC = 0x041C
HAS_NORMALS, HAS_UVS, HAS_COLORS, FACE_NORMALS = 0x0001, 0x0002, 0x0008, 0x0010
SINGLE, DOUBLE = 0x1000, 0x2000


def _shape_offset(data: bytes, path: str, shape_index: int, version: int) -> int:
    """Byte offset of shape ``shape_index`` from the end-of-file dictionary."""
    if len(data) < 8:
        raise ValueError(f"{path}: the serialized file is truncated (no shape dictionary)")
    (count,) = struct.unpack_from("<I", data, len(data) - 4)
    if shape_index >= count:
        raise ValueError(f"shape_index must lie in [0, {count}) for {path!r} "
                         f"(it holds {count} shapes), got {shape_index}")
    size, code = (8, "<Q") if version == 4 else (4, "<I")
    at = len(data) - 4 - size * (count - shape_index)
    if at < 4:
        raise ValueError(f"{path}: invalid shape dictionary at the end of the serialized file")
    (offset,) = struct.unpack_from(code, data, at)
    if offset + 4 > at or struct.unpack_from("<HH", data, offset) != (MAGIC, version):
        raise ValueError(f"{path}: invalid shape dictionary: shape {shape_index} does not "
                         f"start at byte {offset}")
    return offset


def read_serialized(path: str | os.PathLike, shape_index: int = 0, *,
                    face_normals: bool = False, flip_tex_coords: bool = False) -> MeshData:
    """Read shape ``shape_index`` of a Mitsuba ``.serialized`` file (format: module doc).

    As Mitsuba 3's ``serialized`` shape (src/shapes/serialized.cpp): versions 3 and 4,
    single or double precision, normals normalised, the name stored in a version-4 file
    (else ``"<file name>@<shape_index>"``), the face-normals flag ``0x0010`` ignored (as
    Mitsuba 3.9.1 does; pass ``face_normals=True`` for flat shading, which drops the
    normals).  Vertex colors, which Mitsuba skips, are returned as the
    ``"vertex_color"`` attribute.  ``flip_tex_coords`` (uv ``(u, 1 - v)``) is an
    extension: Mitsuba's serialized plugin has no such parameter (default False = Mitsuba).

    ``ValueError`` naming the file for a wrong magic number or version, ``shape_index``
    beyond the shapes of the file, a corrupt or truncated stream, non-finite positions,
    a zero-length normal or a face index out of range; ``TypeError`` for a non-path
    ``path`` or a non-integer ``shape_index``.
    """
    path = check_path(path)
    if isinstance(shape_index, bool) or not isinstance(shape_index, (int, np.integer)):
        raise TypeError(f"shape_index must be an int, got {type(shape_index).__name__}")
    if shape_index < 0:
        raise ValueError(f"shape_index must be >= 0, got {shape_index}")
    face_normals = check_flag("face_normals", face_normals)
    flip_tex_coords = check_flag("flip_tex_coords", flip_tex_coords)
    data = read_bytes(path, "serialized")
    if len(data) < 4 or struct.unpack_from("<H", data)[0] != MAGIC:
        raise ValueError(f"{path}: not a Mitsuba serialized mesh file (bad magic number)")
    (version,) = struct.unpack_from("<H", data, 2)
    if version not in (3, 4):
        raise ValueError(f"{path}: serialized file version {version} is not supported (3 or 4)")
    offset = _shape_offset(data, path, int(shape_index), version) if shape_index else 0
    stream = zlib.decompressobj()
    try:
        raw = stream.decompress(memoryview(data)[offset + 4:])
    except zlib.error as exc:
        raise ValueError(f"{path}: corrupt compressed data in shape {shape_index}: {exc}") from None
    if not stream.eof:
        raise ValueError(f"{path}: the serialized file is truncated (shape {shape_index})")

    def need(n: int, at: int):
        if at + n > len(raw):
            raise ValueError(f"{path}: shape {shape_index} is truncated: its data needs more "
                             f"than the {len(raw)} bytes stored")

    need(4, 0)
    (flags,) = struct.unpack_from("<I", raw)
    at = 4
    name = f"{os.path.basename(path)}@{shape_index}"
    if version == 4:
        end = raw.find(b"\0", at)
        if end < 0:
            need(len(raw) + 1, 0)
        name = raw[at:end].decode("utf-8", "replace") or name
        at = end + 1
    need(16, at)
    nv, nf = struct.unpack_from("<QQ", raw, at)
    at += 16
    real = np.dtype("<f8" if flags & DOUBLE else "<f4")
    index = np.dtype("<u8" if nv > 0xFFFFFFFF else "<u4")

    def array(dtype, rows, cols):
        nonlocal at
        need(rows * cols * dtype.itemsize, at)
        a = np.frombuffer(raw, dtype, rows * cols, at).reshape(rows, cols)
        at += a.nbytes
        return a.astype(np.float64 if dtype.kind == "f" else np.int64)

    pos = array(real, nv, 3)
    if not np.isfinite(pos).all():
        raise ValueError(f"{path}: shape {shape_index} has non-finite vertex positions")
    normals = array(real, nv, 3) if flags & HAS_NORMALS else None
    uvs = array(real, nv, 2) if flags & HAS_UVS else None
    colors = array(real, nv, 3) if flags & HAS_COLORS else None
    faces = array(index, nf, 3)
    if faces.size and faces.max() >= nv:
        raise ValueError(f"{path}: shape {shape_index} has face indices up to {faces.max()} "
                         f"but {nv} vertices")
    if face_normals:
        normals = None
    elif normals is not None:
        normals = unit_normals(normals, f"{path} (shape {shape_index})")
    if uvs is not None and flip_tex_coords:
        uvs[:, 1] = 1.0 - uvs[:, 1]
    attrs = {} if colors is None else {"vertex_color": colors}
    return MeshData(pos, faces, normals, uvs, attrs, name=name)


def _shape_bytes(mesh: MeshData, version: int, double: bool, level: int) -> bytes:
    real = np.dtype("<f8" if double else "<f4")
    colors = mesh.vertex_attributes.get("vertex_color")
    flags = (DOUBLE if double else SINGLE) | (HAS_NORMALS if mesh.normals is not None else 0) \
        | (HAS_UVS if mesh.uvs is not None else 0) | (HAS_COLORS if colors is not None else 0)
    parts = [struct.pack("<I", flags)]
    if version == 4:
        parts.append(mesh.name.encode("utf-8") + b"\0")
    parts.append(struct.pack("<QQ", mesh.vertex_count, mesh.face_count))
    for a in (mesh.vertices, mesh.normals, mesh.uvs, colors):
        if a is not None:
            parts.append(np.ascontiguousarray(a, real).tobytes())
    index = "<u8" if mesh.vertex_count > 0xFFFFFFFF else "<u4"
    parts.append(np.ascontiguousarray(mesh.faces, index).tobytes())
    return struct.pack("<HH", MAGIC, version) + zlib.compress(b"".join(parts), level)


def write_serialized(path: str | os.PathLike, meshes: MeshData | Sequence[MeshData], *,
                     version: int = 4, double: bool = False, level: int = 6) -> None:
    """Write one or several meshes as a Mitsuba ``.serialized`` file (format: module doc).

    Stores positions, normals and uvs (when present) in single (``double=False``) or
    double precision, the ``"vertex_color"`` attribute (3 channels) as vertex colors, the
    name (version 4 only), faces as ``uint32``; each shape is one zlib stream of
    compression ``level`` (0-9), and the file ends with the shape dictionary.  Mitsuba 3
    reads the result with ``{"type": "serialized", "filename": path, "shape_index": i}``.

    ``TypeError`` for a non-path ``path`` or a ``meshes`` that is not MeshData;
    ``ValueError`` for ``version`` not 3 or 4, ``level`` not in 0..9, a name containing
    NUL, attributes the format cannot hold, or (version 3) a file beyond 4 GiB.
    """
    path = check_path(path)
    double = check_flag("double", double)
    if version not in (3, 4) or isinstance(version, bool):
        raise ValueError(f"version must be 3 or 4, got {version!r}")
    if isinstance(level, bool) or not isinstance(level, (int, np.integer)) or not 0 <= level <= 9:
        raise ValueError(f"level must be an int in 0..9, got {level!r}")
    shapes = [meshes] if isinstance(meshes, MeshData) else meshes
    if isinstance(shapes, (str, bytes)) or not isinstance(shapes, Sequence) or not shapes \
            or not all(isinstance(m, MeshData) for m in shapes):
        raise TypeError("meshes must be a MeshData or a non-empty sequence of MeshData")
    for i, m in enumerate(shapes):
        extra = set(m.vertex_attributes) - {"vertex_color"} | set(m.face_attributes)
        color = m.vertex_attributes.get("vertex_color")
        if extra or (color is not None and color.shape[1] != 3):
            raise ValueError(f"meshes[{i}]: a serialized file stores only a 3-channel "
                             f"'vertex_color' attribute, got {sorted(extra) or 'vertex_color'}"
                             f"{'' if extra else f' with {color.shape[1]} channels'}")
        if "\0" in m.name:
            raise ValueError(f"meshes[{i}]: name must not contain NUL characters")
    blobs = [_shape_bytes(m, version, double, int(level)) for m in shapes]
    offsets = np.cumsum([0] + [len(b) for b in blobs[:-1]])
    if version == 3 and offsets[-1] > 0xFFFFFFFF:
        raise ValueError("version 3 stores 32-bit offsets: the file would exceed 4 GiB")
    table = offsets.astype("<u8" if version == 4 else "<u4").tobytes()
    try:
        with open(path, "wb") as fh:
            fh.writelines(blobs + [table, struct.pack("<I", len(blobs))])
    except OSError as exc:
        raise ValueError(f"path: cannot write {path!r}: {exc.strerror or exc}") from None
