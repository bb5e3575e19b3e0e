"""The base of integrator elements: what the renderer needs to know of the integrator a scene
names.  vrlab renders direct lighting (one bounce) with any estimator object; the
integrator element fixes the samples per shading point, whether surfaces are shaded at
all (``shading``: a path of one segment sees emitters only), and ``hide_emitters``."""
from __future__ import annotations

from ... import checks
from ..registry import Element
from ...limits import MAX_SAMPLES

__all__ = ["Integrator"]


class Integrator(Element):
    """``Integrator(emitter_samples=1, bsdf_samples=1, hide_emitters=False, shading=True)``.

    ``emitter_samples``, ``bsdf_samples``: integers in [0, ``limits.MAX_SAMPLES``], not both 0 when
    ``shading``; ``shading`` False: emitters seen directly only (a path of depth 1)."""

    kind = "integrator"

    def __init__(self, *, emitter_samples: int = 1, bsdf_samples: int = 1, hide_emitters: bool = False,
                 shading: bool = True):
        self.emitter_samples, self.bsdf_samples = emitter_samples, bsdf_samples
        self.hide_emitters, self.shading = hide_emitters, shading
        self.validate()

    @property
    def type(self) -> str:
        """The Mitsuba plugin name."""
        return self.plugin_name

    def validate(self) -> None:
        """Check the fields (ranges above)."""
        self.emitter_samples = checks.integer(self.emitter_samples, "emitter_samples", low=0, high=MAX_SAMPLES)
        self.bsdf_samples = checks.integer(self.bsdf_samples, "bsdf_samples", low=0, high=MAX_SAMPLES)
        self.hide_emitters = checks.flag(self.hide_emitters, "hide_emitters")
        self.shading = checks.flag(self.shading, "shading")
        if self.shading and self.emitter_samples + self.bsdf_samples == 0:
            raise ValueError("emitter_samples and bsdf_samples are both 0; at least one must be >= 1")

    def __repr__(self) -> str:
        return (f"{type(self).__name__}(emitter_samples={self.emitter_samples}, bsdf_samples={self.bsdf_samples}, "
                f"hide_emitters={self.hide_emitters}, shading={self.shading})")
