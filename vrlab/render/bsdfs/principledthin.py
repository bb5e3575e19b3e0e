"""``principledthin``: the thin-sheet principled BSDF of Burley 2015 as Mitsuba 3 writes it
(src/bsdfs/principledthin.cpp): a two-dimensional sheet, the same from both sides (a wo below the
surface is the mirror image -wo of one above: every value and sample is turned by
s = sign(wo_z) as a whole vector), that does not bend light.

Lobes, in the order of Mitsuba's lobe choice (its ``sampled_component`` in brackets):

* ``"specular_reflection"`` (3): GGX reflection (``roughness``, ``anisotropic``) with the thin
  Fresnel term lerp(F_dielectric(eta), Schlick(tint R0(eta)), spec_tint), weight spec_trans;
* ``"specular_transmission"`` (2): a GGX reflection of roughness (0.65 eta - 0.35) roughness
  mirrored through the sheet, wi = (x, y, -z) of reflect(wo, m), colour base_color,
  weight spec_trans (1 - F_dielectric);
* ``"diffuse_reflection"`` (0): Burley's diffuse, retro-reflection, fake subsurface
  (``flatness``) and sheen, weight (1 - spec_trans)(1 - diff_trans / 2);
* ``"diffuse_transmission"`` (1): Lambertian, base_color / pi, weight
  (1 - spec_trans) diff_trans / 2 (``diff_trans`` in [0, 2]).

Sampling: the lobe with probabilities proportional to spec_trans r_sr / 2, spec_trans r_st / 2,
(1 - spec_trans)(1 - diff_trans / 2) r_dr and (1 - spec_trans) diff_trans / 2 r_dt (the sampling
rates r; they do not depend on wo), as a :class:`~vrlab.distributions.LobeMixture` (two
uniforms: the first picks the lobe and is reused rescaled, Mitsuba's ``sample1`` and
``sample2``; ``dim_u = 2``).  ``pdf`` is the mixture's density on the whole sphere, counting
also the microfacet directions that land on the other lobe's side; ``pdf_mitsuba`` is
Mitsuba's, which leaves those out (it rejects such samples), and its transmission also leaves
out the normals m with (s wi).m >= 0.  Parameters (Mitsuba's names and defaults, all may be
textures): ``base_color`` (0.5), ``roughness`` (0.5), ``anisotropic``, ``spec_trans``,
``spec_tint``, ``sheen``, ``sheen_tint``, ``flatness`` (0, in [0, 1]), ``diff_trans`` (0, in
[0, 2]), ``eta`` (1.5, > 0), and the sampling rates ``specular_reflectance_sampling_rate``,
``specular_transmittance_sampling_rate``, ``diffuse_reflectance_sampling_rate``,
``diffuse_transmittance_sampling_rate`` (1, >= 0).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ...distributions.base import as_points
from ..registry import register
from .base import BSDFModel, dirs
from .fresnel import fresnel_dielectric
from .principled_lobes import (Flipped, MicrofacetReflection, PrincipledParams, SidedCosine, disney_diffuse, ggx, schlick,
                               schlick_r0, schlick_weight, tint, unit, up, vdot)

__all__ = ["PrincipledThin"]

RATES = ("specular_reflectance_sampling_rate", "specular_transmittance_sampling_rate",
         "diffuse_reflectance_sampling_rate", "diffuse_transmittance_sampling_rate")


@register("bsdf", "principledthin")
class PrincipledThin(PrincipledParams, BSDFModel):
    """Mitsuba 3's thin principled BSDF (see the module docstring)."""

    LOBES = ("specular_reflection", "specular_transmission", "diffuse_reflection", "diffuse_transmission")
    SCALARS = {"roughness": (0.5, 0.0, 1.0), "anisotropic": (0.0, 0.0, 1.0), "spec_trans": (0.0, 0.0, 1.0),
               "spec_tint": (0.0, 0.0, 1.0), "sheen": (0.0, 0.0, 1.0), "sheen_tint": (0.0, 0.0, 1.0),
               "flatness": (0.0, 0.0, 1.0), "diff_trans": (0.0, 0.0, 2.0), "eta": (1.5, 1e-6, 1e6)}
    TEXTURED = ("base_color",) + tuple(SCALARS)
    SCALAR_TEXTURES = tuple(SCALARS)

    def __init__(self, base_color: Any = 0.5, roughness: Any = 0.5, anisotropic: Any = 0.0, spec_trans: Any = 0.0,
                 eta: Any = 1.5, spec_tint: Any = 0.0, sheen: Any = 0.0, sheen_tint: Any = 0.0, flatness: Any = 0.0,
                 diff_trans: Any = 0.0, specular_reflectance_sampling_rate: Any = 1.0,
                 specular_transmittance_sampling_rate: Any = 1.0, diffuse_reflectance_sampling_rate: Any = 1.0,
                 diffuse_transmittance_sampling_rate: Any = 1.0):
        kw = dict(locals())
        self._init_params(base_color, kw)
        self.rates = {n: checks.real(kw[n], n, low=0) for n in RATES}

    @classmethod
    def from_props(cls, p) -> "PrincipledThin":
        return cls(base_color=p.texture("base_color", 0.5), **cls._scalar_props(p),
                   **{n: p.float(n, 1.0) for n in RATES})

    def diffuse_albedo(self) -> np.ndarray:
        return np.zeros(3)

    def _scaled_roughness(self):
        return (0.65 * np.asarray(self.v("eta"), float) - 0.35) * self.v("roughness")

    # -- values -------------------------------------------------------------------------------
    def eval(self, wo, wi):
        """Mitsuba's ``eval``: f |cos theta_i| on both sides (RGB)."""
        wo, wi = dirs(wo, wi)
        shape = np.broadcast_shapes(wo.shape, wi.shape)
        active = wo[..., 2] != 0
        s = np.where(wo[..., 2] < 0, -1.0, 1.0)[..., None]
        a, b = wo * s, wi * s                        # the sheet seen from the front
        ci, co = a[..., 2], b[..., 2]
        refl, refr = co > 0, co < 0
        st, dt = self.v("spec_trans"), np.asarray(self.v("diff_trans"), float) / 2.0
        eta, rough = self.v("eta"), self.v("roughness")
        base = np.asarray(self.v("base_color"), float)
        b_r = b * np.stack(np.broadcast_arrays(1.0, 1.0, np.where(co < 0, -1.0, 1.0)), -1)
        wh, _ = unit(a + b_r)
        cw, cl = vdot(a, wh), vdot(b, wh)
        st_a = np.asarray(st)
        safe_ci = np.where(active, ci, 1.0)
        value = np.zeros(shape)
        if self.has["spec_trans"]:
            F = fresnel_dielectric(cw, eta).F
            on = active & (st_a > 0) & refl & (cw > 0) & (cl > 0)
            normals = ggx(rough, self.v("anisotropic"))
            Fs = 0.0
            if self.has["spec_tint"]:
                F0 = tint(base) * np.asarray(schlick_r0(np.asarray(eta, float)))[..., None]
                Fs = F0 + (1.0 - F0) * schlick(cw, eta)[..., None]
            t = np.asarray(self.v("spec_tint"))[..., None]
            F_thin = F[..., None] + t * (Fs - F[..., None])
            spec = F_thin * (st * normals.D(wh) * normals.G(a, b, wh) / (4.0 * safe_ci))[..., None]
            value += np.where(on[..., None], spec, 0.0)
            on = active & refr & (st_a > 0) & (cw > 0) & (cl < 0)
            scaled = ggx(self._scaled_roughness(), self.v("anisotropic"))
            trans = (st * (1.0 - F) * scaled.D(wh) * scaled.G(a, b, wh) / (4.0 * safe_ci))[..., None] * base
            value += np.where(on[..., None], trans, 0.0)
        on = active & refl & (st_a < 1) & (dt < 1)
        aco = np.abs(co)
        cos_d = vdot(wh, b)
        diff = disney_diffuse(schlick_weight(aco), schlick_weight(ci), rough, cos_d,
                              np.where(on, aco + np.abs(ci), 1.0), self.v("flatness") if self.has["flatness"] else None)
        w = (1.0 - st) * (1.0 - dt)
        value += np.where(on[..., None], (w * co / np.pi * diff)[..., None] * base, 0.0)
        if self.has["sheen"]:
            sheen = self.v("sheen")
            c = 1.0
            if self.has["sheen_tint"]:
                c = 1.0 + np.asarray(self.v("sheen_tint"))[..., None] * (tint(base) - 1.0)
            sh = (sheen * w * schlick_weight(np.abs(cos_d)) * aco)[..., None] * c
            value += np.where((on & (np.asarray(sheen) > 0))[..., None], sh, 0.0)
        if self.has["diff_trans"]:
            on = active & refr & (st_a < 1) & (dt > 0)
            value += np.where(on[..., None], ((1.0 - st) * dt * aco / np.pi)[..., None] * base, 0.0)
        return value.astype(np.result_type(wo, wi), copy=False)

    def f(self, wo, wi):
        wo, wi = dirs(wo, wi)
        c = np.abs(wi[..., 2])
        return self.eval(wo, wi) / np.where(c > 0, c, 1.0)[..., None] * (c > 0)[..., None]

    # -- lobes and sampling -----------------------------------------------------------------------
    def lobe_probabilities(self, wo):
        """``(..., 4)``: Mitsuba's lobe probabilities (0 for a grazing wo, which it does not sample)."""
        wo = as_points(wo, 3, "wo")
        st = np.asarray(self.v("spec_trans"), float)
        dt = np.asarray(self.v("diff_trans"), float) / 2.0 if self.has["diff_trans"] else 0.0 * st
        r = [self.rates[n] for n in RATES]
        has = self.has["spec_trans"]
        P = [st * r[0] / 2.0 if has else 0.0 * st, st * r[1] / 2.0 if has else 0.0 * st,
             r[2] * (1.0 - st) * (1.0 - dt), r[3] * (1.0 - st) * dt]
        seen = wo[..., 2] != 0
        tot = sum(P)
        out = np.stack(np.broadcast_arrays(*[np.where(seen, p, 0.0) for p in P]), -1)
        tot = np.asarray(tot)[..., None]
        return np.divide(out, tot, out=np.zeros(out.shape), where=tot > 0)

    def lobe(self, name, wo):
        self._check_lobe(name)
        wo = as_points(wo, 3, "wo")
        s = np.where(wo[..., 2] < 0, -1.0, 1.0)
        if name == "specular_reflection":
            return MicrofacetReflection(ggx(self.v("roughness"), self.v("anisotropic")), wo)
        if name == "specular_transmission":
            return Flipped(MicrofacetReflection(ggx(self._scaled_roughness(), self.v("anisotropic")), wo))
        return SidedCosine(s if name == "diffuse_reflection" else -s, wo)

    def pdf(self, wo, wi):
        """The mixture's density on the whole sphere (see the module docstring)."""
        wo, wi = dirs(wo, wi)
        return np.asarray(self.distribution(wo).pdf(wi))

    def pdf_mitsuba(self, wo, wi):
        """Mitsuba's ``pdf``: :meth:`pdf` less the specular directions Mitsuba rejects."""
        wo, wi = dirs(wo, wi)
        P = self.lobe_probabilities(wo)
        z = wi[..., 2] * np.where(wo[..., 2] < 0, -1.0, 1.0)
        pdf = P[..., 0] * np.where(z > 0, self.lobe("specular_reflection", wo).pdf(wi), 0.0)
        flip = wi * np.array([1.0, 1.0, -1.0])
        h, _ = unit(wo + flip)
        h = up(h)
        s = np.where(wo[..., 2] < 0, -1.0, 1.0)
        crosses = (z < 0) & (vdot(wi, h) * s < 0)
        pdf = pdf + P[..., 1] * np.where(crosses, self.lobe("specular_transmission", wo).pdf(wi), 0.0)
        pdf = pdf + P[..., 2] * self.lobe("diffuse_reflection", wo).pdf(wi)
        return pdf + P[..., 3] * self.lobe("diffuse_transmission", wo).pdf(wi)

    def _sample_direction(self, wo, u):
        return self.distribution(wo).sample(u)

    def _repr_fields(self):
        return {**self._param_fields(), **self.rates}
