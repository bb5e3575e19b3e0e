"""``roughconductor``: the microfacet reflection of Walter et al. 2007 (Mitsuba 3
``roughconductor``); its normal distributions (``GGX``, ``Beckmann``) are warps of
:mod:`vrlab.distributions`."""
from __future__ import annotations

from typing import Any

import numpy as np

from ..._vec import dot as vdot
from ...distributions.base import as_points
from ..registry import register
from .base import BSDFModel, color_param, dirs, plain, times_rgb
from .fresnel import conductor_index, conductor_index_from_props, fresnel_conductor
from .rough import RoughSurface, half_vector

__all__ = ["RoughConductor"]


@register("bsdf", "roughconductor")
class RoughConductor(RoughSurface, BSDFModel):
    """Rough conductor (Mitsuba 3 ``roughconductor``): the microfacet reflection of Walter et
    al. 2007 with the conductor Fresnel term,

        f = R F(wo.m) D(m) G(wi, wo, m) / (4 cos theta_i cos theta_o),   m = normalize(wi + wo),

    G = G1(wi, m) G1(wo, m) (separable Smith, Heitz 2014, with Mitsuba's G1: exact for GGX,
    the rational approximation of Walter et al. eq. 27 for Beckmann), F the conductor
    Fresnel term of eta + i k (``material`` or ``eta``/``k`` as in
    :mod:`~vrlab.render.bsdfs.conductor`; ``"none"``, the default, is F = 1),
    R = ``specular_reflectance``.  Roughness ``alpha`` or ``alpha_u``/``alpha_v`` (anisotropic,
    along dp/du and dp/dv), ``distribution`` ``"beckmann"`` (default) or ``"ggx"``, and
    sampling by visible normals (``sample_visible``, default true) or by D cos; see
    :mod:`~vrlab.render.bsdfs.rough`.  One-sided: 0 unless wo.z > 0 and wi.z > 0; reflected
    samples below the horizon are wasted, not biased (the pdf is that of the whole sphere).
    """

    LOBES = ("glossy",)
    TEXTURED = ("specular_reflectance", "alpha", "alpha_u", "alpha_v", "eta", "k")
    SCALAR_TEXTURES = ("alpha", "alpha_u", "alpha_v")

    def __init__(self, alpha: Any = 0.1, distribution: str = "beckmann", specular_reflectance: Any = 1.0,
                 sample_visible: bool = True, material: str = "none", eta: Any = None, k: Any = None, *,
                 alpha_u: Any = None, alpha_v: Any = None):
        self._init_roughness(alpha, alpha_u, alpha_v, distribution, sample_visible)
        self.specular_reflectance = color_param(specular_reflectance, "specular_reflectance")
        self.material = material
        self.eta, self.k = conductor_index(material, eta, k)

    @classmethod
    def from_props(cls, p) -> "RoughConductor":
        return cls(specular_reflectance=p.texture("specular_reflectance", 1.0), **cls.roughness_props(p),
                   **conductor_index_from_props(p))

    def at(self, values: dict) -> "RoughConductor":
        """The BSDF at N points: textured roughness becomes per-row alpha (N,) in the normal
        distribution's formulas, which are elementwise in alpha."""
        out = super().at(values)
        self._roughness_at(out, values)
        return out

    def D(self, m: np.ndarray) -> np.ndarray:
        """Microfacet normal distribution D(m) (0 for m.z <= 0)."""
        return self.normals.D(m)

    def G1(self, v: np.ndarray, m: np.ndarray) -> np.ndarray:
        """Smith masking of direction ``v`` for microfacet normal ``m`` (Mitsuba's ``smith_g1``)."""
        return self.normals.G1(as_points(v, 3, "v"), as_points(m, 3, "m"))

    def G(self, wi: np.ndarray, wo: np.ndarray, m: np.ndarray) -> np.ndarray:
        """Separable Smith shadowing-masking G1(wi, m) G1(wo, m)."""
        return self.G1(wi, m) * self.G1(wo, m)

    def _perfect_mirror_facets(self) -> bool:
        return self.material == "none" and not self.textures.keys() & {"eta", "k"} and \
            np.all(np.asarray(self.eta) == 0) and np.all(np.asarray(self.k) == 1)

    def f(self, wo, wi):
        wo, wi = dirs(wo, wi)
        m, ok = half_vector(wo, wi)
        cos_o, cos_i = wo[..., 2], wi[..., 2]
        ok = ok & (cos_o > 0) & (cos_i > 0)
        denom = 4.0 * np.where(ok, cos_o * cos_i, 1.0)
        val = np.where(ok, self.D(m) * self.G(wi, wo, m) / denom, 0.0)
        if self._perfect_mirror_facets():
            return times_rgb(val, self.specular_reflectance, val.dtype)      # F = 1
        F = fresnel_conductor(np.clip(vdot(wo, m), 0.0, 1.0), self.eta, self.k)
        return (val[..., None] * F * self.specular_reflectance).astype(val.dtype, copy=False)

    def pdf(self, wo, wi):
        wo, wi = dirs(wo, wi)
        return self.reflection_pdf(wo, wi)

    def _sample_direction(self, wo, u):
        return self.sample_reflection(wo, u)

    def _repr_fields(self):
        return {**self._roughness_fields(), "specular_reflectance": plain(self.specular_reflectance),
                "material": self.material, "eta": plain(self.eta), "k": plain(self.k)}
