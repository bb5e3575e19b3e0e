"""``moment`` (Mitsuba 3): renders its nested integrator and also outputs the per-pixel second
moments, which Mitsuba's render tests use for their variance.  vrlab keeps per-pixel
moments in every render (the ``stderr`` of :func:`vrlab.render.render`), so it renders the
nested integrator: this element hands over its settings."""
from __future__ import annotations

from ..registry import register
from .base import Integrator

__all__ = ["MomentIntegrator"]


@register("integrator", "moment")
class MomentIntegrator(Integrator):
    """``MomentIntegrator(nested)``: the settings of ``nested`` (an integrator element)."""

    def __init__(self, nested: Integrator):
        if not isinstance(nested, Integrator):
            raise TypeError(f"nested must be a vrlab.render integrator element, got {type(nested).__name__}")
        self.nested = nested
        super().__init__(emitter_samples=nested.emitter_samples, bsdf_samples=nested.bsdf_samples,
                         hide_emitters=nested.hide_emitters, shading=nested.shading)

    @classmethod
    def from_props(cls, p) -> "MomentIntegrator":
        inner = p.children("integrator")
        if len(inner) != 1:
            raise ValueError(f"nested: a moment integrator needs exactly one nested <integrator>, got {len(inner)}")
        return cls(inner[0])
