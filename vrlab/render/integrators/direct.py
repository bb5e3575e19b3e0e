"""``direct`` (Mitsuba 3): direct lighting with ``emitter_samples`` light samples and
``bsdf_samples`` BSDF samples per shading point (both default to ``shading_samples``,
default 1), combined by MIS in Mitsuba (vrlab's default estimator ``"mis-power"`` does the
same; any estimator object may replace it), and ``hide_emitters`` (camera rays then pass
through emitting shapes and see what lies behind them, as in Mitsuba 3.9)."""
from __future__ import annotations

from ..registry import register
from .base import Integrator

__all__ = ["DirectIntegrator"]


@register("integrator", "direct")
class DirectIntegrator(Integrator):
    """Mitsuba's ``direct`` integrator (see the module docstring)."""

    @classmethod
    def from_props(cls, p) -> "DirectIntegrator":
        shading = p.int("shading_samples", 1)
        if shading < 0:
            raise ValueError(f"shading_samples must be >= 0, got {shading}")
        return cls(emitter_samples=p.int("emitter_samples", shading), bsdf_samples=p.int("bsdf_samples", shading),
                   hide_emitters=p.bool("hide_emitters", False))
