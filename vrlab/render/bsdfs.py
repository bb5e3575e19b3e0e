"""BSDF models of the direct-lighting renderer, in the local shading frame (normal = +z).

Conventions (those of Mitsuba 3's ``BSDF.eval``/``sample``):

* ``wo`` is the direction towards the camera (outgoing), ``wi`` the sampled direction
  towards the light; both are unit vectors of shape ``(..., 3)`` that broadcast.
* ``f(wo, wi) -> (..., 3)`` is the BRDF f_r alone (RGB, per steradian);
  ``eval(wo, wi) -> (..., 3)`` is **f_r(wo, wi) * cos(theta_i)** (Mitsuba returns f·cos).
* ``pdf(wo, wi) -> (...)`` is the solid-angle density of ``sample`` on the **whole
  sphere**.  Samplers may produce directions below the horizon (a Phong lobe or a
  microfacet reflection leaning past it); there ``eval`` is 0, so such samples add
  zero and the estimator stays unbiased (the lost mass only costs variance).  On
  wi.z > 0 the pdf equals Mitsuba's; Mitsuba reports 0 below the horizon.
* ``sample(wo, u) -> (wi, weight, pdf)`` with ``u`` of shape ``(..., 2)`` and
  ``weight = eval / pdf`` (0 where the pdf is 0).
* ``distribution(wo)`` is a vrlab distribution (``dim_u = 2``, ``sample(u)``, ``pdf(w)``,
  solid angle) so the estimators (``MonteCarlo``, MIS, ...) can use BSDF sampling.
  ``wo`` broadcasts against the leading shape of ``u``: for per-pixel ``wo`` of shape
  ``(*batch, 3)`` and uniforms ``(*batch, n, 2)`` pass ``wo[..., None, :]``.
* Every model is one-sided: f = 0 when wo.z <= 0 or wi.z <= 0.
* The base class is ``BSDFModel`` (``vrlab.render.BSDF`` is the scene loader's
  description of a ``<bsdf>`` element, a different thing).
* Constructors check their arguments (``TypeError``/``ValueError`` naming them):
  colours a number or an RGB array ``(..., 3)``, finite and in [0, 1e15]; ``alpha`` in
  (0, 1e4]; ``exponent`` in [0, 1e6]; ``distribution`` ``"ggx"`` or ``"beckmann"``.
  ``f``/``eval``/``pdf``/``sample`` check shapes only (``(..., 3)`` directions,
  ``(..., 2)`` uniforms): they run per ray.

Sources: Walter et al. 2007, "Microfacet Models for Refraction through Rough
Surfaces" (D, Beckmann G1 approximation, sampling); Heitz 2014, "Understanding the
Masking-Shadowing Function in Microfacet-Based BRDFs" (separable Smith G); Lafortune &
Willems 1994, "Using the Modified Phong Reflectance Model for Physically Based
Rendering" (normalised Phong); Mitsuba 3 plugin docs (``diffuse``, ``roughconductor``).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .. import checks
from .._vec import dot as vdot
from .._vec import norm as vnorm
from .._vec import outer3, scale, side
from ..distributions import GGX, CosineHemisphere, Mixture, PhongLobe
from ..distributions.base import Distribution, as_points, as_uniforms
from .scene_checks import MAX_ALPHA, MAX_EXPONENT, MAX_VALUE

INV_PI = 1.0 / np.pi
TWO_PI = 2.0 * np.pi

__all__ = [
    "BSDFDirections",
    "BSDFModel",
    "Beckmann",
    "Diffuse",
    "Phong",
    "RoughConductor",
    "mirror",
    "reflect",
]


def reflect(w: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Mirror ``w`` about the unit axis ``m``: 2 (w·m) m - w (invariant under m -> -m)."""
    return scale(m, 2.0 * vdot(w, m)) - w


def mirror(w: np.ndarray) -> np.ndarray:
    """Mirror direction about the local normal +z: (-x, -y, z)."""
    return w * np.array([-1.0, -1.0, 1.0])


def _rgb(value: Any, name: str) -> np.ndarray:
    if value is None:
        raise TypeError(f"{name} must be a number or an RGB array, got None")
    v = checks.finite_array(value, name)
    if v.ndim == 0:
        v = np.full(3, float(v))
    if v.shape[-1:] != (3,) or v.size == 0 or np.any(v < 0) or np.any(v > MAX_VALUE):
        raise ValueError(f"{name}: expected a scalar or RGB array (..., 3) in [0, {MAX_VALUE:g}], got {value!r}")
    return v


def _alpha(value: Any) -> float:
    return checks.real(value, "alpha", low=0, high=MAX_ALPHA, low_open=True)


def _dirs(wo: Any, wi: Any) -> tuple[np.ndarray, np.ndarray]:
    return as_points(wo, 3, "wo"), as_points(wi, 3, "wi")


class BSDFDirections(Distribution):
    """The sampling distribution of ``bsdf`` for a fixed ``wo``: ``sample(u) -> wi``,
    ``pdf(wi)`` (solid angle, whole sphere).  Built by ``BSDFModel.distribution(wo)``."""

    dim_u = 2
    dim_x = 3
    measure = "solid angle"

    def __init__(self, bsdf: BSDFModel, wo: np.ndarray):
        self.bsdf = bsdf
        self.wo = as_points(wo, 3, "wo")

    def sample(self, u: np.ndarray) -> np.ndarray:
        return self.bsdf._sample_direction(self.wo, as_uniforms(u, 2))

    def pdf(self, w: np.ndarray) -> np.ndarray:
        return self.bsdf.pdf(self.wo, w)

    def _repr_fields(self) -> dict:
        return {"bsdf": self.bsdf, "wo_shape": self.wo.shape}


class BSDFModel:
    """Base class: subclasses implement ``f``, ``pdf`` and ``_sample_direction``."""

    def f(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError  # abstract

    def pdf(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError  # abstract

    def _sample_direction(self, wo: np.ndarray, u: np.ndarray) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError  # abstract

    def eval(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """f_r(wo, wi) cos(theta_i), RGB (..., 3); zero below either horizon."""
        wo, wi = _dirs(wo, wi)
        return scale(self.f(wo, wi), np.clip(wi[..., 2], 0.0, None))

    def distribution(self, wo: np.ndarray) -> BSDFDirections:
        """A vrlab distribution of wi for this ``wo`` (see the module notes on broadcasting)."""
        return BSDFDirections(self, wo)

    def sample(self, wo: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(wi, weight, pdf)`` with weight = f cos / pdf (RGB; 0 where pdf is 0)."""
        wo = as_points(wo, 3, "wo")
        wi = self._sample_direction(wo, as_uniforms(u, 2))
        p = self.pdf(wo, wi)
        val = self.eval(wo, wi)
        pos = (p > 0)[..., None]
        weight = np.where(pos, val / np.where(pos, p[..., None], 1.0), 0.0)
        return wi, weight, p

    def __repr__(self) -> str:
        fields = ", ".join(f"{k}={v!r}" for k, v in self._repr_fields().items())
        return f"{type(self).__name__}({fields})"

    def _repr_fields(self) -> dict:
        return {}


def _shape(wo: np.ndarray, u: np.ndarray) -> tuple:
    return np.broadcast_shapes(wo.shape[:-1], u.shape[:-1]) + (3,)


class Diffuse(BSDFModel):
    """Lambertian reflector (Mitsuba ``diffuse``): f = R / pi, cosine-weighted sampling
    p(wi) = cos(theta_i) / pi, so weight = R exactly."""

    def __init__(self, reflectance: Any = 0.5):
        self.reflectance = _rgb(reflectance, "reflectance")
        self._cosine = CosineHemisphere()

    def f(self, wo, wi):
        wo, wi = _dirs(wo, wi)
        return outer3((wo[..., 2] > 0) & (wi[..., 2] > 0), self.reflectance * INV_PI, wo.dtype)

    def pdf(self, wo, wi):
        wo, wi = _dirs(wo, wi)
        p = self._cosine.pdf(wi)
        return np.broadcast_to(p, np.broadcast_shapes(wo.shape[:-1], p.shape))

    def _sample_direction(self, wo, u):
        return np.broadcast_to(self._cosine.sample(u), _shape(wo, u))

    def _repr_fields(self):
        return {"reflectance": self.reflectance.tolist()}


class Beckmann(Distribution):
    """Beckmann microfacet normals m, density D(m) cos(theta_m) (solid angle).

    D(m) = exp(-tan^2 theta / alpha^2) / (pi alpha^2 cos^4 theta) (Walter et al. 2007, eq. 25);
    sampling by inversion: tan^2 theta = -alpha^2 log(1 - u1), phi = 2 pi u2 (eq. 28-29).
    """

    dim_u = 2
    dim_x = 3
    measure = "solid angle"

    def __init__(self, alpha: float):
        self.alpha = _alpha(alpha)

    def D(self, m: np.ndarray) -> np.ndarray:
        """The normal distribution function D(m)."""
        m = as_points(m, 3, "m")
        z = m[..., 2]
        z2 = np.where(z > 0, z * z, 1.0)
        tan2 = (1.0 - z2) / z2
        a2 = self.alpha**2
        return np.where(z > 0, np.exp(-tan2 / a2) / (np.pi * a2 * z2 * z2), 0.0)

    def sample(self, u):
        u = as_uniforms(u, 2)
        tan2 = -self.alpha**2 * np.log1p(-u[..., 0])
        z = 1.0 / np.sqrt(1.0 + tan2)
        r = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
        phi = TWO_PI * u[..., 1]
        return np.stack([r * np.cos(phi), r * np.sin(phi), z], -1)

    def pdf(self, m):
        m = as_points(m, 3, "m")
        return self.D(m) * np.clip(m[..., 2], 0.0, None)

    def _repr_fields(self):
        return {"alpha": self.alpha}


class RoughConductor(BSDFModel):
    """Rough conductor with Fresnel = 1 (Mitsuba 3 ``roughconductor``, ``material="none"``,
    ``sample_visible=false``), isotropic roughness ``alpha``.

    f = R D(m) G(wi, wo, m) / (4 cos theta_i cos theta_o), m = normalize(wi + wo),
    G = G1(wi, m) G1(wo, m) (separable Smith, Heitz 2014), G1(v, m) = 0 when
    (v·m) cos theta_v <= 0, and 1 at normal incidence (tan theta_v = 0):

    * ``"ggx"``: D = alpha^2 / (pi cos^4 (alpha^2 + tan^2)^2), G1 = 2 / (1 + sqrt(1 + alpha^2 tan^2 theta_v));
    * ``"beckmann"``: D = exp(-tan^2/alpha^2) / (pi alpha^2 cos^4); G1 by the rational
      approximation of Walter et al. 2007 (eq. 27), a = 1 / (alpha tan theta_v):
      (3.535 a + 2.181 a^2) / (1 + 2.276 a + 2.577 a^2) if a < 1.6 else 1.  This is what
      Mitsuba 3's ``MicrofacetDistribution::smith_g1`` evaluates for Beckmann (to our
      knowledge of its source, independent of ``sample_visible``).

    Sampling: m ~ D(m) cos theta_m, wi = reflect(wo, m); the density of wi on the whole
    sphere is p(wi) = D(h) cos theta_h / (4 |wo·h|) with h = ±normalize(wi + wo) turned to
    the upper hemisphere (reflect is invariant under m -> -m).  When wo·m < 0 the
    reflected wi lies below the horizon, where f = 0: such samples are wasted, not biased.
    ``R = specular_reflectance`` (RGB, default 1).
    """

    DISTRIBUTIONS = ("ggx", "beckmann")

    def __init__(self, alpha: float = 0.1, distribution: str = "ggx", specular_reflectance: Any = 1.0):
        checks.choice(distribution, "distribution", self.DISTRIBUTIONS)
        self.alpha = _alpha(alpha)
        self.kind = distribution
        self.normals = GGX(self.alpha) if distribution == "ggx" else Beckmann(self.alpha)
        self.specular_reflectance = _rgb(specular_reflectance, "specular_reflectance")

    def D(self, m: np.ndarray) -> np.ndarray:
        """Microfacet normal distribution D(m) (0 for m.z <= 0)."""
        return self.normals.D(m)

    def G1(self, v: np.ndarray, m: np.ndarray) -> np.ndarray:
        """Smith masking of direction ``v`` for microfacet normal ``m``."""
        v = as_points(v, 3, "v")
        z = v[..., 2]
        xy2 = np.clip(1.0 - z * z, 0.0, None)
        z2 = np.where(z != 0, z * z, 1.0)
        tan2 = xy2 / z2  # tan^2 theta_v
        a2t2 = self.alpha**2 * tan2
        if self.kind == "ggx":
            g = 2.0 / (1.0 + np.sqrt(1.0 + a2t2))
        else:
            a = 1.0 / np.sqrt(np.where(a2t2 > 0, a2t2, 1.0))
            g = np.where(a >= 1.6, 1.0, (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a))
        g = np.where(xy2 == 0, 1.0, g)
        g = np.where(z == 0, 0.0, g)
        return np.where(vdot(v, m) * z <= 0, 0.0, g)

    def G(self, wi: np.ndarray, wo: np.ndarray, m: np.ndarray) -> np.ndarray:
        """Separable Smith shadowing-masking G1(wi, m) G1(wo, m)."""
        return self.G1(wi, m) * self.G1(wo, m)

    @staticmethod
    def _half(wo: np.ndarray, wi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        h = wo + wi
        norm = vnorm(h)
        ok = norm > 0
        h = scale(h, 1.0 / np.where(ok, norm, 1.0))
        if not ok.all():
            h = np.where(ok[..., None], h, np.array([0.0, 0.0, 1.0], h.dtype))
        return h, ok

    def f(self, wo, wi):
        wo, wi = _dirs(wo, wi)
        m, ok = self._half(wo, wi)
        cos_o, cos_i = wo[..., 2], wi[..., 2]
        ok = ok & (cos_o > 0) & (cos_i > 0)
        denom = 4.0 * np.where(ok, cos_o * cos_i, 1.0)
        val = np.where(ok, self.D(m) * self.G(wi, wo, m) / denom, 0.0)
        return outer3(val, self.specular_reflectance, val.dtype)

    def pdf(self, wo, wi):
        wo, wi = _dirs(wo, wi)
        h, ok = self._half(wo, wi)
        h = scale(h, side(h[..., 2]))
        dot = np.abs(vdot(wo, h))
        ok = ok & (dot > 0)
        return np.where(ok, self.normals.pdf(h) / (4.0 * np.where(ok, dot, 1.0)), 0.0)

    def _sample_direction(self, wo, u):
        m = self.normals.sample(u)
        return reflect(np.broadcast_to(wo, _shape(wo, u)), m)

    def _repr_fields(self):
        return {"alpha": self.alpha, "distribution": self.kind}


class Phong(BSDFModel):
    """Normalised (modified) Phong BRDF (Lafortune & Willems 1994):

    f = kd / pi + ks (n + 2) / (2 pi) max(0, cos alpha)^n, cos alpha = wi · mirror(wo),
    with mirror(wo) = (-x, -y, z) the mirror direction about the normal.  Reciprocal
    (wi·mirror(wo) = wo·mirror(wi)); albedo <= kd + ks, so keep kd + ks <= 1 per channel.

    Sampling (one uniform picks the lobe, then is rescaled and reused):
    diffuse with probability P_d = mean(kd) / (mean(kd) + mean(ks)), cosine-weighted;
    else wi ~ PhongLobe(n) about mirror(wo), density (n + 1)/(2 pi) cos^n alpha.
    p(wi) = P_d cos(theta_i)/pi [wi.z > 0] + (1 - P_d) (n + 1)/(2 pi) max(0, cos alpha)^n.
    Lobe samples below the horizon have f = 0: their pdf mass is lost, the estimate
    stays unbiased (they contribute zero; p > 0 wherever f cos > 0 since P_d > 0 when kd > 0).
    """

    def __init__(self, kd: Any = 0.5, ks: Any = 0.2, exponent: float = 20.0):
        self.kd = _rgb(kd, "kd")
        self.ks = _rgb(ks, "ks")
        e = checks.real(exponent, "exponent", low=0, high=MAX_EXPONENT)
        self.exponent = e
        md, ms = float(np.mean(self.kd)), float(np.mean(self.ks))
        self.p_diffuse = md / (md + ms) if md + ms > 0 else 1.0
        self._cosine = CosineHemisphere()
        self._lobe = PhongLobe(e)

    def _cos_alpha(self, wo, wi):
        return np.clip(vdot(wi, mirror(wo)), 0.0, 1.0)

    def f(self, wo, wi):
        wo, wi = _dirs(wo, wi)
        ok = ((wo[..., 2] > 0) & (wi[..., 2] > 0))[..., None]
        spec = (self.exponent + 2.0) / TWO_PI * self._cos_alpha(wo, wi) ** self.exponent
        return np.where(ok, self.kd * INV_PI + spec[..., None] * self.ks, 0.0)

    def pdf(self, wo, wi):
        wo, wi = _dirs(wo, wi)
        ca = vdot(wi, mirror(wo))
        lobe = np.where(ca > 0, (self.exponent + 1.0) / TWO_PI * np.clip(ca, 0.0, 1.0) ** self.exponent, 0.0)
        return self.p_diffuse * self._cosine.pdf(wi) + (1.0 - self.p_diffuse) * lobe

    def _sample_direction(self, wo, u):
        mix = Mixture([self._cosine, self._lobe.around(mirror(wo))], [self.p_diffuse, 1.0 - self.p_diffuse])
        return np.broadcast_to(mix.sample(u), _shape(wo, u))

    def _repr_fields(self):
        return {"kd": self.kd.tolist(), "ks": self.ks.tolist(), "exponent": self.exponent}
