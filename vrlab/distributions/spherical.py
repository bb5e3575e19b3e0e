"""Direction distributions in the local frame (+z = normal/axis).  Measure: solid angle.

Every class maps ``u`` of shape ``(..., 2)`` to unit vectors ``(..., 3)`` and has
``pdf(w) -> (...)``; ``invert(w) -> u`` undoes ``sample``.  Use
``dist.around(axis)`` (an ``Oriented`` view) to turn +z to any, possibly batched,
axis.  With z = cos(theta) and phi = 2 pi u2 throughout:

* ``UniformSphere``:     z = 1 - 2 u1, p = 1 / (4 pi)
* ``UniformHemisphere``: z = u1, p = 1 / (2 pi) for z >= 0
* ``CosineHemisphere``:  p = cos(theta) / pi, three constructions from the lectures
  (Russian lecture 4 "Cosine-weighted distribution"; Pharr et al., PBRT 3rd ed. 13.6.3)
* ``PhongLobe(n)``:      z = u1^(1/(n+1)), p = (n + 1) / (2 pi) cos^n(theta)
* ``UniformCone(cos_max)``: z = 1 - u1 (1 - cos_max), p = 1 / (2 pi (1 - cos_max))
  (the solid angle subtended by a sphere seen from outside; PBRT 3rd ed. 14.2.2)

The microfacet normal distributions (``GGX``, ``Beckmann``) live in ``microfacet.py``.

Constructors check their parameters (``TypeError`` for non-numbers, ``ValueError`` for
NaN, inf or values out of range; ``method`` must be one of ``METHODS``); ``sample``,
``pdf`` and ``invert`` check only the array shapes (hot path).
"""
from __future__ import annotations

import numpy as np

from .. import checks
from .base import Distribution, as_points, as_uniforms
from .frames import Oriented
from .planar import concentric_disk, concentric_disk_inverse

TWO_PI = 2.0 * np.pi
INV_PI = 1.0 / np.pi


def _from_z_phi(z: np.ndarray, phi: np.ndarray) -> np.ndarray:
    r = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def _phi_u(w: np.ndarray) -> np.ndarray:
    """u2 = phi / 2 pi in [0, 1) from a direction's azimuth."""
    u2 = np.arctan2(w[..., 1], w[..., 0]) / TWO_PI
    u2 = np.where(u2 < 0, u2 + 1.0, u2)
    return np.where(u2 >= 1.0, 0.0, u2)


class _Direction(Distribution):
    dim_u = 2
    dim_x = 3
    measure = "solid angle"

    def around(self, axis: np.ndarray) -> Oriented:
        """This distribution with +z turned to ``axis`` (shape (..., 3), broadcast; finite,
        non-zero, normalised here)."""
        return Oriented(self, axis)


class UniformSphere(_Direction):
    """Uniform directions on the unit sphere: z = 1 - 2 u1, phi = 2 pi u2, p = 1/(4 pi) sr^-1."""

    def sample(self, u):
        u = as_uniforms(u, 2)
        return _from_z_phi(1.0 - 2.0 * u[..., 0], TWO_PI * u[..., 1])

    def pdf(self, w):
        w = as_points(w, 3, "w")
        return np.full(w.shape[:-1], 1.0 / (4.0 * np.pi))

    def invert(self, w):
        w = as_points(w, 3, "w")
        return np.stack([(1.0 - w[..., 2]) / 2.0, _phi_u(w)], -1)


class UniformHemisphere(_Direction):
    """Uniform directions with z >= 0: z = u1, phi = 2 pi u2, p = 1/(2 pi) sr^-1."""

    def sample(self, u):
        u = as_uniforms(u, 2)
        return _from_z_phi(1.0 - u[..., 0], TWO_PI * u[..., 1])

    def pdf(self, w):
        w = as_points(w, 3, "w")
        return np.where(w[..., 2] >= 0.0, 1.0 / TWO_PI, 0.0)

    def invert(self, w):
        w = as_points(w, 3, "w")
        return np.stack([1.0 - w[..., 2], _phi_u(w)], -1)


class CosineHemisphere(_Direction):
    """Cosine-weighted hemisphere, p(w) = cos(theta) / pi for z >= 0 (solid angle).

    ``method``:
      * ``"inversion"``: invert the CDF of theta, theta = acos(sqrt(u1)), phi = 2 pi u2
        (P(cos theta <= c) = c^2, so cos^2 theta is uniform);
      * ``"disk"`` (Malley's method): a uniform (concentric) disk point (x, y) lifted
        to z = sqrt(1 - x^2 - y^2); projecting dA = cos(theta) d(omega) gives p = cos/pi;
      * ``"sphere-shift"``: w = normalize(n + s) for s uniform on the unit sphere; the
        point n + s lies on a sphere through the origin, whose direction density is
        cos/pi.  Invert: s = 2 (w.n) w - n.
    All three give the same density; they differ in how u maps (stratification, speed).
    """

    METHODS = ("inversion", "disk", "sphere-shift")

    def __init__(self, method: str = "disk"):
        self.method = checks.choice(method, "method", self.METHODS)

    def sample(self, u):
        u = as_uniforms(u, 2)
        if self.method == "inversion":
            return _from_z_phi(np.sqrt(u[..., 0]), TWO_PI * u[..., 1])
        if self.method == "disk":
            d = concentric_disk(u)
            z = np.sqrt(np.clip(1.0 - np.sum(d * d, -1), 0.0, None))
            return np.concatenate([d, z[..., None]], -1)
        s = _from_z_phi(1.0 - 2.0 * u[..., 0], TWO_PI * u[..., 1])
        s[..., 2] += 1.0
        norm = np.linalg.norm(s, axis=-1, keepdims=True)
        # s = -n exactly has probability zero; map it to the normal rather than NaN
        return np.where(norm > 0, s / np.where(norm > 0, norm, 1.0), np.array([0.0, 0.0, 1.0]))

    def pdf(self, w):
        w = as_points(w, 3, "w")
        return np.where(w[..., 2] > 0.0, w[..., 2] * INV_PI, 0.0)

    def invert(self, w):
        w = as_points(w, 3, "w")
        if self.method == "inversion":
            return np.stack([w[..., 2] ** 2, _phi_u(w)], -1)
        if self.method == "disk":
            return concentric_disk_inverse(w[..., :2])
        s = 2.0 * w[..., 2:3] * w
        s[..., 2] -= 1.0
        return np.stack([(1.0 - s[..., 2]) / 2.0, _phi_u(s)], -1)

    def _repr_fields(self):
        return {"method": self.method}


class PhongLobe(_Direction):
    """Normalised Phong lobe about +z: p(w) = (n + 1) / (2 pi) cos^n(theta), z >= 0.

    CDF inversion: cos(theta) = u1^(1/(n+1)) (Lafortune & Willems 1994).
    ``exponent``: a finite real >= 0.
    """

    def __init__(self, exponent: float):
        self.exponent = checks.real(exponent, "exponent", low=0.0)

    def sample(self, u):
        u = as_uniforms(u, 2)
        z = (1.0 - u[..., 0]) ** (1.0 / (self.exponent + 1.0))
        return _from_z_phi(z, TWO_PI * u[..., 1])

    def pdf(self, w):
        w = as_points(w, 3, "w")
        z = np.clip(w[..., 2], 0.0, 1.0)
        return np.where(w[..., 2] > 0.0, (self.exponent + 1.0) / TWO_PI * z**self.exponent, 0.0)

    def invert(self, w):
        w = as_points(w, 3, "w")
        z = np.clip(w[..., 2], 0.0, 1.0)
        return np.stack([1.0 - z ** (self.exponent + 1.0), _phi_u(w)], -1)

    def _repr_fields(self):
        return {"exponent": self.exponent}


class UniformCone(_Direction):
    """Uniform directions in the cone cos(theta) >= cos_max about +z.

    z = 1 - u1 (1 - cos_max), phi = 2 pi u2; p = 1 / (2 pi (1 - cos_max)) inside.
    A sphere of radius r at distance d subtends the cone with cos_max = sqrt(1 - r^2/d^2).
    ``cos_max``: a real in [-1, 1) (a cone half-angle in (0, pi]).
    """

    def __init__(self, cos_max: float):
        c = checks.real(cos_max, "cos_max", low=-1.0, high=1.0, high_open=True)
        self.cos_max = c
        self.solid_angle = TWO_PI * (1.0 - c)

    def sample(self, u):
        u = as_uniforms(u, 2)
        return _from_z_phi(1.0 - u[..., 0] * (1.0 - self.cos_max), TWO_PI * u[..., 1])

    def pdf(self, w):
        w = as_points(w, 3, "w")
        return np.where(w[..., 2] >= self.cos_max, 1.0 / self.solid_angle, 0.0)

    def invert(self, w):
        w = as_points(w, 3, "w")
        return np.stack([(1.0 - w[..., 2]) / (1.0 - self.cos_max), _phi_u(w)], -1)

    def _repr_fields(self):
        return {"cos_max": self.cos_max}
