"""Exact prefix sums for the alias-table construction (used by ``discrete.AliasTable``).

A prefix sum of float64 weights is kept as an integer part ``H`` (exact in float64
after scaling by 2^s) and a small remainder ``L``, so differences of prefix sums, which
decide each alias table column, are exact to ~1e-17 at any n.  The sweeping
construction (Hübschle-Schneider & Sanders 2022) matches lights to heavies with
``searchsorted`` on these sums; ties within a few ulps are settled exactly.
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np

from ..kernels import load_kernel, resolve_kernels

#: ``kernels="auto"`` builds with the compiled kernel from this many weights on; below, the
#: NumPy build takes under ~0.05 s and importing numba (~0.3 s, once per process) would not pay
NUMBA_FROM = 1 << 18


def _alias_kernels(kernels, n: int) -> str:
    """The resolved ``kernels`` switch of an alias table of ``n`` columns: "auto" is "numpy"
    below ``NUMBA_FROM`` columns (without importing numba)."""
    if kernels == "auto" and n < NUMBA_FROM:
        return "numpy"
    return resolve_kernels(kernels)


def _build_compiled(w: np.ndarray, c_hi: float, c_lo: float) -> tuple[np.ndarray, np.ndarray]:
    """``(q, alias)`` from the compiled sweep (``alias_kernel.alias_build``), for
    ``p = w c_hi + w c_lo`` (``c_hi + c_lo = n / sum(w)``)."""
    build = load_kernel("vrlab.distributions.alias_kernel", "alias_build")
    q, alias = np.empty(len(w)), np.empty(len(w), np.int64)
    build(np.ascontiguousarray(w, dtype=np.float64), float(c_hi), float(c_lo), q, alias)
    return q, alias


def _pack(q: np.ndarray, alias: np.ndarray, bits: int, scratch: np.ndarray | None, kernels: str) -> np.ndarray:
    """The packed table ``alias_j << B | round(q_j (2^B - 1))`` (``B = bits``), made in the
    ``alias`` array (``scratch``: a free float buffer of length n, or None).  The rounded
    ``q_j (2^B - 1) <= 2^B - 1`` never spills into the alias bits."""
    if kernels == "numba":
        load_kernel("vrlab.distributions.alias_kernel", "alias_pack")(q, alias, bits)
        return alias
    quant = np.multiply(q, float(2**bits - 1), out=scratch)
    quant += 0.5
    iquant = quant.view(np.int64)
    np.copyto(iquant, quant, casting="unsafe")  # truncate in place: round(q (2^B - 1))
    packed = np.left_shift(alias, bits, out=alias)  # the alias array becomes the table
    packed |= iquant
    return packed


def _scale_bits(total_bound: float) -> int:
    """``s`` such that values summing to <= ``total_bound`` (> 0) have split integer
    parts whose prefix sums stay below 2**52 (exact in float64, with room for rounding)."""
    return 51 - int(np.frexp(float(total_bound))[1])


def _prefix(v: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray]:
    """Prefix sums of ``v >= 0`` with a leading 0, in units of 2**-s, as ``H + L``:
    ``H`` sums the integer parts (exact), ``L`` the remainders (|each| <= 1/2)."""
    m = len(v)
    H = np.empty(m + 1)
    L = np.empty(m + 1)
    H[0] = L[0] = 0.0
    t = np.multiply(v, 2.0 ** s, out=L[1:])  # exact: a power of two
    hi = np.rint(t, out=H[1:])
    t -= hi                # exact remainder
    np.cumsum(hi, out=hi)  # exact: integers below 2**52
    np.cumsum(t, out=t)
    return H, L


def _value(H: np.ndarray, L: np.ndarray, s: int, out: np.ndarray | None = None) -> np.ndarray:
    """Nearest float of a split prefix sum."""
    out = np.add(H, L, out=out)
    out *= 2.0 ** -s
    return out


def _diff(HA, LA, HB, LB, s: int) -> np.ndarray:
    """``A - B`` for split sums; the integer parts subtract exactly."""
    out = np.subtract(HA, HB)
    out += LA
    out -= LB
    out *= 2.0 ** -s
    return out


def _accurate_total(w: np.ndarray, extended: bool | None = None):
    """``sum(w)`` to ~1e-18 relative (the normalisation must not bias every probability
    by the same rounding): in x87 extended precision where the platform has it
    (``np.longdouble``), else exactly as a ``Fraction`` from split sums."""
    if extended is None:
        extended = np.finfo(np.longdouble).nmant >= 63
    if extended:
        return np.sum(w, dtype=np.longdouble)
    s = _scale_bits(len(w) * float(w.max()))
    H, L = _prefix(w, s)
    return (Fraction(int(H[-1])) + Fraction(float(L[-1]))) * Fraction(2) ** -s


def _searchsorted_sorted(a: np.ndarray, v: np.ndarray, side: str, block: int = 4096) -> np.ndarray:
    """``np.searchsorted(a, v, side)`` for sorted ``a`` and sorted ``v``: queries go in
    blocks, each searched only within the slice of ``a`` bracketed by its first and last
    query (shorter binary searches that stay in cache; a loop over blocks, not items)."""
    if len(v) <= 4 * block:
        return np.searchsorted(a, v, side=side)
    out = np.empty(len(v), np.intp)
    starts = np.arange(0, len(v), block)
    ends = np.minimum(starts + block, len(v))
    lo = np.searchsorted(a, v[starts], side=side).tolist()
    hi = np.searchsorted(a, v[ends - 1], side=side).tolist()
    for s, e, l, h in zip(starts.tolist(), ends.tolist(), lo, hi):
        r = np.searchsorted(a[l:h], v[s:e], side=side)
        r += l
        out[s:e] = r
    return out


def _lights_per_heavy(Xf: np.ndarray, Yf: np.ndarray) -> np.ndarray:
    """``k_h = #{l : Y_l < X_(h+1)}`` (h < b-1) and ``k_(b-1) = a``: how many lights
    (deficits starting at ``Yf``) are filled by heavies ``<= h`` (excesses ending at ``Xf``).

    Light l goes to the heavy whose excess interval holds Y_l.  The shorter side is
    searched in the longer one; the other way round is a counting pass.
    """
    a, b = len(Yf), len(Xf)
    if b <= a:
        k = _searchsorted_sorted(Yf, Xf, "left")
    else:
        c = _searchsorted_sorted(Xf, Yf, "right")  # #{h : X_(h+1) <= Y_l}
        np.minimum(c, b - 1, out=c)
        k = np.cumsum(np.bincount(c, minlength=b))
    k[-1] = a
    return k


def _heavy_q(k, HY, LY, HX, LX, s: int) -> np.ndarray:
    """Keep probabilities of the heavy columns: heavy h has paid every deficit up to
    Y_(k_h) but owns excess only up to X_(h+1), so q_h = 1 - (Y_(k_h) - X_(h+1))."""
    qh = _diff(HY[k], LY[k], HX[1:], LX[1:], s)
    np.subtract(1.0, qh, out=qh)
    return qh


def _lights_per_heavy_exact(k, Yf, Xf, HY, LY, HX, LX, s: int) -> np.ndarray:
    """``k`` recomputed with exact comparisons for the lights within a few ulps of some X_h."""
    a, b = len(Yf), len(Xf)
    c = np.repeat(np.arange(b), np.diff(k, prepend=0))  # heavy of each light
    tol = 8.0 * float(np.spacing(max(abs(float(Yf[-1])), abs(float(Xf[-1])), 1.0)))
    lo = np.searchsorted(Xf, Yf - tol, side="left")   # X_1..X_lo surely <= Y
    hi = np.searchsorted(Xf, Yf + tol, side="right")  # X_(hi+1)..X_b surely > Y
    idx = np.flatnonzero(lo < hi)
    if idx.size:
        lo, hi = lo[idx], hi[idx]
        hy, ly = HY[idx], LY[idx]
        while True:  # bisection, log2(window) passes over the few uncertain lights
            open_ = lo < hi
            if not open_.any():
                break
            mid = np.minimum((lo + hi + 1) // 2, b)  # in 1..b where open
            le = _diff(hy, ly, HX[mid], LX[mid], s) >= 0  # X_mid <= Y_l, exactly
            lo = np.where(open_ & le, mid, lo)
            hi = np.where(open_ & ~le, mid - 1, hi)
        c[idx] = np.minimum(lo, b - 1)
    c = np.maximum.accumulate(c)
    k = np.cumsum(np.bincount(c, minlength=b))
    k[-1] = a
    return k
