"""``directional`` (Mitsuba 3): light from infinitely far away, travelling along ``direction``
(or the local +z of ``to_world``), with ``irradiance`` E (default 1) on a surface facing it.
It reaches every point from w = -direction, contribution E (a delta light, :mod:`.base`),
unless something lies anywhere along w."""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ..registry import register
from ..scene_checks import matrix4, rgb
from .base import Emitter, weight_param

__all__ = ["DirectionalLight"]


@register("emitter", "directional")
class DirectionalLight(Emitter):
    """``DirectionalLight(direction=(0, 0, 1), irradiance=1, sampling_weight=1)``."""

    is_delta = True
    is_infinite = True

    def __init__(self, *, direction: Any = (0.0, 0.0, 1.0), irradiance: Any = 1.0, sampling_weight: float = 1.0):
        d = checks.finite_array(direction, "direction").reshape(-1)
        if d.shape != (3,) or not np.linalg.norm(d) > 0:
            raise ValueError(f"direction must be 3 numbers, not all 0, got {direction!r}")
        self.direction = d / np.linalg.norm(d)
        self.irradiance = rgb(irradiance, "irradiance")
        self.sampling_weight = weight_param(sampling_weight)

    @classmethod
    def from_props(cls, p) -> "DirectionalLight":
        if p.has("direction") and p.has("to_world"):
            raise ValueError("direction: give either direction or to_world, not both")
        if p.has("to_world"):
            d = matrix4(p.transform("to_world"), "to_world")[:3, 2]
        else:
            d = p.vector("direction", (0, 0, 1))
        return cls(direction=d, irradiance=p.color("irradiance", 1.0, kind="emission"),
                   sampling_weight=p.float("sampling_weight", 1.0))

    def sample(self, ref, u):
        w = np.broadcast_to(-self.direction.astype(ref.dtype), ref.shape).copy()
        return w, np.ones(len(ref)), self.radiance(ref, w), np.full(len(ref), np.inf)

    def pdf(self, ref, w):
        return np.zeros(len(ref))

    def radiance(self, ref, w):
        return np.broadcast_to(self.irradiance, (len(ref), 3)).copy()

    def power(self, radius: float) -> float:
        return float(np.pi * radius * radius * self.irradiance.mean())
