"""Microfacet normal distributions (NDFs) in the local frame (+z = the macro-surface normal).

Measure: solid angle.  Both NDFs are normalised in projected area, int D(m) cos(theta_m) dm = 1,
so the density of the normals ``sample`` draws is p(m) = D(m) cos(theta_m).  Roughness: one
``alpha`` (isotropic) or ``alpha_u`` along the tangent x and ``alpha_v`` along the bitangent y
(anisotropic, Mitsuba 3's ``alpha_u``/``alpha_v``).  With the stretched slope
q(m) = (m_x^2 / alpha_u^2 + m_y^2 / alpha_v^2) / m_z^2  (= tan^2 theta / alpha^2 if isotropic):

* ``GGX``:      D = 1 / (pi alpha_u alpha_v m_z^4 (1 + q)^2)
  (Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces", eq. 33;
  anisotropic: Heitz 2014, "Understanding the Masking-Shadowing Function in Microfacet-Based
  BRDFs", eq. 85);
* ``Beckmann``: D = exp(-q) / (pi alpha_u alpha_v m_z^4)  (Walter et al. eq. 25; Heitz 2014 eq. 84).

Sampling m ~ D(m) cos(theta_m) (Walter et al. eq. 28-29 and 35-36; the anisotropic azimuth as in
Mitsuba 3): with (c, s) = (cos 2 pi u2, sin 2 pi u2), the azimuth is tan(phi) = (alpha_v /
alpha_u) tan(2 pi u2) in the quadrant of 2 pi u2, alpha(phi)^2 = alpha_u^2 c^2 + alpha_v^2 s^2,
and q = t(u1) with t = u1 / (1 - u1) (GGX) or t = -log(1 - u1) (Beckmann); the normal is
m = normalize(alpha_u sqrt(t) c, alpha_v sqrt(t) s, 1).  ``invert``: u2 = atan2(m_y / alpha_v,
m_x / alpha_u) / 2 pi, u1 = q / (1 + q) (GGX) or 1 - exp(-q) (Beckmann).

Smith masking (Heitz 2014, sec. 5): with the projected roughness alpha_o^2 = cos^2(phi_v)
alpha_u^2 + sin^2(phi_v) alpha_v^2 and a^2 = 1 / (alpha_o^2 tan^2 theta_v), i.e.
alpha_o^2 tan^2 theta_v = (alpha_u^2 v_x^2 + alpha_v^2 v_y^2) / v_z^2,

* GGX:      Lambda = (sqrt(1 + 1 / a^2) - 1) / 2 (exact), G1 = 1 / (1 + Lambda);
* Beckmann: Lambda = (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi)) (exact); ``G1`` is the
  rational approximation of Walter et al. 2007 (eq. 27), (3.535 a + 2.181 a^2) / (1 + 2.276 a
  + 2.577 a^2) for a < 1.6, else 1 (< 0.35 % off 1 / (1 + Lambda)): what Mitsuba 3's
  ``MicrofacetDistribution::smith_g1`` computes.  ``G1_exact`` is 1 / (1 + Lambda).

G1(v, m) = 1 at normal incidence, 0 when (v.m) v_z <= 0 (a facet is not seen from behind);
G = G1(wi, m) G1(wo, m) (separable Smith).  ``visible(wo)`` is the distribution of the normals
visible from ``wo`` (:class:`~vrlab.distributions.visible_normals.VisibleNormals`).

Constructors check the roughness (``TypeError`` for non-numbers, ``ValueError`` for NaN, inf or
values outside [1e-50, 1e50]); ``sample``, ``pdf``, ``invert``, ``D``, ``Lambda``, ``G1`` check
only the array shapes (hot path).  SciPy (erf) is imported only by the Beckmann ``Lambda``.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .. import checks
from .base import as_points, as_uniforms
from .spherical import TWO_PI, _Direction, _phi_u

__all__ = ["MicrofacetNormals", "GGX", "Beckmann"]

INV_SQRT_PI = float(1.0 / np.sqrt(np.pi))


class MicrofacetNormals(_Direction):
    """What the microfacet normal distributions share: the roughness and the Smith masking.

    ``GGX(alpha)`` is isotropic; ``GGX(alpha_u, alpha_v)`` (or ``GGX(alpha_u=..., alpha_v=...)``)
    anisotropic, ``alpha_u`` along the tangent x, ``alpha_v`` along the bitangent y.  Each is a
    real in [1e-50, 1e50] (beyond, alpha^4 under- or overflows in D).  Attributes: ``alpha_u``,
    ``alpha_v``, ``isotropic``; ``alpha`` is the isotropic roughness (an ``AttributeError`` if
    anisotropic; setting it makes the distribution isotropic, unchecked: the renderer sets a
    per-point array of roughness this way).
    """

    ALPHA_RANGE = (1e-50, 1e50)

    def __init__(self, alpha: Any = None, alpha_v: Any = None, *, alpha_u: Any = None):
        if alpha is not None and alpha_u is not None:
            raise TypeError("alpha, alpha_u: give either alpha (or alpha, alpha_v) or alpha_u and alpha_v, not both")
        if alpha is None and alpha_u is None:
            raise TypeError("alpha: missing the roughness (alpha, or alpha_u and alpha_v)")
        if alpha_u is not None and alpha_v is None:
            raise TypeError("alpha_u, alpha_v: an anisotropic roughness needs both alpha_u and alpha_v")
        if alpha_v is None:
            self.alpha = self._roughness(alpha, "alpha")
            return
        self.alpha_u = self._roughness(alpha_u if alpha is None else alpha,
                                       "alpha_u" if alpha is None else "alpha (alpha_u)")
        self.alpha_v = self._roughness(alpha_v, "alpha_v")
        self.isotropic = self.alpha_u == self.alpha_v

    @classmethod
    def _roughness(cls, value: Any, name: str) -> float:
        a = checks.real(value, name, low=0.0, low_open=True)
        lo, hi = cls.ALPHA_RANGE
        if not lo <= a <= hi:
            raise ValueError(f"{name} must be in [{lo:g}, {hi:g}] (D would under- or overflow), got {a:g}")
        return a

    @property
    def alpha(self):
        """The isotropic roughness (``AttributeError`` for an anisotropic distribution)."""
        if not self.isotropic:
            raise AttributeError(f"alpha: {type(self).__name__} is anisotropic, use alpha_u and alpha_v")
        return self.alpha_u

    @alpha.setter
    def alpha(self, value) -> None:
        self.alpha_u = self.alpha_v = value
        self.isotropic = True

    # -- shared formulas ------------------------------------------------------------------
    def _q_parts(self, m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(m_x^2 / alpha_u^2 + m_y^2 / alpha_v^2, m_z^2): q = first / second."""
        x, y = m[..., 0] / self.alpha_u, m[..., 1] / self.alpha_v
        return x * x + y * y, m[..., 2] * m[..., 2]

    def _azimuth(self, u2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(alpha_u cos 2 pi u2, alpha_v sin 2 pi u2): the stretched direction of the azimuth."""
        phi = TWO_PI * u2
        return self.alpha_u * np.cos(phi), self.alpha_v * np.sin(phi)

    def _invert_azimuth(self, m: np.ndarray) -> np.ndarray:
        if self.isotropic:
            return _phi_u(m)
        return _phi_u(np.stack([m[..., 0] / self.alpha_u, m[..., 1] / self.alpha_v], -1))

    def alpha_tan2(self, v: np.ndarray) -> np.ndarray:
        """alpha_o^2 tan^2 theta_v = (alpha_u^2 v_x^2 + alpha_v^2 v_y^2) / v_z^2 = 1 / a^2
        (``inf`` at v_z = 0)."""
        v = as_points(v, 3, "v")
        xy = (self.alpha_u * v[..., 0]) ** 2 + (self.alpha_v * v[..., 1]) ** 2
        z2 = v[..., 2] * v[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(z2 > 0, xy / np.where(z2 > 0, z2, 1.0), np.inf)

    def Lambda(self, v: np.ndarray) -> np.ndarray:
        """Smith's Lambda(v), exact for this NDF (0 at normal incidence, inf at grazing)."""
        return self._lambda(self.alpha_tan2(v))

    def _oriented(self, g: np.ndarray, v: np.ndarray, m: np.ndarray) -> np.ndarray:
        """G1 set to 1 at normal incidence and to 0 where (v.m) v_z <= 0 (as Mitsuba 3)."""
        xy = (self.alpha_u * v[..., 0]) ** 2 + (self.alpha_v * v[..., 1]) ** 2
        g = np.where(xy == 0, 1.0, g)
        vm = v[..., 0] * m[..., 0] + v[..., 1] * m[..., 1] + v[..., 2] * m[..., 2]
        return np.where(vm * v[..., 2] <= 0, 0.0, g)

    def G1(self, v: np.ndarray, m: np.ndarray) -> np.ndarray:
        """Smith masking G1(v, m) as Mitsuba 3's ``smith_g1`` (exact for GGX, Walter's rational
        approximation for Beckmann)."""
        v, m = as_points(v, 3, "v"), as_points(m, 3, "m")
        return self._oriented(self._g1(self.alpha_tan2(v)), v, m)

    def G1_exact(self, v: np.ndarray, m: np.ndarray) -> np.ndarray:
        """Smith masking 1 / (1 + Lambda(v)) with the exact Lambda (oriented as ``G1``)."""
        v, m = as_points(v, 3, "v"), as_points(m, 3, "m")
        return self._oriented(1.0 / (1.0 + self._lambda(self.alpha_tan2(v))), v, m)

    def G(self, wi: np.ndarray, wo: np.ndarray, m: np.ndarray) -> np.ndarray:
        """Separable Smith shadowing-masking G1(wi, m) G1(wo, m) (Mitsuba 3's ``G``)."""
        return self.G1(wi, m) * self.G1(wo, m)

    def pdf(self, m):
        """p(m) = D(m) cos(theta_m) (0 for m_z <= 0)."""
        m = as_points(m, 3, "m")
        return self.D(m) * np.clip(m[..., 2], 0.0, None)

    def visible(self, wo: np.ndarray, newton_steps: int = 3):
        """The distribution of the normals visible from ``wo`` (unit after normalising, z > 0;
        ``(..., 3)`` broadcast over the leading axes of ``u``): see ``VisibleNormals``."""
        from .visible_normals import VisibleNormals      # on first use (start-up time)

        return VisibleNormals(self, wo, newton_steps=newton_steps)

    def _sample_stretched(self, u: np.ndarray, t: np.ndarray) -> np.ndarray:
        """m = normalize(alpha_u sqrt(t) c, alpha_v sqrt(t) s, 1) for q = t (anisotropic)."""
        cx, sy = self._azimuth(u[..., 1])
        r = np.sqrt(t)
        inv = 1.0 / np.sqrt(1.0 + (cx * cx + sy * sy) * t)
        return np.stack([cx * r * inv, sy * r * inv, inv], -1)

    def _repr_fields(self):
        if self.isotropic:
            return {"alpha": self.alpha_u}
        return {"alpha_u": self.alpha_u, "alpha_v": self.alpha_v}


class GGX(MicrofacetNormals):
    """GGX / Trowbridge–Reitz microfacet normals m, density D(m) cos(theta_m) (solid angle).

    D(m) = 1 / (pi alpha_u alpha_v (m_x^2 / alpha_u^2 + m_y^2 / alpha_v^2 + m_z^2)^2), isotropic
    alpha^2 / (pi cos^4(theta) (alpha^2 + tan^2(theta))^2) (Walter et al. 2007, eq. 33; Heitz 2014,
    eq. 85).  Sampling by inversion: tan^2(theta) = alpha(phi)^2 u1 / (1 - u1) (eq. 35-36), the
    azimuth as in the module docstring.  Smith: Lambda = (sqrt(1 + alpha_o^2 tan^2 theta) - 1) / 2,
    G1 = 2 / (1 + sqrt(1 + alpha_o^2 tan^2 theta)) (exact; Heitz 2014, eq. 86).
    ``GGX(alpha)`` or ``GGX(alpha_u, alpha_v)``: reals in [1e-50, 1e50].
    """

    visible_kind = "ggx"

    def D(self, h: np.ndarray) -> np.ndarray:
        """The normal distribution function D(h) (per steradian of h, projected area normalised)."""
        h = as_points(h, 3, "h")
        z = h[..., 2]
        if not self.isotropic:
            xy, z2 = self._q_parts(h)
            denom = xy + z2
            return np.where(z > 0.0, 1.0 / (np.pi * self.alpha_u * self.alpha_v * denom * denom), 0.0)
        a2 = self.alpha**2
        # alpha^2 / (pi (z^2 (alpha^2 - 1) + 1)^2) is the same D without tan; for unit h,
        # z^2 (alpha^2 - 1) + 1 = x^2 + y^2 + alpha^2 z^2, which does not cancel at z -> 1
        # (it would lose 1e-7 / alpha^2 relative in float32)
        denom = h[..., 0] * h[..., 0]
        denom += h[..., 1] * h[..., 1]
        denom += a2 * (z * z)
        return np.where(z > 0.0, a2 / (np.pi * denom * denom), 0.0)

    def sample(self, u):
        u = as_uniforms(u, 2)
        if not self.isotropic:
            # m = normalize(alpha_u sqrt(t) c, alpha_v sqrt(t) s, 1), t = u1 / (1 - u1), written
            # as (alpha_u c sqrt(u1), alpha_v s sqrt(u1), sqrt(1 - u1)) / sqrt(1 - u1 + alpha^2 u1)
            cx, sy = self._azimuth(u[..., 1])
            one_minus = 1.0 - u[..., 0]
            inv = 1.0 / np.sqrt(one_minus + (cx * cx + sy * sy) * u[..., 0])
            r = np.sqrt(u[..., 0]) * inv
            return np.stack([cx * r, sy * r, np.sqrt(one_minus) * inv], -1)
        a2 = self.alpha**2
        # cos^2 theta = 1 / (1 + tan^2 theta) = (1 - u1) / (1 - u1 + alpha^2 u1) and
        # sin^2 theta = alpha^2 u1 / (same): sin from its own formula, not sqrt(1 - cos^2)
        # (which cancels near the pole: a float32 sample would snap to rings there)
        one_minus = 1.0 - u[..., 0]
        inv = 1.0 / (one_minus + a2 * u[..., 0])
        r = np.sqrt(a2 * u[..., 0] * inv)
        phi = TWO_PI * u[..., 1]
        return np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(one_minus * inv)], axis=-1)

    def invert(self, h):
        h = as_points(h, 3, "h")
        xy, z2 = self._q_parts(h)
        z2 = np.where(h[..., 2] > 0, z2, 0.0)
        total = xy + z2
        u1 = xy / np.where(total > 0, total, 1.0)        # q / (1 + q)
        return np.stack([u1, self._invert_azimuth(h)], -1)

    @staticmethod
    def _lambda(a2t2: np.ndarray) -> np.ndarray:
        return 0.5 * (np.sqrt(1.0 + a2t2) - 1.0)

    @staticmethod
    def _g1(a2t2: np.ndarray) -> np.ndarray:
        return 2.0 / (1.0 + np.sqrt(1.0 + a2t2))


class Beckmann(MicrofacetNormals):
    """Beckmann microfacet normals m, density D(m) cos(theta_m) (solid angle).

    D(m) = exp(-q) / (pi alpha_u alpha_v m_z^4) for m_z > 0, else 0, q = (m_x^2 / alpha_u^2 +
    m_y^2 / alpha_v^2) / m_z^2 (= tan^2 theta / alpha^2 isotropic; Walter et al. 2007, eq. 25;
    Heitz 2014, eq. 84), q computed without cancellation near the pole.  ``sample``: q = -log(1 -
    u1), the azimuth as in the module docstring (isotropic: phi = 2 pi u2, tan^2 theta =
    -alpha^2 log(1 - u1), eq. 28-29); ``invert``: u1 = 1 - exp(-q).
    Smith: ``Lambda`` exact, (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi)) (Heitz 2014, eq. 83;
    Walter et al. eq. 24); ``G1`` Walter's rational approximation as Mitsuba 3 (eq. 27, within
    0.35 % of 1 / (1 + Lambda)), ``G1_exact`` 1 / (1 + Lambda).
    ``Beckmann(alpha)`` or ``Beckmann(alpha_u, alpha_v)``: reals in [1e-50, 1e50] (as ``GGX``).
    """

    visible_kind = "beckmann"

    def _q(self, m: np.ndarray) -> np.ndarray:
        z = m[..., 2]
        z2 = np.where(z > 0, z * z, 1.0)
        if self.isotropic:                      # tan^2 theta / alpha^2 (as before anisotropy)
            return (m[..., 0] * m[..., 0] + m[..., 1] * m[..., 1]) / z2 / self.alpha**2
        xy, _ = self._q_parts(m)
        return xy / z2

    def D(self, m: np.ndarray) -> np.ndarray:
        """The normal distribution function D(m) (per steradian of m, projected area normalised)."""
        m = as_points(m, 3, "m")
        z = m[..., 2]
        z2 = np.where(z > 0, z * z, 1.0)
        norm = np.pi * (self.alpha**2 if self.isotropic else self.alpha_u * self.alpha_v)
        return np.where(z > 0, np.exp(-self._q(m)) / (norm * z2 * z2), 0.0)

    def sample(self, u):
        u = as_uniforms(u, 2)
        if not self.isotropic:
            return self._sample_stretched(u, -np.log1p(-u[..., 0]))
        tan2 = -self.alpha**2 * np.log1p(-u[..., 0])
        z = 1.0 / np.sqrt(1.0 + tan2)
        r = np.sqrt(tan2) * z
        phi = TWO_PI * u[..., 1]
        return np.stack([r * np.cos(phi), r * np.sin(phi), z], -1)

    def invert(self, m):
        m = as_points(m, 3, "m")
        return np.stack([-np.expm1(-self._q(m)), self._invert_azimuth(m)], -1)

    @staticmethod
    def _lambda(a2t2: np.ndarray) -> np.ndarray:
        from scipy.special import erfc

        a2t2 = np.asarray(a2t2)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            a = 1.0 / np.sqrt(a2t2)                      # inf at normal incidence, 0 at grazing
            ok = (a > 0) & np.isfinite(a)
            sa = np.where(ok, a, 1.0)
            lam = 0.5 * (np.exp(-sa * sa) * INV_SQRT_PI / sa - erfc(sa))
        return np.where(a > 0, np.where(ok, lam, 0.0), np.inf)

    @staticmethod
    def _g1(a2t2: np.ndarray) -> np.ndarray:
        with np.errstate(divide="ignore"):
            a = 1.0 / np.sqrt(a2t2)
        a = np.where(np.isfinite(a), a, 2.0)             # normal incidence: 1 (set again by _oriented)
        return np.where(a >= 1.6, 1.0, (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a))
