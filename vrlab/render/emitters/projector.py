"""``projector`` (Mitsuba 3): a delta light at the origin of ``to_world`` that projects the
image ``irradiance`` (a texture, or a constant colour: a 1 x 1 image) along its local +z,
with ``scale`` (default 1) and the field of view of a perspective camera of the image's
aspect ratio (``fov``/``fov_axis`` or ``focal_length``; default 50 mm).

A point p with local coordinates (x, y, z) = to_world^-1 p lies in the image at
uv = ((1 - x / (z tan_x)) / 2, (1 - y / (z tan_y)) / 2), tan_y = tan_x / aspect (the
perspective camera's mapping), and receives, when uv is in [0, 1]^2 and z > 0,

    E(uv) pi scale / (z^2 cos),   cos = n . (p - o) / |p - o|,  n = to_world (0, 0, 1),

so that the irradiance on the plane z = 1 facing the projector is E times pi (Mitsuba 3
``Projector::sample_direction``, dist^2 cos^3 = z^2 cos).  A delta light (:mod:`.base`)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ..._vec import matvec3
from ..registry import register
from ..scene_checks import matrix4, rgb
from .base import weight_param
from .point import DeltaPositionLight, delta_towards

__all__ = ["ProjectorLight"]


@register("emitter", "projector")
class ProjectorLight(DeltaPositionLight):
    """``ProjectorLight(irradiance=1, scale=1, fov=None, fov_axis="x", focal_length=None, to_world=None,
    sampling_weight=1)`` (see the module docstring)."""

    def __init__(self, *, irradiance: Any = 1.0, scale: float = 1.0, fov: float | None = None, fov_axis: str = "x",
                 focal_length: Any = None, to_world: Any = None, sampling_weight: float = 1.0):
        from ..sensors.perspective import FOV_AXES, focal_length_fov, fov_x
        from ..textures import Texture

        self.texture = irradiance if isinstance(irradiance, Texture) else None
        self.irradiance = None if self.texture is not None else rgb(irradiance, "irradiance")
        w, h = getattr(self.texture, "resolution", (1, 1)) if self.texture is not None else (1, 1)
        self.aspect = float(w) / float(h)
        self.scale = checks.real(scale, "scale", low=0)
        if fov is not None and focal_length is not None:
            raise ValueError("fov: give either fov or focal_length, not both")
        checks.choice(fov_axis, "fov_axis", FOV_AXES)      # checked also where a focal length overrides it
        if fov is None:
            fov, fov_axis = focal_length_fov("50mm" if focal_length is None else focal_length), "diagonal"
        fov = checks.real(fov, "fov", low=0, high=180, low_open=True, high_open=True)
        self.tan_x = float(np.tan(np.deg2rad(fov_x(fov, fov_axis, self.aspect)) / 2))
        self.tan_y = self.tan_x / self.aspect
        m = matrix4(np.eye(4) if to_world is None else to_world, "to_world")
        if abs(np.linalg.det(m[:3, :3])) < 1e-300:
            raise ValueError("to_world is singular")
        self.to_world, self._inv = m, np.linalg.inv(m[:3, :3])
        self.sampling_weight = weight_param(sampling_weight)

    @classmethod
    def from_props(cls, p) -> "ProjectorLight":
        kw = {}
        if p.has("fov"):
            kw["fov"] = p.float("fov")
        if p.has("focal_length"):
            kw["focal_length"] = p.string("focal_length")
        return cls(irradiance=p.texture("irradiance", kind="emission"), scale=p.float("scale", 1.0),
                   fov_axis=p.string("fov_axis", "x"), to_world=p.transform("to_world"),
                   sampling_weight=p.float("sampling_weight", 1.0), **kw)

    @property
    def position(self) -> np.ndarray:
        return self.to_world[:3, 3]

    def radiance(self, ref, w):
        from ..textures import SurfacePoints

        w, dist = delta_towards(ref, self.position)
        local = matvec3(self._inv, np.asarray(ref, float) - self.position)
        z = local[:, 2]
        zs = np.where(z > 0, z, 1.0)
        uv = np.stack([0.5 - 0.5 * local[:, 0] / (zs * self.tan_x), 0.5 - 0.5 * local[:, 1] / (zs * self.tan_y)], -1)
        inside = (z > 0) & np.all((uv >= 0) & (uv <= 1), axis=-1)
        e = (self.texture.eval(SurfacePoints(np.clip(uv, 0.0, 1.0))) if self.texture is not None
             else np.broadcast_to(self.irradiance, (len(ref), 3)))
        cos = -(np.asarray(w, float) @ self.to_world[:3, 2])
        ok = inside & (cos > 0)
        factor = np.where(ok, np.pi * self.scale / np.where(ok, z * z * cos, 1.0), 0.0)
        return np.asarray(e, float) * factor[:, None]

    def power(self, radius: float) -> float:
        mean = self.irradiance.mean() if self.texture is None else float(np.mean(self.texture.mean()))
        return float(np.pi * self.scale * mean * 4 * self.tan_x * self.tan_y)
