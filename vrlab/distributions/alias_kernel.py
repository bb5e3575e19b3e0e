"""Compiled alias-table construction (Numba): ``AliasTable(weights, kernels="numba")``.

The same table as the NumPy build in :mod:`vrlab.distributions.discrete` (its oracle): the
sweeping construction of Hübschle-Schneider & Sanders ("Parallel Weighted Random
Sampling", ACM TOMS 48(3), 2022), here as one serial two-pointer sweep instead of prefix
sums and searches.  With ``p_i = n w_i / W`` (computed as ``w c_hi + w c_lo``, the oracle's
double-double ``n / W``), light items (``p <= 1``) lay their deficits ``1 - p`` end to end
(``Y_l``: where light l's starts), heavy items their excesses ``p - 1`` (``X_(h+1)``: where
heavy h's ends).  Going through the lights in index order, heavy h fills the lights with
``Y_l`` in ``[X_h, X_(h+1))``; when a light starts at or beyond ``X_(h+1)`` heavy h is
done: ``q_h = 1 - (Y_l - X_(h+1))``, ``alias_h`` = the next heavy, which takes over.  The
last heavy keeps ``q = 1``.  Both running sums are float sums plus their summed rounding errors (Knuth's TwoSum), so
the comparisons and ``Y - X`` are exact to ~1e-32 relative: the table reproduces
``w / sum(w)`` to a few ulps, as the oracle's split prefix sums do.  As in the oracle, a
rounding residue ``sum(1 - p) - sum(p - 1)`` above 2^-45 is spread over the excesses in
proportion (factor ``1 + residue / E``).  Two passes over ``w``, no index arrays.
"""
from __future__ import annotations

from numba import njit

__all__ = ["alias_build", "alias_pack", "SIGNATURES", "COMPILE_SECONDS"]

#: the signatures vrlab.kernels.load_kernels compiles
SIGNATURES = {"alias_build": ["int64(float64[::1], float64, float64, float64[::1], int64[::1])"],
              "alias_pack": ["void(float64[::1], int64[::1], int64)"]}
#: cold compile time (seconds, measured on the development machine), for the notice
COMPILE_SECONDS = 1.0


@njit(cache=True, error_model="numpy")
def _add(hi, lo, x):
    """``(hi, lo) + x`` for a sum kept as ``hi + lo``: ``hi`` the float sum, ``lo`` the sum of
    its rounding errors (Knuth's TwoSum; not renormalised, so the chain through ``hi`` is
    one addition per term)."""
    s = hi + x
    bb = s - hi
    return s, lo + ((hi - (s - bb)) + (x - bb))


@njit(cache=True, error_model="numpy")
def _next_heavy(w, c_hi, c_lo, start):
    """The first index >= start with p > 1 (n if none) and its p."""
    n = len(w)
    i = start
    while i < n:
        p = w[i] * c_hi + w[i] * c_lo
        if p > 1.0:
            return i, p
        i += 1
    return n, 0.0


@njit(cache=True, error_model="numpy")
def _finish(w, c_hi, c_lo, f, q, alias, h, y_hi, y_lo, x_hi, x_lo):
    """Heavy h is done where the next light starts (Y): ``q_h = 1 - (Y - X_(h+1))``, its alias
    the next heavy h2, whose excess extends X.  Returns ``(h2, X_(h2+1))``."""
    q[h] = min(max(1.0 - ((y_hi - x_hi) + (y_lo - x_lo)), 0.0), 1.0)
    h2, ph = _next_heavy(w, c_hi, c_lo, h + 1)
    alias[h] = h2
    x_hi, x_lo = _add(x_hi, x_lo, ph - 1.0)
    x_hi, x_lo = _add(x_hi, x_lo, (ph - 1.0) * f)
    return h2, x_hi, x_lo


@njit(cache=True, error_model="numpy")
def alias_build(w, c_hi, c_lo, q, alias):
    """Fill ``q (n,)`` and ``alias (n,)`` for weights ``w`` with ``n / W = c_hi + c_lo``.
    Returns the number of heavy items (0: every p == 1 up to rounding, every column full)."""
    n = len(w)
    d_hi = d_lo = e_hi = e_lo = 0.0
    b = 0
    for i in range(n):                             # branch-free: adding 0.0 is exact
        p = w[i] * c_hi + w[i] * c_lo
        heavy = p > 1.0
        e_hi, e_lo = _add(e_hi, e_lo, p - 1.0 if heavy else 0.0)
        d_hi, d_lo = _add(d_hi, d_lo, 0.0 if heavy else 1.0 - p)
        b += heavy
    if b == 0 or b == n:
        for i in range(n):
            q[i] = 1.0
            alias[i] = i
        return 0
    residue = (d_hi - e_hi) + (d_lo - e_lo)
    f = residue / e_hi if abs(residue) > 2.0 ** -45 else 0.0
    h, ph = _next_heavy(w, c_hi, c_lo, 0)
    x_hi, x_lo = _add(0.0, 0.0, ph - 1.0)          # X_(h+1): where heavy h's excess ends
    x_hi, x_lo = _add(x_hi, x_lo, (ph - 1.0) * f)
    y_hi = y_lo = 0.0                              # Y_l: where the next light's deficit starts
    done = 0                                       # heavies finished
    for i in range(n):
        p = w[i] * c_hi + w[i] * c_lo
        if p > 1.0:
            continue
        while done < b - 1 and (y_hi - x_hi) + (y_lo - x_lo) >= 0.0:
            h, x_hi, x_lo = _finish(w, c_hi, c_lo, f, q, alias, h, y_hi, y_lo, x_hi, x_lo)
            done += 1
        q[i] = p
        alias[i] = h
        y_hi, y_lo = _add(y_hi, y_lo, 1.0 - p)
    while done < b - 1:                            # heavies left after the last light
        h, x_hi, x_lo = _finish(w, c_hi, c_lo, f, q, alias, h, y_hi, y_lo, x_hi, x_lo)
        done += 1
    q[h] = 1.0                                     # the last heavy keeps what rounding left over
    alias[h] = h
    return b


@njit(cache=True, error_model="numpy")
def alias_pack(q, alias, bits):
    """In place, ``alias_j <- alias_j << bits | int(q_j (2^bits - 1) + 0.5)``: the packed words
    of ``discrete.AliasTable`` (the same operations as its NumPy packing)."""
    scale = float((1 << bits) - 1)
    for i in range(len(q)):
        alias[i] = (alias[i] << bits) | int(q[i] * scale + 0.5)
