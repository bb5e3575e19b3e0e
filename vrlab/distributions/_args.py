"""Argument checks of the shapes and tables in ``vrlab.distributions`` (kept apart so that
``surfaces.py`` and ``discrete.py`` hold the mathematics).  Each error names the argument:
``TypeError`` for a wrong kind, ``ValueError`` for a bad value or shape.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .. import checks
from ..checks import describe as _describe
from .base import ArgumentTypeError, as_float

# ----------------------------------------------------------------------------- discrete tables

def _checked(weights: Any, name: str) -> tuple[np.ndarray, float, float]:
    """``(w, min(w), max(w))`` for valid weights (see ``check_discrete_weights``); non-numbers
    raise ``ArgumentTypeError`` (a ``TypeError`` that is also the ``ValueError`` of old)."""
    try:
        w = as_float(weights, name).astype(np.float64, copy=False)
    except TypeError:
        raise ArgumentTypeError(f"{name}: expected a 1-D array of real numbers, got {_describe(weights)}") from None
    if w.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D array, got shape {w.shape}")
    if w.size == 0:
        raise ValueError(f"{name}: empty; need at least one weight")
    lo, hi = float(w.min()), float(w.max())  # NaN and inf propagate: two cheap reductions
    if np.isfinite(lo) and np.isfinite(hi) and lo >= 0 and hi > 0:
        return w, lo, hi
    nan = np.isnan(w)
    if nan.any():
        raise ValueError(f"{name}: NaN at index {int(np.argmax(nan))}")
    if not np.isfinite(w).all():
        bad = int(np.argmax(~np.isfinite(w)))
        raise ValueError(f"{name}: infinite value {w[bad]} at index {bad}")
    if lo < 0:
        bad = int(np.argmax(w < 0))
        raise ValueError(f"{name}: negative value {w[bad]!r} at index {bad}; weights must be >= 0")
    raise ValueError(f"{name}: all {w.size} weights are zero; need a positive total")


def _uniforms(u: Any, check: bool = True) -> np.ndarray:
    """``u`` as float64 of shape ``(...)``; ``(..., 1)`` with ndim >= 2 drops the last axis.
    ``TypeError`` unless numbers; with ``check``, ``ValueError`` unless in [0, 1)."""
    u = as_float(u, "u").astype(np.float64, copy=False)
    if u.ndim >= 2 and u.shape[-1] == 1:
        u = u[..., 0]
    if check and u.size and not (u.min() >= 0.0 and u.max() < 1.0):  # NaN fails too
        _outside(u)
    return u


def _outside(u: np.ndarray) -> None:
    """Raise the ``ValueError`` for uniforms ``u`` of which some lie outside [0, 1)."""
    bad = ~((u >= 0.0) & (u < 1.0))
    where = tuple(int(i) for i in np.argwhere(bad)[0])
    raise ValueError(f"u: uniforms must lie in [0, 1), but entry {where} is {u[where]!r}")


_flag = checks.flag


# ----------------------------------------------------------------------------- surfaces

def _vector3(v: Any, name: str) -> np.ndarray:
    a = as_float(v, name)                       # float64, or float32 kept
    if a.shape != (3,):
        raise ValueError(f"{name}: expected a 3-vector, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: must be finite, got {a.tolist()}")
    return a


def _square(m: Any, name: str, k: int, what: str) -> np.ndarray:
    """A finite k x k float64 matrix."""
    a = np.array(as_float(m, name), dtype=np.float64)
    if a.shape != (k, k):
        raise ValueError(f"{name}: expected {what}, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: must be finite")
    return a


_SIZES = (1e-100, 1e100)  # lengths of edges, radii, semi-axes: areas and volumes stay finite


def _sizes(lengths: np.ndarray, name: str) -> None:
    lo, hi = _SIZES
    lengths = np.asarray(lengths, dtype=np.float64)
    if not (np.all(lengths >= lo) and np.all(lengths <= hi)):
        raise ValueError(f"{name}: sizes (lengths) must lie in [{lo:g}, {hi:g}], got {np.asarray(lengths).tolist()}")


def _matrix3(m: Any, name: str) -> np.ndarray:
    """A finite 3x3 matrix, not singular (s2 s3 / s1^2 > 1e-12 for its singular values s1 >= s2 >= s3)."""
    a = _square(m, name, 3, "a 3x3 matrix")
    with np.errstate(all="ignore"):
        sv = np.linalg.svd(a, compute_uv=False)
    if sv[0] > 0:
        _sizes(sv[:1], name)
    if not sv[0] > 0 or (sv[1] / sv[0]) * (sv[2] / sv[0]) <= 1e-12:
        raise ValueError(f"{name}: must be non-singular (the shape would be flat)")
    _sizes(sv, name)
    return a


def _rotation3(m: Any, name: str = "rotation") -> np.ndarray:
    if m is None:
        return np.eye(3)
    a = _square(m, name, 3, "an orthogonal 3x3 matrix")
    if not np.allclose(a.T @ a, np.eye(3), atol=1e-9):
        raise ValueError(f"{name}: expected an orthogonal 3x3 matrix (R^T R = I)")
    return a


def _positive3(v: Any, name: str) -> np.ndarray:
    """Three finite numbers > 0 (one number is repeated)."""
    a = np.array(as_float(v, name), dtype=np.float64)
    if a.ndim == 0:
        a = np.repeat(a, 3)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise ValueError(f"{name}: expected 3 finite numbers > 0 (or one), got {v!r}")
    return a


def _affine4(m: Any, name: str = "matrix") -> tuple[np.ndarray, np.ndarray]:
    """Linear part and translation of a 4x4 affine ``to_world`` matrix."""
    a = _square(m, name, 4, "a 4x4 to_world matrix")
    if not np.allclose(a[3], [0.0, 0.0, 0.0, 1.0], rtol=0, atol=1e-12):
        raise ValueError(f"{name}: must be affine (last row 0 0 0 1), got {a[3].tolist()}")
    return a[:3, :3].copy(), a[:3, 3].copy()
