"""``twosided`` (Mitsuba 3): a one-sided BSDF made to reflect alike on both sides of a surface.

Mitsuba evaluates the nested BSDF with both directions mirrored to the front side when
the surface is seen from the back (wo.z < 0): f_2(wo, wi) = f(s wo, s wi) with s the
sign of wo.z.  The renderer does the same by turning the shading normal towards the
viewer, which is what ``twosided = True`` asks of it; in the local frame of that normal
this element is the nested BSDF itself.  A second nested BSDF for the back side is not
supported (refused, naming it).
"""
from __future__ import annotations

from ... import checks
from ..registry import register
from .base import BSDFModel

__all__ = ["TwoSided"]


@register("bsdf", "twosided")
class TwoSided(BSDFModel):
    """``TwoSided(bsdf)``: the one-sided ``bsdf`` on both sides (see the module docstring)."""

    twosided = True

    def __init__(self, bsdf: BSDFModel):
        if not isinstance(bsdf, BSDFModel):
            raise TypeError(f"bsdf must be a vrlab.render BSDF element, got {checks.describe(bsdf)}")
        if bsdf.twosided:
            raise ValueError("bsdf: nested twosided BSDFs are not supported")
        self.inner = bsdf

    @classmethod
    def from_props(cls, p) -> "TwoSided":
        inner = p.children("bsdf")
        if len(inner) != 1:
            raise ValueError("bsdf: twosided needs exactly one nested <bsdf> or <ref> (a different back-side "
                             f"BSDF is not supported), got {len(inner)}")
        return cls(inner[0])

    def f(self, wo, wi):
        return self.inner.f(wo, wi)

    def pdf(self, wo, wi):
        return self.inner.pdf(wo, wi)

    def _sample_direction(self, wo, u):
        return self.inner._sample_direction(wo, u)

    def eval(self, wo, wi):
        return self.inner.eval(wo, wi)

    def distribution(self, wo):
        return self.inner.distribution(wo)

    def sample(self, wo, u):
        return self.inner.sample(wo, u)

    @property
    def needs_tangents(self) -> bool:
        return self.inner.needs_tangents

    @property
    def reciprocal(self) -> bool:
        return self.inner.reciprocal

    @property
    def dim_u(self) -> int:
        return int(self.inner.dim_u)

    @property
    def SCALAR_TEXTURES(self) -> tuple:  # noqa: N802
        return self.inner.SCALAR_TEXTURES

    @property
    def GRADIENT_TEXTURES(self) -> tuple:  # noqa: N802
        return self.inner.GRADIENT_TEXTURES

    @property
    def LOBES(self) -> tuple:  # noqa: N802 - the nested BSDF's class constant
        return self.inner.LOBES

    @property
    def DELTA(self) -> tuple:  # noqa: N802
        return self.inner.DELTA

    def lobe_probabilities(self, wo):
        return self.inner.lobe_probabilities(wo)

    def lobe(self, name, wo):
        return self.inner.lobe(name, wo)

    def delta_value(self, name, wo):
        return self.inner.delta_value(name, wo)

    def sample_lobe(self, wo, u):
        return self.inner.sample_lobe(wo, u)

    def diffuse_albedo(self):
        return self.inner.diffuse_albedo()

    def is_black(self) -> bool:
        return self.inner.is_black()

    def validate(self) -> None:
        self.inner.validate()

    @property
    def textures(self) -> dict:
        return self.inner.textures

    def at(self, values: dict) -> "TwoSided":
        return TwoSided(self.inner.at(values))

    def key(self) -> tuple:
        return (TwoSided,) + self.inner.key()

    def _repr_fields(self):
        return {"bsdf": self.inner}
