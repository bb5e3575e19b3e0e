"""Mitsuba 3 ``perspective`` camera: film positions -> world rays.

Conventions (Mitsuba 3; see :mod:`vrlab.render.transforms`):

* the camera looks along its local +z with +y up; ``to_world`` (e.g. ``look_at``, whose
  columns are ``(left, up, dir, origin)``) maps local to world;
* images are ``(H, W, 3)`` arrays indexed ``[row, column]``, row 0 at the top (local +y)
  and **column 0 at the left edge, which is local +x** (the look_at ``left`` vector):
  the image x axis grows towards local -x;
* a film position ``(x, y)`` is in pixel units, x in [0, W) along columns and y in
  [0, H) along rows; pixel ``(i, j)`` covers ``[j, j+1) x [i, i+1)``.  The box filter
  of width one pixel means a pixel's value is the mean over positions uniform in it;
* the local direction of ``(x, y)`` is ``((1 - 2x/W) tan(fov_x/2), (1 - 2y/H)
  tan(fov_y/2), 1)``, with ``fov_x``/``fov_y`` from :class:`~vrlab.render.Sensor`
  (``fov`` along ``fov_axis``, tan(fov_y/2) = tan(fov_x/2) / aspect).

``Camera(sensor)`` checks that ``sensor`` is a :class:`~vrlab.render.Sensor` (whose
constructor checked its fields); the ray methods run per block and are not checked.
"""
from __future__ import annotations

import numpy as np

from .._vec import norm, scale
from .scene import Sensor

__all__ = ["Camera"]


class Camera:
    """Pinhole camera of a :class:`~vrlab.render.Sensor` (``width`` x ``height`` pixels)."""

    def __init__(self, sensor: Sensor):
        if not isinstance(sensor, Sensor):
            raise TypeError(f"sensor must be a vrlab.render.Sensor, got {type(sensor).__name__}")
        self.width, self.height = int(sensor.width), int(sensor.height)
        self.tan_x = float(np.tan(np.deg2rad(sensor.fov_x) / 2))
        self.tan_y = float(np.tan(np.deg2rad(sensor.fov_y) / 2))
        self.rotation = np.asarray(sensor.to_world, float)[:3, :3].copy()
        self.origin = np.asarray(sensor.to_world, float)[:3, 3].copy()

    def local_directions(self, film: np.ndarray, dtype=np.float64) -> np.ndarray:
        """Unnormalised local directions ``(..., 3)`` of film positions ``(..., 2)``."""
        film = np.asarray(film, dtype)
        x = (1.0 - 2.0 * film[..., 0] / self.width) * self.tan_x
        y = (1.0 - 2.0 * film[..., 1] / self.height) * self.tan_y
        return np.stack([x, y, np.ones_like(x)], -1)

    def rays(self, film: np.ndarray, dtype=np.float64) -> tuple[np.ndarray, np.ndarray]:
        """World ``(origins, unit directions)``, each ``(..., 3)`` of ``dtype`` (the renderer
        uses float32), of film positions ``(..., 2)``."""
        d = self.local_directions(film, dtype) @ self.rotation.T.astype(dtype)
        d = scale(d, 1.0 / norm(d))
        o = np.empty_like(d)
        o[...] = self.origin
        return o, d

    def pixel_rays(self, pixels: np.ndarray, u: np.ndarray, dtype=np.float64) -> tuple[np.ndarray, np.ndarray]:
        """Rays through pixels ``(..., 2)`` = ``(row, column)`` at sub-pixel uniforms ``u (..., 2)``
        (``u[..., 0]`` along the row, i.e. x; ``u[..., 1]`` down the column, i.e. y)."""
        pixels = np.asarray(pixels)
        film = np.stack([pixels[..., 1] + u[..., 0], pixels[..., 0] + u[..., 1]], -1)
        return self.rays(film, dtype)

    def pixel_centers(self) -> tuple[np.ndarray, np.ndarray]:
        """Rays ``(H, W, 3)`` through the pixel centres."""
        i, j = np.meshgrid(np.arange(self.height), np.arange(self.width), indexing="ij")
        return self.pixel_rays(np.stack([i, j], -1), np.full((self.height, self.width, 2), 0.5))
