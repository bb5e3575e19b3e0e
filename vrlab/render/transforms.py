"""4x4 homogeneous transforms with Mitsuba 3's conventions.

Matrices act on column vectors, ``p_world = M @ p_local``.  Inside a Mitsuba
``<transform>`` each new operation *left*-multiplies the matrix accumulated so far,
so ``<translate/><rotate/>`` gives ``R @ T`` (translate first, then rotate).

``look_at`` follows ``Transform4f::look_at`` of Mitsuba 3: ``dir = normalize(target -
origin)``, ``left = normalize(cross(up, dir))``, ``new_up = cross(dir, left)`` and the
matrix columns are ``(left, new_up, dir, origin)``.  A camera therefore looks along its
local +z, with +y up and local +x pointing to the *left* of the image (the image x axis
grows towards local -x).  The frame is right-handed (``left x new_up = dir``).

The builders check their arguments (``TypeError``/``ValueError`` naming them: numbers
finite, vectors of 3, ``matrix`` 16 or 9 numbers, look_at's origin != target and up
not parallel to the view); ``transform_*`` check that ``m`` is a finite 4x4 matrix and
the points or vectors have shape ``(..., 3)``.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .. import checks

__all__ = ["translate", "scale", "rotate", "look_at", "matrix", "compose",
           "transform_points", "transform_vectors", "transform_normals"]


def _vec3(v: Sequence[float] | np.ndarray, name: str) -> np.ndarray:
    a = checks.finite_array(v, name).reshape(-1)
    if a.shape != (3,):
        raise ValueError(f"{name} must be 3 finite numbers, got {v!r}")
    return a


def _matrix(m, name: str = "m") -> np.ndarray:
    m = checks.finite_array(m, name)
    if m.shape != (4, 4):
        raise ValueError(f"{name} must be a 4x4 matrix, got shape {m.shape}")
    return m


def _vectors(p, name: str) -> np.ndarray:
    p = np.asarray(p)
    if p.dtype.kind not in "fiu" or p.ndim == 0 or p.shape[-1] != 3:
        raise ValueError(f"{name} must be real numbers of shape (..., 3), got {p.dtype} {p.shape}")
    return p.astype(float, copy=False)


def translate(v: Sequence[float]) -> np.ndarray:
    """Translation by the vector ``v``."""
    m = np.eye(4)
    m[:3, 3] = _vec3(v, "translate")
    return m


def scale(s: float | Sequence[float]) -> np.ndarray:
    """Scale, uniform (one number) or per axis (three numbers)."""
    a = checks.finite_array(s, "scale").reshape(-1)
    if a.size == 1:
        a = np.repeat(a, 3)
    a = _vec3(a, "scale")
    return np.diag([a[0], a[1], a[2], 1.0])


def rotate(axis: Sequence[float], angle: float, normalize: bool = True) -> np.ndarray:
    """Right-handed rotation by ``angle`` *degrees* about ``axis`` (Rodrigues):
    cos t I + sin t [k]x + (1 - cos t) k k^T with k = axis / |axis|.  ``normalize=False`` uses
    ``axis`` as given, as Mitsuba 3's ``Transform4f::rotate`` and its ``<rotate>`` do (a
    non-unit axis then also scales and shears)."""
    k = _vec3(axis, "rotate axis")
    nk = np.linalg.norm(k)
    if nk == 0:
        raise ValueError("rotate axis must be non-zero")
    if normalize:
        k = k / nk
    t = np.deg2rad(checks.real(angle, "angle"))
    c, s = np.cos(t), np.sin(t)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    m = np.eye(4)
    m[:3, :3] = c * np.eye(3) + s * kx + (1 - c) * np.outer(k, k)
    return m


def look_at(origin: Sequence[float], target: Sequence[float], up: Sequence[float]) -> np.ndarray:
    """Mitsuba 3 look-at: columns ``(left, new_up, dir, origin)``, local +z -> view direction."""
    o, t, u = _vec3(origin, "origin"), _vec3(target, "target"), _vec3(up, "up")
    d = t - o
    if np.linalg.norm(d) == 0:
        raise ValueError("look_at: origin and target coincide")
    d = d / np.linalg.norm(d)
    left = np.cross(u, d)
    if np.linalg.norm(left) < 1e-12 * max(np.linalg.norm(u), 1e-300):
        raise ValueError("look_at: up is zero or parallel to the view direction")
    left = left / np.linalg.norm(left)
    new_up = np.cross(d, left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, new_up, d, o
    return m


def matrix(values: Sequence[float]) -> np.ndarray:
    """Matrix from 16 numbers in row-major order (or 9 for a 3x3 linear part)."""
    a = checks.finite_array(values, "values").reshape(-1)
    if a.size == 16:
        return a.reshape(4, 4).copy()
    if a.size == 9:
        m = np.eye(4)
        m[:3, :3] = a.reshape(3, 3)
        return m
    raise ValueError(f"values: matrix needs 16 (or 9) numbers, got {a.size}")


def compose(*ops: np.ndarray) -> np.ndarray:
    """Apply ``ops`` in order: ``compose(A, B) = B @ A`` (Mitsuba's left-multiplication)."""
    m = np.eye(4)
    for k, op in enumerate(ops):
        m = _matrix(op, f"ops[{k}]") @ m
    return m


def transform_points(m: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Transform points of shape ``(..., 3)`` (with the perspective divide)."""
    m, p = _matrix(m), _vectors(p, "p")
    q = p @ m[:3, :3].T + m[:3, 3]
    w = p @ m[3, :3] + m[3, 3]
    return q if np.all(w == 1.0) else q / w[..., None]


def transform_vectors(m: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Transform direction vectors of shape ``(..., 3)`` (linear part only)."""
    return _vectors(v, "v") @ _matrix(m)[:3, :3].T


def transform_normals(m: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Transform normals of shape ``(..., 3)`` by the inverse transpose (not normalised)."""
    m = _matrix(m)
    if not abs(np.linalg.det(m[:3, :3])) > 0:
        raise ValueError("m: the linear part is singular, normals have no transform")
    return _vectors(n, "n") @ np.linalg.inv(m[:3, :3])
