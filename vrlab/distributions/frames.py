"""Local shading frames: directions with the axis (normal) along +z.

``orthonormal_basis`` is the branchless construction of Duff et al., "Building
an Orthonormal Basis, Revisited" (JCGT 2017): for a unit ``n`` with
``s = sign(n_z)``, ``a = -1/(s + n_z)``, ``b = n_x n_y a``,
``t = (1 + s n_x^2 a, s b, -s n_x)`` and ``b = (b, s + n_y^2 a, -n_y)``.
Everything broadcasts, so many frames (one per pixel) are handled at once.
"""
from __future__ import annotations

import numpy as np

from .._vec import dot, scale
from .._vec import norm as _norm
from .base import Distribution, as_float, as_points


def normalize(v: np.ndarray, name: str = "axis") -> np.ndarray:
    """Unit vectors along ``v`` (shape ``(..., 3)``); a zero or non-finite vector is an error."""
    v = as_points(v, 3, name)
    norm = _norm(v)[..., None]
    if not np.all(np.isfinite(norm)) or np.any(norm == 0):
        raise ValueError(f"{name}: vectors must be finite and non-zero")
    return v / norm


def orthonormal_basis(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tangent ``t`` and bitangent ``b`` with ``(t, b, n)`` right-handed, for unit ``n``."""
    n = as_float(n)
    nx, ny, nz = n[..., 0], n[..., 1], n[..., 2]
    one = n.dtype.type(1.0)
    s = np.where(nz >= 0.0, one, -one)
    a = -1.0 / (s + nz)
    b = nx * ny * a
    t = np.stack([1.0 + s * nx * nx * a, s * b, -s * nx], axis=-1)
    bt = np.stack([b, s + ny * ny * a, -ny], axis=-1)
    return t, bt


class Frame:
    """The orthonormal frames ``(t, b, n)`` of unit normals ``n (..., 3)``, built once
    and reused for several ``to_local`` / ``to_world`` transforms (the renderer needs
    three per shading point)."""

    def __init__(self, n: np.ndarray, t: np.ndarray | None = None, b: np.ndarray | None = None):
        self.n = as_float(n)
        self.t, self.b = orthonormal_basis(self.n) if t is None else (t, b)

    def to_world(self, v: np.ndarray) -> np.ndarray:
        """Local directions ``v`` (+z = the normal) in world coordinates."""
        out = scale(self.t, v[..., 0])
        out += scale(self.b, v[..., 1])
        out += scale(self.n, v[..., 2])
        return out

    def to_local(self, w: np.ndarray) -> np.ndarray:
        """Coordinates of world directions ``w`` in the frame (inverse of ``to_world``)."""
        return np.stack([dot(w, self.t), dot(w, self.b), dot(w, self.n)], axis=-1)

    def take(self, idx) -> Frame:
        """The frames of the rows ``idx``."""
        return Frame(self.n[idx], self.t[idx], self.b[idx])

    def tile(self, k: int) -> Frame:
        """The frames repeated ``k`` times along the first axis (sample i after i - 1)."""
        if k == 1:
            return self
        return Frame(*(np.concatenate([a] * k) for a in (self.n, self.t, self.b)))


def to_world(v: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Map local directions ``v`` (+z = axis) into the frame whose axis is unit ``n``."""
    return Frame(n).to_world(v)


def to_local(w: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Inverse of ``to_world``: coordinates of ``w`` in the frame with axis ``n``."""
    return Frame(n).to_local(w)


class Oriented(Distribution):
    """A local-frame direction distribution turned to point its +z along ``axis``.

    ``axis`` has shape ``(..., 3)`` and broadcasts against the leading shape of the
    samples: for per-pixel normals of shape ``(*batch, 3)`` and uniforms
    ``(*batch, n, d)`` pass ``axis[..., None, :]``.  A rotation keeps solid angle,
    so ``pdf_world(w) = pdf_local(to_local(w))`` (measure: solid angle).
    """

    measure = "solid angle"
    dim_x = 3

    def __init__(self, local: Distribution, axis: np.ndarray):
        if getattr(local, "dim_x", 3) != 3:
            raise ValueError("Oriented: the local distribution must produce 3D directions")
        self.local = local
        self.axis = normalize(axis, "axis")
        self.dim_u = local.dim_u

    def sample(self, u: np.ndarray) -> np.ndarray:
        return to_world(self.local.sample(u), self.axis)

    def pdf(self, w: np.ndarray) -> np.ndarray:
        return self.local.pdf(to_local(np.asarray(w, dtype=float), self.axis))

    def invert(self, w: np.ndarray) -> np.ndarray:
        return self.local.invert(to_local(np.asarray(w, dtype=float), self.axis))

    def _repr_fields(self) -> dict:
        return {"local": self.local, "axis_shape": self.axis.shape}
