r"""The radical inverse and its digit tables (shared by Halton, Hammersley and scrambles).

Radical inverse
---------------
Write ``i = sum_k d_k b^k`` in base ``b`` (digits ``0 <= d_k < b``); the radical
inverse mirrors the digits about the radix point (van der Corput 1935)::

    phi_b(i) = sum_k d_k b^{-k-1}.

The first ``b^m`` values of ``phi_b`` hit every interval ``[j/b^m, (j+1)/b^m)``
exactly once.

Implementation
--------------
Digits are handled ``k`` at a time, with ``B = b^k <= 2^16`` and tables over ``k`` digits.
*Unscrambled* (``radical_inverse``, plain Halton/Hammersley): the sum is accumulated from
the least significant digit, ``((d_0 f_0 + d_1 f_1) + ...)`` with ``f_0 = 1/b`` and
``f_(j+1) = f_j / b``, which is SciPy's floating-point order, so the points equal
``scipy.stats.qmc.Halton(d, scramble=False)``'s bit for bit; a table gives the first ``k``
digits and the higher digits, constant over blocks of ``B`` consecutive indices, are added
per block.  Calls too small to pay for a table (and one-digit bases ``b > 256``) use
:func:`lsd_direct` instead: the same sums digit by digit, for many bases at once, without
tables -- so memory does not grow with the bases (``d = 10^4``).  *Permuted* digits:
tables ``T[r]`` of the permuted digit sums give ``phi(i) = T[i mod B] + phi'(i // B) / B``
(most significant first, exact integer tables), one broadcast addition per block for a
contiguous range.
Output arrays are Fortran-ordered (each coordinate contiguous), as in SciPy.
"""
from __future__ import annotations

import functools
import math
from collections import OrderedDict

import numpy as np
from numpy.typing import ArrayLike

from .base import check_int, clamp_open

_TABLE_LIMIT = 1 << 16     # largest table b^k (entries) per digit group
_PRECISION_BITS = 53       # digits are scrambled until b^-K <= 2^-53



# ---------------------------------------------------------------------------------------
# primes
# ---------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=4)
def _primes_upto(limit: int) -> np.ndarray:
    sieve = np.ones(limit + 1, dtype=bool)
    sieve[:2] = False
    for p in range(2, int(limit ** 0.5) + 1):
        if sieve[p]:
            sieve[p * p::p] = False
    return np.flatnonzero(sieve)


#: most primes first_primes gives (a sieve of ~1.3e8 bytes): far beyond any Halton dimension
MAX_PRIMES = 1 << 23


def first_primes(d: int) -> np.ndarray:
    """The first ``d`` primes ``2, 3, 5, ...`` (int64 array); ``0 <= d <= 2**23``."""
    d = check_int("d", d, 0, MAX_PRIMES)
    if d == 0:
        return np.zeros(0, dtype=np.int64)
    # p_d < d (ln d + ln ln d) for d >= 6 (Rosser 1941)
    limit = 15 if d < 6 else int(d * (math.log(d) + math.log(math.log(d)))) + 1
    return _primes_upto(limit)[:d].astype(np.int64)


# ---------------------------------------------------------------------------------------
# digit tables
# ---------------------------------------------------------------------------------------
def _digits_per_group(b: int) -> int:
    k = 1
    while b ** (k + 1) <= _TABLE_LIMIT:
        k += 1
    return k


def _precision_digits(b: int) -> int:
    K = 1
    while b ** K < (1 << _PRECISION_BITS):
        K += 1
    return K


def _group_table(b: int, perms: np.ndarray | None, k: int) -> np.ndarray:
    """``T[r] = sum_{j<k} pi_j(digit_j(r)) b^{-j-1}`` for ``r < b^k`` (identity if no perms).

    Built in integers (exact) and divided once: ``T = R / b^k``."""
    digits = np.arange(b, dtype=np.int64)
    R = np.zeros(1, dtype=np.int64)
    for j in range(k):
        dj = digits if perms is None else perms[j]
        # index r = digit_j * b^j + r_low  ->  row digit_j, column r_low
        R = np.add.outer(dj * b ** (k - 1 - j), R).ravel()
    return R / float(b ** k)


class _Digits:
    """Radical-inverse tables of one base, identity or with digit permutations."""

    def __init__(self, b: int, perms: np.ndarray | None = None) -> None:
        self.b = b
        self.k = _digits_per_group(b)
        self.B = b ** self.k
        self.K = _precision_digits(b)
        self.G = -(-self.K // self.k)          # digit groups inside float64 precision
        self.perms = perms                    # (G*k, b) or None
        self._tables: dict[int, np.ndarray] = {}
        if perms is None:
            self._tails = np.zeros(self.G + 1)
        else:
            # value of groups g, g+1, ... when all their digits are 0 (permuted zeros)
            # (computed exactly like T_g[0], so that gather() does not depend on how many
            # all-zero groups it expands: T_g[0] + tail(g+1)/B == tail(g) bit for bit)
            zero = perms[:, 0].reshape(self.G, self.k)
            w = b ** np.arange(self.k - 1, -1, -1, dtype=np.int64)
            per_group = (zero @ w) / float(self.B)
            tails = np.zeros(self.G + 1)
            for g in range(self.G - 1, -1, -1):
                tails[g] = per_group[g] + tails[g + 1] / self.B
            self._tails = tails

    def _perms_of(self, g: int) -> np.ndarray | None:
        """Permutations of the ``k`` digits of group ``g`` (None: identity)."""
        if self.perms is None or g >= self.G:
            return None
        return self.perms[g * self.k:(g + 1) * self.k]

    def has_table(self, g: int) -> bool:
        if self._perms_of(g) is None:
            return self.b in _IDENTITY_TABLES
        return g in self._tables

    def table(self, g: int) -> np.ndarray:
        p = self._perms_of(g)
        if p is None:
            return _identity_table(self.b, self.k)
        T = self._tables.get(g)
        if T is None:
            T = self._tables[g] = _group_table(self.b, p, self.k)
        return T

    def lookup(self, g: int, r: np.ndarray) -> np.ndarray:
        """``table(g)[r]``; for a few indices and no table yet, the same values computed
        directly (integer digit sums divided by ``b^k``, bit-identical to the table)."""
        if self.has_table(g) or 8 * r.size >= self.B:
            return self.table(g)[r]
        b, k = self.b, self.k
        p = self._perms_of(g)
        R = np.zeros(r.shape, dtype=np.int64)
        q = r
        for j in range(k):
            q, dig = np.divmod(q, b)
            R += (dig if p is None else p[j][dig]) * b ** (k - 1 - j)
        return R / float(b ** k)

    def tail(self, g: int) -> float:
        return float(self._tails[g]) if g < self.G else 0.0

    # -- evaluation ---------------------------------------------------------------------
    def gather(self, i: np.ndarray, g0: int = 0) -> np.ndarray:
        """Radical inverse (from digit group ``g0`` on) of an int64 array ``i``."""
        B = self.B
        groups = []
        q = i
        while q.size and q.max() > 0:
            q, r = np.divmod(q, B)
            groups.append(r)
        res = np.full(i.shape, self.tail(g0 + len(groups)))
        for j in range(len(groups) - 1, -1, -1):
            res = self.lookup(g0 + j, groups[j]) + res / B
        return res

    def fill_range(self, s: int, n: int, out: np.ndarray, g0: int = 0) -> None:
        """``out[:] = phi(s), ..., phi(s + n - 1)`` (``out`` contiguous, length ``n``)."""
        B = self.B
        if n <= 64 or (8 * n < B and not self.has_table(g0)):
            out[:] = self.gather(np.arange(s, s + n, dtype=np.int64), g0)
            return
        q0, q1 = s // B, (s + n - 1) // B
        hi = np.empty(q1 - q0 + 1)
        self.fill_range(q0, q1 - q0 + 1, hi, g0 + 1)
        hi /= B
        T = self.table(g0)
        a = s - q0 * B
        h = min(n, B - a)                           # rest of the first block
        np.add(T[a:a + h], hi[0], out=out[:h])
        m = (n - h) // B                            # full blocks
        block = out[h:h + m * B].reshape(m, B)      # a view: out is contiguous
        np.add(T[None, :], hi[1:1 + m, None], out=block)
        rest = n - h - m * B
        if rest:
            np.add(T[:rest], hi[1 + m], out=out[h + m * B:])


# Unscrambled tables are shared by all engines: a small LRU cache, at most
# _IDENTITY_MAX tables of at most 2^16 entries each (64 MiB).
_IDENTITY_TABLES: OrderedDict[int, np.ndarray] = OrderedDict()
_IDENTITY_MAX = 128


def _identity_table(b: int, k: int) -> np.ndarray:
    T = _IDENTITY_TABLES.get(b)
    if T is None:
        T = _IDENTITY_TABLES[b] = _group_table(b, None, k)
        if len(_IDENTITY_TABLES) > _IDENTITY_MAX:
            _IDENTITY_TABLES.popitem(last=False)
    else:
        _IDENTITY_TABLES.move_to_end(b)
    return T


@functools.cache
def _identity_digits(b: int) -> _Digits:
    return _Digits(b)


@functools.cache
def _digit_factors(b: int) -> tuple[float, ...]:
    """f_0 = 1/b, f_(j+1) = f_j / b (repeated division, as in SciPy), enough for int64."""
    f = [1.0 / b]
    while len(f) < 64:
        f.append(f[-1] / b)
    return tuple(f)


_LSD_TABLES: OrderedDict[int, np.ndarray] = OrderedDict()
_LSD_BUDGET = 64 << 20  # bytes of unscrambled (LSD-order) tables kept, least recently used dropped
_lsd_bytes = 0


def _lsd_table(b: int, k: int) -> np.ndarray:
    """Radical inverse of every r < b^k, summed from the least significant digit (LRU-cached)."""
    global _lsd_bytes
    T = _LSD_TABLES.get(b)
    if T is not None and T.size == b ** k:
        _LSD_TABLES.move_to_end(b)
        return T
    f = _digit_factors(b)
    q = np.arange(b ** k, dtype=np.int64)
    T = np.zeros(q.shape)
    for j in range(k):
        q, digit = np.divmod(q, b)
        T += f[j] * digit
    old = _LSD_TABLES.pop(b, None)
    _lsd_bytes += T.nbytes - (old.nbytes if old is not None else 0)
    _LSD_TABLES[b] = T
    while _lsd_bytes > _LSD_BUDGET and len(_LSD_TABLES) > 1:
        _lsd_bytes -= _LSD_TABLES.popitem(last=False)[1].nbytes
    return T


_FLOAT_EXACT = 1 << 53  # below it, floor(i / b) and i - q b are exact in float64


def lsd_direct(i: np.ndarray, bases: np.ndarray, out: np.ndarray) -> None:
    """``out[c, r] = phi_{bases[c]}(i[r])`` without tables (``i`` int64, ``out`` C-ordered
    ``(len(bases), len(i))``), summed from the least significant digit in SciPy's float
    order, in cache-sized blocks of columns x rows, each looping over as many digits as
    its smallest base needs (the extra digits are 0: adding ``f * 0`` changes no bit).
    Digits are split off in float64 (exact below 2**53, faster than int64 division)."""
    if not i.size or not len(bases):
        return
    top = int(i.max())
    exact = top < _FLOAT_EXACT
    bases = np.asarray(bases, dtype=np.int64)
    ndigs = np.ones(len(bases), dtype=np.int64)               # base-b digits of the largest index
    for c, b_ in enumerate(bases.tolist()):
        while b_ ** int(ndigs[c]) <= top:
            ndigs[c] += 1
    cuts = np.flatnonzero(np.diff(ndigs)) + 1                   # runs of columns with equal digit counts
    blocks = [(a, e) for a, e in zip(np.r_[0, cuts].tolist(), np.r_[cuts, len(bases)].tolist())]
    for a, e in blocks:
        cb = min(e - a, 256)
        rb = max(64, (1 << 13) // cb)
        for c0 in range(a, e, cb):
            _lsd_block(i, bases[c0:min(e, c0 + cb)], int(ndigs[c0]), exact, rb, out[c0:min(e, c0 + cb)])


def _lsd_block(i: np.ndarray, bi: np.ndarray, ndig: int, exact: bool, rb: int, out: np.ndarray) -> None:
    """One block of columns (bases ``bi``, all indices below ``bi ** ndig``) of
    :func:`lsd_direct`, ``rb`` rows at a time."""
    b = bi.astype(np.float64 if exact else np.int64)[:, None]
    f0 = 1.0 / bi.astype(np.float64)[:, None]
    for r0 in range(0, len(i), rb):
        q = i[r0:r0 + rb].astype(np.float64 if exact else np.int64)[None, :]
        acc = out[:, r0:r0 + rb]
        f = f0
        for k in range(ndig):
            if k == ndig - 1:
                digit = q                                  # the last digit: q < b already
            elif exact:
                quot = np.floor(q / b)
                digit = q - quot * b
                q = quot
            else:
                q, digit = np.divmod(q, b)
            if k == 0:
                np.multiply(f, digit, out=acc)             # 0 + f d == f d exactly
            else:
                acc += f * digit
            f = f / b


def radical_inverse(i: ArrayLike, base: int = 2) -> np.ndarray:
    """Vectorised radical inverse ``phi_b(i) = sum_k d_k b^{-k-1}`` where ``i = sum_k d_k b^k``.

    ``i``: non-negative integers (any shape, int dtype); ``base``: integer >= 2.
    Returns float64 of the same shape (van der Corput 1935; Halton 1960).
    """
    base = check_int("base", base, 2, np.iinfo(np.int64).max)
    try:
        arr = np.asarray(i)
    except (TypeError, ValueError):
        raise TypeError(f"i must be an array of integers, got {type(i).__name__}") from None
    if arr.dtype == object or arr.dtype.kind not in "iu":
        if arr.size == 0 and arr.dtype.kind == "f":
            arr = arr.astype(np.int64)
        else:
            raise TypeError(f"i must be an array of integers, got dtype {arr.dtype}")
    if arr.size and (arr.min() < 0):
        raise ValueError("i must be non-negative")
    if arr.dtype == np.uint64 and arr.size and arr.max() > np.iinfo(np.int64).max:
        raise ValueError("i must be < 2**63")
    flat = arr.astype(np.int64, copy=False).ravel()
    k = _digits_per_group(base)
    if base ** k > _TABLE_LIMIT or base ** k > 8 * flat.size:   # a table would not pay
        out = np.empty((1, flat.size))
        for c0 in range(0, flat.size, 1 << 16):
            lsd_direct(flat[c0:c0 + (1 << 16)], np.array([base]), out[:, c0:c0 + (1 << 16)])
        return clamp_open(out[0]).reshape(arr.shape)
    # summed from the least significant digit, as Halton's points (and SciPy's) are
    q, low = np.divmod(flat, base ** k)
    out = _lsd_table(base, k)[low]
    f, j = _digit_factors(base), k
    while q.size and q.max() > 0:
        q, digit = np.divmod(q, base)
        out += f[j] * digit
        j += 1
    # clamp: for i >= 2^53 the exact value 1 - b^-m can round up to 1.0
    return clamp_open(out).reshape(arr.shape)
