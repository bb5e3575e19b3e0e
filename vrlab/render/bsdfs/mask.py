"""``mask``: a BSDF made partly transparent by an opacity (Mitsuba 3 ``mask``).

With opacity a in [0, 1] (a number or a scalar texture, default 0.5, clamped to [0, 1]):

    f = a f_nested,   plus a null lobe: light passes straight through, wi = -wo, with weight 1 - a.

The null lobe is a delta lobe (one direction per wo), ``"null"``, the last of the lobes; its
integral of f |cos| over that direction is 1 - a.  Sampling follows Mitsuba: the lobe uniform
u0 < a picks the nested BSDF (u0 / a goes on), otherwise the null lobe, which has probability
1 - a (Mitsuba's ``pdf``), so a sample through it weighs (1 - a) / (1 - a) = 1.  Under the
``direct`` integrator this is what a mask does: an emitter behind the surface is seen through it
by BSDF sampling; shadow rays still stop at the surface, as Mitsuba's do.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ...distributions.base import as_points
from ...distributions.lobes import DeltaDirection, LobeMixture
from ..registry import register
from .base import BSDFModel, NestedTextures, check_lobe_mixture, dirs, scale

__all__ = ["Mask"]


def _opacity(value: Any):
    from ..textures import Texture

    if isinstance(value, Texture):
        return value
    a = checks.finite_array(value, "opacity")
    if a.ndim != 0:
        raise ValueError(f"opacity: expected a number or a texture, got an array of shape {a.shape}")
    return float(np.clip(a, 0.0, 1.0))


@register("bsdf", "mask")
class Mask(NestedTextures, BSDFModel):
    """``Mask(bsdf, opacity=0.5)`` (see the module docstring)."""

    TEXTURED = OWN_TEXTURES = OWN_SCALARS = ("opacity",)
    SIGNED_PARAMS = ("opacity",)     # clamped to [0, 1], as Mitsuba does

    def __init__(self, bsdf: BSDFModel, opacity: Any = 0.5):
        if not isinstance(bsdf, BSDFModel):
            raise TypeError(f"bsdf must be a vrlab.render BSDF element, got {checks.describe(bsdf)}")
        check_lobe_mixture(bsdf, "bsdf")
        self.inner = bsdf
        self.opacity = _opacity(opacity)

    @classmethod
    def from_props(cls, p) -> "Mask":
        inner = p.children("bsdf")
        if len(inner) != 1:
            raise ValueError(f"bsdf: mask needs exactly one nested BSDF, got {len(inner)}")
        return cls(inner[0], p.scalar("opacity", 0.5))

    def _a(self, shape: tuple) -> np.ndarray:
        return np.broadcast_to(np.clip(np.asarray(self.opacity, float), 0.0, 1.0), shape)

    # -- lobes: the nested ones, then "null" -----------------------------------------------
    @property
    def LOBES(self) -> tuple:  # noqa: N802
        return tuple(self.inner.LOBES) + ("null",)

    @property
    def DELTA(self) -> tuple:  # noqa: N802
        return tuple(self.inner.DELTA) + ("null",)

    @property
    def dim_u(self) -> int:
        return int(self.inner.dim_u)

    @property
    def reciprocal(self) -> bool:
        return self.inner.reciprocal

    @property
    def twosided(self) -> bool:
        """A mask around ``twosided``: the renderer shades both sides alike."""
        return self.inner.twosided

    @property
    def needs_tangents(self) -> bool:
        return self.inner.needs_tangents

    def lobe_probabilities(self, wo):
        wo = as_points(wo, 3, "wo")
        a = self._a(wo.shape[:-1])[..., None]
        return np.concatenate([a * self.inner.lobe_probabilities(wo), 1.0 - a], -1)

    def lobe(self, name, wo):
        self._check_lobe(name)
        if name == "null":
            return DeltaDirection(-as_points(wo, 3, "wo"))
        return self.inner.lobe(name, wo)

    def delta_value(self, name, wo):
        self._check_lobe(name)
        wo = as_points(wo, 3, "wo")
        if name == "null":
            return -wo, np.broadcast_to((1.0 - self._a(wo.shape[:-1]))[..., None], wo.shape).astype(wo.dtype)
        wi, value = self.inner.delta_value(name, wo)
        return wi, scale(value, self._a(np.shape(value)[:-1]))

    def distribution(self, wo):
        wo = as_points(wo, 3, "wo")
        return LobeMixture([self.lobe(name, wo) for name in self.LOBES], self.lobe_probabilities(wo))

    # -- values: the nested BSDF's, scaled by the opacity -----------------------------------
    def eval(self, wo, wi):
        wo, wi = dirs(wo, wi)
        v = self.inner.eval(wo, wi)
        return scale(v, self._a(v.shape[:-1])).astype(v.dtype, copy=False)

    def f(self, wo, wi):
        wo, wi = dirs(wo, wi)
        v = self.inner.f(wo, wi)
        return scale(v, self._a(v.shape[:-1])).astype(v.dtype, copy=False)

    def pdf(self, wo, wi):
        wo, wi = dirs(wo, wi)
        p = np.asarray(self.inner.pdf(wo, wi))
        return (p * self._a(p.shape)).astype(p.dtype, copy=False)

    def _sample_direction(self, wo, u):
        return self.distribution(wo).sample(u)

    def diffuse_albedo(self):
        if not isinstance(self.opacity, float):
            return np.zeros(3)
        return self.opacity * np.asarray(self.inner.diffuse_albedo(), float)

    def is_black(self) -> bool:
        return False                      # light passes through even where the nested BSDF is black

    # -- textures: the opacity's and the nested BSDF's (as "inner.<name>", NestedTextures) ------
    def at(self, values: dict) -> "Mask":
        out = Mask.__new__(Mask)
        out.inner = self.nested_at(values)
        out.opacity = np.clip(np.asarray(values["opacity"], float), 0.0, 1.0) if "opacity" in values \
            else self.opacity
        return out

    def key(self) -> tuple:
        return (Mask, repr(self.opacity) if isinstance(self.opacity, float) else id(self.opacity), self.inner.key())

    def validate(self) -> None:
        self.inner.validate()

    def _repr_fields(self):
        return {"bsdf": self.inner, "opacity": self.opacity}
