"""Floating-point texture files: Radiance RGBE (``.hdr``) and Portable Float Map (``.pfm``),
read as Mitsuba 3's ``Bitmap`` reads them (src/core/bitmap.cpp, ``read_rgbe`` and
``read_pfm``).  Both are linear (never sRGB-decoded); :func:`vrlab.render.image.read_bitmap`
calls these for the two suffixes.

RGBE (Greg Ward, "Real pixels", Graphics Gems II, 1991; the Radiance picture format):

* header: a first line starting with ``#?`` (``#?RADIANCE``, ``#?RGBE``), text lines
  (``FORMAT=32-bit_rle_rgbe`` required; other lines such as ``EXPOSURE=`` are ignored, as
  Mitsuba ignores them), then the resolution line ``-Y H +X W`` (rows top to bottom, the
  only orientation Mitsuba reads);
* a pixel is 4 bytes (r, g, b, e): value = m 2^(e - 136) for each mantissa m (no half-unit
  offset), 0 when e = 0;
* scanlines (W between 8 and 32767) may be run-length encoded: 4 bytes (2, 2, W >> 8,
  W & 255), then the W bytes of r, of g, of b and of e, each as packets: a byte c > 128
  repeats the next byte c - 128 times, a byte 1 <= c <= 128 is followed by c literal bytes;
  a packet never crosses a channel.  A first scanline without the marker means flat pixels
  from there on (Mitsuba's rule; Radiance's older "1, 1, 1, count" runs are not read, nor by
  Mitsuba).  ``FORMAT=32-bit_rle_xyze`` (CIE XYZ) is refused.

Decoding is vectorised within a scanline: the packet headers of a scanline are the
positions reachable from its first byte by next(i) = i + 2 (a run) or i + 1 + c (literals),
found for all bytes at once by pointer doubling (log2 of the packet count steps), then each
output byte's source is one ``np.repeat`` away.

PFM (Portable Float Map): ``PF`` (RGB) or ``Pf`` (grey), whitespace, width, height and a
scale, one whitespace character, then W H C float32 values, rows from the *bottom* of the
image to the top; a negative scale means little-endian data, a positive one big-endian, and
Mitsuba multiplies the values by |scale| (a scale of 0 is refused here).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

__all__ = ["read_pfm", "read_rgbe", "rgbe_to_float"]


def _bad(name: str, p: Path, why: str) -> ValueError:
    return ValueError(f"{name}: cannot read image {str(p)!r}: {why}")


def rgbe_to_float(rgbe: np.ndarray) -> np.ndarray:
    """``(..., 4)`` uint8 RGBE pixels as ``(..., 3)`` float32: m 2^(e - 136), 0 where e = 0."""
    rgbe = np.asarray(rgbe, np.uint8)
    e = rgbe[..., 3].astype(np.int32)
    f = np.where(e > 0, np.ldexp(np.float32(1), e - 136), 0).astype(np.float32)
    return rgbe[..., :3].astype(np.float32) * f[..., None]


def _chain(nxt: np.ndarray) -> np.ndarray:
    """The sorted positions reachable from 0 by ``i -> nxt[i]`` (``nxt[i] > i``; a value
    >= len(nxt) leaves), by pointer doubling: after k steps the set holds the positions
    0 .. 2^k - 1 jumps away and the table jumps 2^k."""
    n = len(nxt)
    jump = np.append(np.minimum(nxt, n), n)            # n: the sink, mapped to itself
    on = np.zeros(n + 1, bool)
    on[0] = True
    while jump[0] != n:
        on[jump[on]] = True
        jump = jump[jump]
    return np.flatnonzero(on[:n])


def _scanline(window: np.ndarray, width: int) -> tuple[np.ndarray, int] | str:
    """One run-length encoded scanline (after its 4-byte marker) from the bytes ``window``:
    ``((W, 4) uint8 RGBE, bytes used)``, or the reason it is bad."""
    b = window.astype(np.int64)
    if len(b) == 0:
        return "the file ends inside a scanline"
    run = b > 128
    count = np.where(run, b - 128, b)
    nodes = _chain(np.arange(len(b)) + np.where(run, 2, 1 + b))
    counts = count[nodes]
    total = np.cumsum(counts)
    k = int(np.searchsorted(total, 4 * width))
    if k == len(total):
        return "the file ends inside a scanline"
    nodes, counts, total = nodes[:k + 1], counts[:k + 1], total[:k + 1]
    if (counts == 0).any() or total[-1] != 4 * width or not np.isin([width, 2 * width, 3 * width], total).all():
        return "bad run-length encoded scanline data"
    end = int(nodes[-1]) + (2 if run[nodes[-1]] else 1 + int(counts[-1]))
    if end > len(b):
        return "the file ends inside a scanline"
    first = np.repeat(nodes + 1, counts)                       # each output byte's packet data start
    offset = np.arange(4 * width) - np.repeat(total - counts, counts)
    src = first + np.where(np.repeat(run[nodes], counts), 0, offset)
    return window[src].reshape(4, width).T, end


def read_rgbe(p: Path, name: str = "filename") -> np.ndarray:
    """The ``(H, W, 3)`` float32 linear RGB of a Radiance ``.hdr`` file (rows top to bottom).
    ``ValueError`` naming ``name`` and the file for a bad header, an XYZ picture, bad or
    truncated pixel data."""
    raw = np.frombuffer(p.read_bytes(), np.uint8)
    text = raw[:65536].tobytes()
    if not text.startswith(b"#?"):
        raise _bad(name, p, "not a Radiance RGBE file (no '#?' first line)")
    pos, fmt, size = text.index(b"\n") + 1 if b"\n" in text else len(text), None, None
    while size is None:
        nl = text.find(b"\n", pos)
        if nl < 0:
            raise _bad(name, p, "the header ends without a resolution line '-Y H +X W'")
        line = text[pos:nl].decode("latin-1").strip()
        pos = nl + 1
        if line.startswith("FORMAT="):
            fmt = line[7:].strip()
        m = re.fullmatch(r"([-+])([XY])\s+(\d+)\s+([-+])([XY])\s+(\d+)", line)
        if m:
            if m.group(1, 2, 4, 5) != ("-", "Y", "+", "X"):
                raise _bad(name, p, f"resolution line {line!r}: only '-Y H +X W' (rows top to bottom) is read, "
                                    "as in Mitsuba")
            size = int(m.group(3)), int(m.group(6))
    if fmt != "32-bit_rle_rgbe":
        raise _bad(name, p, f"FORMAT={fmt}: expected 32-bit_rle_rgbe" if fmt else "the header has no FORMAT= line")
    h, w = size
    if h < 1 or w < 1:
        raise _bad(name, p, f"image size {w} x {h}")
    data = raw[pos:]
    out = np.empty((h, w, 4), np.uint8)
    y, at = 0, 0
    if 8 <= w <= 0x7FFF:
        while y < h:
            head = data[at:at + 4]
            if len(head) < 4:
                raise _bad(name, p, f"the file ends at scanline {y} of {h}")
            if head[0] != 2 or head[1] != 2 or head[2] & 0x80:
                break                                          # flat pixels from here on
            if (int(head[2]) << 8 | int(head[3])) != w:
                raise _bad(name, p, f"scanline {y}: its width {int(head[2]) << 8 | int(head[3])} is not {w}")
            got = _scanline(data[at + 4:at + 4 + 8 * w], w)
            if isinstance(got, str):
                raise _bad(name, p, f"scanline {y}: {got}")
            out[y], used = got
            at += 4 + used
            y += 1
    if y < h:
        rest = (h - y) * w * 4
        if len(data) - at < rest:
            raise _bad(name, p, f"the file ends early: {len(data) - at} bytes for {(h - y) * w} pixels")
        out[y:] = data[at:at + rest].reshape(h - y, w, 4)
    return rgbe_to_float(out)


def read_pfm(p: Path, name: str = "filename") -> tuple[np.ndarray, str]:
    """``(data (H, W, C) float32, "RGB" or "Y")`` of a ``.pfm`` file, rows top to bottom,
    times |scale| (see the module docstring).  ``ValueError`` naming ``name`` and the file for
    a bad header or too little data."""
    raw = p.read_bytes()
    m = re.match(rb"(P[Ff])\s+(\d+)\s+(\d+)\s+(\S+)\s", raw[:256])
    if m is None:
        raise _bad(name, p, "not a PFM file (expected 'PF' or 'Pf', width, height and scale)")
    w, h = int(m.group(2)), int(m.group(3))
    try:
        scale = float(m.group(4))
    except ValueError:
        raise _bad(name, p, f"the scale {m.group(4).decode('latin-1')!r} is not a number") from None
    if not np.isfinite(scale) or scale == 0 or w < 1 or h < 1:
        raise _bad(name, p, f"size {w} x {h} and scale {scale:g}: expected sizes >= 1 and a finite, nonzero scale")
    c = 3 if m.group(1) == b"PF" else 1
    n = w * h * c
    body = raw[m.end():]
    if len(body) < 4 * n:
        raise _bad(name, p, f"the file ends early: {len(body)} bytes of data for {w} x {h} x {c} floats")
    data = np.frombuffer(body, "<f4" if scale < 0 else ">f4", count=n).astype(np.float32)
    data = data.reshape(h, w, c)[::-1] * np.float32(abs(scale))
    return np.ascontiguousarray(data), "RGB" if c == 3 else "Y"
