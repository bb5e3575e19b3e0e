"""Small helpers of the light-surface modules (``surfaces``, ``solid_angle``): unit vectors and
the sphere's (u1, u2) chart (Archimedes' hat-box: z = 1 - 2 u1, phi = 2 pi u2)."""
from __future__ import annotations

import numpy as np

TWO_PI = 2.0 * np.pi
FOUR_PI = 4.0 * np.pi
_T_EPS = 1e-9  # hits closer than _T_EPS * (bounding radius) are ignored (self-intersection)


def _unit(v: np.ndarray) -> np.ndarray:
    """v / |v| along the last axis, without warnings for zero vectors (they give NaN)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _finish_hits(t: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Misses to inf, hits sorted ascending along the last axis."""
    return np.sort(np.where(valid, t, np.inf), axis=-1)


def _sphere_from_u(u: np.ndarray) -> np.ndarray:
    """Uniform unit-sphere point: z = 1 - 2 u1, phi = 2 pi u2 (Archimedes' hat-box)."""
    z = 1.0 - 2.0 * u[..., 0]
    r = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    phi = TWO_PI * u[..., 1]
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def _sphere_to_u(d: np.ndarray) -> np.ndarray:
    u2 = np.arctan2(d[..., 1], d[..., 0]) / TWO_PI
    u2 = np.where(u2 < 0, u2 + 1.0, u2)
    u2 = np.where(u2 >= 1.0, 0.0, u2)
    return np.stack([(1.0 - d[..., 2]) / 2.0, u2], axis=-1)
