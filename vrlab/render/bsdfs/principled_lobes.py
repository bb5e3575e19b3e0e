"""What Mitsuba 3's ``principled`` and ``principledthin`` BSDFs share (src/bsdfs/principledhelpers.h):
their parameters, Fresnel approximations, the clearcoat's GTR1 normals and the lobes as
distributions of directions.  Not a plugin (no ``@register``).

Formulas (Burley 2012, "Physically Based Shading at Disney"; Burley 2015, "Extending the Disney
BRDF to a BSDF with Integrated Subsurface Scattering"; as Mitsuba 3 writes them):

* Schlick weight ``w(c) = clamp(1 - c, 0, 1)^5``; Schlick's Fresnel ``F = R0 + (1 - R0) w`` with
  ``w`` of |cos theta_i| where the relative index along the ray is > 1, else of the refracted
  cosine (:func:`schlick`); ``R0(eta) = ((eta - 1) / (eta + 1))^2``.
* tint colour ``base_color / Y(base_color)`` (1 where Y = 0), Y Mitsuba's RGB luminance
  0.212671 R + 0.715160 G + 0.072169 B.
* GGX roughness from ``roughness`` r and ``anisotropic`` a: aspect = sqrt(1 - 0.9 a),
  alpha_u = max(1e-3, r^2 / aspect), alpha_v = max(1e-3, r^2 aspect) (along dp/du, dp/dv).
* GTR1 (the clearcoat): D(m) = (alpha^2 - 1) / (pi log(alpha^2) (1 + (alpha^2 - 1) cos^2 theta_m)),
  sampled as D cos (cos^2 theta = (1 - alpha^2^(1 - u_y)) / (1 - alpha^2), phi = 2 pi u_x), no
  visible normals; its masking ``smith_ggx1`` is GGX's G1 with alpha = 0.25.

Lobes as distributions (solid angle, the **whole sphere**; ``wo`` may lie on either side, and the
microfacet lobes draw the normals visible from wo_up = sign(wo_z) wo, Mitsuba's
``mulsign(si.wi, cos_theta_i)``): :class:`MicrofacetReflection` (wi = reflect(wo, m), density
p_m(h) / (4 |wo.h|) with h = normalize(wo + wi) turned to z > 0), :class:`MicrofacetRefraction`
(wi = refract(wo, m) through the interface of relative index eta, or reflect(wo, m) at total
internal reflection; density p_m(h) eta_p^2 |wi.h| / (wo.h + eta_p wi.h)^2 with h =
normalize(wo + eta_p wi), eta_p = eta seen from outside, 1 / eta from inside),
:class:`ClearcoatReflection` (GTR1 normals), :class:`SidedCosine` (cos / pi on one side) and
:class:`Flipped` (a lobe mirrored through the surface: the thin sheet's transmission).
Their densities count every direction they produce, also those past the horizon, which
Mitsuba rejects (its pdf leaves them out; see the BSDFs' ``pdf_mitsuba``).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ...colour import LUMINANCE

from ... import checks
from ...distributions import GGX, CosineHemisphere, VisibleNormals
from ...distributions.base import Distribution, as_points, as_uniforms
from .base import reflect
from .fresnel import fresnel_dielectric, refract

__all__ = ["LUMA", "schlick_weight", "schlick", "schlick_r0", "tint", "ggx_alphas", "ggx", "GTR1",
           "smith_ggx1", "MicrofacetReflection", "MicrofacetRefraction", "ClearcoatReflection", "SidedCosine",
           "Flipped", "PrincipledParams", "unit", "up", "vdot", "weight_param", "texture_or"]

LUMA = LUMINANCE                                     # Mitsuba's luminance of linear sRGB (vrlab.colour)
Z = np.array([0.0, 0.0, 1.0])


def weight_param(value: Any, name: str, low: float = 0.0, high: float = 1.0):
    """A scalar parameter: a texture (returned as it is) or a real in [low, high]."""
    from ..textures import Texture

    if isinstance(value, Texture):
        return value
    return checks.real(value, name, low=low, high=high)


def texture_or(p, name: str, default: float):
    """A scalar parameter of a scene element: a nested ``<texture>`` or a ``<float>``."""
    return p.scalar(name, default)


def disney_diffuse(Fo, Fi, rough, cos_d, cos_sum, flatness=None) -> np.ndarray:
    """Burley's diffuse factor (2012, with retro-reflection): (1 - Fo/2)(1 - Fi/2) + R_r (Fo + Fi
    + Fo Fi (R_r - 1)), R_r = 2 roughness cos_d^2, Fo, Fi the Schlick weights of the two
    directions; with ``flatness`` blended towards Hanrahan-Krueger's subsurface
    approximation 1.25 (F_ss (1 / cos_sum - 1/2) + 1/2), F_ss = (1 + (R_r/2 - 1) Fo)(1 + (R_r/2 - 1) Fi)
    (Mitsuba 3's ``principled``/``principledthin``; ``cos_sum`` = |cos_o| + |cos_i|, not 0)."""
    Rr = 2.0 * rough * cos_d * cos_d
    diff = (1.0 - 0.5 * Fi) * (1.0 - 0.5 * Fo) + Rr * (Fo + Fi + Fo * Fi * (Rr - 1.0))
    if flatness is None:
        return diff
    Fss = (1.0 + (0.5 * Rr - 1.0) * Fo) * (1.0 + (0.5 * Rr - 1.0) * Fi)
    f_ss = 1.25 * (Fss * (1.0 / cos_sum - 0.5) + 0.5)
    return diff + flatness * (f_ss - diff)


# ------------------------------------------------------------------ elementwise helpers
def vdot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(v / |v|, ok)``; rows of length 0 become +z with ok False."""
    n = np.sqrt(vdot(v, v))
    ok = n > 0
    out = v / np.where(ok, n, 1.0)[..., None]
    return np.where(ok[..., None], out, Z), ok


def up(v: np.ndarray) -> np.ndarray:
    """``v`` turned to z >= 0 (Mitsuba's ``mulsign(v, v_z)``: the whole vector)."""
    return v * np.where(v[..., 2] < 0, -1.0, 1.0)[..., None]


def schlick_weight(c: Any) -> np.ndarray:
    m = np.clip(1.0 - np.asarray(c), 0.0, 1.0)
    m2 = m * m
    return m2 * m2 * m


def schlick_r0(eta: Any) -> np.ndarray:
    return ((eta - 1.0) / (eta + 1.0)) ** 2


def schlick(cos_i: np.ndarray, eta: Any) -> np.ndarray:
    """The weight w of Mitsuba's ``calc_schlick`` (F = R0 + (1 - R0) w): the Schlick weight of
    |cos_i| where the relative index along the ray eta_it is > 1, else of the refracted cosine."""
    eta = np.asarray(eta, float)
    eta_it = np.where(cos_i >= 0, eta, 1.0 / eta)
    cos_t = np.sqrt(np.clip(1.0 - (1.0 - cos_i * cos_i) / (eta_it * eta_it), 0.0, None))
    return np.where(eta_it > 1.0, schlick_weight(np.abs(cos_i)), schlick_weight(cos_t))


def tint(base_color: np.ndarray) -> np.ndarray:
    """``base_color / Y`` (1 where the luminance Y is 0)."""
    lum = np.asarray(base_color) @ LUMA
    ok = lum > 0
    return np.where(ok[..., None], base_color / np.where(ok, lum, 1.0)[..., None], 1.0)


def ggx_alphas(roughness: Any, anisotropic: Any) -> tuple[Any, Any]:
    r2 = np.asarray(roughness, float) ** 2
    aspect = np.sqrt(1.0 - 0.9 * np.asarray(anisotropic, float))
    au, av = np.maximum(1e-3, r2 / aspect), np.maximum(1e-3, r2 * aspect)
    return (float(au), float(av)) if au.ndim == 0 and av.ndim == 0 else (au, av)


def ggx(roughness: Any, anisotropic: Any) -> GGX:
    """The GGX normals of a roughness and anisotropy (numbers, or per-row arrays)."""
    au, av = ggx_alphas(roughness, anisotropic)
    if isinstance(au, float) and isinstance(av, float):
        return GGX(au) if au == av else GGX(alpha_u=au, alpha_v=av)
    normals = object.__new__(GGX)            # per-row roughness: the formulas are elementwise
    normals.alpha_u, normals.alpha_v, normals.isotropic = np.asarray(au), np.asarray(av), False
    return normals


def smith_ggx1(v: np.ndarray, m: np.ndarray, alpha: float) -> np.ndarray:
    """Mitsuba's ``smith_ggx1``: GGX's G1 of an isotropic alpha; 0 where (v.m) v_z <= 0."""
    c2 = v[..., 2] * v[..., 2]
    tan2 = np.where(c2 > 0, (1.0 - c2) / np.where(c2 > 0, c2, 1.0), np.inf)
    g = 2.0 / (1.0 + np.sqrt(1.0 + alpha * alpha * tan2))
    g = np.where(v[..., 2] == 1.0, 1.0, g)
    return np.where(vdot(v, m) * v[..., 2] <= 0, 0.0, g)


class GTR1:
    """Burley's GTR1 normal distribution (isotropic ``alpha``; numbers or per-row arrays)."""

    def __init__(self, alpha: Any):
        self.alpha = alpha

    def D(self, m: np.ndarray) -> np.ndarray:
        a2 = np.asarray(self.alpha, float) ** 2
        c = m[..., 2]
        d = (a2 - 1.0) / (np.pi * np.log(a2) * (1.0 + (a2 - 1.0) * c * c))
        return np.where(d * c > 1e-20, d, 0.0)

    def pdf(self, m: np.ndarray) -> np.ndarray:
        return np.where(m[..., 2] < 0, 0.0, m[..., 2] * self.D(m))

    def sample(self, u: np.ndarray) -> np.ndarray:
        a2 = np.asarray(self.alpha, float) ** 2
        c2 = (1.0 - a2 ** (1.0 - u[..., 1])) / (1.0 - a2)
        s, c = np.sqrt(np.clip(1.0 - c2, 0.0, None)), np.sqrt(np.clip(c2, 0.0, None))
        phi = 2.0 * np.pi * u[..., 0]
        return np.stack([np.cos(phi) * s, np.sin(phi) * s, c], -1)


# ------------------------------------------------------------------ lobes
class _Lobe(Distribution):
    dim_u, dim_x, measure = 2, 3, "solid angle"

    def __init__(self, wo: np.ndarray):
        self.wo = as_points(wo, 3, "wo")
        self.seen = self.wo[..., 2] != 0                   # Mitsuba ignores grazing wo (nothing sampled)
        self.wo_up = np.where(self.seen[..., None], up(self.wo), Z)

    def _wo(self, u: np.ndarray) -> np.ndarray:
        return np.broadcast_to(self.wo, np.broadcast_shapes(self.wo.shape[:-1], u.shape[:-1]) + (3,))

    def _repr_fields(self):
        return {"wo_shape": self.wo.shape}


class MicrofacetReflection(_Lobe):
    """wi = reflect(wo, m), m visible from wo_up (GGX ``normals``)."""

    def __init__(self, normals, wo):
        super().__init__(wo)
        self.normals, self.visible = normals, VisibleNormals(normals, self.wo_up)

    def sample_normal(self, u):
        u = as_uniforms(u, 2)
        return self.visible.sample(u)

    def sample(self, u):
        u = as_uniforms(u, 2)
        return reflect(self._wo(u), self.sample_normal(u))

    def normal_and_jacobian(self, w):
        """(h, |dh / dwi|): the normal that reflects wo to ``w``."""
        h, ok = unit(self.wo + w)
        h = up(h)
        d = np.abs(vdot(self.wo, h))
        ok = ok & (d > 0) & self.seen
        return h, np.where(ok, 0.25 / np.where(ok, d, 1.0), 0.0)

    def pdf(self, w):
        w = as_points(w, 3, "w")
        h, jac = self.normal_and_jacobian(w)
        return self.visible.pdf(h) * jac


class MicrofacetRefraction(_Lobe):
    """wi = refract(wo, m) (relative index ``eta`` = inside / outside), m visible from wo_up;
    reflect(wo, m) where m totally reflects."""

    def __init__(self, normals, wo, eta):
        super().__init__(wo)
        self.eta = eta
        self.eta_p = np.where(self.wo[..., 2] > 0, eta, 1.0 / np.asarray(eta, float))
        self.reflection = MicrofacetReflection(normals, self.wo)

    def sample(self, u):
        u = as_uniforms(u, 2)
        wo = self._wo(u)
        m = self.reflection.sample_normal(u)
        _, cos_t, _, eta_ti = fresnel_dielectric(vdot(wo, m), self.eta)
        return np.where((cos_t == 0)[..., None], reflect(wo, m), refract(wo, cos_t, eta_ti, m))

    def normal_and_jacobian(self, w):
        h, ok = unit(self.wo + self.eta_p[..., None] * w)
        h = up(h)
        a, b = vdot(self.wo, h), vdot(w, h)
        denom = a + self.eta_p * b
        ok = ok & (a * b < 0) & (denom != 0) & self.seen
        jac = self.eta_p ** 2 * np.abs(b) / np.where(ok, denom * denom, 1.0)
        return h, np.where(ok, jac, 0.0)

    def pdf(self, w):
        w = as_points(w, 3, "w")
        h, jac = self.normal_and_jacobian(w)
        p = self.reflection.visible.pdf(h) * jac
        hr, jr = self.reflection.normal_and_jacobian(w)
        tir = fresnel_dielectric(vdot(self.wo, hr), self.eta).cos_theta_t == 0
        return p + np.where(tir, self.reflection.visible.pdf(hr) * jr, 0.0)


class ClearcoatReflection(_Lobe):
    """wi = reflect(wo, m), m ~ GTR1(alpha) D cos (all normals, as Mitsuba)."""

    def __init__(self, alpha, wo):
        super().__init__(wo)
        self.gtr1 = GTR1(alpha)

    def sample(self, u):
        u = as_uniforms(u, 2)
        return reflect(self._wo(u), self.gtr1.sample(u))

    def pdf(self, w):
        w = as_points(w, 3, "w")
        h, ok = unit(self.wo + w)
        h = up(h)
        d = np.abs(vdot(self.wo, h))
        ok = ok & (d > 0) & self.seen
        return np.where(ok, self.gtr1.pdf(h) / (4.0 * np.where(ok, d, 1.0)), 0.0)


class SidedCosine(_Lobe):
    """cos / pi on the side ``side`` (+1 or -1 per row) of the surface: the cosine-weighted
    hemisphere's direction times ``side`` (the whole vector, as Mitsuba's ``mulsign``)."""

    def __init__(self, side, wo):
        super().__init__(wo)
        self.side = np.asarray(side, float)
        self._cos = CosineHemisphere()

    def sample(self, u):
        u = as_uniforms(u, 2)
        return self._cos.sample(u) * self.side[..., None]

    def pdf(self, w):
        w = as_points(w, 3, "w")
        z = w[..., 2] * self.side
        return np.where(self.seen & (z > 0), z / np.pi, 0.0)


class Flipped(Distribution):
    """``lobe`` mirrored through the surface: (x, y, z) -> (x, y, -z)."""

    dim_u, dim_x, measure = 2, 3, "solid angle"
    _F = np.array([1.0, 1.0, -1.0])

    def __init__(self, lobe: Distribution):
        self.lobe = lobe

    def sample(self, u):
        return np.asarray(self.lobe.sample(u)) * self._F

    def pdf(self, w):
        return self.lobe.pdf(as_points(w, 3, "w") * self._F)

    def _repr_fields(self):
        return {"lobe": self.lobe}


# ------------------------------------------------------------------ parameters
class PrincipledParams:
    """The parameters of both BSDFs: ``base_color`` (a colour or texture) and ``SCALARS``
    ``{name: (default, low, high)}``, each a number in [low, high] or a texture (per-row values
    after ``at``).  ``has[name]``: given as a texture or non-zero (Mitsuba's ``get_flag``: its
    lobe exists)."""

    SCALARS: dict = {}

    def _init_params(self, base_color: Any, values: dict) -> None:
        from ..textures import Texture
        from .base import color_param

        self.base_color = color_param(base_color, "base_color")
        for name, (_, low, high) in self.SCALARS.items():
            setattr(self, name, weight_param(values[name], name, low, high))
        self.has = {name: isinstance(getattr(self, name), Texture) or getattr(self, name) != 0
                    for name in self.SCALARS}

    @classmethod
    def _scalar_props(cls, p) -> dict:
        return {name: texture_or(p, name, default) for name, (default, _, _) in cls.SCALARS.items()}

    def v(self, name: str):
        """Parameter ``name``'s value (a number, or per-row values of a textured one)."""
        from ..textures import Texture

        value = getattr(self, name)
        if isinstance(value, Texture):
            raise ValueError(f"{name}: a textured parameter has values only at points: use the BSDF's at()")
        return value

    @property
    def needs_tangents(self) -> bool:
        """An anisotropic roughness is oriented along dp/du."""
        return bool(self.has["anisotropic"])

    @property
    def reciprocal(self) -> bool:
        """Without specular transmission (which Mitsuba 3 scales by 1 / eta^2, and the thin model
        evaluates with a roughness of its own), the lobes are reciprocal."""
        return not self.has["spec_trans"]

    def _param_fields(self) -> dict:
        from .base import plain

        return {"base_color": plain(self.base_color), **{k: plain(getattr(self, k)) for k in self.SCALARS}}
