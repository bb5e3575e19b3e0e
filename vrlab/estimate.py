"""``Estimate`` and the mergeable moment accumulator behind it.

Moments are accumulated with Welford's update generalised to blocks (Chan, Golub &
LeVeque 1979, "Updating formulae and a pairwise algorithm for computing sample
variances"): for two blocks with counts n_a, n_b, means m_a, m_b and sums of squared
deviations M_a, M_b,

    n = n_a + n_b,  delta = m_b - m_a,
    m = m_a + delta n_b / n,  M = M_a + M_b + delta^2 n_a n_b / n.

So a run of 10^8 samples goes in chunks with bounded memory, and the result does
not depend on the chunk size beyond rounding.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import checks

# Sample values whose variance float64 cannot carry are refused (the helpers below): squared
# deviations that overflow (deviations beyond about 1e154 / sqrt(n)), or a variance below
# LOW_VARIANCE (9e-302) while the samples are not all equal (deviations below about 1e-150), where
# squares fall out of float64's normal range and the variance and stderr would silently be 0.
LOW_VARIANCE = 2.0 ** -1000


def unrepresentable(what: str) -> ValueError:
    """The error for samples whose variance float64 cannot carry (``what`` says why)."""
    return ValueError(f"values: {what}, so their variance and standard error cannot be computed in float64; "
                      "rescale the integrand (multiply f by a power of 10 and the estimate by its inverse)")


def moments_finite(values: np.ndarray, mean: np.ndarray, m2: np.ndarray) -> bool:
    """True when the moments ``mean`` and ``m2`` of ``values`` are finite; False when the
    values themselves are not (left to the callers' own checks); an overflow of finite values
    is refused."""
    if np.all(np.isfinite(mean)) and np.all(np.isfinite(m2)):
        return True
    if np.all(np.isfinite(values)):
        what = "squared deviations" if np.all(np.isfinite(mean)) else "sum"
        raise unrepresentable(f"samples up to {np.max(np.abs(values)):.3g} in magnitude: their {what} overflow "
                              "float64")
    return False


def check_spread(values: np.ndarray, axis: int, mean: np.ndarray, m2: np.ndarray) -> None:
    """Refuse (``ValueError`` naming the values) finite samples ``values`` (float64, along
    ``axis``) whose ``mean`` or sum of squared deviations ``m2`` overflowed, or whose variance
    lies below :data:`LOW_VARIANCE` although they are not all equal (see the module note).
    Non-finite samples are left to the callers' own checks."""
    if not moments_finite(values, mean, m2):
        return
    m = values.shape[axis]
    low = np.asarray(m2) < LOW_VARIANCE * max(m - 1, 1)
    if m > 1 and np.any(low):
        rows = np.moveaxis(values, axis, -1)[low]
        spread = np.max(rows, -1) - np.min(rows, -1)
        if np.any(spread > 0):
            raise unrepresentable(f"samples that differ by at most {np.max(spread):.3g}: the squares of "
                                  "their deviations underflow float64")


def check_merged(m2: np.ndarray, parts: tuple, delta: np.ndarray, n: int) -> None:
    """Refuse a merged sum of squared deviations ``m2`` of ``n`` samples that overflowed
    (the two ``parts``' sums were finite) or whose variance fell below :data:`LOW_VARIANCE`
    while the parts' means differ by ``delta`` (their squared difference underflowed)."""
    if all(np.all(np.isfinite(q)) for q in parts) and not np.all(np.isfinite(m2)):
        raise unrepresentable("blocks of samples whose squared deviations overflow float64 when merged")
    low = np.asarray(m2) < LOW_VARIANCE * max(n - 1, 1)
    gap = np.broadcast_to(np.abs(np.asarray(delta, dtype=float)), low.shape)
    if np.any(low & (gap != 0)):
        raise unrepresentable(f"blocks of samples whose means differ by about {np.max(gap[low]):.3g}: the "
                              "squares of such differences underflow float64")


class Moments:
    """Running count, mean and sum of squared deviations along the last axis (batched)."""

    def __init__(self) -> None:
        self.count = 0
        self.mean: np.ndarray | float = 0.0
        self.m2: np.ndarray | float = 0.0

    def add(self, values: np.ndarray, axis: int = -1) -> "Moments":
        """Merge a block of samples ``values (*batch, m)``, or with the samples along
        ``axis`` (no transposed copy, e.g. the renderer's ``(pixels, spp, 3)``)."""
        single = getattr(values, "dtype", None) == np.float32
        v = np.asarray(values, dtype=float)
        m = v.shape[axis]
        if m == 0:
            return self
        with np.errstate(over="ignore", under="ignore"):
            mean_b = v.mean(axis=axis)
            dev = v - np.expand_dims(mean_b, axis)
            dev *= dev
            m2_b = dev.sum(axis=axis)
        if not single:      # float32 samples' squares cannot leave float64's range
            check_spread(v, axis, mean_b, m2_b)
        return self.merge_stats(m, mean_b, m2_b)

    def merge_stats(self, n_b: int, mean_b, m2_b) -> "Moments":
        if self.count == 0:
            self.count, self.mean, self.m2 = n_b, np.asarray(mean_b, float), np.asarray(m2_b, float)
            return self
        n = self.count + n_b
        delta = mean_b - self.mean
        with np.errstate(over="ignore", under="ignore"):
            m2 = self.m2 + m2_b + delta * delta * (self.count * n_b / n)
        check_merged(m2, (self.m2, m2_b), delta, n)
        self.mean = self.mean + delta * (n_b / n)
        self.m2 = m2
        self.count = n
        return self

    def merge(self, other: "Moments") -> "Moments":
        """Fold another accumulator into this one (e.g. from another worker)."""
        if other.count:
            self.merge_stats(other.count, other.mean, other.m2)
        return self

    # -- the statistics protocol (checkpoints, tiles): state, from_state, concat ---------------
    def state(self) -> dict:
        """The accumulator as plain arrays ``{"kind", "count", "mean", "m2"}`` (what a
        checkpoint stores; :meth:`from_state` rebuilds it exactly)."""
        return {"kind": type(self).__name__, "count": np.asarray(self.count),
                "mean": np.asarray(self.mean), "m2": np.asarray(self.m2)}

    @classmethod
    def from_state(cls, state: dict) -> "Moments":
        """The accumulator of :meth:`state`'s dict (``ValueError`` naming ``state`` if it is not one)."""
        out = cls()
        try:
            out.count = int(np.asarray(state["count"]))
            out.mean, out.m2 = _array_or_float(state["mean"]), _array_or_float(state["m2"])
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"state: not the state of a {cls.__name__} ({exc!r})") from None
        return out

    @classmethod
    def concat(cls, parts: list, axis: int = 0) -> "Moments":
        """Accumulators of disjoint *batch elements* (the same units, e.g. blocks of pixels of
        a tile) joined along batch ``axis``; all must hold the same count."""
        parts = list(parts)
        if len(parts) == 1:
            return parts[0]
        if len({p.count for p in parts}) != 1:
            raise ValueError("parts: concat joins batch elements with the same number of units")
        out = cls()
        out.count = parts[0].count
        out.mean = np.concatenate([np.asarray(p.mean) for p in parts], axis=axis)
        out.m2 = np.concatenate([np.asarray(p.m2) for p in parts], axis=axis)
        return out

    @property
    def variance(self):
        """Unbiased sample variance of one sample (ddof = 1)."""
        if self.count < 2:
            return np.full(np.shape(self.mean), np.nan)
        return self.m2 / (self.count - 1)


def _array_or_float(value):
    a = np.asarray(value, dtype=float)
    return float(a) if a.ndim == 0 else a


@dataclass
class Estimate:
    """A Monte Carlo estimate with its standard error.

    ``value`` and ``stderr`` have the integrand's batch shape (scalars for a plain
    integral).  ``n`` counts independent sample units (points, pairs, replicates),
    ``n_evals`` integrand evaluations (the cost), ``seconds`` wall time.
    ``variance`` is the per-unit sample variance, so stderr = sqrt(variance / n).
    """

    value: Any
    stderr: Any
    n: int
    n_evals: int
    seconds: float = 0.0
    variance: Any = None
    method: str = ""
    extra: dict = field(default_factory=dict)

    def ci(self, level: float = 0.95):
        """Normal-theory confidence interval ``(lo, hi)`` at ``level``."""
        level = checks.real(level, "level", low=0.0, high=1.0, low_open=True, high_open=True)
        from scipy import stats

        z = stats.norm.ppf(0.5 + level / 2)
        v, s = np.asarray(self.value), np.asarray(self.stderr)
        return v - z * s, v + z * s

    def zscore(self, exact):
        """(value - exact) / stderr: about N(0, 1) for a calibrated unbiased estimator."""
        exact = checks.finite_array(exact, "exact")
        with np.errstate(divide="ignore", invalid="ignore"):
            return (np.asarray(self.value) - exact) / np.asarray(self.stderr)

    @property
    def efficiency(self):
        """1 / (variance of the estimate x seconds): higher is better (equal-time comparisons)."""
        with np.errstate(divide="ignore"):
            return 1.0 / (np.asarray(self.stderr) ** 2 * self.seconds)

    def to_dict(self) -> dict:
        """Plain-Python fields (arrays as lists) for JSON and DataFrames."""
        def plain(v):
            a = np.asarray(v)
            return a.item() if a.ndim == 0 else a.tolist()
        out = {"value": plain(self.value), "stderr": plain(self.stderr), "n": int(self.n),
               "n_evals": int(self.n_evals), "seconds": float(self.seconds), "method": self.method}
        if self.variance is not None:
            out["variance"] = plain(self.variance)
        out.update({k: plain(v) if isinstance(v, (np.ndarray, np.generic, float, int)) else v
                    for k, v in self.extra.items()})
        return out

    @classmethod
    def from_moments(cls, mom: Moments, n_evals: int, seconds: float = 0.0, method: str = "",
                     **extra) -> "Estimate":
        var = mom.variance
        stderr = np.sqrt(var / mom.count) if mom.count else np.nan
        def scalar(a):
            a = np.asarray(a, dtype=float)
            return float(a) if a.ndim == 0 else a
        return cls(scalar(mom.mean), scalar(stderr), int(mom.count), int(n_evals), seconds,
                   scalar(var), method, dict(extra))

    def __repr__(self) -> str:
        if np.ndim(self.value) == 0:
            return (f"Estimate({self.value:.6g} ± {self.stderr:.3g}, n={self.n}, n_evals={self.n_evals}, "
                    f"{self.seconds:.3g} s{', ' + self.method if self.method else ''})")
        return f"Estimate(shape={np.shape(self.value)}, n={self.n}, n_evals={self.n_evals})"
