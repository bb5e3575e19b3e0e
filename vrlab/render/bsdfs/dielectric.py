"""``dielectric``: a smooth interface between two dielectrics, e.g. glass and air (Mitsuba 3
``dielectric``, src/bsdfs/dielectric.cpp).

Two delta lobes, in Mitsuba's component order, on both sides of the surface:

* ``"reflection"``: wi = mirror(wo) = (-x, -y, z), value ``specular_reflectance * F``;
* ``"transmission"``: wi = refract(wo) (Snell's law about the normal,
  :func:`~vrlab.render.bsdfs.fresnel.refract`), value
  ``specular_transmittance * (1 - F) / eta_it^2``,

with F, cos theta_t and eta_it from :func:`~vrlab.render.bsdfs.fresnel.fresnel_dielectric`
at cos theta_o = wo.z and eta = ``int_ior / ext_ior``: seen from inside (wo.z < 0) the
relative index is 1 / eta.  The factor 1 / eta_it^2 is the radiance of Mitsuba's
``TransportMode::Radiance``: transmitted radiance is compressed (or spread) with the solid
angle as it crosses the interface (Veach 1997, 5.2).  Under total internal reflection F = 1
and nothing is transmitted (the transmission atom is then -wo with value 0).

Sampling (Mitsuba's ``sample``): reflection with probability F, transmission with 1 - F; the
sample's weight is the value over that probability (``specular_reflectance``, or
``specular_transmittance / eta_it^2``).  ``eval`` and ``pdf`` are 0 everywhere (no density in
solid angle).  Shadow rays and light samples never reach a delta lobe: the renderer needs an
estimator with the ``"bsdf"`` technique.

Parameters (Mitsuba's names and defaults): ``int_ior`` ("bk7", 1.5046), ``ext_ior`` ("air",
1.000277), each a positive number or a name of :data:`~vrlab.render.bsdfs.fresnel.IOR_TABLE`;
``specular_reflectance`` and ``specular_transmittance`` (1), colours or textures.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..registry import register
from .base import BSDFModel, color_param, dirs, mirror, plain, shape_of
from .fresnel import fresnel_dielectric, ior_from_props, ior_param, ior_value, refract

__all__ = ["Dielectric", "SmoothInterface"]


class SmoothInterface(BSDFModel):
    """Common part of ``dielectric`` and ``thindielectric``: two delta lobes on both sides,
    ``eval`` = ``pdf`` = 0; subclasses give :meth:`_lobes` -> (R, wi_t, value_t scale)."""

    LOBES = ("reflection", "transmission")
    DELTA = ("reflection", "transmission")
    TEXTURED = ("specular_reflectance", "specular_transmittance")
    DEFAULT_INT = "bk7"

    def __init__(self, int_ior: Any = "bk7", ext_ior: Any = "air", specular_reflectance: Any = 1.0,
                 specular_transmittance: Any = 1.0):
        self.int_ior, self.ext_ior = int_ior, ext_ior
        self.specular_reflectance, self.specular_transmittance = specular_reflectance, specular_transmittance
        self.validate()

    def validate(self) -> None:
        self.int_ior = ior_param(self.int_ior, "int_ior")
        self.ext_ior = ior_param(self.ext_ior, "ext_ior")
        self.specular_reflectance = color_param(self.specular_reflectance, "specular_reflectance")
        self.specular_transmittance = color_param(self.specular_transmittance, "specular_transmittance")
        self.eta = ior_value(self.int_ior, "int_ior") / ior_value(self.ext_ior, "ext_ior")

    @classmethod
    def from_props(cls, p):
        return cls(int_ior=ior_from_props(p, "int_ior", cls.DEFAULT_INT), ext_ior=ior_from_props(p, "ext_ior", "air"),
                   specular_reflectance=p.texture("specular_reflectance", 1.0),
                   specular_transmittance=p.texture("specular_transmittance", 1.0))

    def _lobes(self, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
        raise NotImplementedError  # abstract

    def f(self, wo, wi):
        wo, wi = dirs(wo, wi)
        return np.zeros(np.broadcast_shapes(wo.shape, wi.shape), np.result_type(wo, wi))

    def eval(self, wo, wi):
        """0 on both sides: all of the BSDF is in its delta lobes (``delta_value``)."""
        return self.f(wo, wi)

    def pdf(self, wo, wi):
        wo, wi = dirs(wo, wi)
        return np.zeros(np.broadcast_shapes(wo.shape[:-1], wi.shape[:-1]), np.result_type(wo, wi))

    def _sample_direction(self, wo, u):
        return np.broadcast_to(self.distribution(wo).sample(u), shape_of(wo, u))

    def lobe_probabilities(self, wo):
        """``(..., 2)``: (R, 1 - R), Mitsuba's choice of lobe."""
        wo = dirs(wo, wo)[0]
        R = self._lobes(wo)[0]
        return np.stack([R, 1.0 - R], -1)

    def delta_value(self, name: str, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self._check_lobe(name)
        wo = dirs(wo, wo)[0]
        R, wi_t, scale_t = self._lobes(wo)
        if name == "reflection":
            value = R[..., None] * self.specular_reflectance
            return mirror(wo), value.astype(wo.dtype, copy=False)
        value = ((1.0 - R) * scale_t)[..., None] * self.specular_transmittance
        return wi_t, value.astype(wo.dtype, copy=False)

    def _repr_fields(self):
        return {"int_ior": self.int_ior, "ext_ior": self.ext_ior,
                "specular_reflectance": plain(self.specular_reflectance),
                "specular_transmittance": plain(self.specular_transmittance)}


@register("bsdf", "dielectric")
class Dielectric(SmoothInterface):
    """Smooth dielectric interface (see the module docstring): delta lobes ``"reflection"``
    (probability F) and ``"transmission"`` (1 - F), both sides."""

    reciprocal = False               # radiance transport scales refraction by 1 / eta^2

    def _lobes(self, wo):
        F, cos_t, eta_it, eta_ti = fresnel_dielectric(wo[..., 2], self.eta)
        wi = refract(wo, cos_t, eta_ti).astype(wo.dtype, copy=False)
        tir = (cos_t == 0)[..., None]
        wi = np.where(tir, -wo, wi)                      # total internal reflection: an empty atom
        return F, wi, eta_ti * eta_ti
