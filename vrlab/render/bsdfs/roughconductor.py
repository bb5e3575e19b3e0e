"""``roughconductor``: the microfacet reflection of Walter et al. 2007 (Mitsuba 3
``roughconductor``); its normal distributions (``GGX``, ``Beckmann``) are warps of
:mod:`vrlab.distributions`."""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ..._vec import dot as vdot
from ..._vec import norm as vnorm
from ..._vec import scale, side
from ...distributions import GGX, Beckmann
from ...distributions.base import as_points
from ..registry import register
from .base import BSDFModel, alpha_param, color_param, dirs, plain, reflect, shape_of, times_rgb
from .fresnel import conductor_index, conductor_index_from_props, fresnel_conductor

__all__ = ["RoughConductor"]


@register("bsdf", "roughconductor")
class RoughConductor(BSDFModel):
    """Rough conductor (Mitsuba 3 ``roughconductor``), isotropic roughness ``alpha``.  Mitsuba samples visible normals by
    default (``sample_visible=true``); vrlab samples the full NDF either way: the
    expected image is the same, only the noise differs.

    f = R F(wo·m) D(m) G(wi, wo, m) / (4 cos theta_i cos theta_o), m = normalize(wi + wo),
    F the conductor Fresnel term of eta + i k (``material`` or ``eta``/``k`` as in
    :mod:`~vrlab.render.bsdfs.conductor`; ``"none"``, the default, is F = 1),
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
    LOBES = ("glossy",)
    TEXTURED = ("specular_reflectance", "alpha", "eta", "k")
    SCALAR_TEXTURES = ("alpha",)

    def __init__(self, alpha: Any = 0.1, distribution: str = "beckmann", specular_reflectance: Any = 1.0,
                 sample_visible: bool = True, material: str = "none", eta: Any = None, k: Any = None):
        from ..textures import Texture

        checks.choice(distribution, "distribution", self.DISTRIBUTIONS)
        self.distribution_type = distribution
        if isinstance(alpha, Texture):        # a roughness texture (eval_1 at each shading point: ``at``)
            self.alpha, self.normals = alpha, None
        else:
            self.alpha = alpha_param(alpha)
            self.normals = GGX(self.alpha) if distribution == "ggx" else Beckmann(self.alpha)
        self.specular_reflectance = color_param(specular_reflectance, "specular_reflectance")
        self.sample_visible = checks.flag(sample_visible, "sample_visible")
        self.material = material
        self.eta, self.k = conductor_index(material, eta, k)

    @classmethod
    def from_props(cls, p) -> "RoughConductor":
        alpha = p.object("alpha", ("texture",)) if p.has("alpha") and p.element("alpha").tag == "texture" \
            else p.float("alpha", 0.1)
        return cls(alpha=alpha, distribution=p.string("distribution", "beckmann", cls.DISTRIBUTIONS),
                   specular_reflectance=p.texture("specular_reflectance", 1.0),
                   sample_visible=p.bool("sample_visible", True), **conductor_index_from_props(p))

    def at(self, values: dict) -> "RoughConductor":
        """The BSDF at N points: a textured roughness becomes per-row alpha (N,) in the normal
        distribution's formulas, which are elementwise in alpha."""
        out = super().at(values)
        if "alpha" in values:
            alpha = np.clip(np.asarray(values["alpha"], float), 1e-4, None)     # Mitsuba clamps alpha too
            normals = object.__new__(GGX if self.distribution_type == "ggx" else Beckmann)
            normals.alpha = alpha
            out.alpha, out.normals = alpha, normals
        return out

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
        if self.distribution_type == "ggx":
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
        wo, wi = dirs(wo, wi)
        m, ok = self._half(wo, wi)
        cos_o, cos_i = wo[..., 2], wi[..., 2]
        ok = ok & (cos_o > 0) & (cos_i > 0)
        denom = 4.0 * np.where(ok, cos_o * cos_i, 1.0)
        val = np.where(ok, self.D(m) * self.G(wi, wo, m) / denom, 0.0)
        if self.material == "none" and not self.textures.keys() & {"eta", "k"} and \
                np.all(np.asarray(self.eta) == 0) and np.all(np.asarray(self.k) == 1):
            return times_rgb(val, self.specular_reflectance, val.dtype)      # F = 1: a perfect mirror's facets
        F = fresnel_conductor(np.clip(vdot(wo, m), 0.0, 1.0), self.eta, self.k)
        return (val[..., None] * F * self.specular_reflectance).astype(val.dtype, copy=False)

    def pdf(self, wo, wi):
        wo, wi = dirs(wo, wi)
        h, ok = self._half(wo, wi)
        h = scale(h, side(h[..., 2]))
        dot = np.abs(vdot(wo, h))
        ok = ok & (dot > 0)
        return np.where(ok, self.normals.pdf(h) / (4.0 * np.where(ok, dot, 1.0)), 0.0)

    def _sample_direction(self, wo, u):
        m = self.normals.sample(u)
        return reflect(np.broadcast_to(wo, shape_of(wo, u)), m)

    def _repr_fields(self):
        return {"alpha": self.alpha, "distribution": self.distribution_type,
                "specular_reflectance": plain(self.specular_reflectance), "material": self.material,
                "eta": plain(self.eta), "k": plain(self.k)}


