"""The distribution protocol shared by every warp in vrlab.

A distribution maps uniforms ``u`` of shape ``(..., dim_u)`` in [0, 1) to points
``x`` of shape ``(..., dim_x)`` and reports the density of what it produces,
``pdf(x) -> (...)``, with respect to the measure named in ``measure``
("length", "area", "solid angle", "counting").  Where the map is invertible,
``invert(x) -> u`` undoes ``sample``.

The protocol is duck-typed: estimators only need ``dim_u``, ``sample`` and
``pdf``.  ``Distribution`` is a convenience base class, not a requirement.
"""
from __future__ import annotations

from typing import Any

import numpy as np


def as_float(x: Any) -> np.ndarray:
    """``x`` as a float64 array, or as it is if it is a float32 array (the renderer's
    vectors are float32; everything else computes in float64)."""
    x = np.asarray(x)
    return x if x.dtype == np.float32 else x.astype(np.float64, copy=False)


def as_points(x: Any, k: int, name: str = "x") -> np.ndarray:
    """Check that ``x`` holds points of a ``k``-dimensional domain: shape ``(..., k)``
    (float64, or float32 kept: see :func:`as_float`)."""
    x = as_float(x)
    if x.ndim == 0 or x.shape[-1] != k:
        raise ValueError(f"{name}: expected shape (..., {k}), got {x.shape}")
    return x


def as_uniforms(u: Any, dim_u: int) -> np.ndarray:
    """Check that ``u`` has shape ``(..., dim_u)`` (values are not range-checked: hot path;
    float32 is kept, see :func:`as_float`)."""
    u = as_float(u)
    if u.ndim == 0 or u.shape[-1] != dim_u:
        raise ValueError(f"u: expected uniforms of shape (..., {dim_u}), got {u.shape}")
    return u


def uniforms32(u: Any) -> np.ndarray:
    """Uniforms in [0, 1) as float32, still in [0, 1): float32 rounding could reach 1."""
    return np.minimum(np.asarray(u, dtype=np.float32), np.nextafter(np.float32(1), np.float32(0)))


class Distribution:
    """Base class: subclasses set ``dim_u``, ``dim_x``, ``measure`` and implement
    ``sample`` and ``pdf`` (and ``invert`` where the warp is a bijection)."""

    dim_u: int = 1
    dim_x: int = 1
    measure: str = "length"

    def sample(self, u: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError  # abstract

    def pdf(self, x: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError  # abstract

    def sample_pdf(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(x, pdf(x))`` for ``x = sample(u)``; subclasses may share work."""
        x = self.sample(u)
        return x, self.pdf(x)

    def __repr__(self) -> str:
        fields = ", ".join(f"{k}={v!r}" for k, v in self._repr_fields().items())
        return f"{type(self).__name__}({fields})"

    def _repr_fields(self) -> dict:
        return {}


def positive_float(value: Any, name: str) -> float:
    """``float(value)`` if finite and > 0, else ``ValueError`` naming ``name``."""
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return v
