"""``roughplastic``: a rough dielectric coating over a diffuse base (Mitsuba 3 ``roughplastic``,
src/bsdfs/roughplastic.cpp; Weidlich & Wilkie 2007, "Arbitrarily Layered Micro-Facet Surfaces",
with the coating of Walter et al. 2007).

Two continuous lobes, in Mitsuba's component order (one-sided: 0 unless wo.z > 0 and wi.z > 0):

* ``"specular"``: the coating's microfacet reflection (as ``roughconductor`` with the dielectric
  Fresnel term), with h = normalize(wo + wi)::

      f cos theta_i = R_s F(wo.h) D(h) G(wo, wi, h) / (4 cos theta_o)

* ``"diffuse"``: light refracted through the rough coating, scattered by the base and refracted
  out, the internal reflections summed in closed form::

      f cos theta_i = R' T(cos theta_o) T(cos theta_i) cos(theta_i) / (pi eta^2),
      R' = R_d / (1 - F_int)        (``nonlinear=false``, the default)
      R' = R_d / (1 - R_d F_int)    (``nonlinear=true``)

with R_s = ``specular_reflectance``, R_d = ``diffuse_reflectance``, eta = ``int_ior /
ext_ior``, F the dielectric Fresnel term (:func:`~vrlab.render.bsdfs.fresnel.fresnel_dielectric`),
D and G Mitsuba's (G1 rational for Beckmann, :mod:`vrlab.distributions.microfacet`).

**The two tables** (Mitsuba 3 ``parameters_changed``, which integrates them numerically when
the BSDF is built; include/mitsuba/render/microfacet.h ``eval_transmittance`` and
``eval_reflectance``): for the 64 cosines mu_k = max(1e-6, k / 63) and v_k = (sqrt(1 - mu_k^2),
0, mu_k), with m drawn from the normals visible from v_k (always by visible normals, whatever
``sample_visible`` says) at the nodes of a tensor Gauss-Legendre rule on [0, 1]^2 (32 x 32 nodes
if the relative index > 1, else 128 x 128)::

      T(mu_k)  = E_m[(1 - F(v_k.m; eta)) G1(refract(v_k, m), m)]          (rough transmittance)
      R1(mu_k) = E_m[F(v_k.m; 1/eta) G1(reflect(v_k, m), m)]             (reflect(.).z > 0)
      F_int    = 2 mean_k(R1(mu_k) mu_k)                                  (internal reflectance)

T at any cosine is the linear interpolation of the table (Mitsuba's ``lerp_gather``).  F_int is
a plain mean over the 64 cosines (a Riemann sum of 2 int R1(mu) mu dmu), as Mitsuba computes it;
vrlab reproduces the same quadrature (:func:`rough_tables`) with its own visible-normal sampler,
which draws Mitsuba's normals from the same uniforms (tests/test_bsdf_families.py measures the
agreement).

Sampling (Mitsuba's ``sample``): with w_s = mean(R_s) / (mean(R_d) + mean(R_s)) (Mitsuba's scalar
texture means) the lobes have the probabilities P_s = (1 - T(cos theta_o)) w_s and P_d =
T(cos theta_o) (1 - w_s), normalised (``lobe_probabilities``); the specular lobe reflects wo about
a normal visible from wo (``sample_visible``, default) or drawn from D cos
(:class:`~vrlab.render.bsdfs.rough.MicrofacetReflection`), the diffuse lobe samples the cosine
hemisphere.  ``pdf`` = P_s p_s + P_d cos(theta_i) / pi on the whole sphere (Mitsuba reports 0
below the horizon; for Beckmann's visible normals Mitsuba's reported p_s uses its rational G1
and is not the density of its samples: vrlab's is, see :mod:`~vrlab.render.bsdfs.rough`).

Parameters (Mitsuba's names and defaults): ``distribution`` ("beckmann" or "ggx"), ``alpha``
(0.1, a number: Mitsuba refuses an anisotropic roughness here, and the tables fix one alpha, so
no texture), ``sample_visible`` (true), ``int_ior`` ("polypropylene"), ``ext_ior`` ("air"),
numbers or names of :data:`~vrlab.render.bsdfs.fresnel.IOR_TABLE` (they must differ),
``diffuse_reflectance`` (0.5) and ``specular_reflectance`` (1), colours or textures,
``nonlinear`` (false).
"""
from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np

from ... import checks
from ..._vec import dot as vdot
from ...distributions import GGX, Beckmann, CosineHemisphere, VisibleNormals
from ..registry import register
from .base import INV_PI, BSDFModel, color_param, dirs, plain, reflect, shape_of, times_rgb
from .fresnel import fresnel_dielectric, interface_iors, ior_from_props, refract
from .plastic import scalar_mean
from .rough import MicrofacetReflection, RoughSurface, half_vector

__all__ = ["RoughPlastic", "rough_tables"]

TABLE_SIZE = 64          # Mitsuba's MI_ROUGH_TRANSMITTANCE_RES


def _table_cosines() -> np.ndarray:
    return np.maximum(1e-6, np.linspace(0.0, 1.0, TABLE_SIZE))


def _visible_expectation(distribution: str, alpha: float, eta: float, transmit: bool) -> np.ndarray:
    """``(64,)``: E_m[...] of the module docstring at the table's cosines, by Mitsuba's tensor
    Gauss-Legendre rule over the visible-normal sampler's uniforms."""
    res = 32 if eta > 1 else 128
    nodes, weights = np.polynomial.legendre.leggauss(res)
    ux, uy = np.meshgrid(0.5 * nodes + 0.5, 0.5 * nodes + 0.5)
    wx, wy = np.meshgrid(weights, weights)
    u = np.stack([ux.ravel(), uy.ravel()], -1)
    w = 0.25 * (wx * wy).ravel()
    normals = (GGX if distribution == "ggx" else Beckmann)(alpha)
    out = np.empty(TABLE_SIZE)
    for k, mu in enumerate(_table_cosines()):
        v = np.array([np.sqrt(1.0 - mu * mu), 0.0, mu])
        m = VisibleNormals(normals, v).sample(u)
        vm = np.sum(v * m, -1)
        F, cos_t, _, eta_ti = fresnel_dielectric(vm, eta)
        if transmit:
            out_dir = refract(v, cos_t, eta_ti, m)
            val = normals.G1(out_dir, m) * (1.0 - F)
            val = np.where(out_dir[..., 2] * v[2] >= 0, 0.0, val)
        else:
            out_dir = reflect(np.broadcast_to(v, m.shape), m)
            val = normals.G1(out_dir, m) * F
            val = np.where(out_dir[..., 2] <= 0, 0.0, val)
        out[k] = np.sum(val * w)
    return out


@lru_cache(maxsize=32)
def rough_tables(distribution: str, alpha: float, eta: float) -> tuple[np.ndarray, float]:
    """``(T (64,), F_int)``: Mitsuba 3's rough transmittance table at mu_k = max(1e-6, k / 63) and
    internal reflectance of a ``roughplastic`` (see the module docstring), cached per
    (distribution, alpha, eta)."""
    checks.choice(distribution, "distribution", ("ggx", "beckmann"))
    T = _visible_expectation(distribution, float(alpha), float(eta), True)
    R = _visible_expectation(distribution, float(alpha), 1.0 / float(eta), False)
    T.setflags(write=False)
    return T, float(2.0 * np.mean(R * _table_cosines()))


def lerp_table(table: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Mitsuba's ``lerp_gather``: the table (values at k / (n - 1)) linearly interpolated at x in
    [0, 1] (the last interval extrapolates beyond 1)."""
    n = len(table)
    x = np.asarray(x) * (n - 1)
    i = np.clip(np.floor(x), 0, n - 2).astype(np.int64)
    t = x - i
    return (1.0 - t) * table[i] + t * table[i + 1]


@register("bsdf", "roughplastic")
class RoughPlastic(RoughSurface, BSDFModel):
    """Rough plastic (see the module docstring): continuous lobes ``"specular"`` and ``"diffuse"``."""

    LOBES = ("specular", "diffuse")
    TEXTURED = ("diffuse_reflectance", "specular_reflectance")

    def __init__(self, alpha: Any = 0.1, distribution: str = "beckmann", int_ior: Any = "polypropylene",
                 ext_ior: Any = "air", diffuse_reflectance: Any = 0.5, specular_reflectance: Any = 1.0,
                 nonlinear: bool = False, sample_visible: bool = True, *, alpha_u: Any = None, alpha_v: Any = None):
        from ..textures import Texture

        if alpha_u is not None or alpha_v is not None:
            raise ValueError("alpha_u, alpha_v: roughplastic takes one isotropic alpha (Mitsuba 3 refuses an "
                             "anisotropic roughness here)")
        if isinstance(alpha, Texture):
            raise TypeError("alpha: roughplastic needs a number, not a texture (its tables are computed for one "
                            "roughness, as in Mitsuba 3)")
        self._init_roughness(alpha, None, None, distribution, sample_visible)
        self.int_ior, self.ext_ior, self.eta = interface_iors(int_ior, ext_ior)
        self.inv_eta2 = 1.0 / (self.eta * self.eta)
        self.diffuse_reflectance = color_param(diffuse_reflectance, "diffuse_reflectance")
        self.specular_reflectance = color_param(specular_reflectance, "specular_reflectance")
        self.nonlinear = checks.flag(nonlinear, "nonlinear")
        d, s = scalar_mean(self.diffuse_reflectance), scalar_mean(self.specular_reflectance)
        total = float(d + s)
        self.specular_sampling_weight = float(s) / total if total > 0 else 0.5
        self.transmittance, self.internal_reflectance = rough_tables(distribution, self.alpha, self.eta)
        self._cosine = CosineHemisphere()

    @classmethod
    def from_props(cls, p) -> "RoughPlastic":
        return cls(int_ior=ior_from_props(p, "int_ior", "polypropylene"), ext_ior=ior_from_props(p, "ext_ior", "air"),
                   diffuse_reflectance=p.texture("diffuse_reflectance", 0.5),
                   specular_reflectance=p.texture("specular_reflectance", 1.0),
                   nonlinear=p.bool("nonlinear", False), **cls.roughness_props(p))

    def _T(self, c: np.ndarray) -> np.ndarray:
        return lerp_table(self.transmittance, np.clip(c, 0.0, 1.0))

    def eval(self, wo, wi):
        wo, wi = dirs(wo, wi)
        co, ci = wo[..., 2], wi[..., 2]
        ok = (co > 0) & (ci > 0)
        h, okh = half_vector(wo, wi)
        spec = self.normals.D(h) * self.normals.G(wi, wo, h) * fresnel_dielectric(vdot(wo, h), self.eta).F
        spec = np.where(ok & okh, spec / (4.0 * np.where(ok, co, 1.0)), 0.0)
        R = self.diffuse_reflectance
        R = R / (1.0 - (R * self.internal_reflectance if self.nonlinear else self.internal_reflectance))
        diff = np.where(ok, (INV_PI * self.inv_eta2) * ci * self._T(co) * self._T(ci), 0.0)
        out = times_rgb(spec, self.specular_reflectance) + times_rgb(diff, R)
        return out.astype(np.result_type(wo, wi), copy=False)

    def f(self, wo, wi):
        wo, wi = dirs(wo, wi)
        ci = wi[..., 2]
        e = self.eval(wo, wi)
        return e / np.where(ci > 0, ci, 1.0)[..., None]

    def pdf(self, wo, wi):
        wo, wi = dirs(wo, wi)
        return np.asarray(self.distribution(wo).pdf(wi)).astype(np.result_type(wo, wi), copy=False)

    def _sample_direction(self, wo, u):
        return np.broadcast_to(self.distribution(wo).sample(u), shape_of(wo, u))

    def lobe_probabilities(self, wo):
        """``(..., 2)``: Mitsuba's (P_s, P_d) normalised; 0 for wo.z <= 0 (nothing is sampled)."""
        wo = dirs(wo, wo)[0]
        c = wo[..., 2]
        t = self._T(c)
        ws = self.specular_sampling_weight
        ps, pd = (1.0 - t) * ws, t * (1.0 - ws)
        total = ps + pd
        ok = (c > 0) & (total > 0)
        tt = np.where(ok, total, 1.0)
        return np.stack([np.where(ok, ps / tt, 0.0), np.where(ok, pd / tt, 0.0)], -1)

    def lobe(self, name, wo):
        self._check_lobe(name)
        if name == "diffuse":
            return self._cosine
        return MicrofacetReflection(self, dirs(wo, wo)[0])

    def _repr_fields(self):
        return {**self._roughness_fields(), "int_ior": self.int_ior, "ext_ior": self.ext_ior,
                "diffuse_reflectance": plain(self.diffuse_reflectance),
                "specular_reflectance": plain(self.specular_reflectance), "nonlinear": self.nonlinear}
