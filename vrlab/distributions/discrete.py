"""Discrete distributions over indices 0..n-1: Walker's alias table and a CDF table.

Both map one uniform per draw to an index, ``sample(u) -> i``, and report
``pmf(i) = w_i / sum(w)`` (measure: counting).  ``u`` has shape ``(...)`` or
``(..., 1)`` (``dim_u = 1``; a trailing axis of length 1 on an array with two or
more axes is the coordinate axis and is dropped), the indices have shape ``(...)``.
``u`` must lie in [0, 1): ``sample`` checks that (two reductions, a few per cent of a
draw) and raises ``ValueError`` naming ``u`` otherwise.  ``sample(u, return_remapped=True)``
also returns the part of ``u`` the choice did not use, rescaled to [0, 1) and
independent of the chosen index, so it can drive a further warp (as when a
renderer picks a light and then a point on it with the same uniform).
Zero-weight indices are never sampled.

``AliasTable`` -- Walker's alias method (A. J. Walker, Electronics Letters 10(8),
1974, and "An efficient method for generating discrete random variables with general
distributions", ACM TOMS 3(3), 1977; M. D. Vose, IEEE TSE 17(9), 1991, for the
O(n) construction).  Scale the weights to ``p_i = n w_i / sum(w)`` (mean 1).
Column ``j`` keeps its own index with probability ``q_j``, else gives ``alias_j``::

    x = u n,  j = floor(x),  i = j if x - j < q_j else alias_j,
    P(i) = (q_i + sum_{j: alias_j = i} (1 - q_j)) / n = p_i / n.

Construction: the *sweeping* construction of Hübschle-Schneider and Sanders
("Parallel Weighted Random Sampling", ACM TOMS 48(3), 2022; arXiv:1903.00227)
written with prefix sums instead of a loop.  Light items (``p <= 1``) lay their
deficits ``1 - p`` end to end (prefix sums ``Y``), heavy items their excesses
``p - 1`` (prefix sums ``X``).  Light ``l`` is filled by the heavy item whose excess
interval ``[X_h, X_(h+1))`` holds ``Y_l`` (a ``searchsorted``).  A heavy item that has
given more than its excess is then light itself and the next heavy item fills its
column: ``q_h = 1 - (Y_(k_h) - X_(h+1))``, ``alias_h = h + 1``, with ``k_h`` the
number of lights filled by heavies ``<= h``.  The prefix sums are split into an
integer part (exact in float64) and a small remainder, so ``Y - X`` is exact to
~1e-17 at any ``n``: the table reproduces ``w / sum(w)`` to a few ulps (relative,
also for tiny weights), and look-ups within ulps of a tie are settled exactly.

Sampling a table of more than 2^17 columns reads one 64-bit word per draw,
``alias_j << B | round(q_j 2^B)`` with ``B = min(52, 63 - bits(n))``: one random memory access,
the cost that dominates for large tables.  Either way the split point is resolved
finer than ``u n`` itself (``n 2**-53`` for 53-bit uniforms).

``CDFTable`` -- inversion: ``i = #{k : C_k <= u}`` for the cumulative sums ``C``
(``np.searchsorted``, O(log n) per draw, O(n) build); the leftover uniform is
``(u - C_(i-1)) / (C_i - C_(i-1))``.
"""
from __future__ import annotations

from fractions import Fraction
from typing import Any

import numpy as np

from ..checks import describe as _describe
from ._args import _checked, _flag, _outside, _uniforms
from .alias_build import (_accurate_total, _alias_kernels, _build_compiled, _diff, _heavy_q, _lights_per_heavy,
                          _lights_per_heavy_exact, _pack, _prefix, _scale_bits, _value)
from .base import Distribution

__all__ = ["AliasTable", "CDFTable", "check_discrete_weights"]

_ONE_MINUS = float(np.nextafter(1.0, 0.0))  # the largest float below 1
_SMALL = 1 << 17  # up to this many columns the alias sampler uses float thresholds + index pairs
_CHUNK_SMALL = 1 << 14  # draws per block in the alias sampling loops (temporaries stay in cache)
_CHUNK_PACKED = 1 << 16


def check_discrete_weights(weights: Any, name: str = "weights") -> np.ndarray:
    """``weights`` as a float64 1-D array of finite non-negative values with a positive
    total, else ``ValueError`` naming the problem and the first offending index."""
    return _checked(weights, name)[0]


# --- exact prefix sums --------------------------------------------------------------
# A value v >= 0 is split as v = hi 2^-s + lo with hi an integer (held in a float) and
# |lo| <= 2^-(s+1); both parts are exact.  With s chosen so that the sum of the hi stays
# below 2^53, the float cumsum of hi is exact, and the cumsum of the tiny lo has an
# error far below the ulp of the totals.  Differences of two prefix sums then subtract
# the integer parts exactly: the alias construction needs Y_k - X_h to ~1e-17, not to
# the ~1e-9 that a plain float cumsum of 10^7 values would give.

class _Discrete(Distribution):
    """Shared parts: weights, pmf, checks of indices."""

    dim_u = 1
    dim_x = 0  # a draw is a scalar index: sample(u) has shape (...)
    measure = "counting"

    def __init__(self, weights: Any):
        w, lo, hi = _checked(weights, "weights")
        self.n = int(w.size)
        self._uniform = lo == hi
        e = int(np.frexp(hi)[1])
        if abs(e) > 900:  # huge or tiny weights: scale by a power of two (exact) so sums stay finite
            w = np.ldexp(w, -e)
        else:
            e = 0
            if isinstance(weights, np.ndarray) and np.may_share_memory(w, weights):
                w = w.copy()  # pmf must not follow later edits of the caller's array
        w.flags.writeable = False
        self._w = w
        self._W_ext = _accurate_total(w)
        self._W = float(self._W_ext)
        with np.errstate(over="ignore"):
            self.total = float(np.ldexp(self._W, e))  # sum of the weights (inf if it overflows)
        self._probs = None

    def _scale_to(self, target: float) -> tuple[float, float]:
        """``target / sum(w)`` as an unevaluated sum of two floats."""
        if isinstance(self._W_ext, Fraction):
            c = Fraction(target) / self._W_ext
            hi = float(c)
            return hi, float(c - Fraction(hi))
        c = np.longdouble(target) / self._W_ext
        hi = float(c)
        return hi, float(c - np.longdouble(hi))

    @property
    def probabilities(self) -> np.ndarray:
        """All normalised probabilities ``w / sum(w)`` (read-only array of length ``n``)."""
        if self._probs is None:
            hi, lo = self._scale_to(1.0)
            probs = self._w * hi
            probs += self._w * lo
            probs.flags.writeable = False
            self._probs = probs
        return self._probs

    def pmf(self, i: Any = None) -> np.ndarray:
        """``P(index = i) = w_i / sum(w)`` for integer indices ``i`` (0 outside ``[0, n)``);
        with no argument, the whole array of probabilities.  ``i`` may be integral floats;
        ``TypeError`` for other kinds, ``ValueError`` for non-integral, NaN or inf values."""
        probs = self.probabilities
        if i is None:
            return probs
        try:
            i = np.asarray(i)
        except ValueError:
            raise ValueError(f"i: expected an array of integer indices, got {_describe(i)}") from None
        if i.dtype.kind not in "iu":
            if i.dtype.kind != "f":
                raise TypeError(f"i: expected integer indices, got dtype {i.dtype}")
            if not np.all(np.isfinite(i)):
                raise ValueError("i: expected integer indices, got NaN or infinite values")
            if not np.all(np.floor(i) == i):
                raise ValueError("i: expected integer indices, got non-integral values")
            i = i.astype(np.int64)
        inside = (i >= 0) & (i < self.n)
        return np.where(inside, probs[np.where(inside, i, 0)], 0.0)

    def pdf(self, x: Any) -> np.ndarray:
        """Alias of ``pmf`` (density with respect to the counting measure)."""
        return self.pmf(x)

    def sample_pdf(self, u: Any) -> tuple[np.ndarray, np.ndarray]:
        i = self.sample(u)
        return i, self.probabilities[i]

    def __len__(self) -> int:
        return self.n

    def _repr_fields(self) -> dict:
        return {"n": self.n, "total": self.total}


class AliasTable(_Discrete):
    """Walker's alias table over indices ``0..n-1`` with probabilities ``w / sum(w)``.

    O(n) vectorised build (prefix-sum sweeping construction, see the module notes),
    O(1) per draw: ``x = u n, j = floor(x), i = j if x - j < q_j else alias_j``.
    ``kernels``: "numpy" builds as above, "numba" by the compiled serial sweep of ``alias_kernel``
    (the same table, faster), "auto" (default) by numba where importable and ``n >= 2^18``.

    Attributes: ``n``, ``total`` (sum of the weights), ``q`` (column keep
    probabilities), ``alias`` (column aliases; irrelevant where ``q_j = 1``),
    ``probabilities``, ``kernels`` (the resolved switch); ``dim_u = 1``, measure "counting".
    """

    def __init__(self, weights: Any, *, kernels: str = "auto", _exact: bool = False):
        super().__init__(weights)
        n = self.n
        self.kernels = _alias_kernels(kernels, n)
        q, alias, scratch = self._build(_exact)
        q.flags.writeable = False
        self.q = q
        self._alias = alias
        self._qe = self._alias_i = None  # for the remapped uniform, made on first use
        if n <= _SMALL:
            # cache-resident tables: thresholds on x = u n, and [j, alias_j] pairs picked
            # by 2j + (x >= j + q_j)
            ar = np.arange(n, dtype=np.intp)
            self._thresh = ar + q
            pairs = np.empty((n, 2), np.intp)
            pairs[:, 0] = ar
            pairs[:, 1] = alias
            self._pairs = pairs.reshape(-1)
        else:
            # one 64-bit word per column, alias_j << B | Q_j with Q_j = q_j 2^B rounded:
            # a draw reads one random word (the cost at large n is that memory access).
            # B = min(52, 63 - bits(n)) >= 32: finer than u n resolves (n 2^-53 for 53-bit u)
            bits = min(52, 63 - max(1, (n - 1).bit_length()))
            self._bits, self._packed, self._alias = bits, _pack(q, alias, bits, scratch, self.kernels), None

    @property
    def alias(self) -> np.ndarray:
        """Column aliases (read-only; irrelevant where ``q_j = 1``)."""
        if self._alias is None:
            self._alias = self._packed >> self._bits
        self._alias.flags.writeable = False
        return self._alias

    # construction -----------------------------------------------------------------
    def _build(self, exact: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """``(q, alias, free float buffer of length n or None)`` by the prefix-sum sweep;
        ``exact`` forces exact interval look-ups."""
        n, w = self.n, self._w
        if self._uniform:  # every column is full
            return np.ones(n), np.arange(n), None
        # p = n w / W with n / W as a double-double: each p_i is rounded once, on its own
        c_hi, c_lo = self._scale_to(float(n))
        if self.kernels == "numba":
            return (*_build_compiled(w, c_hi, c_lo), None)
        p = w * c_hi
        scratch = np.multiply(w, c_lo)  # reused below: fewer fresh pages to fault in
        p += scratch
        heavy_mask = p > 1.0
        heavy = np.flatnonzero(heavy_mask)
        np.logical_not(heavy_mask, out=heavy_mask)
        light = np.flatnonzero(heavy_mask)
        del heavy_mask
        q = p  # light columns keep q = p
        b, a = len(heavy), len(light)
        if b == 0 or a == 0:  # every p == 1 up to rounding
            q[:] = 1.0
            return q, np.arange(n), scratch
        deficit = np.take(p, light, out=scratch[:a], mode="clip")  # (clip: no buffering of out)
        np.subtract(1.0, deficit, out=deficit)
        excess = np.take(p, heavy, out=scratch[a:], mode="clip")
        excess -= 1.0
        s = _scale_bits(n)
        HY, LY = _prefix(deficit, s)  # Y_0..Y_a: light l's deficit is [Y_l, Y_(l+1))
        HX, LX = _prefix(excess, s)   # X_0..X_b: heavy h's excess is [X_h, X_(h+1))
        Yf = _value(HY[:-1], LY[:-1], s, out=deficit)  # where each light's deficit starts
        Xf = _value(HX[1:], LX[1:], s, out=excess)     # where each heavy's excess ends (> 0)
        del deficit, excess
        # sum(deficits) - sum(excesses) = n - sum(p) is a rounding residue; the last heavy
        # absorbs it, unless it is large enough to matter (e.g. biased by repeated
        # weights): then it is spread over the excesses in proportion
        residue = _diff(HY[-1:], LY[-1:], HX[-1:], LX[-1:], s)[0]
        if abs(residue) > 2.0**-45:
            adj = Xf * (residue / Xf[-1])
            LX[1:] += adj * 2.0**s
            Xf += adj
            del adj
        k = _lights_per_heavy(Xf, Yf)
        qh = _heavy_q(k, HY, LY, HX, LX, s)
        if exact or not ((qh >= 0.0).all() and (qh <= 1.0).all()):
            # a float look-up was off near a tie: settle those lights exactly
            k = _lights_per_heavy_exact(k, Yf, Xf, HY, LY, HX, LX, s)
            qh = _heavy_q(k, HY, LY, HX, LX, s)
        np.clip(qh, 0.0, 1.0, out=qh)
        qh[-1] = 1.0  # the last heavy keeps what rounding left over (ulps)
        q[heavy] = qh
        alias = np.empty(n, np.int64)
        of = np.bincount(k[:-1], minlength=len(light) + 1)[:-1]
        np.cumsum(of, out=of)  # lights k_(h-1) .. k_h - 1 are filled by heavy h
        alias[light] = np.take(heavy, of)
        del of
        alias[heavy[:-1]] = heavy[1:]
        alias[heavy[-1]] = heavy[-1]
        return q, alias, scratch

    def table_pmf(self) -> np.ndarray:
        """The distribution the table encodes, ``(q_i + sum_{alias_j = i} (1 - q_j)) / n``."""
        return (self.q + np.bincount(self.alias, weights=1.0 - self.q, minlength=self.n)) / self.n

    # sampling ---------------------------------------------------------------------
    def sample(self, u: Any, return_remapped: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Indices for uniforms ``u`` in [0, 1) of shape ``(...)`` or ``(..., 1)``.

        With ``return_remapped=True`` returns ``(i, r)``: ``r = f / q_j`` if the column
        kept its own index, else ``(f - q_j) / (1 - q_j)`` (``f = x - j``), uniform on
        [0, 1) and independent of ``i``.  ``u`` outside [0, 1) raises ``ValueError``.
        """
        remap = _flag(return_remapped, "return_remapped")
        u = _uniforms(u, check=remap)
        if remap:
            return self._sample_remap(u)
        flat = u.reshape(-1)
        out = np.empty(flat.size, np.intp)
        if self.n <= _SMALL:
            block, size = self._block_small, _CHUNK_SMALL
        else:
            block, size = self._block_packed, _CHUNK_PACKED
        for start in range(0, flat.size, size):  # blocks of draws (not items): temporaries stay in cache
            chunk = flat[start:start + size]
            if not (chunk.min() >= 0.0 and chunk.max() < 1.0):  # checked in cache; NaN fails too
                _outside(u)
            block(chunk, out[start:start + size])
        return out.reshape(u.shape)

    def _block_small(self, u: np.ndarray, out: np.ndarray) -> None:
        x = u * self.n
        j = x.astype(np.intp)
        c = x >= self._thresh[j]
        j += j
        j += c  # 2j + 1 picks the alias
        out[...] = self._pairs[j]

    def _block_packed(self, u: np.ndarray, out: np.ndarray) -> None:
        bits = self._bits
        x = u * self.n
        j = x.astype(np.intp)
        x -= j
        x *= float(2**bits)  # f 2^B, exact
        word = self._packed[j]
        own = x < (word & ((1 << bits) - 1))  # f < Q_j 2^-B
        word >>= bits  # alias_j
        j -= word
        j *= own
        np.add(word, j, out=out)  # j where own, else alias_j

    def _split_points(self) -> np.ndarray:
        """The split point each column's sampler really uses (``q`` to below u's resolution)."""
        if self._qe is None:
            if self.n <= _SMALL:
                self._qe = self._thresh - np.arange(self.n, dtype=np.float64)  # exact
            else:
                self._qe = np.ldexp((self._packed & ((1 << self._bits) - 1)).astype(np.float64), -self._bits)
            self._alias_i = self.alias.astype(np.intp)
        return self._qe

    def _sample_remap(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        qe = self._split_points()
        x = u * self.n
        j = x.astype(np.intp)
        f = x - j
        qj = qe[j]
        own = f < qj  # the same decision as the fast path
        i = np.where(own, j, self._alias_i[j])
        r = np.where(own, f, f - qj)
        r /= np.where(own, qj, 1.0 - qj)  # > 0 in the branch taken
        np.minimum(r, _ONE_MINUS, out=r)
        return i, r

    def sample_remap(self, u: Any) -> tuple[np.ndarray, np.ndarray]:
        """``sample(u, return_remapped=True)``."""
        return self.sample(u, return_remapped=True)


class CDFTable(_Discrete):
    """Inversion of the cumulative distribution: ``i = #{k : C_k <= u}`` by binary search.

    ``C_k = (w_0 + ... + w_k) / sum(w)`` computed with exact prefix sums (so each
    step ``C_k - C_(k-1)`` is the weight to a few ulps), ``C_(n-1) = 1``; O(n) build,
    O(log n) per draw.  The leftover uniform is ``(u - C_(i-1)) / (C_i - C_(i-1))``.
    Attribute ``cdf``: the array ``C`` (length ``n``).  Probabilities are resolved to
    the ulp of ``C`` (absolute, ~1e-16); the alias table keeps them to relative precision.
    """

    def __init__(self, weights: Any):
        super().__init__(weights)
        w = self._w
        s = _scale_bits(self._W)
        H, L = _prefix(w, s)
        cdf = _value(H[1:], L[1:], s)
        cdf /= self._W
        np.maximum.accumulate(cdf, out=cdf)
        last = int(np.flatnonzero(w)[-1])
        cdf[last:] = 1.0
        cdf.flags.writeable = False
        self.cdf = cdf
        self._last = last
        self._search = cdf[:last]  # any u lands on an index <= last (a positive weight)

    def sample(self, u: Any, return_remapped: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Indices for uniforms ``u`` in [0, 1) of shape ``(...)`` or ``(..., 1)``;
        with ``return_remapped=True`` also ``(u - C_(i-1)) / (C_i - C_(i-1))``.  ``u``
        outside [0, 1) raises ``ValueError``."""
        u = _uniforms(u)
        i = np.searchsorted(self._search, u, side="right")
        if not _flag(return_remapped, "return_remapped"):
            return i
        lo = np.where(i > 0, self.cdf[np.maximum(i - 1, 0)], 0.0)
        r = (u - lo) / (self.cdf[i] - lo)  # the chosen step has positive width
        np.clip(r, 0.0, _ONE_MINUS, out=r)
        return i, r

    def sample_remap(self, u: Any) -> tuple[np.ndarray, np.ndarray]:
        """``sample(u, return_remapped=True)``."""
        return self.sample(u, return_remapped=True)

    def table_pmf(self) -> np.ndarray:
        """The distribution the table encodes: ``C_i - C_(i-1)``."""
        return np.diff(self.cdf, prepend=0.0)
