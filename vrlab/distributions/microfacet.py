"""Microfacet normal distributions in the local frame (+z = the macro-surface normal).

Measure: solid angle.  ``Beckmann(alpha)``: D(m) = exp(-tan^2 theta / alpha^2) /
(pi alpha^2 cos^4 theta) (Walter et al. 2007, "Microfacet Models for Refraction through Rough
Surfaces", eq. 25), normalised in projected area, int D(m) cos(theta_m) dm = 1, so the
density of the sampled normals is p(m) = D(m) cos(theta_m).  Sampling inverts the CDF of
theta: tan^2 theta = -alpha^2 log(1 - u1), phi = 2 pi u2 (eq. 28-29).  (GGX lives in
``spherical.py``.)
"""
from __future__ import annotations

import numpy as np

from .base import as_points, as_uniforms
from .spherical import TWO_PI, MicrofacetNormals, _phi_u

__all__ = ["Beckmann"]


class Beckmann(MicrofacetNormals):
    """Beckmann microfacet normals m, density D(m) cos(theta_m) (solid angle).

    D(m) = exp(-tan^2 theta / alpha^2) / (pi alpha^2 cos^4 theta) for m.z > 0, else 0
    (Walter et al. 2007, eq. 25), with tan^2 theta = (m_x^2 + m_y^2) / m_z^2 (no cancellation
    near the pole).  ``sample``: tan^2 theta = -alpha^2 log(1 - u1), phi = 2 pi u2 (eq. 28-29),
    cos theta = 1 / sqrt(1 + tan^2), sin theta = tan theta cos theta; ``invert``:
    u1 = 1 - exp(-tan^2 theta / alpha^2).  ``alpha``: a real in [1e-50, 1e50] (as ``GGX``).
    """

    @staticmethod
    def _tan2(m: np.ndarray) -> np.ndarray:
        z = m[..., 2]
        z2 = np.where(z > 0, z * z, 1.0)
        return (m[..., 0] * m[..., 0] + m[..., 1] * m[..., 1]) / z2

    def D(self, m: np.ndarray) -> np.ndarray:
        """The normal distribution function D(m) (per steradian of m, projected area normalised)."""
        m = as_points(m, 3, "m")
        z = m[..., 2]
        z2 = np.where(z > 0, z * z, 1.0)
        a2 = self.alpha**2
        return np.where(z > 0, np.exp(-self._tan2(m) / a2) / (np.pi * a2 * z2 * z2), 0.0)

    def sample(self, u):
        u = as_uniforms(u, 2)
        tan2 = -self.alpha**2 * np.log1p(-u[..., 0])
        z = 1.0 / np.sqrt(1.0 + tan2)
        r = np.sqrt(tan2) * z
        phi = TWO_PI * u[..., 1]
        return np.stack([r * np.cos(phi), r * np.sin(phi), z], -1)

    def pdf(self, m):
        m = as_points(m, 3, "m")
        return self.D(m) * np.clip(m[..., 2], 0.0, None)

    def invert(self, m):
        m = as_points(m, 3, "m")
        return np.stack([-np.expm1(-self._tan2(m) / self.alpha**2), _phi_u(m)], -1)

    def _repr_fields(self):
        return {"alpha": self.alpha}
