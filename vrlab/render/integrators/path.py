"""``path`` and ``volpath`` (Mitsuba 3) with ``max_depth`` 1 or 2: what such a path tracer
computes is what vrlab renders.  A path of depth 1 sees the emitters directly and shades
nothing; depth 2 adds one bounce, which is direct lighting (Mitsuba's path tracer then
takes one emitter sample and one BSDF sample per shading point, combined by MIS, as
vrlab's default estimator does).  A larger or infinite (-1, the default) depth is
global illumination, which vrlab does not render: refused, naming ``max_depth``.
``rr_depth`` is read and has no effect at these depths (Russian roulette starts later);
``volpath`` is accepted for scenes without participating media (vrlab has none)."""
from __future__ import annotations

from ..registry import register
from .base import Integrator

__all__ = ["PathIntegrator", "VolumetricPathIntegrator"]


@register("integrator", "path")
class PathIntegrator(Integrator):
    """``PathIntegrator(max_depth=2, hide_emitters=False)`` (see the module docstring)."""

    def __init__(self, *, max_depth: int = 2, hide_emitters: bool = False):
        if isinstance(max_depth, bool) or not isinstance(max_depth, int) or max_depth not in (1, 2):
            raise ValueError(f"max_depth={max_depth!r}: vrlab renders direct lighting only, i.e. paths of depth 1 "
                             "(emitters seen directly) or 2 (one bounce); use max_depth 2, or a <integrator "
                             "type=\"direct\">")
        self.max_depth = max_depth
        super().__init__(emitter_samples=1, bsdf_samples=1, hide_emitters=hide_emitters, shading=max_depth == 2)

    @classmethod
    def from_props(cls, p) -> "PathIntegrator":
        rr = p.int("rr_depth", 5)
        if rr < 1:
            raise ValueError(f"rr_depth must be >= 1, got {rr}")
        return cls(max_depth=p.int("max_depth", -1), hide_emitters=p.bool("hide_emitters", False))


@register("integrator", "volpath")
class VolumetricPathIntegrator(PathIntegrator):
    """``volpath`` without media: the same as ``path`` (see the module docstring)."""
