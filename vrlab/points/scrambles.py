r"""Per-dimension digit generators: plain, random digit permutations, Owen scrambling.

Scrambling (randomised QMC; the estimator becomes unbiased and replicates give an
error estimate)
* ``scramble=True`` -- random digit permutations (Braaten & Weller 1979; the
  randomisation of Owen 2017, *A randomized Halton algorithm in R*, also used by
  ``scipy.stats.qmc.Halton``): for every dimension and every digit position ``k`` an
  independent uniformly random permutation ``pi_k`` of ``{0..b-1}``::

      x = sum_k pi_k(d_k) b^{-k-1}.

  The infinitely many trailing zero digits of ``i`` are permuted too (``pi_k(0)`` is
  usually not 0), so the sum runs over ``K`` digit positions, the smallest ``K``
  with ``b^{-K} <= 2^{-53}``: the digits beyond it do not change a float64.
  Bases ``b <= 2**12`` (the first 564 dimensions) get full permutation tables; larger
  bases get random affine maps ``pi_k(d) = (a_k d + c_k) mod b`` (``a_k != 0``), which
  have the same pairwise laws (see :class:`_AffineColumns`) and need no tables, so that
  ``d = 10^4`` takes megabytes, not the ~12 GB of full tables.
* ``scramble="owen"`` -- nested scrambling (Owen 1995): the permutation applied to
  digit ``k`` also depends on the digits ``d_0 .. d_{k-1}`` before it (the node
  ``p = i mod b^k`` of the b-ary tree the point is in).  Here each node's permutation
  is a random affine map ``d -> (a d + c) mod b`` (``a != 0``) with ``a`` and ``c``
  from 64-bit hashes of the node under per-engine random seeds.  For prime ``b``
  these maps are 2-point uniform (two distinct digits go to a uniformly random pair
  of distinct digits), which is what the uniformity of each point and the pairwise
  (variance) properties of nested scrambling depend on; in base 2 this *is* nested
  uniform scrambling.  Digits at positions ``k < L`` (``b^L >= 2^32``) are scrambled
  node by node, those below ``b^-L`` are an independent hashed uniform per point;
  point indices must stay below ``2^32``.  Results do not depend on how the
  indices are split across calls.
"""
from __future__ import annotations

import numpy as np

from .base import clamp_open
from .radical import (
    _digit_factors,
    _Digits,
    _digits_per_group,
    _identity_digits,
    _lsd_table,
    _precision_digits,
    lsd_direct,
)

_OWEN_INDEX_LIMIT = 1 << 32
#: scramble=True: bases up to this get full random permutation tables (SciPy's randomisation);
#: larger ones random affine digit maps (same pairwise laws), see _AffineColumns
PERMUTATION_TABLE_MAX_BASE = 1 << 12
ScrambleArg = bool | str
# ---------------------------------------------------------------------------------------
# per-dimension generators
# ---------------------------------------------------------------------------------------
def _mix64(x: np.ndarray) -> np.ndarray:
    """SplitMix64 finaliser (Steele, Lea & Flood 2014): a bijective 64-bit hash (in place)."""
    x ^= x >> 30
    x *= 0xBF58476D1CE4E5B9
    x ^= x >> 27
    x *= 0x94D049BB133111EB
    x ^= x >> 31
    return x


class _PlainColumns:
    """Unscrambled radical inverses of several bases, summed from the least significant
    digit: ``((d_0 f_0 + d_1 f_1) + d_2 f_2) + ...`` with ``f_0 = 1/b``, ``f_(k+1) = f_k / b``.

    This is the floating-point operation order of ``scipy.stats.qmc.Halton(d,
    scramble=False)``, so the points agree with SciPy's bit for bit.  Per call and column,
    either a table (LRU-cached) gives the first ``k`` digits and the higher digits,
    constant over blocks of ``b^k`` consecutive indices, are added per block -- when the
    call is large enough to pay for the table -- or all columns without a table are done
    together digit by digit (:func:`~vrlab.points.radical.lsd_direct`): the same sums, so
    the choice never changes a point, and ``d = 10^4`` needs no per-base tables.
    """

    def __init__(self, bases: list[int]) -> None:
        self.bases = np.asarray(bases, dtype=np.int64)
        self.width = len(bases)
        self.k = np.array([_digits_per_group(b) for b in bases], dtype=np.int64)
        self.B = np.array([b ** k for b, k in zip(bases, self.k)], dtype=np.int64)

    def fill(self, s: int, n: int, out: np.ndarray) -> None:
        if n == 0 or self.width == 0:
            return
        ndig = np.ceil(np.log(s + n + 1.0) / np.log(self.bases.astype(np.float64)))
        # a table of k >= 2 digits pays off once built (a one-digit table saves nothing)
        tabled = (self.k >= 2) & (n * ndig >= self.B * self.k)
        for c in np.flatnonzero(tabled):
            self._fill_table(int(self.bases[c]), int(self.k[c]), s, n, out[:, c])
        direct = np.flatnonzero(~tabled)
        if direct.size:
            i = np.arange(s, s + n, dtype=np.int64)
            cuts = np.flatnonzero(np.diff(direct) != 1) + 1
            for a, e in zip(np.r_[0, cuts].tolist(), np.r_[cuts, direct.size].tolist()):
                c0, c1 = int(direct[a]), int(direct[e - 1]) + 1      # a run of adjacent columns:
                target = out[:, c0:c1].T                             # C-ordered when out is F-ordered
                if not target.flags.c_contiguous:
                    target = np.empty((c1 - c0, n))
                lsd_direct(i, self.bases[c0:c1], target)
                if target.base is None:
                    out[:, c0:c1] = target.T
        if s + n > 1 << 50:  # only huge indices can round up to 1.0
            clamp_open(out)

    @staticmethod
    def _fill_table(b: int, k: int, s: int, n: int, out: np.ndarray) -> None:
        B, f = b ** k, _digit_factors(b)
        q, low = np.divmod(np.arange(s, s + n, dtype=np.int64), B)
        np.take(_lsd_table(b, k), low, out=out, mode="clip")  # clip: unbuffered
        q0 = int(q[0])
        block = q - q0 if q0 else q                       # block of each index, from 0
        qq = np.arange(q0, int(q[-1]) + 1, dtype=np.int64)  # one entry per block
        j = k
        while qq.size and qq.max() > 0:
            qq, digit = np.divmod(qq, b)
            out += (f[j] * digit)[block]
            j += 1


class _PerColumn:
    """One generator per column (``fill(s, n, out_column)``)."""

    def __init__(self, dims: list) -> None:
        self.dims = dims
        self.width = len(dims)

    def fill(self, s: int, n: int, out: np.ndarray) -> None:
        for c, dim in enumerate(self.dims):
            dim.fill(s, n, out[:, c])


class _PermutedDim:
    """Random digit permutations, one per digit position (``scramble=True``)."""

    def __init__(self, b: int, rng: np.random.Generator) -> None:
        proto = _identity_digits(b)
        count = proto.G * proto.k
        perms = rng.permuted(np.broadcast_to(np.arange(b, dtype=np.int64), (count, b)), axis=1)
        self.digits = _Digits(b, perms)

    def fill(self, s: int, n: int, out: np.ndarray) -> None:
        self.digits.fill_range(s, n, out)
        clamp_open(out)


class _AffineColumns:
    """Random digit permutations of large bases (``b > 2**12``) as random affine maps
    ``d -> (a_k d + c_k) mod b``, ``a_k`` uniform on ``1..b-1`` and ``c_k`` on ``0..b-1``,
    independent per column and digit position ``k < K``.

    For a prime ``b`` these maps form a sharply 2-transitive group, so every pair of
    distinct digits goes to a uniformly random pair of distinct digits: each point is
    uniform and every pairwise law -- hence the estimator's mean and variance -- is
    exactly that of uniform random permutations, with two integers per position instead
    of a table of ``b`` (``K b`` integers per column would be ~12 GB at ``d = 10^4``).
    All columns are computed together, most significant digit last (Horner).
    """

    def __init__(self, bases: list[int], rng: np.random.Generator) -> None:
        self.bases = np.asarray(bases, dtype=np.int64)
        self.width = len(bases)
        K = np.array([_precision_digits(b) for b in bases], dtype=np.int64)
        self.K = int(K.max()) if len(bases) else 0
        active = np.arange(self.K)[:, None] < K[None, :]              # (K, width)
        self.a = np.where(active, rng.integers(1, self.bases, size=(self.K, self.width)), 0)
        self.c = np.where(active, rng.integers(0, self.bases, size=(self.K, self.width)), 0)

    def fill(self, s: int, n: int, out: np.ndarray) -> None:
        if n == 0 or self.width == 0:
            return
        top = s + n - 1
        exact = top < 1 << 53                      # digits split off in float64 (exact)
        cb = min(self.width, 256)
        rb = max(64, (1 << 13) // cb)
        for c0 in range(0, self.width, cb):
            bi = self.bases[c0:c0 + cb]
            ndig = 1                               # digits of the indices (the rest are 0)
            while int(bi[0]) ** ndig <= top and ndig < self.K:
                ndig += 1
            a, c = self.a[:, c0:c0 + cb], self.c[:, c0:c0 + cb]
            b = bi.astype(np.float64 if exact else np.int64)
            tail = np.zeros(len(bi))               # positions >= ndig: digit 0 -> c_k
            for k in range(self.K - 1, ndig - 1, -1):
                tail += c[k]
                tail /= bi
            for r0 in range(0, n, rb):
                m = min(rb, n - r0)
                q = np.arange(s + r0, s + r0 + m, dtype=np.float64 if exact else np.int64)[:, None]
                digits = []
                for _ in range(ndig):              # least significant first
                    quot = np.floor(q / b) if exact else q // b
                    digits.append(q - quot * b)
                    q = quot
                res = np.broadcast_to(tail, (m, len(bi))).copy()
                for k in range(ndig - 1, -1, -1):  # Horner, same operations as for all K digits
                    e = a[k] * digits[k] + c[k]
                    res += e - (np.floor(e / b) if exact else e // b) * b
                    res /= b
                out[r0:r0 + m, c0:c0 + cb] = res
        clamp_open(out)


class _OwenDim:
    """Nested (Owen) scrambling with hashed affine node permutations (``scramble="owen"``).

    Digit ``k`` (weight ``b^{-k-1}``) of point ``j`` lies in node ``p = j mod b^k``; it
    becomes ``(a d_k + c) mod b`` with ``a = 1 + h_k(p) mod (b-1)`` (``a = 1`` in base 2)
    and ``c`` = digit ``k`` (most significant first) of ``H(p) = h(p) mod b^L``.  Taking
    ``c`` from ``H(p)`` makes the digits of point ``j`` past its last nonzero digit equal
    to the digits of ``H(j)``, so all of them come from one hash per point; the digits
    below ``b^{-L}`` are one more independent uniform per point.  The first ``k0`` levels
    (``b^{k0} <= 2^16``) are tabulated over ``j mod b^{k0}``.
    """

    def __init__(self, b: int, rng: np.random.Generator) -> None:
        self.b = b
        L = 1
        while b ** L < _OWEN_INDEX_LIMIT:
            L += 1
        self.L = L
        self.bL = b ** L
        self.k0 = min(_digits_per_group(b), L)
        # seeds: one per level (for a), one for H, one for the tail below b^-L
        self.seeds = rng.integers(0, np.iinfo(np.uint64).max, size=L + 2, dtype=np.uint64, endpoint=True)
        self._table: np.ndarray | None = None

    def _hash(self, p: np.ndarray, seed: np.uint64) -> np.ndarray:
        return _mix64(p.astype(np.uint64) ^ seed)

    def _H(self, p: np.ndarray) -> np.ndarray:
        """``H(p)``, uniform on ``[0, b^L)`` (int64)."""
        h = self._hash(p, self.seeds[self.L])
        if self.b == 2:
            return (h >> np.uint64(64 - self.L)).astype(np.int64)
        # multiply-shift by floats: floor(u * b^L), u with 53 random bits
        return ((h >> np.uint64(11)).astype(np.float64) * (self.bL * 2.0 ** -53)).astype(np.int64)

    def _level(self, k: int, p: np.ndarray, dig: np.ndarray) -> np.ndarray:
        """Scrambled digit ``k`` of points in nodes ``p`` with original digits ``dig``."""
        b = self.b
        H = self._H(p)
        if b == 2:
            return dig ^ ((H >> (self.L - 1 - k)) & 1)
        c = _mod(H // b ** (self.L - 1 - k), b)
        a = _mod(self._hash(p, self.seeds[k]) >> np.uint64(1), np.uint64(b - 1)).astype(np.int64) + 1
        return _mod(a * dig + c, b)

    def _low_table(self) -> np.ndarray:
        if self._table is None:
            b = self.b
            r = np.arange(b ** self.k0, dtype=np.int64)
            V = np.zeros_like(r)
            for k in range(self.k0):
                q, p = _divmod(r, b ** k)
                V = V * b + self._level(k, p, _mod(q, b))
            self._table = V
        return self._table

    def fill(self, s: int, n: int, out: np.ndarray) -> None:
        if s + n > _OWEN_INDEX_LIMIT:
            raise ValueError(f"n: scramble='owen' supports point indices below 2**32, asked up to {s + n - 1}")
        b, L = self.b, self.L
        # tabulate levels 0 .. k0-1 only when the call is large enough to pay for the table
        # (the table caches the very same formula, so results do not depend on this choice)
        use_table = self._table is not None or 4 * n >= b ** self.k0
        k_start = self.k0 if use_table else 0
        ndig = 0
        while b ** ndig <= s + n - 1:
            ndig += 1
        K1 = max(k_start, ndig)
        w = b ** (L - K1)
        for c0 in range(0, n, _CHUNK):                       # blocks of points: temporaries stay in cache
            j = np.arange(s + c0, s + min(n, c0 + _CHUNK), dtype=np.int64)
            if use_table:
                R = self._low_table()[_mod(j, b ** self.k0)]  # levels 0 .. k0-1
            else:
                R = np.zeros(len(j), dtype=np.int64)
            for k in range(k_start, K1):                     # levels with nonzero digits
                q, p = _divmod(j, b ** k)
                R = R * b + self._level(k, p, _mod(q, b))
            # levels K1 .. L-1: every digit of j is 0 there and the node is j itself
            R = R * w + _mod(self._H(j), w)
            tail = (self._hash(j, self.seeds[L + 1]) >> np.uint64(11)).astype(np.float64) * 2.0 ** -53
            np.divide(R + tail, float(self.bL), out=out[c0:c0 + len(j)])
        clamp_open(out)


def _divmod(x: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
    q = x // m
    return q, x - q * m


def _mod(x: np.ndarray, m) -> np.ndarray:
    return x - (x // m) * m


_CHUNK = 1 << 15


def _scramble_mode(scramble: ScrambleArg) -> str | None:
    if scramble is False or (isinstance(scramble, np.bool_) and not scramble):
        return None
    if scramble is True or (isinstance(scramble, np.bool_) and scramble):
        return "permutation"
    if isinstance(scramble, str) and scramble.lower() in ("permutation", "owen"):
        return scramble.lower()
    raise ValueError("scramble must be False, True (random digit permutations), 'permutation' or 'owen'; "
                     f"got {scramble!r}")


def _make_dims(bases: list[int], mode: str | None, rng: np.random.Generator) -> list:
    """Column groups, in column order, each with ``width`` and ``fill(s, n, out_block)``."""
    if mode is None:
        return [_PlainColumns(bases)]
    if mode == "owen":
        return [_PerColumn([_OwenDim(b, rng) for b in bases])]
    small = [b for b in bases if b <= PERMUTATION_TABLE_MAX_BASE]
    groups: list = [_PerColumn([_PermutedDim(b, rng) for b in small])]
    if len(small) < len(bases):
        groups.append(_AffineColumns(bases[len(small):], rng))
    return groups
