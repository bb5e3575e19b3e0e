"""Stanford PLY reader (ASCII, binary little and big endian) with Mitsuba 3's conventions.

Elements whose rows all have the same size (the usual case) are read column by column as
strided views of the body, one copy per column; ASCII bodies are converted by one
``np.fromstring`` call.  Elements with lists of
varying length (a mix of triangles and quads) are split into rows by pointer doubling
(vectorised, O(n log n)) instead of a Python loop over the rows.
"""
from __future__ import annotations

import os
import re
import warnings

import numpy as np

from .data import MeshData, check_flag, check_path, fan, read_bytes, unit_normals

__all__ = ["read_ply"]

_TYPES = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4",
          "uint": "u4", "float": "f4", "double": "f8", "int8": "i1", "uint8": "u1",
          "int16": "i2", "uint16": "u2", "int32": "i4", "uint32": "u4", "long": "i8",
          "ulong": "u8", "half": "f2", "float16": "f2", "float32": "f4", "float64": "f8"}
_FORMATS = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}
_END_HEADER = re.compile(rb"(?:^|\n)end_header[ \t\r]*\n")
_POSTFIX = ("xyzw", "rgba", "0123", "1234")     # Mitsuba's attribute name schemes


class _Prop:
    """One ``property`` line: ``dtype`` of the value (or of the list items) and, for a
    list, ``count`` the dtype of its length."""

    def __init__(self, name, dtype, count=None):
        self.name, self.dtype, self.count = name, np.dtype(dtype), count and np.dtype(count)


def _header(data: bytes, path: str):
    """``(byte order or None for ASCII, [(element, count, [_Prop])], body offset)``."""
    if not re.match(rb"ply[ \t\r]*\n", data):
        raise ValueError(f"{path}: not a PLY file (it must start with a 'ply' line)")
    m = _END_HEADER.search(data)
    if m is None:
        raise ValueError(f"{path}: invalid PLY header: no 'end_header' line")
    fmt, elements = 0, []
    for no, line in enumerate(data[:m.start()].decode("latin-1").split("\n")[1:], 2):
        tok = line.split()
        where = f"{path}:{no}: invalid PLY header"
        if not tok or tok[0] in ("comment", "obj_info"):
            continue
        if tok[0] == "format":
            if len(tok) != 3 or tok[1] not in _FORMATS or tok[2] != "1.0":
                raise ValueError(f"{where}: expected 'format ascii|binary_little_endian|"
                                 f"binary_big_endian 1.0', got {line.strip()!r}")
            fmt = _FORMATS[tok[1]]
        elif tok[0] == "element":
            if len(tok) != 3 or not tok[2].isdigit():
                raise ValueError(f"{where}: expected 'element <name> <count>', "
                                 f"got {line.strip()!r}")
            elements.append((tok[1], int(tok[2]), []))
        elif tok[0] == "property":
            if not elements:
                raise ValueError(f"{where}: 'property' before any 'element'")
            bo = "<" if fmt in (0, None) else fmt
            if len(tok) == 3 and tok[1] in _TYPES:
                prop = _Prop(tok[2], bo + _TYPES[tok[1]])
            elif len(tok) == 5 and tok[1] == "list" and tok[2] in _TYPES and tok[3] in _TYPES \
                    and _TYPES[tok[2]][0] in "iu":
                prop = _Prop(tok[4], bo + _TYPES[tok[3]], bo + _TYPES[tok[2]])
            else:
                raise ValueError(f"{where}: expected 'property <type> <name>' or 'property list "
                                 f"<integer type> <type> <name>' with types {sorted(_TYPES)}, "
                                 f"got {line.strip()!r}")
            if any(p.name == prop.name for p in elements[-1][2]):
                raise ValueError(f"{where}: duplicate property {prop.name!r}")
            elements[-1][2].append(prop)
        else:
            raise ValueError(f"{where}: unknown keyword {tok[0]!r}")
    if fmt == 0:
        raise ValueError(f"{path}: invalid PLY header: no 'format' line")
    return fmt, elements, m.end()


class _Body:
    """The element data: ``values`` (ASCII: every number of the body as float64) or
    ``raw`` (binary bytes); ``pos`` is the next unread number / byte."""

    def __init__(self, path, data, offset, order):
        self.path, self.binary, self.pos = path, order is not None, 0
        if self.binary:
            self.raw = np.frombuffer(data, np.uint8, offset=offset)
            return
        try:
            self.values = np.fromstring(data[offset:], sep=" ")
        except ValueError:
            tail = data[offset:].split(b"\n")
            bad = next((i for i, ln in enumerate(tail) if not _numbers(ln)), 0)
            line = data[:offset].count(b"\n") + bad + 1
            raise ValueError(f"{path}:{line}: PLY data is not numbers: "
                             f"{tail[bad].decode('latin-1').strip()[:80]!r}") from None

    @property
    def size(self):
        return len(self.raw) if self.binary else len(self.values)

    def column(self, dtype: np.dtype, start: int, count: int, stride: int, width: int = 0) -> np.ndarray:
        """A strided view of ``count`` values (``width`` > 0: rows of ``width`` values) of
        ``dtype``, the first at ``start`` after ``pos``, one every ``stride`` (bytes, or numbers
        for ASCII)."""
        if not self.binary:
            v = self.values[self.pos + start:self.pos + start + count * stride:stride] if not width else \
                np.lib.stride_tricks.as_strided(self.values[self.pos + start:], (count, width),
                                                (stride * self.values.itemsize, self.values.itemsize),
                                                writeable=False)
            return v
        shape, strides = ((count,), (stride,)) if not width else ((count, width), (stride, dtype.itemsize))
        return np.ndarray(shape, dtype, self.raw.data, self.pos + start, strides)

    def take(self, dtype: np.dtype, at: np.ndarray) -> np.ndarray:
        """Values of ``dtype`` at the given offsets (bytes, or numbers for ASCII)."""
        if not self.binary:
            return self.values[at]
        n = len(self.raw) - dtype.itemsize + 1
        view = np.ndarray((max(n, 0),), dtype, self.raw.data, 0, (1,))
        return view[at]


def _numbers(line: bytes) -> bool:
    try:
        np.fromstring(line, sep=" ")
        return True
    except ValueError:
        return False


def _row_offsets(body: _Body, props, start):
    """Offset of every property of the row(s) starting at ``start`` (array): a list of
    ``(offset, length or None)`` per property, and the offset where the rows end."""
    unit = (lambda dt: dt.itemsize) if body.binary else (lambda dt: 1)
    off, out = start, []
    for p in props:
        if p.count is None:
            out.append((off, None))
            off = off + unit(p.dtype)
        else:
            n = body.take(p.count, np.clip(off, 0, max(body.size - unit(p.count), 0)))
            ok = (off + unit(p.count) <= body.size) & (n >= 0) & (n < 2 ** 31)
            if not body.binary:
                ok &= n == np.floor(n)
            n = np.where(ok, n, -1).astype(np.int64)
            out.append((off, n))
            off = off + unit(p.count) + np.maximum(n, 0) * unit(p.dtype)
            off = np.where(n >= 0, off, body.size + 1)
    return out, off


def _row_starts(body: _Body, props, count: int, name: str) -> np.ndarray:
    """Start offsets of the ``count`` rows of an element (and where it ends), found by
    pointer doubling: with ``L`` the map from an offset to the next row's offset,
    ``S <- S ++ L[S]`` and ``L <- L o L`` double the known prefix of the chain."""
    size, start = body.size, body.pos
    sink = size + 1 - start                     # relative index of "past the end"
    link = np.empty(sink + 1, np.int32 if sink < 2 ** 31 else np.int64)
    for a in range(0, sink, 1 << 22):           # in chunks, to bound the temporaries
        b = min(a + (1 << 22), sink)
        _, nxt = _row_offsets(body, props, np.arange(start + a, start + b))
        link[a:b] = np.minimum(np.asarray(nxt, np.int64) - start, sink)
    link[sink] = sink                           # the sink maps to itself
    chain = np.zeros(1, np.int64)
    while len(chain) < count + 1 and chain[-1] != sink:
        chain = np.concatenate([chain, link[chain]])
        if len(chain) < count + 1:
            link = link[link]
    chain = chain[:count + 1]
    if len(chain) < count + 1 or chain[-1] >= sink:
        raise ValueError(f"{body.path}: the PLY file is truncated or its '{name}' lists "
                         f"are invalid (the {count} rows run past the end of the data)")
    return chain + start


def _read_element(body: _Body, name: str, count: int, props) -> dict:
    """The columns of one element: ``name -> array`` for values, ``name -> (lengths,
    items)`` for lists; advances ``body.pos``."""
    unit = (lambda dt: dt.itemsize) if body.binary else (lambda dt: 1)
    if count == 0 or not props:
        return {p.name: (np.zeros(0, np.int64), np.zeros(0)) if p.count else np.zeros(0)
                for p in props}
    first, end = _row_offsets(body, props, np.array([body.pos]))
    lengths = [None if n is None else int(n[0]) for _, n in first]
    row = int(end[0]) - body.pos
    if end[0] <= body.size and row > 0 and body.pos + count * row <= body.size:
        # try: every row like the first one (then every column is a strided view of the body)
        rel = [int(o[0]) - body.pos for o, _ in first]
        if all(n is None or np.all(body.column(p.count, r, count, row) == n)
               for p, r, n in zip(props, rel, lengths)):
            out = {}
            for p, r, n in zip(props, rel, lengths):
                if n is None:
                    vals = out[p.name] = np.array(body.column(p.dtype, r, count, row))
                else:
                    vals = np.array(body.column(p.dtype, r + unit(p.count), count, row, n).reshape(-1))
                    out[p.name] = (np.full(count, n, np.int64), vals)
                if not body.binary and p.dtype.kind in "iu" and np.any(vals != np.floor(vals)):
                    raise ValueError(f"{body.path}: PLY '{name}' property {p.name!r} must hold integers")
            body.pos += count * row
            return out
    if all(p.count is None for p in props):
        raise ValueError(f"{body.path}: the PLY file is truncated: element '{name}' needs "
                         f"{count * row} {'bytes' if body.binary else 'numbers'}, "
                         f"{body.size - body.pos} are left")
    starts = _row_starts(body, props, count, name)
    cols, _ = _row_offsets(body, props, starts[:-1])
    out = {}
    for p, (off, n) in zip(props, cols):
        if n is None:
            out[p.name] = body.take(p.dtype, off)
        else:
            n = n.astype(np.int64)
            k = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
            at = np.repeat(off + unit(p.count), n) + k * unit(p.dtype)
            out[p.name] = (n, body.take(p.dtype, at))
        vals = out[p.name][1] if p.count else out[p.name]
        if not body.binary:
            for v, dt in ((vals, p.dtype), (n, p.count)):
                if dt is not None and dt.kind in "iu" and np.any(v != np.floor(v)):
                    raise ValueError(f"{body.path}: PLY '{name}' property {p.name!r} must "
                                     "hold integers")
    body.pos = int(starts[-1])
    return out


def _group(names, kind: str, reserved: set, path: str) -> list[tuple[str, list[str]]]:
    """Mitsuba 3's grouping of extra PLY properties into mesh attributes (src/shapes/ply.h,
    ``find_other_fields``): ``r g b [a]`` (or ``red green blue [alpha]``) make
    ``<kind>_color``; consecutive ``<p>_x <p>_y <p>_z`` (schemes ``xyzw``, ``rgba``,
    ``0123``, ``1234``) make ``<kind>_<p>`` (``<kind>_<p>_color`` for ``rgba``), from 1
    or 3 fields.  Anything else is ignored with a warning, as Mitsuba does."""
    groups, seen, cur = [], set(), None
    ignored = []

    def flush():
        nonlocal cur
        pre, scheme, fields = cur
        if len(fields) in (1, 3):
            groups.append((f"{kind}_{pre}{'_color' if scheme == 1 else ''}", fields))
            seen.add(pre)
        else:
            ignored.append(f"{'/'.join(fields)} (1 or 3 fields are grouped)")
        cur = None

    for nm in names:
        if nm in reserved:
            continue
        pre, _, post = nm.rpartition("_")
        if not pre or len(post) != 1 or (cur is None and pre in seen):
            if cur is not None:
                flush()
            ignored.append(nm)
            continue
        if cur is not None and pre != cur[0]:
            flush()
        if cur is None:
            scheme = next((s for s, chars in enumerate(_POSTFIX) if chars[0] == post), None)
            if scheme is None:
                ignored.append(nm)
                continue
            cur = (pre, scheme, [])
        if len(cur[2]) >= 4 or post != _POSTFIX[cur[1]][len(cur[2])]:
            ignored.append(f"{'/'.join(cur[2] + [nm])} (bad name sequence)")
            cur = None
            continue
        cur[2].append(nm)
    if cur is not None:
        flush()
    if ignored:
        warnings.warn(f"{path}: PLY {kind} properties ignored as Mitsuba 3 ignores them: "
                      f"{', '.join(ignored)}", stacklevel=4)
    return groups


def _colors(cols: dict, kind: str) -> tuple[list, set]:
    """Mitsuba's color group (``r g b [a]`` or ``red green blue [alpha]``) and the names
    it reserves."""
    for names in (("r", "g", "b", "a"), ("red", "green", "blue", "alpha")):
        if all(n in cols for n in names[:3]):
            fields = list(names[:3]) + ([names[3]] if names[3] in cols else [])
            return [(f"{kind}_color", fields)], set(fields) | {"r", "g", "b", "a"}
    return [], {"r", "g", "b", "a"}


def read_ply(path: str | os.PathLike, *, face_normals: bool = False,
             flip_tex_coords: bool = False) -> MeshData:
    """Read a PLY triangle mesh as Mitsuba 3's ``ply`` shape does (src/shapes/ply.cpp, ply.h).

    ASCII and binary (little or big endian) PLY 1.0 with the types ``char uchar short
    ushort int uint float double`` and the aliases ``int8 .. float64 long ulong half``.
    The ``vertex`` element gives ``x y z``; ``nx ny nz`` (normalised) unless
    ``face_normals``; uvs from ``u v``, else ``texture_u texture_v``, else ``s t``, as
    ``(u, 1 - v)`` when ``flip_tex_coords`` (Mitsuba's default for PLY: False).  The
    ``face`` element's ``vertex_index`` (else ``vertex_indices``) lists give the faces;
    polygons are fan-triangulated ``(c_0, c_j, c_{j+1})`` (an extension: Mitsuba 3.9.1
    accepts triangles only) and their face attributes repeated per triangle.  Other
    properties become ``vertex_*``/``face_*`` attributes by Mitsuba's grouping rules
    (see ``_group``); other elements are skipped.  Values keep their number (Mitsuba
    3.9.1 rescales integer-typed positions and ``<p>_x`` attributes to [0, 1]).

    ``ValueError`` naming the file for a malformed header, truncated data or trailing
    data, non-numbers in an ASCII body, a missing ``x y z`` or face list, a polygon with
    fewer than 3 corners, an index out of range, non-finite positions or a zero-length
    normal; ``TypeError`` unless ``path`` is a path.
    """
    path = check_path(path)
    face_normals = check_flag("face_normals", face_normals)
    flip_tex_coords = check_flag("flip_tex_coords", flip_tex_coords)
    data = read_bytes(path, "PLY")
    order, elements, offset = _header(data, path)
    body = _Body(path, data, offset, order)
    read = {}
    for name, count, props in elements:
        read.setdefault(name, _read_element(body, name, count, props))
    if body.pos != body.size:
        raise ValueError(f"{path}: trailing data after the PLY elements "
                         f"({body.size - body.pos} {'bytes' if body.binary else 'numbers'})")
    if "vertex" not in read or not all(isinstance(read["vertex"].get(c), np.ndarray)
                                       for c in "xyz"):
        raise ValueError(f"{path}: the PLY file has no 'vertex' element with x, y, z properties")
    vcols = read["vertex"]
    pos = np.stack([vcols[c] for c in "xyz"], axis=1).astype(np.float64)
    if not np.isfinite(pos).all():
        raise ValueError(f"{path}: vertex positions must be finite")
    nv = len(pos)
    lists = {k: v for k, v in read.get("face", {}).items() if isinstance(v, tuple)}
    key = "vertex_index" if "vertex_index" in lists else "vertex_indices"
    if key not in lists or not len(lists[key][0]):
        raise ValueError(f"{path}: the PLY file has no faces (a 'face' element with a "
                         "'vertex_index' or 'vertex_indices' list)")
    n, idx = lists[key]
    if (n < 3).any():
        raise ValueError(f"{path}: PLY face {int(np.argmax(n < 3))} has fewer than 3 vertices")
    idx = idx.astype(np.int64)
    if idx.min() < 0 or idx.max() >= nv:
        raise ValueError(f"{path}: PLY face indices must lie in [0, {nv}), got "
                         f"[{idx.min()}, {idx.max()}]")
    if (n == 3).all():
        faces, poly = idx.reshape(-1, 3), None
    else:
        tri, poly = fan(n, np.cumsum(n) - n)
        faces = idx[tri]
    normals = None
    if not face_normals and all(c in vcols for c in ("nx", "ny", "nz")):
        normals = unit_normals(np.stack([vcols[c] for c in ("nx", "ny", "nz")], 1)
                               .astype(np.float64), path)
    uvs = None
    for u, v in (("u", "v"), ("texture_u", "texture_v"), ("s", "t")):
        if u in vcols and v in vcols:
            uvs = np.stack([vcols[u], vcols[v]], 1).astype(np.float64)
            if flip_tex_coords:
                uvs[:, 1] = 1.0 - uvs[:, 1]
            uv_names = {u, v}
            break
    else:
        uv_names = set()
    attrs = {}
    for kind, cols, base in (("vertex", vcols, {"x", "y", "z", "nx", "ny", "nz", "u", "v"}
                              | uv_names), ("face", read.get("face", {}), {key})):
        groups, reserved = _colors(cols, kind)
        scalar = [k for k, v in cols.items() if isinstance(v, np.ndarray)]
        others = [k for k, v in cols.items() if not isinstance(v, np.ndarray) and k != key]
        if kind == "face" and others:
            warnings.warn(f"{path}: PLY face list properties ignored: {', '.join(others)}",
                          stacklevel=2)
        groups += _group(scalar, kind, base | reserved, path)
        attrs[kind] = {a: np.stack([cols[f] for f in fields], 1).astype(np.float64)
                       for a, fields in groups}
    if poly is not None:
        attrs["face"] = {a: v[poly] for a, v in attrs["face"].items()}
    return MeshData(pos, faces, normals, uvs, attrs["vertex"], attrs["face"],
                    name=os.path.basename(path))
