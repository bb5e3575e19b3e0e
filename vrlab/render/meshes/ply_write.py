"""PLY writer whose files Mitsuba 3's ``ply`` shape and :func:`read_ply` read back."""
from __future__ import annotations

import io
import os

import numpy as np

from .data import MeshData, check_flag, check_path

__all__ = ["write_ply"]


def _fields(name: str, dim: int, kind: str, where: str) -> tuple[str, list[str]]:
    """PLY property names of attribute ``name`` (and their grouping prefix) such that
    Mitsuba's grouping rules (see ``ply._group``) give ``name`` back."""
    base = name[len(kind) + 1:]
    if base == "color" and dim in (3, 4):
        return "", list("rgba"[:dim])
    if not base or any(c.isspace() for c in base) or dim not in (1, 3):
        raise ValueError(f"{where}: attribute {name!r} with {dim} channels cannot be written: "
                         "Mitsuba's PLY reader groups 1 or 3 properties (3 or 4 for "
                         f"'{kind}_color') under a non-empty name without spaces")
    if base.endswith("_color") and len(base) > 6:
        return base[:-6], [f"{base[:-6]}_{c}" for c in "rgb"[:dim]]
    return base, [f"{base}_{c}" for c in "xyz"[:dim]]


def _columns(mesh: MeshData, kind: str) -> list[tuple[str, np.ndarray]]:
    attrs = mesh.vertex_attributes if kind == "vertex" else mesh.face_attributes
    cols, prefixes = [], {}
    for name, a in attrs.items():
        prefix, names = _fields(name, a.shape[1], kind, f"mesh.{kind}_attributes")
        if prefix in prefixes:
            raise ValueError(f"mesh.{kind}_attributes: {name!r} and {prefixes[prefix]!r} "
                             f"would share the PLY property prefix {prefix!r}")
        prefixes[prefix] = name
        cols += list(zip(names, a.T))
    return cols


def write_ply(path: str | os.PathLike, mesh: MeshData, *, binary: bool = True,
              dtype: str = "float32", big_endian: bool = False) -> None:
    """Write ``mesh`` as a PLY file (binary little/big endian, or ASCII).

    Vertex properties ``x y z``, ``nx ny nz`` (if ``mesh.normals``), ``u v`` (if
    ``mesh.uvs``, written as stored: read back with ``flip_tex_coords=False``), then the
    vertex attributes named so that Mitsuba 3's grouping (src/shapes/ply.h) restores
    them: ``vertex_color`` -> ``r g b [a]``, ``vertex_<p>_color`` -> ``<p>_r ..``,
    ``vertex_<p>`` -> ``<p>_x [<p>_y <p>_z]``; faces as ``list uchar uint
    vertex_indices`` followed by the face attributes named likewise.  Reals are written
    as ``dtype`` (``"float32"``, what Mitsuba keeps, or ``"float64"``, lossless).

    ``TypeError`` for a non-path ``path`` or a ``mesh`` that is not MeshData;
    ``ValueError`` for another ``dtype``, attributes Mitsuba could not read back, or a
    file that cannot be written.
    """
    path = check_path(path)
    if not isinstance(mesh, MeshData):
        raise TypeError(f"mesh must be a MeshData, got {type(mesh).__name__}")
    binary = check_flag("binary", binary)
    big_endian = check_flag("big_endian", big_endian)
    if dtype not in ("float32", "float64", np.float32, np.float64):
        raise ValueError(f"dtype must be 'float32' or 'float64', got {dtype!r}")
    real = np.dtype(dtype)
    if mesh.vertex_count > 0xFFFFFFFF:
        raise ValueError("mesh: PLY 'uint' face indices hold at most 2**32 vertices")
    vcols = [(c, mesh.vertices[:, k]) for k, c in enumerate("xyz")]
    if mesh.normals is not None:
        vcols += [(c, mesh.normals[:, k]) for k, c in enumerate(("nx", "ny", "nz"))]
    if mesh.uvs is not None:
        vcols += [(c, mesh.uvs[:, k]) for k, c in enumerate("uv")]
    vcols += _columns(mesh, "vertex")
    fcols = _columns(mesh, "face")
    tname = "float" if real == np.float32 else "double"
    fmt = "ascii" if not binary else "binary_big_endian" if big_endian else "binary_little_endian"
    head = ["ply", f"format {fmt} 1.0", "comment written by vrlab",
            f"element vertex {mesh.vertex_count}"]
    head += [f"property {tname} {c}" for c, _ in vcols]
    head += [f"element face {mesh.face_count}", "property list uchar uint vertex_indices"]
    head += [f"property {tname} {c}" for c, _ in fcols]
    out = io.BytesIO()
    out.write(("\n".join(head + ["end_header"]) + "\n").encode("ascii"))
    if binary:
        bo = ">" if big_endian else "<"
        vrec = np.empty(mesh.vertex_count, [(c, bo + real.str[1:]) for c, _ in vcols])
        for c, a in vcols:
            vrec[c] = a
        frec = np.empty(mesh.face_count, [("n", "u1"), ("i", bo + "u4", (3,))]
                        + [(c, bo + real.str[1:]) for c, _ in fcols])
        frec["n"], frec["i"] = 3, mesh.faces
        for c, a in fcols:
            frec[c] = a
        out.write(vrec.tobytes())
        out.write(frec.tobytes())
    else:
        num = "%.9g" if real == np.float32 else "%.17g"
        np.savetxt(out, np.stack([a for _, a in vcols], 1).astype(real), fmt=num)
        ftab = np.concatenate([np.full((mesh.face_count, 1), 3), mesh.faces], 1)
        if fcols:   # object table: integer and real columns keep their own formats
            reals = np.stack([a for _, a in fcols], 1).astype(real)
            ftab = np.concatenate([ftab.astype(object), reals.astype(object)], 1)
        np.savetxt(out, ftab, fmt=["%d"] * 4 + [num] * len(fcols))
    try:
        with open(path, "wb") as fh:
            fh.write(out.getbuffer())
    except OSError as exc:
        raise ValueError(f"path: cannot write {path!r}: {exc.strerror or exc}") from None
