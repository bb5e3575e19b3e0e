"""``conductor``: a smooth metal, a perfect specular reflection weighted by the conductor Fresnel
term (Mitsuba 3 ``conductor``).

The BRDF is a delta lobe: f_r(wo, wi) cos(theta_i) = R F(cos theta_o) delta(wi - mirror(wo)),
so its integral over the one direction mirror(wo) = (-x, -y, z) is R F(wo.z) (``delta_value``),
with F the unpolarised Fresnel reflectance of the complex index eta + i k
(:func:`~vrlab.render.bsdfs.fresnel.fresnel_conductor`) and R = ``specular_reflectance``.
It reflects only light arriving from the front (wo.z > 0), like every one-sided model here.
Sampling returns mirror(wo) with probability 1; no light sample can reach that direction, so
the renderer refuses estimators without a ``"bsdf"`` technique on scenes with such a surface.

Parameters (Mitsuba's): ``material`` (``"none"``: eta = 0, k = 1, F = 1; or a named metal,
:data:`~vrlab.render.spectra.CONDUCTORS`) or ``eta`` and ``k``; ``specular_reflectance``
(default 1); all but ``material`` may be textures.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..registry import register
from .base import BSDFModel, color_param, dirs, mirror, plain, shape_of
from .fresnel import conductor_index, conductor_index_from_props, fresnel_conductor

__all__ = ["Conductor"]


@register("bsdf", "conductor")
class Conductor(BSDFModel):
    """Smooth conductor (see the module docstring): one delta lobe ``"specular"``."""

    LOBES = ("specular",)
    DELTA = ("specular",)
    TEXTURED = ("eta", "k", "specular_reflectance")

    def __init__(self, material: str = "none", eta: Any = None, k: Any = None, specular_reflectance: Any = 1.0):
        self.material = material
        self.eta, self.k = conductor_index(material, eta, k)
        self.specular_reflectance = color_param(specular_reflectance, "specular_reflectance")

    @classmethod
    def from_props(cls, p) -> "Conductor":
        return cls(**conductor_index_from_props(p), specular_reflectance=p.texture("specular_reflectance", 1.0))

    def f(self, wo, wi):
        wo, wi = dirs(wo, wi)
        return np.zeros(np.broadcast_shapes(wo.shape, wi.shape), np.result_type(wo, wi))

    def pdf(self, wo, wi):
        wo, wi = dirs(wo, wi)
        return np.zeros(np.broadcast_shapes(wo.shape[:-1], wi.shape[:-1]), np.result_type(wo, wi))

    def _sample_direction(self, wo, u):
        return np.broadcast_to(mirror(wo), shape_of(wo, u))

    def delta_value(self, name: str, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(mirror(wo), R F(wo.z))``, 0 for wo below the horizon."""
        self._check_lobe(name)
        wo = dirs(wo, wo)[0]
        c = wo[..., 2]
        F = fresnel_conductor(np.clip(c, 0.0, 1.0), self.eta, self.k)          # (..., 3)
        value = np.where((c > 0)[..., None], F, 0.0) * self.specular_reflectance
        return mirror(wo), value.astype(wo.dtype, copy=False)

    def _repr_fields(self):
        return {"material": self.material, "eta": plain(self.eta), "k": plain(self.k),
                "specular_reflectance": plain(self.specular_reflectance)}
