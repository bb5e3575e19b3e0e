"""``area`` (Mitsuba 3): a diffuse emitter on the surface of the shape that carries it,
radiance L_e(x, w) = ``radiance`` towards the side its normal faces (one-sided)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ..registry import register
from ..scene_checks import rgb
from .base import Emitter

__all__ = ["AreaEmitter"]


@register("emitter", "area")
class AreaEmitter(Emitter):
    """``AreaEmitter(radiance)``: one number or RGB, finite, >= 0 (stored as ``(3,)``)."""

    is_area = True

    def __init__(self, radiance: Any):
        self.radiance = rgb(radiance, "radiance")

    @classmethod
    def from_props(cls, p) -> "AreaEmitter":
        return cls(p.color("radiance", kind="emission"))

    def validate(self) -> None:
        self.radiance = rgb(self.radiance, "radiance")

    def __repr__(self) -> str:
        return f"AreaEmitter(radiance={np.asarray(self.radiance).tolist()})"
