"""``spot`` (Mitsuba 3): a point light at the origin of ``to_world`` shining along its local +z,
``intensity`` I (default 1), ``cutoff_angle`` (degrees, default 20) and ``beam_width``
(default 3/4 of the cutoff).  With theta the angle between the local +z and the direction
from the light to p, the contribution is I f(theta) / d^2, f = 1 inside the beam, the linear
ramp (cutoff - theta) / (cutoff - beam_width) between beam and cutoff, 0 beyond (Mitsuba 3
``SpotLight::falloff_curve``), times an optional projected ``texture`` looked up at
uv = (1/2 + x / (2 z tan(cutoff)), 1/2 + y / (2 z tan(cutoff))) of that local direction
(Mitsuba's ``direction_to_uv``).  A delta light (:mod:`.base`)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ..._vec import matvec3
from ..registry import register
from ..scene_checks import matrix4, rgb
from .base import weight_param
from .point import DeltaPositionLight, delta_towards

__all__ = ["SpotLight"]


@register("emitter", "spot")
class SpotLight(DeltaPositionLight):
    """``SpotLight(to_world=None, intensity=1, cutoff_angle=20, beam_width=None, sampling_weight=1)``."""

    def __init__(self, *, to_world: Any = None, intensity: Any = 1.0, cutoff_angle: float = 20.0,
                 beam_width: float | None = None, texture: Any = None, sampling_weight: float = 1.0):
        from ..textures import Texture

        if texture is not None and not isinstance(texture, Texture):
            raise TypeError(f"texture must be a texture element, got {checks.describe(texture)}")
        self.texture = texture
        m = matrix4(np.eye(4) if to_world is None else to_world, "to_world")
        if abs(np.linalg.det(m[:3, :3])) < 1e-300:
            raise ValueError("to_world is singular")
        self.to_world = m
        self.intensity = rgb(intensity, "intensity")
        self.cutoff_angle = checks.real(cutoff_angle, "cutoff_angle", low=0, high=180, low_open=True)
        bw = 0.75 * self.cutoff_angle if beam_width is None else beam_width
        self.beam_width = checks.real(bw, "beam_width", low=0, high=self.cutoff_angle)
        self.sampling_weight = weight_param(sampling_weight)
        self._inv = np.linalg.inv(m[:3, :3])
        self._cut, self._beam = np.deg2rad(self.cutoff_angle), np.deg2rad(self.beam_width)

    @classmethod
    def from_props(cls, p) -> "SpotLight":
        kw = {"beam_width": p.float("beam_width")} if p.has("beam_width") else {}
        tex = p.object("texture", ("texture",))
        return cls(to_world=p.transform("to_world"), intensity=p.color("intensity", 1.0, kind="emission"),
                   cutoff_angle=p.float("cutoff_angle", 20.0), sampling_weight=p.float("sampling_weight", 1.0),
                   texture=tex, **kw)

    @property
    def position(self) -> np.ndarray:
        return self.to_world[:3, 3]

    def falloff(self, d_local: np.ndarray) -> np.ndarray:
        """f(theta) of local directions (not necessarily unit) from the light."""
        d = d_local / np.maximum(np.linalg.norm(d_local, axis=-1, keepdims=True), 1e-300)
        cos = d[..., 2]
        ramp = (self._cut - np.arccos(np.clip(cos, -1.0, 1.0))) / max(self._cut - self._beam, 1e-300)
        inner = np.where(cos >= np.cos(self._beam), 1.0, ramp)
        return np.where(cos > np.cos(self._cut), inner, 0.0)

    def radiance(self, ref, w):
        w, dist = delta_towards(ref, self.position)
        local = matvec3(self._inv, -np.asarray(w, float))
        out = self.intensity[None, :] * (self.falloff(local) / np.maximum(dist * dist, 1e-30))[:, None]
        if self.texture is not None:
            from ..textures import SurfacePoints

            z = np.where(local[:, 2] > 0, local[:, 2], 1.0) * np.tan(self._cut)
            uv = np.stack([0.5 + 0.5 * local[:, 0] / z, 0.5 + 0.5 * local[:, 1] / z], -1)
            out = out * self.texture.eval(SurfacePoints(uv))
        return out

    def emission_cone(self) -> tuple | None:
        """pbrt-v4's spot bounds: the axis w = to_world (0, 0, 1), theta_o = beam_width, theta_e =
        cutoff - beam_width (+1e-6 rad against rounding: the light BVH must never give 0 where
        the falloff is positive).  None (every direction) when to_world is not a rotation times
        a uniform scale: the world-space cone is then not circular."""
        m = self.to_world[:3, :3]
        gram = m.T @ m
        if not np.allclose(gram, gram[0, 0] * np.eye(3), rtol=1e-9, atol=1e-12 * gram[0, 0]):
            return None
        w = m[:, 2] / np.linalg.norm(m[:, 2])
        return w, float(np.cos(self._beam)), float(np.cos(min(self._cut - self._beam + 1e-6, np.pi)))

    def power(self, radius: float) -> float:
        # the cone's solid angle out to the middle of the ramp
        half = 0.5 * (self._cut + self._beam)
        return float(2 * np.pi * (1 - np.cos(half)) * self.intensity.mean())
