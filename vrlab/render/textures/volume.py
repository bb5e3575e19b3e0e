"""``volume``: a 3D volume read at the surface point (Mitsuba 3 ``volume``, src/textures/volume.cpp).

The value at a surface point is the nested volume's value at the point's world position
(``si.p``; uv plays no part): ``eval`` is the volume's ``eval`` (RGB), ``eval_1`` its
``eval_1`` (one channel: the value; three: the luminance).  ``volume``: a volume element
(:mod:`vrlab.render.volumes`: ``gridvolume``, ``constvolume``), or a number or an RGB colour
(``<float>``/``<rgb>``/``<spectrum>`` in a scene file), which becomes a ``constvolume``, as
Mitsuba's documentation says (its default is 0.75; Mitsuba 3.9.1 itself refuses a colour
there, "expected object", and crashes without a volume: vrlab takes both).  The volume's
``to_world`` aligns it with the object.  The surface point must carry its position: a
``spot`` or ``projector`` texture (looked up by uv alone) cannot be a volume texture.

``mean`` is not defined by Mitsuba for this texture (its value depends on the surface); here
it is the volume's mean value (the mean of the grid's cells), which a light's power estimate
or a ``plastic``'s sampling weight reads.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..registry import element_class, register
from .base import Texture, surface_points

__all__ = ["VolumeTexture"]


@register("texture", "volume")
class VolumeTexture(Texture):
    """``VolumeTexture(volume=0.75)`` (see the module docstring)."""

    def __init__(self, volume: Any = 0.75):
        from ..volumes.base import Volume

        if not isinstance(volume, Volume):
            if getattr(volume, "kind", None) is not None:
                raise TypeError(f"volume must be a volume element, a number or an RGB colour, got a {volume.kind}")
            volume = element_class("volume", "constvolume")(volume)
        self.volume = volume

    @classmethod
    def from_props(cls, p) -> "VolumeTexture":
        given = p.element("volume")
        if given is not None and given.tag not in ("float", "integer", "rgb", "spectrum"):
            return cls(p.object("volume", ("volume",)))
        return cls(p.color("volume", 0.75, kind="unbounded"))

    def validate(self) -> None:
        self.volume.validate()

    def _p(self, si: Any) -> np.ndarray:
        si = surface_points(si)
        if si.p is None:
            raise ValueError("si.p: the volume texture needs the surface points' world positions (SurfacePoints.p)")
        return si.p

    def eval(self, si: Any) -> np.ndarray:
        """RGB ``(N, 3)``: the volume's value at ``si.p``."""
        return self.volume.eval(self._p(si))

    def eval_1(self, si: Any) -> np.ndarray:
        """``(N,)``: the volume's scalar value at ``si.p``."""
        return self.volume.eval_1(self._p(si))

    def mean(self) -> np.ndarray:
        """The volume's mean value ``(3,)`` (see the module docstring)."""
        return np.asarray(self.volume.mean(), float)

    def mean_1(self) -> float:
        """The luminance of :meth:`mean` for a grid, the channel mean for a constant."""
        from .base import LUMINANCE

        m = self.mean()
        const = element_class("volume", "constvolume")
        return float(m.mean()) if isinstance(self.volume, const) else float(m @ LUMINANCE)

    def __repr__(self) -> str:
        return f"VolumeTexture(volume={self.volume!r})"
