"""``point`` (Mitsuba 3): an isotropic point light at ``position`` (or the translation of
``to_world``) of ``intensity`` I (W/sr; default 1, an emission spectrum or rgb).  It reaches p
from one direction, w = (position - p) / d, with radiance-like contribution I / d^2 (a delta
light: see :mod:`.base`)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ..._vec import norm, scale
from ..registry import register
from ..scene_checks import matrix4, rgb
from .base import Emitter, weight_param

__all__ = ["DeltaPositionLight", "PointLight", "delta_towards"]


def delta_towards(ref: np.ndarray, position: np.ndarray):
    """``(w, dist)``: unit directions from ``ref (m, 3)`` to ``position (3,)`` and distances."""
    v = position.astype(ref.dtype) - ref
    dist = norm(v)
    return scale(v, 1.0 / np.where(dist > 0, dist, 1.0)), dist


class DeltaPositionLight(Emitter):
    """A light at one point (``position``): it reaches p only along w = (position - p) / d,
    density 1 in the counting measure, and arrives with ``radiance(ref, w)``."""

    is_delta = True

    def sample(self, ref, u):
        w, dist = delta_towards(ref, self.position)
        return w, np.ones(len(ref)), self.radiance(ref, w), dist

    def pdf(self, ref, w):
        return np.zeros(len(ref))

    def light_bounds(self) -> tuple:
        """Its position (a box of size 0) and its ``emission_cone`` (every direction if None)."""
        pos = np.asarray(self.position, float)
        cone = self.emission_cone()
        return (pos, pos, np.array([0.0, 0.0, 1.0]), -1.0, 0.0) if cone is None else (pos, pos, *cone)


@register("emitter", "point")
class PointLight(DeltaPositionLight):
    """``PointLight(position=(0, 0, 0), intensity=1, sampling_weight=1)``."""

    def __init__(self, *, position: Any = (0.0, 0.0, 0.0), intensity: Any = 1.0, sampling_weight: float = 1.0):
        p = checks.finite_array(position, "position").reshape(-1)
        if p.shape != (3,):
            raise ValueError(f"position must be 3 numbers, got {position!r}")
        self.position = p.astype(float)
        self.intensity = rgb(intensity, "intensity")
        self.sampling_weight = weight_param(sampling_weight)

    @classmethod
    def from_props(cls, p) -> "PointLight":
        if p.has("position") and p.has("to_world"):
            raise ValueError("position: give either position or to_world, not both")
        pos = p.point("position", (0, 0, 0)) if not p.has("to_world") else matrix4(p.transform("to_world"), "to_world")[:3, 3]
        return cls(position=pos, intensity=p.color("intensity", 1.0, kind="emission"),
                   sampling_weight=p.float("sampling_weight", 1.0))

    def radiance(self, ref, w):
        _, dist = delta_towards(ref, self.position)
        return self.intensity[None, :] / np.maximum(dist * dist, 1e-30)[:, None]

    def power(self, radius: float) -> float:
        return float(4 * np.pi * self.intensity.mean())
