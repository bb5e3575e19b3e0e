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
from .radical import _TABLE_LIMIT, _Digits, _digit_factors, _digits_per_group, _identity_digits, _lsd_table  # noqa: F401

_OWEN_INDEX_LIMIT = 1 << 32
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


class _PlainDim:
    """Unscrambled radical inverse, summed from the least significant digit:
    ``((d_0 f_0 + d_1 f_1) + d_2 f_2) + ...`` with ``f_0 = 1/b``, ``f_(k+1) = f_k / b``.

    This is the floating-point operation order of ``scipy.stats.qmc.Halton(d,
    scramble=False)``, so the points agree with SciPy's bit for bit.  The first ``k``
    digits come from a table built in the same order; the higher digits are constant
    over blocks of ``b^k`` consecutive indices and are added per block.
    """

    def __init__(self, b: int) -> None:
        self.b = b
        self.k = _digits_per_group(b)
        self.B = b ** self.k
        self.f = _digit_factors(b)
        self.table = _lsd_table(b, self.k)

    def fill(self, s: int, n: int, out: np.ndarray) -> None:
        if n == 0:
            return
        q, low = np.divmod(np.arange(s, s + n, dtype=np.int64), self.B)
        np.take(self.table, low, out=out)
        q0 = int(q[0])
        block = q - q0 if q0 else q                       # block of each index, from 0
        qq = np.arange(q0, int(q[-1]) + 1, dtype=np.int64)  # one entry per block
        j = self.k
        while qq.size and qq.max() > 0:
            qq, digit = np.divmod(qq, self.b)
            out += (self.f[j] * digit)[block]
            j += 1
        if s + n > 1 << 50:  # only huge indices can round up to 1.0
            clamp_open(out)


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
            raise ValueError(f"scramble='owen' supports point indices below 2**32, asked up to {s + n - 1}")
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
    raise ValueError(f"scramble must be False, True (random digit permutations), 'permutation' or 'owen'; got {scramble!r}")


def _make_dims(bases: list[int], mode: str | None, rng: np.random.Generator) -> list:
    if mode is None:
        return [_PlainDim(b) for b in bases]
    if mode == "permutation":
        return [_PermutedDim(b, rng) for b in bases]
    return [_OwenDim(b, rng) for b in bases]


