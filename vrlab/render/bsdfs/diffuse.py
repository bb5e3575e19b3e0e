"""``diffuse``: the Lambertian BRDF f = R / pi (Mitsuba 3 ``diffuse``, ``reflectance`` default 0.5,
a colour or a texture)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ..registry import register
from ...distributions import CosineHemisphere
from .base import INV_PI, BSDFModel, color_param, dirs, plain, shape_of, times_rgb

__all__ = ["Diffuse"]


@register("bsdf", "diffuse")
class Diffuse(BSDFModel):
    """Lambertian reflector (Mitsuba ``diffuse``): f = R / pi, cosine-weighted sampling
    p(wi) = cos(theta_i) / pi, so weight = R exactly."""

    LOBES = ("diffuse",)
    TEXTURED = ("reflectance",)

    def __init__(self, reflectance: Any = 0.5):
        self.reflectance = color_param(reflectance, "reflectance")
        self._cosine = CosineHemisphere()

    def f(self, wo, wi):
        wo, wi = dirs(wo, wi)
        return times_rgb((wo[..., 2] > 0) & (wi[..., 2] > 0), self.reflectance * INV_PI, wo.dtype)

    def pdf(self, wo, wi):
        wo, wi = dirs(wo, wi)
        p = self._cosine.pdf(wi)
        return np.broadcast_to(p, np.broadcast_shapes(wo.shape[:-1], p.shape))

    def _sample_direction(self, wo, u):
        return np.broadcast_to(self._cosine.sample(u), shape_of(wo, u))

    @classmethod
    def from_props(cls, p) -> "Diffuse":
        return cls(reflectance=p.texture("reflectance", 0.5))

    def diffuse_albedo(self) -> np.ndarray:
        return self.reflectance

    def is_black(self) -> bool:
        return not self.textures and not np.any(self.reflectance > 0)

    def validate(self) -> None:
        self.reflectance = color_param(self.reflectance, "reflectance")

    def _repr_fields(self):
        return {"reflectance": plain(self.reflectance)}


