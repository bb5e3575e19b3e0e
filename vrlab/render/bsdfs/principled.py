"""``principled``: the Disney BSDF of Burley 2012/2015 as Mitsuba 3 writes it (src/bsdfs/principled.cpp).

Lobes, in Mitsuba's component order (and its ``sampled_component`` indices 0-3):

* ``"diffuse"``: Burley's diffuse with retro-reflection, blended towards the Hanrahan-Krueger
  "fake subsurface" by ``flatness``, plus the ``sheen`` (tinted by ``sheen_tint``), weight
  brdf = (1 - metallic)(1 - spec_trans), front side only; sampled cos / pi;
* ``"clearcoat"``: GTR1 normals of alpha = lerp(0.1, 0.001, clearcoat_gloss), Schlick Fresnel
  R0 = 0.04, masking ``smith_ggx1`` of alpha 0.25, weight clearcoat / 4, front side only,
  f cos = clearcoat/4 F D G |cos theta_i| (Mitsuba's, without 1 / (4 cos cos)); sampled by D cos;
* ``"specular_transmission"``: rough dielectric refraction (Walter et al. 2007) of relative index
  ``eta`` with GGX normals (``roughness``, ``anisotropic``; :mod:`.principled_lobes`), weight
  bsdf = (1 - metallic) spec_trans, colour sqrt(base_color), both sides, radiance scaled by
  1 / eta_path^2;
* ``"specular_reflection"``: GGX reflection with the principled Fresnel: on the front side
  (1 - metallic)(1 - spec_tint) F_dielectric + metallic Schlick(base_color) + (1 - metallic)
  spec_tint Schlick(tint R0(eta)); seen from inside bsdf F_dielectric.

``eta`` (> 0) or ``specular`` (default 0.5, eta = 2 / (1 - sqrt(0.08 specular)) - 1), not both;
with a transmission lobe eta = 1 becomes 1.001 and specular = 0 becomes 1e-3 (as Mitsuba).

Sampling (Mitsuba's ``sample``, three uniforms, ``dim_u = 3``): a GGX normal m visible from
wo_up = sign(wo_z) wo is drawn from u[0:2] first; the Fresnel term F = F_dielectric(wo.m) sets
the lobe probabilities, front side: diffuse brdf r_d, clearcoat clearcoat r_c / 4, transmission
r_s bsdf (1 - F), reflection r_s (1 - bsdf (1 - F)) (normalised; the r_* are the sampling rates);
seen from inside: reflection F, transmission 1 - F (nothing when bsdf = 0).  u[2] (Mitsuba's
``sample1``) picks the lobe by that CDF, and the lobe's direction comes from m (the specular
lobes) or from u[0:2] (cos / pi; a GTR1 normal).  The density of wi on the whole sphere is

    p(wi) = P_d cos/pi + P_c p_c(wi) + P_r(F(wo.h_r)) p_m(h_r) / (4 |wo.h_r|)
            + P_t(F(wo.h_t)) p_m(h_t) eta_p^2 |wi.h_t| / (wo.h_t + eta_p wi.h_t)^2,

h_r = normalize(wo + wi), h_t = normalize(wo + eta_p wi) (turned up; h_t where wi crosses the
facet), so ``pdf`` is exact although the choice depends on m.  ``pdf`` counts every produced
direction; Mitsuba's pdf (``pdf_mitsuba``) leaves out the directions it rejects: reflections
past the horizon, refractions that stay on wo's side, clearcoat reflections about normals facing
away from wo, and it reports the reflection density seen from inside where bsdf = 0 (where it
samples nothing).  ``pdf`` >= ``pdf_mitsuba``, equal where no produced direction is rejected.

``lobe(name, wo)`` is each lobe's own sampler (its normal, then its direction; the refraction
reflects at total internal reflection), for MIS over lobes; the lobe probabilities depend on m,
so ``lobe_probabilities(wo, m)`` needs the microfacet normal.  Parameters (Mitsuba's names and
defaults; all may be textures): ``base_color`` (0.5), ``roughness`` (0.5), ``anisotropic``,
``metallic``, ``spec_trans``, ``spec_tint``, ``sheen``, ``sheen_tint``, ``flatness``,
``clearcoat``, ``clearcoat_gloss`` (0, all in [0, 1]), ``eta``/``specular``; the sampling rates
``diffuse_reflectance_sampling_rate``, ``main_specular_sampling_rate`` (> 0) and
``clearcoat_sampling_rate`` (1 each, >= 0).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ...distributions.base import as_points, as_uniforms
from ...distributions import CosineHemisphere
from ..registry import register
from .base import BSDFDirections, BSDFModel, dirs, reflect, shape_of
from .fresnel import fresnel_dielectric, refract
from .principled_lobes import (GTR1, ClearcoatReflection, MicrofacetReflection, MicrofacetRefraction,
                               PrincipledParams, SidedCosine, disney_diffuse, ggx, schlick, schlick_r0, schlick_weight,
                               smith_ggx1, tint, unit, up, vdot)

__all__ = ["Principled"]

_UNIT = (0.0, 0.0, 1.0)


@register("bsdf", "principled")
class Principled(PrincipledParams, BSDFModel):
    """Mitsuba 3's principled BSDF (see the module docstring)."""

    LOBES = ("diffuse", "clearcoat", "specular_transmission", "specular_reflection")
    SCALARS = {"roughness": (0.5, *_UNIT[1:]), "anisotropic": _UNIT, "metallic": _UNIT, "spec_trans": _UNIT,
               "spec_tint": _UNIT, "sheen": _UNIT, "sheen_tint": _UNIT, "flatness": _UNIT, "clearcoat": _UNIT,
               "clearcoat_gloss": _UNIT}
    TEXTURED = ("base_color",) + tuple(SCALARS)
    SCALAR_TEXTURES = tuple(SCALARS)
    dim_u = 3
    CLEARCOAT_WEIGHT = 0.25          # "clearcoat has 1/4 of the main specular reflection energy"

    def __init__(self, base_color: Any = 0.5, roughness: Any = 0.5, anisotropic: Any = 0.0, metallic: Any = 0.0,
                 spec_trans: Any = 0.0, eta: Any = None, specular: Any = None, spec_tint: Any = 0.0,
                 sheen: Any = 0.0, sheen_tint: Any = 0.0, flatness: Any = 0.0, clearcoat: Any = 0.0,
                 clearcoat_gloss: Any = 0.0, diffuse_reflectance_sampling_rate: Any = 1.0,
                 main_specular_sampling_rate: Any = 1.0, clearcoat_sampling_rate: Any = 1.0):
        kw = dict(locals())
        self._init_params(base_color, kw)
        if eta is not None and specular is not None:
            raise ValueError("eta, specular: give either eta or specular, not both")
        self.specular = None
        if eta is not None:
            self.eta = checks.real(eta, "eta", low=0, low_open=True)
            if self.has["spec_trans"] and self.eta == 1:
                self.eta = 1.001                          # eta = 1 is not plausible for transmission
        else:
            s = checks.real(0.5 if specular is None else specular, "specular", low=0, high=12.5, high_open=True)
            if self.has["spec_trans"] and s == 0:
                s = 1e-3
            self.specular = s
            self.eta = 2.0 / (1.0 - np.sqrt(0.08 * s)) - 1.0
        self.rates = {n: checks.real(kw[n], n, low=0) for n in ("diffuse_reflectance_sampling_rate",
                                                               "main_specular_sampling_rate", "clearcoat_sampling_rate")}
        if self.rates["main_specular_sampling_rate"] <= 0:
            raise ValueError("main_specular_sampling_rate: must be > 0")

    @classmethod
    def from_props(cls, p) -> "Principled":
        rates = {n: p.float(n, 1.0) for n in ("diffuse_reflectance_sampling_rate", "main_specular_sampling_rate",
                                              "clearcoat_sampling_rate")}
        return cls(base_color=p.texture("base_color", 0.5), eta=p.float("eta", None) if p.has("eta") else None,
                   specular=p.float("specular", None) if p.has("specular") else None,
                   **cls._scalar_props(p), **rates)

    def diffuse_albedo(self) -> np.ndarray:
        return np.zeros(3)            # not a constant times k_d / pi: no Lambertian control variate

    # -- the pieces -------------------------------------------------------------------------
    def _weights(self):
        met, st = self.v("metallic"), self.v("spec_trans")
        return (1.0 - met) * (1.0 - st), (1.0 - met) * st if self.has["spec_trans"] else 0.0 * met

    def _dielectric(self, cos_i):
        """F_dielectric, cos theta_t, eta_it, eta_ti at cos theta_i = wo.m."""
        return fresnel_dielectric(cos_i, self.eta)

    def _normals(self):
        return ggx(self.v("roughness"), self.v("anisotropic"))

    def _clearcoat_alpha(self):
        return 0.1 + (0.001 - 0.1) * np.asarray(self.v("clearcoat_gloss"), float)

    def _probabilities(self, front, F):
        """(P_d, P_c, P_t, P_r) of the lobe choice at Fresnel terms F (exact: 0 inside where bsdf = 0)."""
        brdf, bsdf = self._weights()
        r = self.rates
        pd = brdf * r["diffuse_reflectance_sampling_rate"]
        pc = self.CLEARCOAT_WEIGHT * self.v("clearcoat") * r["clearcoat_sampling_rate"] if self.has["clearcoat"] \
            else 0.0 * pd
        rs = r["main_specular_sampling_rate"]
        tot = pd + pc + rs
        inside = (F + (1.0 - F)) if self.has["spec_trans"] else F
        inside = np.where(inside > 0, inside, 1.0)
        seen = ~front & (np.asarray(bsdf) > 0)
        P_d, P_c = np.where(front, pd / tot, 0.0), np.where(front, pc / tot, 0.0)
        P_t = np.where(front, rs * bsdf * (1.0 - F) / tot, np.where(seen, (1.0 - F) / inside, 0.0))
        P_r = np.where(front, rs * (1.0 - bsdf * (1.0 - F)) / tot, np.where(seen, F / inside, 0.0))
        if not self.has["spec_trans"]:
            P_t = 0.0 * P_t
        return P_d, P_c, P_t, P_r

    def lobe_probabilities(self, wo, m=None):
        """``(..., 4)``: the probabilities of (diffuse, clearcoat, transmission, reflection) when
        the GGX normal drawn first is ``m`` (they depend on it through F(wo.m))."""
        if m is None:
            raise ValueError("m: principled's lobe probabilities depend on the microfacet normal drawn first "
                             "(F(wo.m)); give m, or use distribution(wo) / sample_lobe")
        wo, m = dirs(wo, m)
        front = wo[..., 2] > 0
        P = self._probabilities(front, self._dielectric(vdot(wo, m)).F)
        seen = (wo[..., 2] != 0)
        return np.stack([np.where(seen, np.broadcast_to(p, seen.shape), 0.0) for p in P], -1)

    def _principled_fresnel(self, F, cos_i, front, base):
        met, tint_w = self.v("metallic"), self.v("spec_tint")
        eta_it = np.where(cos_i >= 0, self.eta, 1.0 / self.eta)
        w = schlick(cos_i, self.eta)[..., None]
        Fs = 0.0
        if self.has["metallic"]:
            Fs = Fs + np.asarray(met)[..., None] * (base + (1.0 - base) * w)
        if self.has["spec_tint"]:
            F0 = tint(base) * schlick_r0(eta_it)[..., None]
            Fs = Fs + np.asarray((1.0 - met) * tint_w)[..., None] * (F0 + (1.0 - F0) * w)
        _, bsdf = self._weights()
        front_F = ((1.0 - met) * (1.0 - tint_w) * F)[..., None] + Fs
        return np.where(front[..., None], front_F, (bsdf * F)[..., None])

    # -- values -------------------------------------------------------------------------------
    def eval(self, wo, wi):
        """Mitsuba's ``eval``: f |cos theta_i| on both sides (RGB)."""
        wo, wi = dirs(wo, wi)
        shape = np.broadcast_shapes(wo.shape, wi.shape)
        ci, co = wo[..., 2], wi[..., 2]
        active, front = ci != 0, ci > 0
        refl, refr = ci * co > 0, ci * co < 0
        brdf, bsdf = self._weights()
        base = np.asarray(self.v("base_color"), float)
        rough, met = self.v("roughness"), self.v("metallic")
        eta_p = np.where(front, self.eta, 1.0 / self.eta)
        wh, _ = unit(wo + wi * np.where(refl, 1.0, eta_p)[..., None])
        wh = up(wh)
        cw, cl = vdot(wo, wh), vdot(wi, wh)
        F = self._dielectric(cw).F
        s = np.where(ci >= 0, 1.0, -1.0)
        compat_r, compat_t = (cw * s > 0) & (cl * s > 0), (cw * s > 0) & (cl * s < 0)
        normals = self._normals()
        D, G = normals.D(wh), normals.G(wo, wi, wh)
        aci, aco = np.abs(ci), np.abs(co)
        safe_ci = np.where(active, ci, 1.0)
        value = np.zeros(shape)
        on = active & refl & compat_r & (F > 0)
        spec = self._principled_fresnel(F, cw, front, base) * (D * G / (4.0 * np.where(active, aci, 1.0)))[..., None]
        value += np.where(on[..., None], spec, 0.0)
        if self.has["spec_trans"]:
            on = active & (np.asarray(bsdf) > 0) & refr & compat_t & (F < 1)
            d = cw + eta_p * cl
            t = np.abs((1.0 - F) * D * G * cw * cl / (safe_ci * np.where(on, d * d, 1.0)))   # eta_p^2 / eta_p^2
            value += np.where(on[..., None], np.sqrt(base) * (bsdf * t)[..., None], 0.0)
        if self.has["clearcoat"]:
            cc = self.v("clearcoat")
            on = active & (np.asarray(cc) > 0) & refl & compat_r & front
            Fcc = 0.04 + 0.96 * schlick(cw, self.eta)
            Dcc = GTR1(self._clearcoat_alpha()).D(wh)
            Gcc = smith_ggx1(wo, wh, 0.25) * smith_ggx1(wi, wh, 0.25)
            value += np.where(on, cc * self.CLEARCOAT_WEIGHT * Fcc * Dcc * Gcc * aco, 0.0)[..., None]
        on = active & (np.asarray(brdf) > 0) & refl & front
        cos_d = vdot(wh, wi)
        diff = disney_diffuse(schlick_weight(aco), schlick_weight(aci), rough, cos_d,
                              np.where(on, aco + aci, 1.0), self.v("flatness") if self.has["flatness"] else None)
        value += np.where(on[..., None], (brdf * aco / np.pi * diff)[..., None] * base, 0.0)
        if self.has["sheen"]:          # Mitsuba adds it inside the diffuse branch (scalar variants)
            sheen = self.v("sheen")
            on_s = on & (np.asarray(sheen) > 0) & (1.0 - np.asarray(met) > 0)
            c = 1.0
            if self.has["sheen_tint"]:
                c = 1.0 + np.asarray(self.v("sheen_tint"))[..., None] * (tint(base) - 1.0)
            sh = (sheen * (1.0 - met) * schlick_weight(np.abs(cos_d)) * aco)[..., None] * c
            value += np.where(on_s[..., None], sh, 0.0)
        return value.astype(np.result_type(wo, wi), copy=False)

    def f(self, wo, wi):
        wo, wi = dirs(wo, wi)
        c = np.abs(wi[..., 2])
        return self.eval(wo, wi) / np.where(c > 0, c, 1.0)[..., None] * (c > 0)[..., None]

    def _pdf(self, wo, wi, mitsuba: bool):
        wo, wi = dirs(wo, wi)
        ci, co = wo[..., 2], wi[..., 2]
        front = ci > 0
        same = ci * co > 0
        normals = self._normals()
        R = MicrofacetReflection(normals, wo)
        h, jac = R.normal_and_jacobian(wi)
        p_d, p_c, _, p_r = self._probabilities(front, self._dielectric(vdot(wo, h)).F)
        if mitsuba:                    # Mitsuba's pdf seen from inside ignores bsdf = 0
            F = self._dielectric(vdot(wo, h)).F
            p_r = np.where(front, p_r, 1.0 if not self.has["spec_trans"] else F)
        pdf = np.where(same | (not mitsuba), p_r * R.visible.pdf(h) * jac, 0.0)
        pdf = pdf + p_d * np.where(co > 0, co / np.pi, 0.0)
        if self.has["spec_trans"]:
            T = MicrofacetRefraction(normals, wo, self.eta)
            ht, jt = T.normal_and_jacobian(wi)
            F = self._dielectric(vdot(wo, ht)).F
            p_t = self._probabilities(front, F)[2]
            if mitsuba:
                p_t = np.where(front, p_t, 1.0 - F)
            pdf = pdf + np.where(~same | (not mitsuba), p_t * R.visible.pdf(ht) * jt, 0.0)
        if self.has["clearcoat"]:
            C = ClearcoatReflection(self._clearcoat_alpha(), wo)
            ok = (same & (vdot(wo, h) > 0)) | (not mitsuba)
            pdf = pdf + np.where(ok, p_c * C.pdf(wi), 0.0)
        return np.where(ci != 0, pdf, 0.0)

    def pdf(self, wo, wi):
        """The density of ``distribution(wo).sample`` on the whole sphere (see the module docstring)."""
        return self._pdf(wo, wi, False)

    def pdf_mitsuba(self, wo, wi):
        """Mitsuba's ``pdf``: what :meth:`pdf` counts, less the directions Mitsuba rejects."""
        return self._pdf(wo, wi, True)

    # -- sampling -------------------------------------------------------------------------------
    def distribution(self, wo):
        return BSDFDirections(self, wo)

    def sample_lobe(self, wo, u):
        """``(wi, k)``: Mitsuba's sample for uniforms ``u (..., 3)`` (u[2] = its ``sample1``) and
        the index k of its lobe (= Mitsuba's ``sampled_component``)."""
        wo = as_points(wo, 3, "wo")
        u = as_uniforms(u, 3)
        wo_b = np.broadcast_to(wo, shape_of(wo, u))
        R = MicrofacetReflection(self._normals(), wo)
        m = R.sample_normal(u[..., :2])
        F, cos_t, _, eta_ti = self._dielectric(vdot(wo_b, m))
        P_d, P_c, P_t, _ = self._probabilities(wo_b[..., 2] > 0, F)
        u1 = u[..., 2]
        c1 = P_d
        c2 = c1 + P_c
        c3 = c2 + P_t
        k = np.where(u1 < c1, 0, np.where(u1 < c2, 1, np.where(u1 < c3, 2, 3)))
        wi = reflect(wo_b, m)
        wi = np.where((k == 2)[..., None] & (cos_t != 0)[..., None], refract(wo_b, cos_t, eta_ti, m), wi)
        if np.any(k == 1):
            wi = np.where((k == 1)[..., None], reflect(wo_b, GTR1(self._clearcoat_alpha()).sample(u[..., :2])), wi)
        if np.any(k == 0):
            wi = np.where((k == 0)[..., None], CosineHemisphere().sample(u[..., :2]), wi)
        return wi, k

    def _sample_direction(self, wo, u):
        return self.sample_lobe(wo, u)[0]

    def lobe(self, name, wo):
        self._check_lobe(name)
        wo = as_points(wo, 3, "wo")
        if name == "diffuse":
            return SidedCosine(1.0, wo)
        if name == "clearcoat":
            return ClearcoatReflection(self._clearcoat_alpha(), wo)
        if name == "specular_transmission":
            return MicrofacetRefraction(self._normals(), wo, self.eta)
        return MicrofacetReflection(self._normals(), wo)

    def _repr_fields(self):
        eta = {"eta": self.eta} if self.specular is None else {"specular": self.specular}
        return {**self._param_fields(), **eta, **self.rates}
