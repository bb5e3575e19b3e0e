"""``constant`` (Mitsuba 3): an environment of the same ``radiance`` L (default 1) in every
direction, at infinity.  Sampled uniformly on the sphere (``UniformSphere``, density
1 / (4 pi) in solid angle, as Mitsuba); rays that leave the scene see L."""
from __future__ import annotations

from typing import Any

import numpy as np

from ...distributions import UniformSphere
from ..registry import register
from ..scene_checks import rgb
from .base import Emitter, weight_param

__all__ = ["ConstantEnvironment"]


@register("emitter", "constant")
class ConstantEnvironment(Emitter):
    """``ConstantEnvironment(radiance=1, sampling_weight=1)``."""

    is_infinite = True

    def __init__(self, *, radiance: Any = 1.0, sampling_weight: float = 1.0):
        self.radiance_value = rgb(radiance, "radiance")
        self.sampling_weight = weight_param(sampling_weight)
        self._sphere = UniformSphere()

    @classmethod
    def from_props(cls, p) -> "ConstantEnvironment":
        return cls(radiance=p.color("radiance", 1.0, kind="emission"), sampling_weight=p.float("sampling_weight", 1.0))

    def sample(self, ref, u):
        w = np.asarray(self._sphere.sample(np.asarray(u, float)), ref.dtype)
        return w, np.full(len(ref), 1.0 / (4 * np.pi)), self.radiance(ref, w), np.full(len(ref), np.inf)

    def pdf(self, ref, w):
        return np.full(len(ref), 1.0 / (4 * np.pi))

    def radiance(self, ref, w):
        return np.broadcast_to(self.radiance_value, (len(w), 3)).copy()

    def power(self, radius: float) -> float:
        return float(4 * np.pi * np.pi * radius * radius * self.radiance_value.mean())
