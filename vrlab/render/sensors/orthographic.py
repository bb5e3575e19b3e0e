"""``orthographic`` (Mitsuba 3): parallel rays along the local +z from the film rectangle
[-1, 1] x [-1/aspect, 1/aspect] in the plane z = ``near_clip`` (checked against Mitsuba
3's ``Sensor.sample_ray``): a normalised film position s starts at
((1 - 2 s_x), (1 - 2 s_y) / aspect, near_clip).  ``to_world`` may scale (it sets the
extent of the film in the world), as in Mitsuba."""
from __future__ import annotations

import numpy as np

from ..registry import register
from ..scene_checks import affine
from .base import Sensor

__all__ = ["OrthographicCamera"]


@register("sensor", "orthographic")
class OrthographicCamera(Sensor):
    """``OrthographicCamera(**sensor)`` (see the module docstring)."""

    def __init__(self, **common):
        super().__init__(**common)
        self.validate()

    @classmethod
    def from_props(cls, p) -> "OrthographicCamera":
        return cls(**cls.common(p))

    def validate(self) -> None:
        super().validate()
        affine(self.to_world, "to_world")

    def local_rays(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        f = s.dtype.type
        x = f(1) - 2 * s[..., 0]
        y = (f(1) - 2 * s[..., 1]) / f(self.aspect)
        o = np.stack([x, y, np.full_like(x, self.near_clip)], -1)
        d = np.zeros_like(o)
        d[..., 2] = 1.0
        return o, d
