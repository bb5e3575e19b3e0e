"""What the rough (microfacet) BSDFs share: roughness parameters, the normal distribution and
reflection sampling by visible or full normals.  Not a plugin (no ``@register``).

Roughness, as Mitsuba 3's ``roughconductor``/``roughplastic``/``roughdielectric`` read it:
``alpha`` (isotropic), or ``alpha_u`` and ``alpha_v`` (along the shading frame's s = dp/du and
t = n x s; the BSDF then asks the renderer for that frame, ``needs_tangents``); numbers or
textures (per-point values, clamped below at 1e-4 as Mitsuba clamps them).  ``distribution``:
``"beckmann"`` or ``"ggx"`` (:class:`~vrlab.distributions.Beckmann`,
:class:`~vrlab.distributions.GGX`).

Reflection sampling (Walter et al. 2007; Heitz & d'Eon 2014): a microfacet normal m is drawn
from the visible normals of wo (``sample_visible``, Mitsuba's default;
:class:`~vrlab.distributions.VisibleNormals`) or from D(m) cos theta_m, and wi = reflect(wo, m).
Reflection about m has the Jacobian 1 / (4 |wo . m|), so on the whole sphere

    p(wi) = p_m(h) / (4 |wo . h|),   h = normalize(wo + wi) turned to the upper hemisphere.

For visible normals p_m is the exact-Lambda density of the sampler (``VisibleNormals.pdf``:
for Beckmann it differs from Mitsuba's reported pdf, which uses a rational G1, by up to
0.35 %; vrlab divides by the density it samples).  A wo below the horizon is sampled as its
mirror image (x, y, |z|) (the BSDF is 0 there; sampler and pdf agree).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ..._vec import dot as vdot
from ..._vec import norm as vnorm
from ..._vec import scale, side
from ...distributions import GGX, Beckmann, VisibleNormals
from ...distributions.base import Distribution, as_points, as_uniforms
from .base import alpha_param, reflect, shape_of

__all__ = ["MicrofacetReflection", "RoughSurface", "half_vector"]

MIN_ALPHA = 1e-4          # Mitsuba clamps a textured roughness from below


def half_vector(wo: np.ndarray, wi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(h, ok)``: h = normalize(wo + wi) (``ok`` False where wo = -wi, h = +z there)."""
    h = wo + wi
    length = vnorm(h)
    ok = length > 0
    h = scale(h, 1.0 / np.where(ok, length, 1.0))
    if not ok.all():
        h = np.where(ok[..., None], h, np.array([0.0, 0.0, 1.0], h.dtype))
    return h, ok


class MicrofacetReflection(Distribution):
    """The reflection lobe of a rough BSDF for a fixed ``wo`` as a distribution (``dim_u = 2``):
    ``sample`` = :meth:`RoughSurface.sample_reflection`, ``pdf`` =
    :meth:`RoughSurface.reflection_pdf` (whole sphere)."""

    dim_u, dim_x, measure = 2, 3, "solid angle"

    def __init__(self, surface: "RoughSurface", wo: np.ndarray):
        self.surface, self.wo = surface, as_points(wo, 3, "wo")

    def sample(self, u):
        return self.surface.sample_reflection(self.wo, as_uniforms(u, 2))

    def pdf(self, w):
        return self.surface.reflection_pdf(self.wo, as_points(w, 3, "w"))

    def _repr_fields(self):
        return {"surface": self.surface, "wo_shape": self.wo.shape}


class RoughSurface:
    """Mixin of the rough BSDFs (see the module docstring).  Subclasses call
    :meth:`_init_roughness` in ``__init__`` and :meth:`roughness_props` in ``from_props``."""

    DISTRIBUTIONS = ("ggx", "beckmann")

    def _init_roughness(self, alpha: Any, alpha_u: Any, alpha_v: Any, distribution: str,
                        sample_visible: bool) -> None:
        from ..textures import Texture

        checks.choice(distribution, "distribution", self.DISTRIBUTIONS)
        self.distribution_type = distribution
        self.sample_visible = checks.flag(sample_visible, "sample_visible")
        if (alpha_u is None) != (alpha_v is None):
            raise ValueError("alpha_u, alpha_v: an anisotropic roughness needs both alpha_u and alpha_v")
        if alpha_u is not None:
            if not isinstance(alpha, Texture):
                alpha_param(alpha)               # unused beside alpha_u, alpha_v, but never garbage
            self.alpha = None
            self.alpha_u, self.alpha_v = (v if isinstance(v, Texture) else alpha_param(v, name)
                                          for v, name in ((alpha_u, "alpha_u"), (alpha_v, "alpha_v")))
        else:
            self.alpha = alpha if isinstance(alpha, Texture) else alpha_param(alpha)
            # a texture is looked up once, as ``alpha``; ``at`` then sets alpha_u = alpha_v = alpha
            self.alpha_u = self.alpha_v = None if isinstance(alpha, Texture) else self.alpha
        self.normals = self._make_normals(self.alpha_u, self.alpha_v)

    @classmethod
    def roughness_props(cls, p, default_distribution: str = "beckmann", default_alpha: float = 0.1) -> dict:
        """``alpha`` / ``alpha_u`` / ``alpha_v`` (numbers or textures), ``distribution`` and
        ``sample_visible`` of a scene element."""
        value = p.scalar
        out = {"distribution": p.string("distribution", default_distribution, cls.DISTRIBUTIONS),
               "sample_visible": p.bool("sample_visible", True)}
        if p.has("alpha_u") or p.has("alpha_v"):
            if p.has("alpha"):
                raise ValueError("alpha: give either alpha or alpha_u and alpha_v, not both")
            out.update(alpha_u=value("alpha_u", None), alpha_v=value("alpha_v", None))
        else:
            out["alpha"] = value("alpha", default_alpha)
        return out

    def _make_normals(self, au: Any, av: Any):
        """The normal distribution for roughness values (numbers or per-row arrays; None while
        a texture is not evaluated yet)."""
        if not isinstance(au, (float, np.ndarray)) or not isinstance(av, (float, np.ndarray)):
            return None
        cls = GGX if self.distribution_type == "ggx" else Beckmann
        if isinstance(au, float) and isinstance(av, float):
            return cls(au) if au == av else cls(alpha_u=au, alpha_v=av)
        normals = object.__new__(cls)            # per-row roughness: the formulas are elementwise
        normals.alpha_u, normals.alpha_v, normals.isotropic = au, av, au is av
        return normals

    @property
    def needs_tangents(self) -> bool:
        """An anisotropic roughness is oriented along dp/du."""
        return self.alpha is None

    def _roughness_at(self, out, values: dict) -> None:
        """Per-row roughness of a textured BSDF (``at``)."""
        changed = False
        for name in ("alpha", "alpha_u", "alpha_v"):
            if name in values:
                setattr(out, name, np.clip(np.asarray(values[name], float), MIN_ALPHA, None))
                changed = True
        if changed:
            if out.alpha is not None and "alpha" in values:
                out.alpha_u = out.alpha_v = out.alpha
            out.normals = out._make_normals(out.alpha_u, out.alpha_v)

    # -- reflection by microfacet normals ---------------------------------------------------
    def _upper(self, wo: np.ndarray) -> np.ndarray:
        return wo * np.where(wo[..., 2:3] < 0, np.array([1.0, 1.0, -1.0], wo.dtype), np.ones(3, wo.dtype))

    def normal_pdf(self, wo: np.ndarray, m: np.ndarray) -> np.ndarray:
        """The density of the sampled microfacet normals m (visible from wo, or D cos)."""
        if self.sample_visible:
            return VisibleNormals(self.normals, self._upper(wo)).pdf(m)
        return self.normals.pdf(m)

    def sample_normal(self, wo: np.ndarray, u: np.ndarray) -> np.ndarray:
        if self.sample_visible:
            wo_b = np.broadcast_to(self._upper(wo), shape_of(wo, u))
            return VisibleNormals(self.normals, wo_b).sample(u)
        return self.normals.sample(u)

    def reflection_pdf(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """p(wi) on the whole sphere of wi = reflect(wo, m), m from :meth:`sample_normal`."""
        h, ok = half_vector(wo, wi)
        h = scale(h, side(h[..., 2]))
        d = np.abs(vdot(wo, h))
        ok = ok & (d > 0)
        return np.where(ok, self.normal_pdf(wo, h) / (4.0 * np.where(ok, d, 1.0)), 0.0)

    def sample_reflection(self, wo: np.ndarray, u: np.ndarray) -> np.ndarray:
        return reflect(np.broadcast_to(wo, shape_of(wo, u)), self.sample_normal(wo, u))

    def _roughness_fields(self) -> dict:
        rough = {"alpha": self.alpha} if self.alpha is not None else {"alpha_u": self.alpha_u,
                                                                      "alpha_v": self.alpha_v}
        return {**rough, "distribution": self.distribution_type, "sample_visible": self.sample_visible}
