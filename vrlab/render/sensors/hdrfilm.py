"""``hdrfilm`` (Mitsuba 3): the image.  ``width``/``height`` (default 768 x 576), a crop window
``crop_offset_x/y``, ``crop_width``/``crop_height`` (default: the whole film), the
reconstruction filter (a nested ``<rfilter>``, default ``gaussian`` as in Mitsuba), and
output settings that vrlab reads but that do not change the image values:
``pixel_format`` (``rgb``, ``rgba``: vrlab outputs RGB), ``component_format``,
``file_format``, ``sample_border``, ``compensate``."""
from __future__ import annotations

import copy
from typing import Any

from ... import checks
from ..registry import register
from .base import Film, ReconstructionFilter, check_size

__all__ = ["HDRFilm"]

PIXEL_FORMATS = ("rgb", "rgba")
FILE_FORMATS = ("openexr", "exr", "rgbe", "pfm")
COMPONENT_FORMATS = ("float16", "float32", "uint32")


@register("film", "hdrfilm")
class HDRFilm(Film):
    """``HDRFilm(width=768, height=576, crop_offset_x=0, crop_offset_y=0, crop_width=None,
    crop_height=None, rfilter=None)`` (see the module docstring)."""

    def __init__(self, *, width: int = 768, height: int = 576, crop_offset_x: int = 0, crop_offset_y: int = 0,
                 crop_width: int | None = None, crop_height: int | None = None, rfilter: Any = None,
                 pixel_format: str = "rgb"):
        from ..registry import element_class

        self.width, self.height = width, height
        self.crop_offset_x, self.crop_offset_y = crop_offset_x, crop_offset_y
        self.crop_width = width - crop_offset_x if crop_width is None else crop_width
        self.crop_height = height - crop_offset_y if crop_height is None else crop_height
        self.rfilter = element_class("rfilter", "gaussian")() if rfilter is None else rfilter   # Mitsuba's default
        self.pixel_format = checks.choice(pixel_format, "pixel_format", PIXEL_FORMATS)
        self.validate()

    @classmethod
    def from_props(cls, p) -> "HDRFilm":
        p.string("file_format", "openexr", FILE_FORMATS)
        p.string("component_format", "float32", COMPONENT_FORMATS)
        p.bool("sample_border", False)
        p.bool("compensate", False)
        w, h = p.int("width", 768), p.int("height", 576)
        kw = {k: p.int(k, None) for k in ("crop_width", "crop_height") if p.has(k)}
        return cls(width=w, height=h, crop_offset_x=p.int("crop_offset_x", 0), crop_offset_y=p.int("crop_offset_y", 0),
                   rfilter=p.child("rfilter"), pixel_format=p.string("pixel_format", "rgb", PIXEL_FORMATS), **kw)

    def validate(self) -> None:
        self.width, self.height = check_size(self.width, self.height)
        self.crop_offset_x = checks.integer(self.crop_offset_x, "crop_offset_x", low=0, high=self.width - 1)
        self.crop_offset_y = checks.integer(self.crop_offset_y, "crop_offset_y", low=0, high=self.height - 1)
        self.crop_width = checks.integer(self.crop_width, "crop_width", low=1, high=self.width - self.crop_offset_x)
        self.crop_height = checks.integer(self.crop_height, "crop_height", low=1,
                                          high=self.height - self.crop_offset_y)
        if not isinstance(self.rfilter, ReconstructionFilter):
            raise TypeError(f"rfilter must be a vrlab.render rfilter element, got {checks.describe(self.rfilter)}")

    def resized(self, width: int, height: int) -> "HDRFilm":
        """A copy of ``width`` x ``height`` pixels without a crop window."""
        out = copy.copy(self)
        out.width, out.height = width, height
        out.crop_offset_x = out.crop_offset_y = 0
        out.crop_width, out.crop_height = width, height
        out.validate()
        return out

    def __repr__(self) -> str:
        return f"HDRFilm({self.width}x{self.height}, crop={self.crop_width}x{self.crop_height}, rfilter={self.rfilter!r})"
