"""``constvolume``: one value everywhere (Mitsuba 3 ``constvolume``, src/volumes/const.cpp).

``value`` (default 1): a number or an RGB colour (``<float>``, ``<rgb>`` or ``<spectrum>`` in
a scene file, converted as Mitsuba's RGB variants do for an unbounded value); ``eval`` is
the colour, ``eval_1`` the mean of its channels (Mitsuba evaluates the value as a constant
``srgb`` texture).  A ``<float>`` or ``<rgb>`` given where a volume is expected (the
``volume`` texture's ``volume``) becomes one, as Mitsuba's ``Properties::volume`` does.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..registry import register
from ..textures.base import ConstantTexture
from .base import Volume

__all__ = ["ConstVolume"]


@register("volume", "constvolume")
class ConstVolume(Volume):
    """``ConstVolume(value=1.0, to_world=None)`` (see the module docstring)."""

    def __init__(self, value: Any = 1.0, to_world: Any = None):
        super().__init__(to_world)
        self.value = ConstantTexture(value, name="value")

    @classmethod
    def from_props(cls, p) -> "ConstVolume":
        return cls(p.color("value", 1.0, kind="unbounded"), p.transform("to_world"))

    def eval(self, p: Any) -> np.ndarray:
        return np.broadcast_to(self.value.color, (len(self.local(p)), 3)).copy()

    def eval_1(self, p: Any) -> np.ndarray:
        return np.full(len(self.local(p)), self.value.mean_1())

    def mean(self) -> np.ndarray:
        return self.value.mean()

    def __repr__(self) -> str:
        return f"ConstVolume(value={self.value.color.tolist()})"
