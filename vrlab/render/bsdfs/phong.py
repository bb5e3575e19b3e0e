"""``phong`` (vrlab's own element; Mitsuba 3 has no Phong plugin): the normalised modified
Phong BRDF, ``diffuse_reflectance`` k_d (0.5), ``specular_reflectance`` k_s (0.2),
``exponent`` n (30)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ..._vec import dot as vdot
from ...distributions import CosineHemisphere, Mixture, PhongLobe
from ..registry import register
from ..scene_checks import MAX_EXPONENT
from .base import INV_PI, TWO_PI, BSDFModel, dirs, mirror, rgb_param, shape_of

__all__ = ["Phong"]


@register("bsdf", "phong")
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
        self.kd = rgb_param(kd, "kd")
        self.ks = rgb_param(ks, "ks")
        e = checks.real(exponent, "exponent", low=0, high=MAX_EXPONENT)
        self.exponent = e
        md, ms = float(np.mean(self.kd)), float(np.mean(self.ks))
        self.p_diffuse = md / (md + ms) if md + ms > 0 else 1.0
        self._cosine = CosineHemisphere()
        self._lobe = PhongLobe(e)

    @classmethod
    def from_props(cls, p) -> "Phong":
        return cls(kd=p.color("diffuse_reflectance", 0.5), ks=p.color("specular_reflectance", 0.2),
                   exponent=p.float("exponent", 30.0))

    def diffuse_albedo(self) -> np.ndarray:
        return self.kd

    def _cos_alpha(self, wo, wi):
        return np.clip(vdot(wi, mirror(wo)), 0.0, 1.0)

    def f(self, wo, wi):
        wo, wi = dirs(wo, wi)
        ok = ((wo[..., 2] > 0) & (wi[..., 2] > 0))[..., None]
        spec = (self.exponent + 2.0) / TWO_PI * self._cos_alpha(wo, wi) ** self.exponent
        return np.where(ok, self.kd * INV_PI + spec[..., None] * self.ks, 0.0)

    def pdf(self, wo, wi):
        wo, wi = dirs(wo, wi)
        ca = vdot(wi, mirror(wo))
        lobe = np.where(ca > 0, (self.exponent + 1.0) / TWO_PI * np.clip(ca, 0.0, 1.0) ** self.exponent, 0.0)
        return self.p_diffuse * self._cosine.pdf(wi) + (1.0 - self.p_diffuse) * lobe

    def _sample_direction(self, wo, u):
        mix = Mixture([self._cosine, self._lobe.around(mirror(wo))], [self.p_diffuse, 1.0 - self.p_diffuse])
        return np.broadcast_to(mix.sample(u), shape_of(wo, u))

    def _repr_fields(self):
        return {"kd": self.kd.tolist(), "ks": self.ks.tolist(), "exponent": self.exponent}
