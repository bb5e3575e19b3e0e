"""``perspective`` (Mitsuba 3): a pinhole camera.

The field of view is ``fov`` (degrees, along ``fov_axis``: ``x`` (default), ``y``,
``diagonal``, ``smaller`` or ``larger``) or ``focal_length`` (35 mm film equivalent,
e.g. ``"50mm"``: fov = 2 atan(sqrt(36^2 + 24^2) / (2 f)) along the diagonal); with
neither, Mitsuba's 50 mm.  A normalised film position s (shifted by
``principal_point_offset_x/y``, in units of the film) has the local direction

    ((1 - 2 s_x) tan(fov_x / 2), (1 - 2 s_y) tan(fov_x / 2) / aspect, 1),

and its ray starts on the near plane (z = ``near_clip``), as in Mitsuba 3 (checked
against its ``Sensor.sample_ray``).  ``to_world`` must be a rigid motion.
"""
from __future__ import annotations

import re
from typing import Any

import numpy as np

from ... import checks
from ..._vec import norm, scale
from ..registry import register
from ..scene_checks import rigid
from .base import Sensor

__all__ = ["PerspectiveCamera", "fov_x"]

FOV_AXES = ("x", "y", "diagonal", "smaller", "larger")


def fov_x(fov: float, axis: str, aspect: float) -> float:
    """Horizontal field of view (degrees) of ``fov`` along ``axis`` (Mitsuba's ``parse_fov``)."""
    if axis == "smaller":
        axis = "y" if aspect > 1 else "x"
    elif axis == "larger":
        axis = "x" if aspect > 1 else "y"
    if axis == "x":
        return fov
    if axis == "y":
        return float(np.rad2deg(2 * np.arctan(np.tan(np.deg2rad(fov) / 2) * aspect)))
    diag = 2 * np.tan(np.deg2rad(fov) / 2)
    width = diag / np.sqrt(1 + 1 / aspect**2)
    return float(np.rad2deg(2 * np.arctan(width / 2)))


def focal_length_fov(text: Any) -> float:
    """The diagonal field of view of a 35 mm equivalent ``focal_length`` ("50mm" or 50)."""
    m = re.fullmatch(r"\s*([0-9.eE+-]+)\s*(mm)?\s*", str(text))
    f = None
    if m:
        try:
            f = float(m.group(1))
        except ValueError:
            f = None
    if f is None or not np.isfinite(f) or f <= 0:
        raise ValueError(f"focal_length: expected a length in mm such as '50mm', got {text!r}")
    return float(np.rad2deg(2 * np.arctan(np.hypot(36.0, 24.0) / (2 * f))))


@register("sensor", "perspective")
class PerspectiveCamera(Sensor):
    """``PerspectiveCamera(fov=None, fov_axis="x", focal_length=None, principal_point_offset_x=0,
    principal_point_offset_y=0, **sensor)`` (see the module docstring)."""

    def __init__(self, *, fov: float | None = None, fov_axis: str = "x", focal_length: Any = None,
                 principal_point_offset_x: float = 0.0, principal_point_offset_y: float = 0.0, **common):
        super().__init__(**common)
        if fov is not None and focal_length is not None:
            raise ValueError("fov: give either fov or focal_length, not both")
        if fov is None:
            fov, fov_axis = focal_length_fov("50mm" if focal_length is None else focal_length), "diagonal"
        self.fov = checks.real(fov, "fov", low=0, high=180, low_open=True, high_open=True)
        self.fov_axis = checks.choice(fov_axis, "fov_axis", FOV_AXES)
        self.principal_point_offset_x = checks.real(principal_point_offset_x, "principal_point_offset_x")
        self.principal_point_offset_y = checks.real(principal_point_offset_y, "principal_point_offset_y")
        self.validate()

    @classmethod
    def from_props(cls, p) -> "PerspectiveCamera":
        return cls(**cls.view(p), **cls.common(p))

    @staticmethod
    def view(p) -> dict:
        """The field-of-view parameters of a perspective sensor in a scene file."""
        fov = p.float("fov", None) if p.has("fov") else None
        focal = p.string("focal_length", None) if p.has("focal_length") else None
        return dict(fov=fov, fov_axis=p.string("fov_axis", "x", FOV_AXES), focal_length=focal,
                    principal_point_offset_x=p.float("principal_point_offset_x", 0.0),
                    principal_point_offset_y=p.float("principal_point_offset_y", 0.0))

    def validate(self) -> None:
        super().validate()
        rigid(self.to_world, "to_world")
        fx = self.fov_x
        if not 0 < fx < 180:                 # only by rounding, with a very wide image
            raise ValueError(f"fov: the horizontal field of view {fx:g} must be in (0, 180)")

    @property
    def fov_x(self) -> float:
        """Horizontal field of view in degrees."""
        return fov_x(self.fov, self.fov_axis, self.aspect)

    @property
    def fov_y(self) -> float:
        """Vertical field of view in degrees."""
        return float(np.rad2deg(2 * np.arctan(np.tan(np.deg2rad(self.fov_x) / 2) / self.aspect)))

    def rays(self, film: np.ndarray, dtype=np.float64) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`Sensor.rays`, in ``dtype`` from the film positions on, with the local
        direction (x, y, 1) taken straight to the world, d = x R_0 + y R_1 + R_2 (elementwise:
        the same bits in every process), and the origin on the near plane, o = t + near d."""
        film = np.asarray(film)
        f = np.dtype(dtype).type
        tx = np.tan(np.deg2rad(self.fov_x) / 2)
        # (1 - 2 (x / W + ppx)) tan = a_x x + b_x, likewise for y with tan / aspect
        ax, bx = -2 * tx / self.film.width, (1 - 2 * self.principal_point_offset_x) * tx
        ty = tx / self.aspect
        ay, by = -2 * ty / self.film.height, (1 - 2 * self.principal_point_offset_y) * ty
        x = (film[..., 0] * ax + bx).astype(dtype)
        y = (film[..., 1] * ay + by).astype(dtype)
        m = self.to_world.astype(dtype)
        d = x[..., None] * m[:3, 0]
        d += y[..., None] * m[:3, 1]
        d += m[:3, 2]
        o = d * f(self.near_clip)
        o += m[:3, 3]
        d = scale(d, 1.0 / norm(d))
        return o, d

    def local_rays(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        t = np.tan(np.deg2rad(self.fov_x) / 2)
        one = s.dtype.type(1)
        x = (one - 2 * (s[..., 0] + s.dtype.type(self.principal_point_offset_x))) * s.dtype.type(t)
        y = (one - 2 * (s[..., 1] + s.dtype.type(self.principal_point_offset_y))) * s.dtype.type(t / self.aspect)
        d = np.stack([x, y, np.ones_like(x)], -1)
        return d * s.dtype.type(self.near_clip), d
