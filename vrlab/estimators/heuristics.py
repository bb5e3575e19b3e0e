"""MIS weights and the checks MIS and one-sample MIS share (Veach 1997, 9.2).

With q_k = n_k p_k(x) (multi-sample) or c_k p_k(x) (one-sample), a heuristic maps q (..., K)
to weights w (..., K): ``balance`` w_i = q_i / sum_k q_k; ``power`` w_i = q_i^beta /
sum_k q_k^beta; ``maximum`` w_i = 1 for the largest q_i (ties split); ``cutoff`` balance
among the q_k >= alpha max q; or a user's callable, checked against Veach's conditions
(finite, summing to 1 over the techniques with q_k > 0).  Also: sample counts per
technique (``split_counts``, ``unit_counts``) and technique names resolved per integrand.
"""
from __future__ import annotations

from typing import Any, Callable, Sequence

import numpy as np

from .. import checks
from ..distributions.base import as_float, checked_pdf
from .base import check_technique, resolve_distribution

HEURISTICS = ("balance", "power", "maximum", "cutoff", "optimal")


# ----------------------------------------------------------------------------------------
# weights
# ----------------------------------------------------------------------------------------
def _check_heuristic(heuristic: Any, allowed: Sequence[str]) -> None:
    if callable(heuristic):
        return
    if not isinstance(heuristic, str) or heuristic not in allowed:
        raise ValueError(f"heuristic: unknown {heuristic!r}; allowed: {', '.join(allowed)} "
                         "or a callable q -> w")


def _check_beta_alpha(beta: float, alpha: float) -> tuple[float, float]:
    return (checks.real(beta, "beta", low=0.0, low_open=True),
            checks.real(alpha, "alpha (the cutoff)", low=0.0, high=1.0))


def mis_weights(q: np.ndarray, heuristic: str | Callable = "balance", *, beta: float = 2.0,
                alpha: float = 0.1) -> np.ndarray:
    """MIS weights w (..., K) from q_k = n_k p_k(x) (..., K) (Veach 1997, 9.2).

    ``balance``, ``power`` (exponent ``beta``), ``maximum`` (ties split equally) and
    ``cutoff`` (techniques with q_k >= ``alpha`` max q, balanced among themselves), or
    a callable ``q -> w``.  Where every q_k is 0 all weights are 0.
    """
    _check_heuristic(heuristic, HEURISTICS[:4])
    q = as_float(q)                     # float64, or the renderer's float32
    if callable(heuristic):
        return check_heuristic_weights(heuristic, q)
    beta, alpha = _check_beta_alpha(beta, alpha)
    # techniques on the first axis: NumPy is slow on a short last axis (the renderer has
    # K = 2 for millions of rows), fast on rows of a contiguous (K, ...) array
    qk = np.ascontiguousarray(np.moveaxis(q, -1, 0))
    if heuristic == "balance":
        s = qk
    else:
        mx = np.maximum.reduce(qk, axis=0)
        if heuristic == "power":
            r = np.divide(qk, mx, out=np.zeros_like(qk), where=mx > 0)  # scaled: no overflow
            s = r**beta
        elif heuristic == "maximum":
            s = ((qk >= mx) & (mx > 0)).astype(qk.dtype)
        else:  # cutoff
            s = np.where(qk >= alpha * mx, qk, 0.0)
    total = np.add.reduce(s, axis=0)
    return np.moveaxis(np.divide(s, total, out=np.zeros_like(s), where=total > 0), 0, -1)


def check_heuristic_weights(heuristic: Callable, q: np.ndarray) -> np.ndarray:
    """``heuristic(q)`` checked against Veach's conditions: finite weights of q's shape that
    sum to 1 over the techniques with q_k > 0 wherever some q_k > 0 (ValueError otherwise)."""
    name = getattr(heuristic, "__name__", type(heuristic).__name__)
    try:
        w = np.broadcast_to(np.asarray(heuristic(q), dtype=q.dtype), q.shape)
    except ValueError:
        raise ValueError(f"heuristic {name!r}: its weights must have the shape of q, {q.shape}") from None
    if not np.isfinite(w).all():
        raise ValueError(f"heuristic {name!r}: returned non-finite weights")
    covered = q > 0
    total = np.where(covered, w, 0.0).sum(-1)
    tol = 1e-3 if q.dtype == np.float32 else 1e-6
    bad = covered.any(-1) & (np.abs(total - 1.0) > tol)
    if bad.any():
        i = tuple(int(k) for k in np.argwhere(bad)[0])
        raise ValueError(f"heuristic {name!r}: the weights of the techniques with q_k > 0 must sum to 1 (else the "
                         f"MIS estimate is biased); at q = {q[i].tolist()} they sum to {float(total[i]):.6g}")
    return w


def split_counts(n: int, fractions: np.ndarray, minimum: int = 2) -> np.ndarray:
    """Sample counts n_i: n c_i rounded (largest remainder) so that sum n_i = n.

    Every technique with c_i > 0 gets at least ``minimum`` samples (2: its variance
    needs two); techniques with c_i = 0 get none.  ``ValueError`` if n is too small.
    """
    c = np.asarray(fractions, float) / np.sum(fractions)
    active = c > 0
    if n < minimum * active.sum():
        raise ValueError(f"n: {int(active.sum())} techniques need n >= {minimum * int(active.sum())} "
                         f"samples ({minimum} each), got {n}")
    ideal = n * c
    counts = np.where(active, np.maximum(np.floor(ideal), minimum), 0).astype(np.int64)
    while counts.sum() > n:  # at most K steps: take from the most over-served
        over = np.where(counts > minimum, counts - ideal, -np.inf)
        counts[np.argmax(over)] -= 1
    while counts.sum() < n:  # largest remainder
        under = np.where(active, ideal - counts, -np.inf)
        counts[np.argmax(under)] += 1
    return counts


def _check_fractions(fractions: Any, k: int, name: str) -> np.ndarray:
    if fractions is None:
        return np.full(k, 1.0 / k)
    try:
        c = np.asarray(fractions, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{name}: expected {k} numbers, got {fractions!r}") from None
    if c.ndim != 1 or len(c) != k:
        raise ValueError(f"{name}: expected {k} values (one per distribution), got shape {c.shape}")
    if not np.all(np.isfinite(c)):
        raise ValueError(f"{name}: values must be finite, got {c.tolist()}")
    if np.any(c < 0):
        raise ValueError(f"{name}: values must be >= 0, got {c.tolist()}")
    if not c.sum() > 0:
        raise ValueError(f"{name}: all values are zero (no technique would be sampled)")
    return c / c.sum()


def _check_distributions(distributions: Any) -> list:
    dists = list(distributions) if isinstance(distributions, (list, tuple)) else None
    if not dists:
        raise ValueError("distributions: expected a non-empty list of distributions or technique names")
    return [check_technique(d, f"distributions[{i}]") for i, d in enumerate(dists)]


def resolve_all(distributions: list, integrand) -> list:
    """The distributions, with technique names replaced by the integrand's techniques."""
    if integrand is None:
        if not any(isinstance(d, str) for d in distributions):
            return distributions
        raise ValueError("distributions: technique names are resolved per integrand; pass the integrand")
    return [resolve_distribution(d, integrand, f"distributions[{i}]") for i, d in enumerate(distributions)]


def unit_counts(fractions: Any, normalised: np.ndarray) -> np.ndarray | None:
    """Samples per technique in one sample unit: the given ``fractions`` when they are whole
    numbers (``[2, 1]``: two of the first, one of the second), else the smallest whole
    multiple of the normalised fractions up to 64 (``[0.5, 0.5]`` -> ``[1, 1]``); None
    if there is none (irrational-looking fractions)."""
    if fractions is None:
        return np.ones(len(normalised), np.int64)
    raw = np.asarray(fractions, float)
    if np.all(raw == np.round(raw)) and raw.max() <= 1 << 16:
        return raw.astype(np.int64)
    for k in range(1, 65):
        r = normalised * k
        if np.allclose(r, np.round(r), rtol=0.0, atol=1e-9):
            return np.round(r).astype(np.int64)
    return None


def _check_dims(dists: list, integrand) -> None:
    dims = {getattr(d, "dim_x", None) for d in dists} - {None}
    if len(dims) > 1:
        raise ValueError(f"distributions: points of different dimensions {sorted(dims)}")
    if dims and dims.pop() != integrand.dim:
        raise ValueError(f"distributions: points of dimension {[getattr(d, 'dim_x', None) for d in dists]}, "
                         f"but the integrand's domain has dimension {integrand.dim}")


def _stack_pdfs(dists: list, x: np.ndarray) -> np.ndarray:
    """p_k(x) for every technique, broadcast and stacked on a last axis (..., K)."""
    ps = np.broadcast_arrays(*[checked_pdf(d, x, f"distributions[{k}]") for k, d in enumerate(dists)])
    return np.stack(ps, -1)
