"""``roughdielectric``: a rough interface between two dielectrics, reflecting and refracting
through its microfacets (Mitsuba 3 ``roughdielectric``, src/bsdfs/roughdielectric.cpp; Walter et
al. 2007, "Microfacet Models for Refraction through Rough Surfaces").

Both sides: wo.z > 0 is outside (relative index eta = ``int_ior / ext_ior``), wo.z < 0 inside
(eta' = 1 / eta); eta_o below is the index seen from wo's side (eta or 1 / eta).  With D, G =
G1(wo, m) G1(wi, m) (Mitsuba's G1: rational for Beckmann) and F = F(wo.m) the dielectric Fresnel
term (:func:`~vrlab.render.bsdfs.fresnel.fresnel_dielectric`, inverted index for wo.m < 0)::

    reflection   (wo.z wi.z > 0), m = ±normalize(wo + wi):
        f |cos theta_i| = R F D G / (4 |cos theta_o|)
    transmission (wo.z wi.z < 0), m = ±normalize(wo + eta_o wi)  (Walter's generalised half vector):
        f |cos theta_i| = T (1 - F) D G eta_o^2 |wo.m| |wi.m| / (eta_o^2 |cos theta_o| (wo.m + eta_o wi.m)^2)

m turned to m.z > 0, R = ``specular_reflectance``, T = ``specular_transmittance``.  The second
eta_o^2 in the denominator is Mitsuba's radiance-mode scaling 1 / eta_o^2 of transmitted radiance
(Veach 1997, 5.2; Walter's paper misses it).  ``eval`` is f |cos theta_i| on both sides (0 at
wo.z = 0, which Mitsuba ignores).

**Sampling** (Mitsuba's ``sample``, ``dim_u = 3``): m from the normals visible from wo' =
sign(wo.z) wo (``sample_visible``, default; :class:`~vrlab.distributions.VisibleNormals`) or from
D cos with Walter's widened roughness alpha (1.2 - 0.2 sqrt|cos theta_o|) (``sample_visible=
false``, as Mitsuba), using u[..., :2] (Mitsuba's ``sample2``); then reflection wi = reflect(wo,
m) if u[..., 2] <= F(wo.m) (u[..., 2] is Mitsuba's ``sample1``), else refraction wi =
refract(wo, m) (:func:`~vrlab.render.bsdfs.fresnel.refract`; at total internal reflection F = 1:
always reflected, so no sample fails).  With p_m the density of m:

    reflection branch:    p_m(m_r) F(wo.m_r) / (4 |wo.m_r|),                m_r = ±normalize(wo + wi)
    transmission branch:  p_m(m_t) (1 - F(wo.m_t)) e^2 |wi.m_t| / (wo.m_t + e wi.m_t)^2,
                          m_t = ±normalize(wo + e wi), e = eta if wo.m_t > 0 else 1 / eta

(the Jacobians of reflection, 1 / (4 |wo.m|), and refraction, Walter et al. eq. 17).  ``pdf`` is
their **sum** on the whole sphere, each branch where it can produce wi (a transmission term only
where wi is the refraction of wo about m_t: wi.m_t and wo.m_t of opposite signs; with the full
NDF both e may contribute, with visible normals only e = eta_o).  A reflected sample can land on
the far side and a refracted one on wo's side (steep facets): there eval uses the other formula
(0 through G's side checks in most places), and the density still counts them, so the estimator
is unbiased.  Mitsuba's ``pdf`` instead takes the reflection branch alone for wi on wo's side
and the transmission branch alone on the far side (with its side checks), and for Beckmann's
visible normals its rational G1 (not the density of its samples, within 0.35 %); ``branch_pdfs``
gives vrlab's two branches apart, which tests compare with Mitsuba's.

**Lobes**: ``LOBES = ("reflection", "transmission")``.  ``lobe(name, wo)`` samples one branch
alone (m as above, then always reflect / always refract; ``dim_u = 2``): its density is the
branch's term with the factor F or 1 - F dropped.  At total internal reflection the transmission
lobe cannot refract: it reflects instead, and its density includes those reflections (the
reflection term restricted to F(wo.m_r) = 1), so it stays the exact density of what it draws.
``distribution(wo)`` is Mitsuba's sampler above (:class:`RoughDielectricDirections`), not a
mixture of the lobes: the choice of lobe depends on m.  ``lobe_probabilities(wo)`` therefore
cannot be the probabilities ``sample`` picks the lobes with for a fixed wo by a cheap formula;
it returns the Fresnel reflectance at the macro normal, (F(wo.z), 1 - F(wo.z)): a valid choice
for one-sample MIS over the two lobes (and what ``blendbsdf``/``normalmap`` mix the lobes with),
an approximation of the true branch probabilities E_m[F(wo.m)].

Parameters (Mitsuba's names and defaults): ``distribution`` ("beckmann" or "ggx"), ``alpha``
(0.1) or ``alpha_u``/``alpha_v`` (anisotropic, along dp/du and dp/dv; numbers or textures),
``sample_visible`` (true), ``int_ior`` ("bk7"), ``ext_ior`` ("air"), numbers or names of
:data:`~vrlab.render.bsdfs.fresnel.IOR_TABLE` (they must differ), ``specular_reflectance`` and
``specular_transmittance`` (1), colours or textures.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..._vec import dot as vdot
from ..._vec import norm as vnorm
from ..._vec import scale
from ...distributions import VisibleNormals
from ...distributions.base import Distribution, as_points, as_uniforms
from ..registry import register
from .base import BSDFModel, color_param, dirs, plain, reflect, shape_of, times_rgb
from .fresnel import fresnel_dielectric, interface_iors, ior_from_props, refract
from .rough import RoughSurface, half_vector

__all__ = ["RoughDielectric", "RoughDielectricDirections"]

MODES = ("mixture", "reflection", "transmission")


def _turn_up(m: np.ndarray) -> np.ndarray:
    """m turned to the upper hemisphere (Mitsuba's ``mulsign(m, m.z)``)."""
    return m * np.where(m[..., 2:3] < 0, -1.0, 1.0)


class RoughDielectricDirections(Distribution):
    """wi of a ``roughdielectric`` for a fixed ``wo``: ``mode`` ``"mixture"`` is Mitsuba's sampler
    (``dim_u = 3``: m from u[..., :2], reflection if u[..., 2] <= F), ``"reflection"`` and
    ``"transmission"`` the lobes (``dim_u = 2``).  ``pdf``: the exact density on the whole
    sphere (see the module docstring)."""

    dim_x, measure = 3, "solid angle"

    def __init__(self, bsdf: "RoughDielectric", wo: np.ndarray, mode: str = "mixture"):
        self.bsdf, self.wo, self.mode = bsdf, as_points(wo, 3, "wo"), mode
        self.dim_u = 3 if mode == "mixture" else 2

    def sample(self, u):
        return self.bsdf._sample_branches(self.wo, as_uniforms(u, self.dim_u), self.mode)

    def pdf(self, w):
        p_r, p_t = self.bsdf.branch_pdfs(self.wo, as_points(w, 3, "w"), self.mode)
        return p_r + p_t

    def _repr_fields(self):
        return {"bsdf": self.bsdf, "wo_shape": self.wo.shape, "mode": self.mode}


@register("bsdf", "roughdielectric")
class RoughDielectric(RoughSurface, BSDFModel):
    """Rough dielectric interface (see the module docstring): continuous lobes ``"reflection"`` and
    ``"transmission"``, both sides."""

    LOBES = ("reflection", "transmission")
    reciprocal = False               # radiance transport scales refraction by 1 / eta^2
    TEXTURED = ("specular_reflectance", "specular_transmittance", "alpha", "alpha_u", "alpha_v")
    SCALAR_TEXTURES = ("alpha", "alpha_u", "alpha_v")
    dim_u = 3

    def __init__(self, alpha: Any = 0.1, distribution: str = "beckmann", int_ior: Any = "bk7", ext_ior: Any = "air",
                 specular_reflectance: Any = 1.0, specular_transmittance: Any = 1.0, sample_visible: bool = True, *,
                 alpha_u: Any = None, alpha_v: Any = None):
        self._init_roughness(alpha, alpha_u, alpha_v, distribution, sample_visible)
        self.int_ior, self.ext_ior, self.eta = interface_iors(int_ior, ext_ior)
        self.specular_reflectance = color_param(specular_reflectance, "specular_reflectance")
        self.specular_transmittance = color_param(specular_transmittance, "specular_transmittance")

    @classmethod
    def from_props(cls, p) -> "RoughDielectric":
        return cls(int_ior=ior_from_props(p, "int_ior", "bk7"), ext_ior=ior_from_props(p, "ext_ior", "air"),
                   specular_reflectance=p.texture("specular_reflectance", 1.0),
                   specular_transmittance=p.texture("specular_transmittance", 1.0), **cls.roughness_props(p))

    def at(self, values: dict) -> "RoughDielectric":
        """The BSDF at N points (textured roughness: per-row alpha, see ``roughconductor``)."""
        out = super().at(values)
        self._roughness_at(out, values)
        return out

    # -- values -----------------------------------------------------------------------------
    def eval(self, wo, wi):
        """f |cos theta_i| on both sides (reflection on wo's side, transmission across)."""
        wo, wi = dirs(wo, wi)
        co, ci = wo[..., 2], wi[..., 2]
        active = co != 0
        refl = co * ci > 0
        eta_o = np.where(co > 0, self.eta, 1.0 / self.eta)
        h = wo + wi * np.where(refl, 1.0, eta_o)[..., None]
        length = vnorm(h)
        ok = active & (length > 0)
        m = _turn_up(scale(h, 1.0 / np.where(ok, length, 1.0)))
        D = self.normals.D(m)
        G = self.normals.G1(wo, m) * self.normals.G1(wi, m)
        dom, dim_ = vdot(wo, m), vdot(wi, m)
        F = fresnel_dielectric(dom, self.eta).F
        aco = np.where(ok, np.abs(co), 1.0)
        r = F * D * G / (4.0 * aco)
        den = dom + eta_o * dim_
        den = np.where(den != 0, den, 1.0)
        t = np.abs((1.0 - F) * D * G * dom * dim_ / (aco * den * den))      # eta_o^2 / eta_o^2 (radiance)
        r = np.where(ok & refl, r, 0.0)
        t = np.where(ok & ~refl, t, 0.0)
        out = times_rgb(r, self.specular_reflectance) + times_rgb(t, self.specular_transmittance)
        return out.astype(np.result_type(wo, wi), copy=False)

    def f(self, wo, wi):
        wo, wi = dirs(wo, wi)
        ci = np.abs(wi[..., 2])
        return self.eval(wo, wi) / np.where(ci > 0, ci, 1.0)[..., None]

    # -- microfacet normals as sampled --------------------------------------------------------
    def _sampling_normals(self, wo: np.ndarray):
        """(normal distribution, wo' = sign(wo.z) wo, active): Walter's widened roughness for
        the full NDF (as Mitsuba), the BSDF's own for visible normals."""
        c = wo[..., 2]
        active = c != 0
        wo_up = wo * np.where(c < 0, -1.0, 1.0)[..., None]
        wo_up = np.where(active[..., None], wo_up, np.array([0.0, 0.0, 1.0], wo.dtype))
        if self.sample_visible:
            return self.normals, wo_up, active
        s = 1.2 - 0.2 * np.sqrt(np.abs(c))
        au = np.asarray(self.alpha_u) * s
        av = au if (self.alpha_u is self.alpha_v) else np.asarray(self.alpha_v) * s
        return self._make_normals(au, av), wo_up, active

    def _m_pdf(self, normals, wo_up: np.ndarray, m: np.ndarray) -> np.ndarray:
        if self.sample_visible:
            return VisibleNormals(normals, wo_up).pdf(m)
        return normals.pdf(m)

    def branch_pdfs(self, wo: np.ndarray, wi: np.ndarray, mode: str = "mixture") -> tuple[np.ndarray, np.ndarray]:
        """``(p_r, p_t)``: the densities at ``wi`` of the samples of the reflection and of the
        transmission branch (``mode``: Mitsuba's sampler, whose branch weights are F and 1 - F,
        or one lobe alone); ``pdf`` is their sum."""
        p_r, p_same, p_other = self.branch_terms(wo, wi, mode)
        return p_r, p_same + p_other

    def branch_terms(self, wo: np.ndarray, wi: np.ndarray, mode: str = "mixture") -> tuple:
        """``(p_r, p_t, p_t')``: the reflection branch's density and the transmission branch's
        two terms, p_t by the index of wo's side (eta_o, wo.m of the sign of wo.z: the only one
        of visible normals, and the one Mitsuba's ``pdf`` counts) and p_t' by the other (normals
        facing away from wo, drawn by the full NDF only)."""
        wo, wi = dirs(wo, wi)
        shape = np.broadcast_shapes(wo.shape, wi.shape)
        wo, wi = np.broadcast_to(wo, shape), np.broadcast_to(wi, shape)
        normals, wo_up, active = self._sampling_normals(wo)
        # reflection
        h, ok = half_vector(wo, wi)
        m = _turn_up(h)
        d = vdot(wo, m)
        F = fresnel_dielectric(d, self.eta).F
        weight = {"mixture": F, "reflection": np.ones_like(F), "transmission": (F >= 1).astype(F.dtype)}[mode]
        ok = ok & active & (d != 0)
        p_r = np.where(ok, self._m_pdf(normals, wo_up, m) * weight / (4.0 * np.abs(np.where(ok, d, 1.0))), 0.0)
        # transmission: both relative indices (the side of wo.m decides which one refracts)
        p_same, p_other = np.zeros_like(p_r), np.zeros_like(p_r)
        if mode == "reflection":
            return p_r, p_same, p_other
        outside = wo[..., 2] > 0
        for e, sign in ((self.eta, 1.0), (1.0 / self.eta, -1.0)):
            h = wo + e * wi
            length = vnorm(h)
            okt = active & (length > 0)
            m = _turn_up(scale(h, 1.0 / np.where(okt, length, 1.0)))
            dom, dim_ = vdot(wo, m), vdot(wi, m)
            okt = okt & (sign * dom > 0) & (dom * dim_ < 0)
            if not okt.any():
                continue
            F = fresnel_dielectric(dom, self.eta).F
            weight = (1.0 - F) if mode == "mixture" else (F < 1).astype(F.dtype)
            den = dom + e * dim_
            den = np.where(okt, den, 1.0)
            jac = e * e * np.abs(dim_) / (den * den)
            p = np.where(okt, self._m_pdf(normals, wo_up, m) * weight * jac, 0.0)
            same = outside if sign > 0 else ~outside
            p_same = p_same + np.where(same, p, 0.0)
            p_other = p_other + np.where(same, 0.0, p)
        return p_r, p_same, p_other

    def _sample_branches(self, wo: np.ndarray, u: np.ndarray, mode: str) -> np.ndarray:
        shape = shape_of(wo, u)
        wo_b = np.broadcast_to(wo, shape)
        normals, wo_up, _ = self._sampling_normals(wo)
        if self.sample_visible:
            m = VisibleNormals(normals, np.broadcast_to(wo_up, shape)).sample(u[..., :2])
        else:
            m = normals.sample(u[..., :2])
        m = np.broadcast_to(m, shape)
        F, cos_t, _, eta_ti = fresnel_dielectric(vdot(wo_b, m), self.eta)
        wr = reflect(wo_b, m)
        if mode == "reflection":
            return wr
        wt = refract(wo_b, cos_t, eta_ti, m)
        pick_r = (u[..., 2] <= F) if mode == "mixture" else (F >= 1)
        return np.where(pick_r[..., None], wr, wt).astype(np.result_type(wo, u), copy=False)

    # -- the BSDF interface -------------------------------------------------------------------
    def pdf(self, wo, wi):
        p_r, p_t = self.branch_pdfs(wo, wi)
        return (p_r + p_t).astype(np.result_type(*dirs(wo, wi)), copy=False)

    def _sample_direction(self, wo, u):
        return self._sample_branches(wo, u, "mixture")

    def distribution(self, wo):
        """Mitsuba's sampler for ``wo`` (``dim_u = 3``; see the module docstring)."""
        return RoughDielectricDirections(self, as_points(wo, 3, "wo"))

    def lobe(self, name, wo):
        """One branch alone (``dim_u = 2``): always reflect, or always refract (reflect at total
        internal reflection)."""
        self._check_lobe(name)
        return RoughDielectricDirections(self, as_points(wo, 3, "wo"), name)

    def lobe_probabilities(self, wo):
        """``(..., 2)``: (F(wo.z), 1 - F(wo.z)), the Fresnel term at the macro normal: not what
        ``sample`` picks the lobes with (that depends on the sampled m; see the module
        docstring), but a valid choice of lobe for one-sample MIS and for mixtures."""
        wo = dirs(wo, wo)[0]
        F = fresnel_dielectric(wo[..., 2], self.eta).F
        return np.stack([F, 1.0 - F], -1)

    def _repr_fields(self):
        return {**self._roughness_fields(), "int_ior": self.int_ior, "ext_ior": self.ext_ior,
                "specular_reflectance": plain(self.specular_reflectance),
                "specular_transmittance": plain(self.specular_transmittance)}
