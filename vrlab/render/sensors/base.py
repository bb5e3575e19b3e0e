"""The bases of the sensor, film, reconstruction-filter and sampler elements.

A sensor maps film positions to rays.  Conventions (Mitsuba 3): the camera looks along its
local +z with +y up; ``to_world`` (e.g. ``lookat``, whose columns are ``(left, up, dir,
origin)``) maps local to world; images are ``(H, W, 3)`` arrays indexed ``[row,
column]``, row 0 at the top (local +y) and column 0 at the left edge, which is local +x.
A film position ``(x, y)`` is in pixel units of the whole film, x in [0, W) along
columns and y in [0, H) along rows; its normalised position is ``s = (x, y) / (W, H)``.
A crop window (``crop_offset_*``, ``crop_width``/``crop_height`` of the film) renders
the pixels ``crop_offset + (column, row)`` of the film as an image of the crop's size.

Pixel (i, j) is the filter-weighted mean of the radiance around its centre: with the
film's reconstruction filter w (separable, radius r), E = int w(x - c) L(x) dx / int w.
The renderer draws the sub-pixel offset x - c from the filter's normalised density
(:meth:`ReconstructionFilter.offsets`, a warp of :mod:`vrlab.distributions`), so a
pixel sample's expected value is E exactly, as Mitsuba's splatting converges to.
"""
from __future__ import annotations

import copy
from typing import Any

import numpy as np

from ... import checks
from ..._vec import matvec3, norm, scale
from ..registry import Element
from ..scene_checks import MAX_PIXELS, MAX_SIDE, matrix4

__all__ = ["Film", "ReconstructionFilter", "Sampler", "Sensor"]


class ReconstructionFilter(Element):
    """Base of the ``rfilter`` elements: ``radius`` (pixels) and ``offsets``, the
    distribution of sub-pixel offsets ``(..., 2)`` with density w(x) w(y) / (int w)^2."""

    kind = "rfilter"
    radius = 0.5

    @property
    def offsets(self):  # pragma: no cover - every filter overrides it
        raise NotImplementedError

    def sample_offsets(self, u: np.ndarray) -> np.ndarray:
        """Sub-pixel offsets of uniforms ``u (..., 2)``: ``offsets.sample(u)``."""
        return self.offsets.sample(u)


class Sampler(Element):
    """Base of the ``sampler`` elements: ``sample_count`` (spp, >= 1), ``seed`` (>= 0; vrlab
    seeds with ``render(rng=...)``) and ``points``, the vrlab point set that plays its part
    (a name for :class:`vrlab.points.SetSampler`, or None for i.i.d. uniforms)."""

    kind = "sampler"
    points: str | None = None

    def __init__(self, *, sample_count: int = 4, seed: int = 0):
        self.sample_count = checks.integer(sample_count, "sample_count", low=1)
        self.seed = checks.integer(seed, "seed", low=0)

    @classmethod
    def from_props(cls, p) -> "Sampler":
        return cls(sample_count=p.int("sample_count", 4), seed=p.int("seed", 0))

    def __repr__(self) -> str:
        return f"{type(self).__name__}(sample_count={self.sample_count})"


class Film(Element):
    """Base of the ``film`` elements: ``width``, ``height``, the crop window and ``rfilter``."""

    kind = "film"


class Sensor(Element):
    """Base of the sensor elements: ``to_world``, ``film`` (default: Mitsuba's ``hdrfilm``,
    768 x 576 with a gaussian filter), ``sampler`` (default ``independent``, 4 spp),
    ``near_clip`` (default 0.01: rays start there), ``far_clip`` (1e4) and ``focus_distance``
    (default: ``far_clip``; any finite number).  As in Mitsuba 3, whose ``ProjectiveCamera``
    reads ``focus_distance`` for every projective sensor, a pinhole (``perspective``) or
    ``orthographic`` camera accepts it and ignores it; ``thinlens`` focuses there.
    Subclasses implement ``local_rays(s)`` for normalised film positions ``s (..., 2)``."""

    kind = "sensor"
    #: uniforms a camera sample takes: 2 for the sub-pixel offset, more for a lens (thinlens: 4)
    camera_dims = 2

    def __init__(self, *, to_world: Any = None, film: Any = None, sampler: Any = None,
                 near_clip: float = 1e-2, far_clip: float = 1e4, focus_distance: float | None = None,
                 id: str | None = None):
        from ..registry import element_class

        self.to_world = matrix4(np.eye(4) if to_world is None else to_world, "to_world")
        # Mitsuba's defaults, found through the registry (the elements' modules import this one)
        self.film = element_class("film", "hdrfilm")() if film is None else film
        self.sampler = element_class("sampler", "independent")() if sampler is None else sampler
        if not isinstance(self.film, Film):
            raise TypeError(f"film must be a vrlab.render film element, got {checks.describe(film)}")
        if not isinstance(self.sampler, Sampler):
            raise TypeError(f"sampler must be a vrlab.render sampler element, got {checks.describe(sampler)}")
        self.near_clip = checks.real(near_clip, "near_clip", low=0, low_open=True)
        self.far_clip = checks.real(far_clip, "far_clip", low=0, low_open=True)
        if not self.far_clip > self.near_clip:
            raise ValueError(f"far_clip must be > near_clip, got near_clip={self.near_clip:g}, "
                             f"far_clip={self.far_clip:g}")
        self.focus_distance = self.far_clip if focus_distance is None else checks.real(focus_distance,
                                                                                       "focus_distance")
        self.id = id

    @staticmethod
    def common(p) -> dict:
        """Parameters of every sensor in a scene file."""
        return dict(to_world=p.transform("to_world"), film=p.child("film"), sampler=p.child("sampler"),
                    near_clip=p.float("near_clip", 1e-2), far_clip=p.float("far_clip", 1e4),
                    focus_distance=p.float("focus_distance") if p.has("focus_distance") else None)

    @property
    def type(self) -> str:
        """The Mitsuba plugin name."""
        return self.plugin_name

    @property
    def width(self) -> int:
        """Image width: the crop window's."""
        return self.film.crop_width

    @property
    def height(self) -> int:
        """Image height: the crop window's."""
        return self.film.crop_height

    @property
    def spp(self) -> int:
        """Samples per pixel of the sensor's sampler."""
        return self.sampler.sample_count

    @property
    def rfilter(self) -> str:
        """The plugin name of the film's reconstruction filter."""
        return self.film.rfilter.plugin_name

    @property
    def aspect(self) -> float:
        """Aspect ratio of the whole film (width / height)."""
        return self.film.width / self.film.height

    @property
    def origin(self) -> np.ndarray:
        return self.to_world[:3, 3].copy()

    def with_size(self, width: int | None = None, height: int | None = None) -> "Sensor":
        """A copy whose film has this size (the crop window reset to the whole film)."""
        out = copy.copy(self)
        out.film = self.film.resized(self.film.width if width is None else width,
                                     self.film.height if height is None else height)
        out.validate()
        return out

    def validate(self) -> None:
        self.to_world = matrix4(self.to_world, "to_world")
        self.film.validate()

    # ------------------------------------------------------------------ rays
    def local_rays(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - abstract
        """Local ``(origins, directions)`` ``(..., 3)`` of normalised film positions ``s (..., 2)``."""
        raise NotImplementedError

    def rays(self, film: np.ndarray, dtype=np.float64) -> tuple[np.ndarray, np.ndarray]:
        """World ``(origins, unit directions)`` ``(..., 3)`` of film positions ``(..., 2)`` in
        pixel units of the whole film (column, row), computed in ``dtype`` from the normalised
        positions on (float32 for the renderer, as Mitsuba's scalar variants)."""
        s = (np.asarray(film, np.float64) / np.array([self.film.width, self.film.height], float)).astype(dtype)
        o, d = self.local_rays(s)
        m = self.to_world.astype(dtype)
        d = matvec3(m[:3, :3], d)
        d = scale(d, 1.0 / norm(d))
        o = matvec3(m[:3, :3], o)
        o += m[:3, 3]
        return o, d

    def pixel_rays(self, pixels: np.ndarray, u: np.ndarray, dtype=np.float64) -> tuple[np.ndarray, np.ndarray]:
        """Rays through image pixels ``(..., 2)`` = ``(row, column)`` at sub-pixel uniforms
        ``u (..., 2)`` (``u[..., 0]`` along the row, i.e. x), warped to offsets by the film's
        filter (the box filter: offsets u - 1/2, uniform in the pixel; wider filters cut at
        the film's edge).  A lens's uniforms follow (``u[..., 2:camera_dims]``; without
        them its rays leave from the lens centre)."""
        pixels = np.asarray(pixels)
        lens = u[..., 2:self.camera_dims] if self.camera_dims > 2 and np.shape(u)[-1] >= self.camera_dims else None
        u = u[..., :2]
        f = self.film
        if f.rfilter.radius > 0.5:
            # the image-plane samples stay on the (crop) film, so an edge pixel's filter is cut
            # there (Mitsuba's sample_border=false): offsets from the window [-c, size - c]
            centre = pixels[..., ::-1] + 0.5
            delta = f.rfilter.offsets.window(-centre, np.array([self.width, self.height], float) - centre).sample(
                np.asarray(u, np.float64))
        else:
            delta = f.rfilter.sample_offsets(np.asarray(u, np.float64))
        film = np.stack([pixels[..., 1] + (f.crop_offset_x + 0.5) + delta[..., 0],
                         pixels[..., 0] + (f.crop_offset_y + 0.5) + delta[..., 1]], -1)
        return self.rays(film, dtype) if lens is None else self.rays(film, dtype, lens)

    def pixel_centers(self) -> tuple[np.ndarray, np.ndarray]:
        """Rays ``(H, W, 3)`` through the pixel centres."""
        i, j = np.meshgrid(np.arange(self.height), np.arange(self.width), indexing="ij")
        film = np.stack([j + self.film.crop_offset_x + 0.5, i + self.film.crop_offset_y + 0.5], -1)
        return self.rays(film)


def check_size(width: Any, height: Any) -> tuple[int, int]:
    """Film ``width``, ``height`` in [1, MAX_SIDE], at most MAX_PIXELS pixels."""
    w = checks.integer(width, "width", low=1, high=MAX_SIDE)
    h = checks.integer(height, "height", low=1, high=MAX_SIDE)
    if w * h > MAX_PIXELS:
        raise ValueError(f"width x height = {w} x {h} exceeds {MAX_PIXELS} pixels (e.g. 8192 x 8192)")
    return w, h
