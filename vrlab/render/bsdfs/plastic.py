"""``plastic``: a smooth dielectric coating over a diffuse base (Mitsuba 3 ``plastic``,
src/bsdfs/plastic.cpp).

Two lobes, in Mitsuba's component order:

* ``"specular"`` (delta): the coating's mirror reflection, wi = mirror(wo) = (-x, -y, z),
  whose integral of f |cos| is ``specular_reflectance * F(cos theta_o)`` (``delta_value``);
* ``"diffuse"``: light refracted into the coating, scattered by the base and refracted out,
  with the internal reflections summed in closed form::

      f cos theta_i = R' (1 - F(cos theta_o)) (1 - F(cos theta_i)) cos(theta_i) / (pi eta^2),
      R' = R / (1 - F_dr,int)          (``nonlinear=false``, the default)
      R' = R / (1 - R F_dr,int)        (``nonlinear=true``: colours shift with the scattering)

  with R = ``diffuse_reflectance``, F the unpolarised Fresnel reflectance of the relative index
  eta = ``int_ior / ext_ior`` (:func:`~vrlab.render.bsdfs.fresnel.fresnel_dielectric`) and
  F_dr,int = F_dr(1 / eta) the diffuse Fresnel reflectance of the inside of the coating
  (:func:`~vrlab.render.bsdfs.fresnel.fresnel_diffuse_reflectance`).  ``eval``/``pdf`` are
  this lobe alone (the delta lobe has no density), as Mitsuba's.

Sampling (Mitsuba's ``sample``): with the specular sampling weight
w_s = mean(specular_reflectance) / (mean(diffuse_reflectance) + mean(specular_reflectance))
(Mitsuba's scalar texture means: a colour's channel average; 1 for an absent
``specular_reflectance``) the lobes are chosen with probabilities proportional to
P_s = F(cos theta_o) w_s and P_d = (1 - F(cos theta_o)) (1 - w_s); the diffuse lobe samples
the cosine-weighted hemisphere, so pdf = P_d cos(theta_i) / pi.  One-sided: nothing for
wo.z <= 0 or wi.z <= 0 (``twosided`` makes it two-sided).  ``diffuse_albedo`` is 0: the
diffuse part is not k_d / pi times a constant, so the renderer's ``"lambertian"`` control does
not apply.

Parameters (Mitsuba's names and defaults): ``int_ior`` ("polypropylene", 1.49), ``ext_ior``
("air", 1.000277), each a positive number or a name of
:data:`~vrlab.render.bsdfs.fresnel.IOR_TABLE`; ``diffuse_reflectance`` (0.5) and
``specular_reflectance`` (1), colours or textures; ``nonlinear`` (false).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ...distributions import CosineHemisphere
from ..registry import register
from .base import INV_PI, BSDFModel, color_param, dirs, mirror, plain, shape_of
from .fresnel import fresnel_diffuse_reflectance, fresnel_dielectric, ior_from_props, ior_param, ior_value

__all__ = ["Plastic"]


def scalar_mean(value: Any) -> Any:
    """Mitsuba's scalar ``Texture::mean()``: a texture's ``mean_1``, a colour's channel average."""
    from ..textures import Texture

    if isinstance(value, Texture):
        return value.mean_1()
    return np.mean(value, axis=-1)


@register("bsdf", "plastic")
class Plastic(BSDFModel):
    """Smooth plastic (see the module docstring): lobes ``"specular"`` (delta) and ``"diffuse"``."""

    LOBES = ("specular", "diffuse")
    DELTA = ("specular",)
    TEXTURED = ("diffuse_reflectance", "specular_reflectance")

    def __init__(self, int_ior: Any = "polypropylene", ext_ior: Any = "air", diffuse_reflectance: Any = 0.5,
                 specular_reflectance: Any = 1.0, nonlinear: bool = False):
        self.int_ior, self.ext_ior = int_ior, ext_ior
        self.diffuse_reflectance, self.specular_reflectance = diffuse_reflectance, specular_reflectance
        self.nonlinear = nonlinear
        self._cosine = CosineHemisphere()
        self.validate()

    def validate(self) -> None:
        self.int_ior = ior_param(self.int_ior, "int_ior")
        self.ext_ior = ior_param(self.ext_ior, "ext_ior")
        self.diffuse_reflectance = color_param(self.diffuse_reflectance, "diffuse_reflectance")
        self.specular_reflectance = color_param(self.specular_reflectance, "specular_reflectance")
        self.nonlinear = checks.flag(self.nonlinear, "nonlinear")
        self.eta = ior_value(self.int_ior, "int_ior") / ior_value(self.ext_ior, "ext_ior")
        self.inv_eta2 = 1.0 / (self.eta * self.eta)
        self.fdr_int = float(fresnel_diffuse_reflectance(1.0 / self.eta))
        d, s = scalar_mean(self.diffuse_reflectance), scalar_mean(self.specular_reflectance)
        total = np.asarray(d + s, float)
        # both means 0: a black BSDF, whose choice of lobe does not matter (Mitsuba: 0/0)
        w = np.divide(s, total, out=np.full(total.shape, 0.5), where=total > 0)
        self.specular_sampling_weight = float(w) if w.ndim == 0 else w

    @classmethod
    def from_props(cls, p) -> "Plastic":
        return cls(int_ior=ior_from_props(p, "int_ior", "polypropylene"), ext_ior=ior_from_props(p, "ext_ior", "air"),
                   diffuse_reflectance=p.texture("diffuse_reflectance", 0.5),
                   specular_reflectance=p.texture("specular_reflectance", 1.0),
                   nonlinear=p.bool("nonlinear", False))

    def _fresnel(self, c: np.ndarray) -> np.ndarray:
        return fresnel_dielectric(c, self.eta).F

    def f(self, wo, wi):
        wo, wi = dirs(wo, wi)
        co, ci = wo[..., 2], wi[..., 2]
        R = self.diffuse_reflectance
        R = R / (1.0 - (R * self.fdr_int if self.nonlinear else self.fdr_int))
        s = (1.0 - self._fresnel(co)) * (1.0 - self._fresnel(ci)) * (self.inv_eta2 * INV_PI)
        s = np.where((co > 0) & (ci > 0), s, 0.0)
        out = s[..., None] * R
        return out.astype(np.result_type(wo, wi), copy=False)

    def pdf(self, wo, wi):
        wo, wi = dirs(wo, wi)
        pd = self.lobe_probabilities(wo)[..., 1]
        p = np.asarray(self._cosine.pdf(wi))
        return (pd * p).astype(np.result_type(wo, wi), copy=False)

    def _sample_direction(self, wo, u):
        return np.broadcast_to(self.distribution(wo).sample(u), shape_of(wo, u))

    def lobe_probabilities(self, wo):
        """``(..., 2)``: Mitsuba's (P_s, P_d) normalised; 0 for wo.z <= 0 (nothing is sampled)."""
        wo = dirs(wo, wo)[0]
        c = wo[..., 2]
        F = self._fresnel(np.clip(c, 0.0, 1.0))
        ws = self.specular_sampling_weight
        ps, pd = F * ws, (1.0 - F) * (1.0 - ws)
        total = ps + pd
        ok = (c > 0) & (total > 0)
        t = np.where(ok, total, 1.0)
        return np.stack([np.where(ok, ps / t, 0.0), np.where(ok, pd / t, 0.0)], -1)

    def lobe(self, name, wo):
        self._check_lobe(name)
        if name == "diffuse":
            return self._cosine
        return super().lobe(name, wo)

    def delta_value(self, name: str, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(mirror(wo), specular_reflectance F(wo.z))``, 0 for wo below the horizon."""
        self._check_lobe(name)
        if name not in self.DELTA:
            return super().delta_value(name, wo)
        wo = dirs(wo, wo)[0]
        c = wo[..., 2]
        F = np.where(c > 0, self._fresnel(np.clip(c, 0.0, 1.0)), 0.0)
        value = F[..., None] * self.specular_reflectance
        return mirror(wo), value.astype(wo.dtype, copy=False)

    def _repr_fields(self):
        return {"int_ior": self.int_ior, "ext_ior": self.ext_ior,
                "diffuse_reflectance": plain(self.diffuse_reflectance),
                "specular_reflectance": plain(self.specular_reflectance), "nonlinear": self.nonlinear}
