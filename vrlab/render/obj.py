"""A tiny Wavefront OBJ reader for the ``obj`` shape (triangles with face normals)."""
from __future__ import annotations

import os

import numpy as np

from .scene_checks import MAX_COORD

__all__ = ["read_obj"]


def _index(token: str, n_verts: int) -> int:
    """0-based vertex index of one ``f`` token (``i``, ``i/t``, ``i//n``, ``i/t/n``)."""
    head = token.split("/")[0]
    try:
        i = int(head)
    except ValueError:
        raise ValueError(f"face index {head!r} is not an integer") from None
    if i == 0:
        raise ValueError("face index 0: OBJ indices start at 1 (negative ones count back)")
    k = i - 1 if i > 0 else n_verts + i
    if not 0 <= k < n_verts:
        raise ValueError(f"face index {i} is out of range: {n_verts} vertices are defined "
                         "before this line")
    return k


def _vertex(tok: list[str]) -> list[float]:
    if len(tok) < 4:
        raise ValueError(f"a vertex needs 3 coordinates, got {len(tok) - 1}")
    try:
        xyz = [float(x) for x in tok[1:4]]
    except ValueError:
        raise ValueError(f"vertex coordinates {' '.join(tok[1:4])!r} are not numbers") from None
    if not all(np.isfinite(xyz)):
        raise ValueError(f"vertex coordinates must be finite, got {' '.join(tok[1:4])}")
    if max(map(abs, xyz)) > MAX_COORD:
        raise ValueError(f"vertex coordinates must lie within +-{MAX_COORD:g}, got {' '.join(tok[1:4])}")
    return xyz


def read_obj(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, bool]:
    """Tiny OBJ reader: ``(vertices (V,3), triangles (T,3) int, has_vertex_normals)``.

    Reads ``v`` and ``f`` lines (``f`` indices may be ``i``, ``i/t``, ``i//n``, ``i/t/n``,
    negative = relative; vertices must come before the faces that use them); polygons
    are fan-triangulated; other lines are ignored.  ``ValueError`` naming the file and
    line for a malformed ``v``/``f`` line, a non-finite or too large (> 1e8) coordinate,
    an index 0 or out of range, a file without faces or whose faces all have zero area,
    or a file that cannot be read (missing, a folder, not UTF-8 text); ``TypeError``
    unless ``path`` is a path.  Single degenerate triangles are kept (rays miss them).
    """
    if not isinstance(path, (str, os.PathLike)) or isinstance(path, bytes):
        raise TypeError(f"path must be a file path (str or os.PathLike), got {type(path).__name__}")
    verts: list[list[float]] = []
    faces: list[list[int]] = []
    has_vn = False
    try:
        with open(path, encoding="utf-8") as fh:
            for lineno, line in enumerate(fh, 1):
                tok = line.split()
                if not tok:
                    continue
                try:
                    if tok[0] == "v":
                        verts.append(_vertex(tok))
                    elif tok[0] == "vn":
                        has_vn = True
                    elif tok[0] == "f":
                        if len(tok) < 4:
                            raise ValueError(f"a face needs >= 3 vertices, got {len(tok) - 1}")
                        idx = [_index(t, len(verts)) for t in tok[1:]]
                        faces += [[idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1)]
                except ValueError as exc:
                    raise ValueError(f"{path}:{lineno}: {exc}") from None
    except UnicodeDecodeError:
        raise ValueError(f"path: {str(path)!r} is not a UTF-8 text OBJ file") from None
    except OSError as exc:
        raise ValueError(f"path: cannot read OBJ file {str(path)!r}: {exc.strerror or exc}") from None
    if not faces:
        raise ValueError(f"{path}: the OBJ file has no faces ('f' lines)")
    v, f = np.array(verts, float), np.array(faces, np.int64)
    tri = v[f]
    if not np.any(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])):
        raise ValueError(f"{path}: every face of the OBJ file has zero area")
    return v, f, has_vn
