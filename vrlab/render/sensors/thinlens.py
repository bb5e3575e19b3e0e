"""``thinlens`` (Mitsuba 3): a perspective camera with a thin lens, for depth of field.

The field of view is the perspective camera's (``fov``/``fov_axis`` or ``focal_length``).
A camera sample takes two more uniforms, for a point on the aperture: the disk of radius
``aperture_radius`` (required, >= 0; 0 is the pinhole) by the concentric map
(:class:`vrlab.distributions.Disk`, Shirley & Chiu 1997, as Mitsuba's
``square_to_uniform_disk_concentric``).  The ray from aperture point a = (a_x, a_y, 0) goes
through the point the pinhole ray of the same film position meets on the plane of focus,
z = ``focus_distance`` (default: ``far_clip``, as in Mitsuba):

    d = normalize(F (x, y, 1) - a),   o = a + (near_clip / d_z) d,

with (x, y, 1) the perspective camera's local direction.  Points on the plane of focus are
sharp; elsewhere a point spreads over a circle of confusion of radius
r |z - F| / z (in the plane of focus, scaled).  Every ray has weight 1, as in Mitsuba
(checked against its ``Sensor.sample_ray``).  ``to_world`` must be a rigid motion.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ..._vec import matvec3, norm, scale
from ...distributions import Disk
from ..registry import register
from .perspective import PerspectiveCamera

__all__ = ["ThinLensCamera"]


@register("sensor", "thinlens")
class ThinLensCamera(PerspectiveCamera):
    """``ThinLensCamera(aperture_radius, focus_distance=None, **perspective)`` (see the
    module docstring; ``focus_distance`` None: ``far_clip``)."""

    camera_dims = 4

    def __init__(self, *, aperture_radius: float, focus_distance: float | None = None, **perspective: Any):
        self.aperture_radius = checks.real(aperture_radius, "aperture_radius", low=0.0)
        super().__init__(**perspective)
        self.focus_distance = self.far_clip if focus_distance is None else \
            checks.real(focus_distance, "focus_distance", low=0.0, low_open=True)
        self.validate()

    @classmethod
    def from_props(cls, p) -> "ThinLensCamera":
        if not p.has("aperture_radius"):
            raise ValueError("aperture_radius: a thinlens sensor needs it (the radius of the aperture in scene "
                             "units; 0 is a pinhole)")
        return cls(aperture_radius=p.float("aperture_radius"), **cls.view(p), **cls.common(p))

    @property
    def aperture(self) -> Disk:
        """The aperture disk's warp (concentric map), in the lens plane."""
        return Disk(max(self.aperture_radius, 1e-300))

    def rays(self, film: np.ndarray, dtype=np.float64, lens: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`PerspectiveCamera.rays`, through aperture points of uniforms ``lens (...,
        2)`` (None: the lens centre, the pinhole rays)."""
        if lens is None or self.aperture_radius == 0:
            return super().rays(film, dtype)
        f = np.dtype(dtype).type
        s = (np.asarray(film, np.float64) / np.array([self.film.width, self.film.height], float)).astype(dtype)
        pin = self.local_rays(s)[1]                               # (x, y, 1)
        a = np.zeros(pin.shape, dtype)
        a[..., :2] = self.aperture.sample(np.asarray(lens, dtype))
        d = pin * f(self.focus_distance) - a
        d = scale(d, 1.0 / norm(d))
        o = a + scale(d, f(self.near_clip) / d[..., 2])
        m = self.to_world.astype(dtype)
        d = matvec3(m[:3, :3], d)
        o = matvec3(m[:3, :3], o)
        o += m[:3, 3]
        return o, scale(d, 1.0 / norm(d))
