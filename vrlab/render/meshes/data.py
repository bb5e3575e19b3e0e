"""The mesh record shared by the readers, and the helpers they have in common.

:class:`MeshData` is what :func:`~vrlab.render.meshes.read_obj`,
:func:`~vrlab.render.meshes.read_ply` and :func:`~vrlab.render.meshes.read_serialized`
return: an indexed triangle mesh laid out the way Mitsuba 3 stores a ``Mesh`` (one
position, and optionally one normal and one uv, per vertex; three vertex indices per
face), so that the arrays can be compared one to one with ``mi.traverse(shape)``'s
``vertex_positions``, ``vertex_normals``, ``vertex_texcoords`` and ``faces``.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field, replace

import numpy as np

__all__ = ["MeshData", "vertex_normals"]


def _as_array(name: str, a, dtype, cols: int | None, rows: int | None = None) -> np.ndarray:
    """``a`` as a C-contiguous ``dtype`` array of shape ``(rows, cols)`` (``ValueError`` if not)."""
    try:
        out = np.ascontiguousarray(a, dtype=dtype)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a numeric array, got {type(a).__name__}") from None
    want = f"({'N' if rows is None else rows}, {'k' if cols is None else cols})"
    if out.ndim != 2 or (cols is not None and out.shape[1] != cols) \
            or (rows is not None and out.shape[0] != rows):
        raise ValueError(f"{name} must have shape {want}, got {out.shape}")
    return out


@dataclass(frozen=True, eq=False)
class MeshData:
    """An indexed triangle mesh as Mitsuba 3 holds it (Mitsuba 3 convention, src/render/mesh.cpp).

    - ``vertices``: ``(V, 3)`` float64 positions (object space: no ``to_world`` applied);
    - ``faces``: ``(F, 3)`` int64 vertex indices, counter-clockwise seen from the front
      (the geometric normal is ``normalize(cross(p1 - p0, p2 - p0))``);
    - ``normals``: ``(V, 3)`` float64 unit per-vertex shading normals, or ``None`` when the
      file has none (Mitsuba then computes them: see :func:`vertex_normals` and
      :meth:`with_vertex_normals`) or when read with ``face_normals=True`` (flat shading);
    - ``uvs``: ``(V, 2)`` float64 texture coordinates (after the reader's
      ``flip_tex_coords``), or ``None``;
    - ``vertex_attributes`` / ``face_attributes``: extra per-vertex ``(V, k)`` / per-face
      ``(F, k)`` float64 arrays keyed by Mitsuba's ``mesh_attribute`` names
      (``"vertex_color"``, ``"face_color"``, ``"vertex_<prefix>"``, ...);
    - ``name``: the shape's name (the file name, or the name stored in a serialized file).

    The constructor converts and checks the arrays (``ValueError``/``TypeError`` naming
    the field): shapes, finite values, face indices in ``[0, V)``.
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None
    uvs: np.ndarray | None = None
    vertex_attributes: dict = field(default_factory=dict)
    face_attributes: dict = field(default_factory=dict)
    name: str = ""

    def __post_init__(self):
        v = _as_array("vertices", self.vertices, np.float64, 3)
        f = self.faces
        if isinstance(f, np.ndarray) and f.dtype.kind == "f":
            raise TypeError(f"faces must be an integer array, got dtype {f.dtype}")
        f = _as_array("faces", f, np.int64, 3)
        nv = len(v)
        if not np.isfinite(v).all():
            raise ValueError("vertices must be finite")
        if f.size and (f.min() < 0 or f.max() >= nv):
            raise ValueError(f"faces must index vertices in [0, {nv}), got indices in "
                             f"[{f.min()}, {f.max()}]")
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "faces", f)
        for key, cols in (("normals", 3), ("uvs", 2)):
            a = getattr(self, key)
            if a is not None:
                a = _as_array(key, a, np.float64, cols, nv)
                if not np.isfinite(a).all():
                    raise ValueError(f"{key} must be finite")
                object.__setattr__(self, key, a)
        for key, rows in (("vertex_attributes", nv), ("face_attributes", len(f))):
            attrs = getattr(self, key)
            if not isinstance(attrs, dict):
                raise TypeError(f"{key} must be a dict of name -> array, "
                                f"got {type(attrs).__name__}")
            prefix = key.split("_")[0] + "_"
            checked = {}
            for name, a in attrs.items():
                if not isinstance(name, str) or not name.startswith(prefix):
                    raise ValueError(f"{key}: names must be strings starting with {prefix!r}, "
                                     f"got {name!r}")
                checked[name] = _as_array(f"{key}[{name!r}]", a, np.float64, None, rows)
            object.__setattr__(self, key, checked)
        if not isinstance(self.name, str):
            raise TypeError(f"name must be a str, got {type(self.name).__name__}")

    @property
    def vertex_count(self) -> int:
        """``V``, the number of vertices."""
        return len(self.vertices)

    @property
    def face_count(self) -> int:
        """``F``, the number of triangles."""
        return len(self.faces)

    def with_vertex_normals(self) -> "MeshData":
        """This mesh with ``normals`` filled in as Mitsuba 3 does when a file has none.

        Returns ``self`` when ``normals`` is already set; otherwise a copy whose normals
        are :func:`vertex_normals` ``(vertices, faces)`` (Mitsuba 3 convention,
        ``Mesh::recompute_vertex_normals`` in src/render/mesh.cpp).
        """
        if self.normals is not None:
            return self
        return replace(self, normals=vertex_normals(self.vertices, self.faces))


def _unit_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle between unit vectors, accurate near 0 and pi (Mitsuba 3 ``unit_angle``):
    ``2 asin(|a - b| / 2)`` if ``a . b >= 0``, else ``pi - 2 asin(|a + b| / 2)``."""
    dot = np.einsum("...i,...i->...", a, b)
    half_minus = np.linalg.norm(a - b, axis=-1) / 2
    half_plus = np.linalg.norm(a + b, axis=-1) / 2
    return np.where(dot >= 0, 2 * np.arcsin(np.minimum(half_minus, 1.0)),
                    np.pi - 2 * np.arcsin(np.minimum(half_plus, 1.0)))


def vertex_normals(vertices, faces) -> np.ndarray:
    """Angle-weighted vertex normals ``(V, 3)``, as Mitsuba 3 computes them for a mesh without.

    ``n_v = normalize(sum_f theta_{f,v} n_f)`` over the triangles ``f`` that use vertex
    ``v``, with ``n_f = normalize(cross(p1 - p0, p2 - p0))`` and ``theta_{f,v}`` the
    interior angle of ``f`` at ``v`` (Thuermer and Wuethrich, "Computing vertex normals
    from polygonal facets", JGT 3(1), 1998).  Triangles of zero area are skipped; a vertex
    that no non-degenerate triangle uses gets the placeholder ``(1, 0, 0)``.  Mitsuba 3
    convention, ``Mesh::recompute_vertex_normals`` in src/render/mesh.cpp (which computes
    in float32; this is float64).
    """
    v = _as_array("vertices", vertices, np.float64, 3)
    f = _as_array("faces", faces, np.int64, 3)
    if f.size and (f.min() < 0 or f.max() >= len(v)):
        raise ValueError(f"faces must index vertices in [0, {len(v)})")
    p = v[f]                                        # (F, 3 corners, 3 xyz)
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    length = np.linalg.norm(n, axis=1)
    ok = length > 0
    p, f, n = p[ok], f[ok], n[ok] / length[ok, None]
    # Interior angle at corner j, between the edges towards the two other corners.
    e_next = np.roll(p, -1, axis=1) - p             # p[j+1] - p[j]
    e_prev = np.roll(p, 1, axis=1) - p              # p[j-1] - p[j]
    e_next /= np.linalg.norm(e_next, axis=2, keepdims=True)
    e_prev /= np.linalg.norm(e_prev, axis=2, keepdims=True)
    theta = _unit_angle(e_next, e_prev)             # (F, 3)
    acc = np.zeros((len(v), 3))
    w = (theta[:, :, None] * n[:, None, :]).reshape(-1, 3)
    idx = f.ravel()
    for k in range(3):
        acc[:, k] = np.bincount(idx, weights=w[:, k], minlength=len(v))
    norm = np.linalg.norm(acc, axis=1)
    bad = norm == 0
    acc[bad] = (1.0, 0.0, 0.0)
    norm[bad] = 1.0
    return acc / norm[:, None]


# ---------------------------------------------------------------- helpers for the readers

def check_path(path) -> str:
    """``path`` as a str (``TypeError`` unless it is a str or ``os.PathLike``)."""
    if isinstance(path, bytes) or not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a file path (str or os.PathLike), got {type(path).__name__}")
    return os.fspath(path)


def check_flag(name: str, value) -> bool:
    """A keyword that must be a bool (``TypeError`` otherwise)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def read_bytes(path: str, kind: str) -> bytes:
    """The whole file (``ValueError`` naming it when it cannot be read)."""
    try:
        with open(path, "rb") as fh:
            return fh.read()
    except OSError as exc:
        raise ValueError(f"path: cannot read {kind} file {path!r}: {exc.strerror or exc}") from None


def fan(counts: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fan triangulation of polygons: ``(T, 3)`` corner indices and the polygon of each.

    A polygon with corners ``c_0 .. c_{k-1}`` (``k = counts[i] >= 3``, ``c_j =
    offsets[i] + j``) gives the triangles ``(c_0, c_j, c_{j+1})``, ``j = 1 .. k-2``:
    Mitsuba 3's OBJ loader (src/shapes/obj.cpp) triangulates this way.
    """
    nt = counts.astype(np.int64) - 2
    poly = np.repeat(np.arange(len(counts)), nt)
    first = offsets[poly]
    j = np.arange(len(poly)) - np.repeat(np.cumsum(nt) - nt, nt) + 1
    return np.stack([first, first + j, first + j + 1], axis=1), poly


def unit_normals(n: np.ndarray, where: str) -> np.ndarray:
    """Normalise file normals as Mitsuba 3 does; ``ValueError`` for zero-length or non-finite."""
    length = np.linalg.norm(n, axis=1)
    bad = ~(np.isfinite(length) & (length > 0))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"{where}: vertex normal {i} ({', '.join(f'{x:g}' for x in n[i])}) "
                         "has zero length or is not finite (read with face_normals=True to "
                         "ignore the file's normals)")
    return n / length[:, None]
