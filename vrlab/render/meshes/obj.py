"""Wavefront OBJ reader that builds the same vertex buffers as Mitsuba 3's ``obj`` shape.

The whole file is parsed with NumPy on its bytes (no Python loop over lines): lines are
classified by their keyword, the text of each kind is gathered into one buffer and
converted by a single ``np.fromstring`` call; tokens are located through cumulative sums
over "events" (token starts, slashes, newlines).  Only error paths look at single lines.
"""
from __future__ import annotations

import os

import numpy as np

from .data import MeshData, check_flag, check_path, fan, read_bytes, vertex_normals

__all__ = ["read_obj"]

_LEAD = np.zeros(256, bool)
_LEAD[[9, 13, 32]] = True                # what Mitsuba skips at the start of a line
_SEP = np.zeros(256, bool)
_SEP[[9, 32]] = True                     # what must follow a keyword
_V, _VT, _VN, _F = 1, 2, 3, 4
_KEYWORD_LEN = np.array([0, 1, 2, 2, 1], np.int64)


class _Lines:
    """Line table of the file: start, first non-blank byte, end (its ``\\n``), kind."""

    def __init__(self, data: bytes):
        self.buf = buf = np.frombuffer(data + b"\n\0\0\0", np.uint8)
        end = np.flatnonzero(buf == 10)
        self.end = end[:-1] if data.endswith(b"\n") else end   # the added \n ends no line
        self.start = np.concatenate(([0], self.end[:-1] + 1))
        first = self.start.copy()
        idx = np.flatnonzero(_LEAD[buf[first]])
        pos = first[idx]
        while idx.size:                         # vectorised over the indented lines
            pos = pos + 1
            more = _LEAD[buf[pos]]
            first[idx[~more]] = pos[~more]
            idx, pos = idx[more], pos[more]
        self.first = first
        c0, c1, c2 = buf[first], buf[first + 1], buf[first + 2]
        kind = np.zeros(len(first), np.int8)
        is_v = c0 == ord("v")
        kind[is_v & _SEP[c1]] = _V
        kind[is_v & (c1 == ord("t")) & _SEP[c2]] = _VT
        kind[is_v & (c1 == ord("n")) & _SEP[c2]] = _VN
        kind[(c0 == ord("f")) & _SEP[c1]] = _F
        self.kind = kind

    def text(self, i: int) -> str:
        """Line ``i`` (0-based) as text, for error messages."""
        s = self.buf[self.start[i]:self.end[i]].tobytes().decode("utf-8", "replace").strip()
        return repr(s if len(s) <= 80 else s[:77] + "...")

    def gather(self) -> dict:
        """Per kind of line: its bytes after the keyword (each line ending in ``\\n``, with
        comments blanked), the global index of each line, the offset of each ``\\n``."""
        lines = np.flatnonzero(self.kind)
        kind = self.kind[lines]
        d = np.zeros(len(self.buf) + 1, np.int8)     # the ranges [lo, end] are disjoint
        d[self.first[lines] + _KEYWORD_LEN[kind]] = kind    # and no lo is another's end + 1
        d[self.end[lines] + 1] = -kind
        code = np.cumsum(d[:-1], dtype=np.int8)
        out = {}
        for k in (_V, _VT, _VN, _F):
            sub = self.buf[code == k]
            nl = np.flatnonzero(sub == 10)
            hashes = np.flatnonzero(sub == ord("#"))
            if hashes.size:                          # '#' to the end of the line: comment
                stop, first = np.unique(nl[np.searchsorted(nl, hashes)], return_index=True)
                d = np.zeros(len(sub) + 1, np.int8)
                d[hashes[first]], d[stop] = 1, -1
                sub[np.cumsum(d[:-1], dtype=np.int8).view(bool)] = 32
            out[k] = sub, lines[kind == k], nl
        return out


def _starts(sep: np.ndarray) -> np.ndarray:
    """Mask of the bytes that start a run of non-``sep`` bytes."""
    start = ~sep
    start[1:] &= sep[:-1]
    return start


def _line_of(newline_events: np.ndarray) -> np.ndarray:
    """Line index of every event, given which events are the lines' ``\\n``."""
    return np.cumsum(newline_events) - newline_events


def _parse(sub: np.ndarray, dtype) -> np.ndarray | None:
    """All whitespace-separated numbers of ``sub`` (``None`` if one is not a number)."""
    try:
        return np.fromstring(sub.tobytes(), dtype=dtype, sep=" ")
    except ValueError:
        return None


def _first_bad_line(sub: np.ndarray, nl: np.ndarray, dtype) -> int:
    """Index of the first line of ``sub`` that does not parse (bisection: O(len(sub)))."""
    lo, hi = 0, len(nl)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        a = nl[lo - 1] + 1 if lo else 0
        if _parse(sub[a:nl[mid - 1] + 1], dtype) is None:
            hi = mid
        else:
            lo = mid
    return lo


class _Parser:
    """One OBJ file being read; ``fail`` raises a ``ValueError`` naming file and line."""

    def __init__(self, path: str, data: bytes):
        self.path, self.lines = path, _Lines(data)
        self.kinds = self.lines.gather()

    def fail(self, line: int, msg: str):
        raise ValueError(f"{self.path}:{line + 1}: {msg}: {self.lines.text(line)}")

    def floats(self, kind: int, k: int, what: str) -> tuple[np.ndarray, np.ndarray]:
        """The first ``k`` numbers of every line of ``kind`` (``(n, k)``), and the lines."""
        sub, lines, nl = self.kinds[kind]
        if not len(lines):
            return np.zeros((0, k)), lines
        events = _starts(sub <= 32)             # token starts, and the \\n
        events[nl] = True
        ev = np.flatnonzero(events)
        del events
        e_nl = sub[ev] == 10
        e_tok = ~e_nl
        per_line = np.diff(np.cumsum(e_tok)[e_nl], prepend=0)
        if (per_line < k).any():
            self.fail(lines[np.argmax(per_line < k)], f"a {what} needs {k} numbers")
        if (per_line > k).any():                # Mitsuba ignores what follows: blank it
            seen = np.cumsum(e_tok)             # tokens up to each event
            before = np.concatenate(([0], seen[e_nl]))[_line_of(e_nl)]
            rank = seen - 1 - before            # rank of each token in its line
            cut = ev[e_tok & (rank >= k)]
            ws = sub <= 32
            end = np.flatnonzero(~ws[:-1] & ws[1:]) + 1     # token ends, in token order
            d = np.zeros(len(sub) + 1, np.int8)
            d[cut], d[end[np.searchsorted(end, cut)]] = 1, -1
            sub[np.cumsum(d[:-1], dtype=np.int8).view(bool)] = 32
        vals = _parse(sub, np.float64)
        if vals is None:
            self.fail(lines[_first_bad_line(sub, nl, np.float64)],
                      f"{what} values are not numbers")
        vals = vals.reshape(-1, k)
        bad = ~np.isfinite(vals).all(axis=1)
        if bad.any():
            self.fail(lines[np.argmax(bad)], f"{what} values must be finite")
        return vals, lines

    def corners(self):
        """Per corner of every ``f`` line: raw (file) v, vt, vn indices (0 = absent), the
        ``f`` line of each corner (index into the returned lines), corners per line, the
        first corner of each line and the ``f`` lines."""
        sub, lines, nl = self.kinds[_F]
        slash = sub == ord("/")
        sep = sub <= 32
        sep |= slash
        events = _starts(sep)                   # number starts, then also / and \\n
        del sep
        events |= slash
        events[nl] = True
        ev = np.flatnonzero(events)
        del events
        byte = sub[ev]
        e_s, e_nl = byte == ord("/"), byte == 10
        e_n = ~(e_s | e_nl)                     # a number starts at every other event
        after_ws = sub[np.maximum(ev - 1, 0)] <= 32
        e_c = e_n & after_ws                    # ... and a corner where whitespace precedes
        line = _line_of(e_nl)
        if (e_s & after_ws).any():
            self.fail(lines[line[np.argmax(e_s & after_ws)]],
                      "a face corner must start with a vertex index")
        cev = np.flatnonzero(e_c)               # event of each corner start
        cline = line[cev]
        sub[slash] = 32                         # "3/1/2" -> "3 1 2" (sub is a copy)
        del slash
        vals = _parse(sub, np.int64)
        nev = np.flatnonzero(e_n)
        if vals is None or len(vals) != len(nev):
            self.fail(lines[_first_bad_line(sub, nl, np.int64)],
                      "face indices must be integers (v, v/vt, v//vn or v/vt/vn)")
        cid = np.cumsum(e_c) - 1                # corner of every event
        slashes = np.cumsum(e_s)
        slot = (slashes - slashes[cev][cid])[nev]
        if (slot > 2).any():
            self.fail(lines[line[nev[np.argmax(slot > 2)]]],
                      "a face corner has at most 3 indices (v/vt/vn)")
        nc = len(cev)
        raw = np.zeros((3, nc), np.int64)
        raw[slot, cid[nev]] = vals
        has = np.zeros((3, nc), bool)
        has[slot, cid[nev]] = True
        count = np.bincount(cline, minlength=len(lines))
        if (count < 3).any():
            self.fail(lines[np.argmax(count < 3)], "a face needs at least 3 vertices")
        offset = np.cumsum(count) - count
        for s in (1, 2):                        # Mitsuba 3.9.1 keeps the previous corner's
            last = np.where(has[s], np.arange(nc), -1)   # vt/vn when a corner omits them
            np.maximum.accumulate(last, out=last)
            raw[s] = np.where(last >= offset[cline], raw[s][last], 0)
        return raw, cline, count, offset, lines

    def resolve(self, raw, present, above, limit, cline, flines, what):
        """0-based indices of the corners' 1-based file indices ``raw`` (negative: relative
        to the ``above`` entries defined above the line); a positive index must be below
        ``limit`` (per corner), a negative one must not reach before the first entry."""
        a = above[cline]
        idx = np.where(raw > 0, raw - 1, a + raw)
        bad = present & ((raw == 0) | (idx < 0) | ((raw > 0) & (idx >= limit)))
        if bad.any():
            i = int(np.argmax(bad))
            r, line = int(raw[i]), int(flines[cline[i]])
            if r == 0:
                self.fail(line, f"{what} index 0 is invalid: OBJ indices start at 1")
            n = int(limit[i]) if r > 0 else int(a[i])
            where = " before this line" if r < 0 or what == "vertex" else " in the file"
            self.fail(line, f"{what} index {r} is out of range: {n} {what} entries are "
                      f"defined{where}")
        return np.where(present, idx, -1)


def read_obj(path: str | os.PathLike, *, face_normals: bool = False,
             flip_tex_coords: bool = True) -> MeshData:
    """Read a Wavefront OBJ file into the vertex and face buffers Mitsuba 3 builds from it.

    Reads ``v`` (first 3 numbers), ``vt`` (first 2), ``vn`` (first 3) and ``f`` lines
    with corners ``v``, ``v/vt``, ``v//vn`` or ``v/vt/vn``; indices are 1-based, negative
    ones count back from the last entry defined above the line (an extension: Mitsuba
    3.9.1 rejects them).  Every other line (``#``, ``o``, ``g``, ``s``, ``usemtl``,
    ``mtllib``, ``l``, ...) is ignored, and ``#`` starts a comment anywhere.  As Mitsuba
    3 (src/shapes/obj.cpp):

    - a polygon ``c_0 .. c_{k-1}`` is fan-triangulated into ``(c_0, c_j, c_{j+1})``;
    - one vertex is made per distinct ``(v, vt, vn)`` corner, numbered in order of first
      appearance, so ``V``, the vertex order and ``faces`` equal Mitsuba's; a corner that
      omits vt or vn reuses those of the previous corner of the same ``f`` line, as
      Mitsuba 3.9.1 does;
    - normals are normalised; uvs are ``(u, 1 - v)`` when ``flip_tex_coords`` (Mitsuba's
      default for OBJ: True);
    - ``face_normals=True`` (flat shading) drops the normals (``normals=None``) but keeps
      the vertex split by vn, as Mitsuba does.

    ``normals`` is ``None`` when no corner names a vn (Mitsuba then computes them:
    :meth:`MeshData.with_vertex_normals`); corners without vn in a file where others have
    one get the computed normal (Mitsuba 3.9.1 leaves them uninitialised), and corners
    without vt get uv ``(0, 0)``.  ``uvs`` is ``None`` when no corner names a vt.

    ``ValueError`` naming file and line for a non-number, a missing coordinate, a
    non-finite value, a zero-length normal, an index 0 or out of range (v must be defined
    above the face; positive vt/vn may be defined anywhere, as in Mitsuba), a corner with
    more than 3 indices, a face with fewer than 3 corners, a file without faces or that
    cannot be read; ``TypeError`` unless ``path`` is a path.
    """
    path = check_path(path)
    face_normals = check_flag("face_normals", face_normals)
    flip_tex_coords = check_flag("flip_tex_coords", flip_tex_coords)
    p = _Parser(path, read_bytes(path, "OBJ"))
    pos, _ = p.floats(_V, 3, "vertex (v)")
    uv, _ = p.floats(_VT, 2, "texture coordinate (vt)")
    nrm, vn_lines = p.floats(_VN, 3, "normal (vn)")
    if not face_normals and len(nrm):
        length = np.linalg.norm(nrm, axis=1)
        if (length == 0).any():
            p.fail(int(vn_lines[np.argmax(length == 0)]),
                   "a normal (vn) must not have zero length")
        nrm /= length[:, None]
    raw, cline, count, offset, flines = p.corners()
    if not len(flines):
        raise ValueError(f"{path}: the OBJ file has no faces ('f' lines)")
    above = [np.cumsum(p.lines.kind == k)[flines] for k in (_V, _VT, _VN)]  # per f line
    iv = p.resolve(raw[0], np.ones(len(cline), bool), above[0], above[0][cline], cline,
                   flines, "vertex")
    it = p.resolve(raw[1], raw[1] != 0, above[1], np.full(len(cline), len(uv)), cline, flines,
                   "texture coordinate")
    inn = p.resolve(raw[2], raw[2] != 0, above[2], np.full(len(cline), len(nrm)), cline,
                    flines, "normal")
    # one vertex per distinct (v, vt, vn), numbered by first appearance (Mitsuba's map)
    nt, nn = len(uv) + 1, len(nrm) + 1
    if len(pos) * nt * nn < 2 ** 62:
        key = (iv * nt + (it + 1)) * nn + (inn + 1)
        _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
    else:
        _, first, inverse = np.unique(np.stack([iv, it, inn], 1), axis=0,
                                      return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    vid = rank[inverse.ravel()]                 # vertex id of every corner
    rep = first[order]                          # the corner that made each vertex
    tri, _ = fan(count, offset)
    faces = vid[tri]
    uvs = None
    if (it >= 0).any():
        if flip_tex_coords:
            uv[:, 1] = 1.0 - uv[:, 1]
        uvs = np.where((it[rep] >= 0)[:, None], uv[np.maximum(it[rep], 0)], 0.0)
    normals = None
    if not face_normals and (inn >= 0).any():
        normals = nrm[np.maximum(inn[rep], 0)]
        missing = inn[rep] < 0
        if missing.any():
            normals[missing] = vertex_normals(pos[iv[rep]], faces)[missing]
    return MeshData(pos[iv[rep]], faces, normals, uvs, name=os.path.basename(path))
