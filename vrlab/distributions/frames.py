"""Local shading frames: directions with the axis (normal) along +z.

``orthonormal_basis`` is the branchless construction of Duff et al., "Building
an Orthonormal Basis, Revisited" (JCGT 2017): for a unit ``n`` with
``s = sign(n_z)``, ``a = -1/(s + n_z)``, ``b = n_x n_y a``,
``t = (1 + s n_x^2 a, s b, -s n_x)`` and ``b = (b, s + n_y^2 a, -n_y)``.
Everything broadcasts, so many frames (one per pixel) are handled at once.

Checks: ``Frame(n)``, ``to_world`` and ``to_local`` need unit normals ``(..., 3)``
(finite, |n| within 1e-3 of 1) and vectors of shape ``(..., 3)``; ``orthonormal_basis``
checks only shapes.  ``Oriented`` normalises its ``axis`` (finite, non-zero).
"""
from __future__ import annotations

import numpy as np

from .. import checks
from .._vec import dot, scale
from .._vec import norm as _norm
from .base import Distribution, as_points, as_uniforms, check_broadcast, is_distribution

_UNIT_TOL = 1e-3  # |n|^2 may differ from 1 by this much (float32 normals are ~1e-7 off)


def normalize(v: np.ndarray, name: str = "axis") -> np.ndarray:
    """Unit vectors along ``v`` (shape ``(..., 3)``); a zero or non-finite vector is an error."""
    v = as_points(v, 3, name)
    with np.errstate(over="ignore", invalid="ignore"):
        norm = _norm(v)[..., None]
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: vectors must be finite, got a non-finite entry")
    if np.any(norm == 0):
        raise ValueError(f"{name}: vectors must be non-zero, got a zero vector")
    if not np.all(np.isfinite(norm)):  # huge entries: scale first
        v = v / np.max(np.abs(v), axis=-1, keepdims=True)
        norm = _norm(v)[..., None]
    return v / norm


def unit_vectors(n: np.ndarray, name: str = "n") -> np.ndarray:
    """``n`` checked to hold unit vectors ``(..., 3)`` (|n|^2 within 1e-3 of 1; NaN fails)."""
    n = as_points(n, 3, name)
    with np.errstate(over="ignore", invalid="ignore"):
        ok = np.abs(dot(n, n) - 1.0) <= _UNIT_TOL
    if not np.all(ok):
        where = tuple(int(i) for i in np.argwhere(~ok)[0])
        raise ValueError(f"{name}: expected finite unit vectors, but the vector at {where} is "
                         f"{n[where].tolist()} (use normalize())")
    return n


def orthonormal_basis(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tangent ``t`` and bitangent ``b`` with ``(t, b, n)`` right-handed, for unit ``n``
    (shape ``(..., 3)``; only the shape is checked)."""
    n = as_points(n, 3, "n")
    nx, ny, nz = n[..., 0], n[..., 1], n[..., 2]
    one = n.dtype.type(1.0)
    s = np.where(nz >= 0.0, one, -one)
    a = -1.0 / (s + nz)
    b = nx * ny * a
    t = np.stack([1.0 + s * nx * nx * a, s * b, -s * nx], axis=-1)
    bt = np.stack([b, s + ny * ny * a, -ny], axis=-1)
    return t, bt


def tangent_towards(n: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The unit tangent of unit normals ``n`` closest to ``v`` (Gram-Schmidt: normalize(v -
    n (n.v)), the shading frame's s when v = dp/du); where v is parallel to n, the tangent of
    :func:`orthonormal_basis`.  Shapes ``(..., 3)`` broadcast; float64."""
    n, v = np.asarray(n, np.float64), np.asarray(v, np.float64)
    s = v - n * np.sum(n * v, -1, keepdims=True)
    length = np.linalg.norm(s, axis=-1, keepdims=True)
    ok = length > 1e-12
    s = s / np.where(ok, length, 1.0)
    if ok.all():
        return s
    return np.where(ok, s, orthonormal_basis(np.broadcast_to(n, s.shape))[0])


class Frame:
    """The orthonormal frames ``(t, b, n)`` of unit normals ``n (..., 3)``, built once
    and reused for several ``to_local`` / ``to_world`` transforms (the renderer needs
    three per shading point).  Checked: ``n`` holds unit vectors ``(..., 3)``; ``t`` and
    ``b``, if given (both), unit vectors of ``n``'s shape orthogonal to it and each other."""

    def __init__(self, n: np.ndarray, t: np.ndarray | None = None, b: np.ndarray | None = None):
        n = unit_vectors(n, "n")
        if t is None and b is None:
            self._set(n, *orthonormal_basis(n))
            return
        if t is None or b is None:
            raise ValueError("t, b: give both the tangent t and the bitangent b, or neither")
        t, b = unit_vectors(t, "t"), unit_vectors(b, "b")
        if t.shape != n.shape or b.shape != n.shape:
            raise ValueError(f"t, b: expected the shape of n {n.shape}, got {t.shape} and {b.shape}")
        for x, y, name in ((t, n, "t, n"), (b, n, "b, n"), (t, b, "t, b")):
            if not np.all(np.abs(dot(x, y)) <= _UNIT_TOL):
                raise ValueError(f"{name}: the frame's vectors must be orthogonal")
        self._set(n, t, b)

    def _set(self, n: np.ndarray, t: np.ndarray, b: np.ndarray) -> Frame:
        self.n, self.t, self.b = n, t, b
        return self

    @classmethod
    def _trusted(cls, n: np.ndarray, t: np.ndarray | None = None, b: np.ndarray | None = None) -> Frame:
        """A frame of already-checked unit ``n`` (internal hot paths: no checks)."""
        if t is None:
            t, b = orthonormal_basis(n)
        return cls.__new__(cls)._set(n, t, b)

    def to_world(self, v: np.ndarray) -> np.ndarray:
        """Local directions ``v`` (+z = the normal, shape (..., 3)) in world coordinates."""
        v = check_broadcast(as_points(v, 3, "v"), "v", self.n.shape[:-1], "n")
        out = scale(self.t, v[..., 0])
        out += scale(self.b, v[..., 1])
        out += scale(self.n, v[..., 2])
        return out

    def to_local(self, w: np.ndarray) -> np.ndarray:
        """Coordinates of world directions ``w`` (..., 3) in the frame (inverse of ``to_world``)."""
        w = check_broadcast(as_points(w, 3, "w"), "w", self.n.shape[:-1], "n")
        return np.stack([dot(w, self.t), dot(w, self.b), dot(w, self.n)], axis=-1)

    def take(self, idx) -> Frame:
        """The frames of the rows ``idx``."""
        try:
            return Frame._trusted(self.n[idx], self.t[idx], self.b[idx])
        except IndexError as exc:
            raise IndexError(f"idx: {exc}") from None

    def tile(self, k: int) -> Frame:
        """The frames repeated ``k`` times along the first axis (sample i after i - 1)."""
        k = checks.integer(k, "k", low=1)
        if k == 1:
            return self
        return Frame._trusted(*(np.concatenate([a] * k) for a in (self.n, self.t, self.b)))


def to_world(v: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Map local directions ``v`` (+z = axis) into the frame whose axis is unit ``n``
    (both (..., 3), broadcast; ``n`` checked as in ``Frame``)."""
    return Frame(n).to_world(v)


def to_local(w: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Inverse of ``to_world``: coordinates of ``w`` in the frame with axis ``n``."""
    return Frame(n).to_local(w)


class Oriented(Distribution):
    """A local-frame direction distribution turned to point its +z along ``axis`` (or into a
    given :class:`Frame`: local x, y, z along its t, b, n).

    ``axis`` has shape ``(..., 3)`` and broadcasts against the leading shape of the
    samples: for per-pixel normals of shape ``(*batch, 3)`` and uniforms
    ``(*batch, n, d)`` pass ``axis[..., None, :]``.  A rotation keeps solid angle,
    so ``pdf_world(w) = pdf_local(to_local(w))`` (measure: solid angle).
    Checked: ``local`` is a distribution of 3D directions; ``axis`` finite and non-zero.
    """

    measure = "solid angle"
    dim_x = 3

    def __init__(self, local: Distribution, axis: np.ndarray):
        if not is_distribution(local):
            raise TypeError(f"local must be a distribution (dim_u, sample, pdf), got {type(local).__name__}")
        if getattr(local, "dim_x", 3) != 3:
            raise ValueError(f"local: the local distribution must produce 3D directions, got dim_x={local.dim_x!r}")
        self.local = local
        self.dim_u = local.dim_u
        if isinstance(axis, Frame):              # a whole frame (a tangent along dp/du, as a normal map's)
            self.axis, self._frame = axis.n, axis
        else:
            self.axis = normalize(axis, "axis")
            self._frame = None

    @property
    def frame(self) -> Frame:
        if self._frame is None:
            self._frame = Frame._trusted(self.axis)
        return self._frame

    def sample(self, u: np.ndarray) -> np.ndarray:
        u = check_broadcast(as_uniforms(u, self.dim_u), "u", self.axis.shape[:-1], "axis")
        return self.frame.to_world(self.local.sample(u))

    def _local(self, w: np.ndarray) -> np.ndarray:
        w = check_broadcast(as_points(w, 3, "w"), "w", self.axis.shape[:-1], "axis")
        return self.frame.to_local(w.astype(np.float64, copy=False))

    def pdf(self, w: np.ndarray) -> np.ndarray:
        return self.local.pdf(self._local(w))

    def invert(self, w: np.ndarray) -> np.ndarray:
        return self.local.invert(self._local(w))

    def _repr_fields(self) -> dict:
        return {"local": self.local, "axis_shape": self.axis.shape}
