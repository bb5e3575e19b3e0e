"""Mitsuba 3's reconstruction filters ``box``, ``tent`` and ``gaussian`` as warps of sub-pixel
offsets (see :mod:`.base`: a pixel sample's offset is drawn from the filter's normalised
density, so its expected value is the filter-weighted mean Mitsuba's film converges to).
The warps live in :mod:`vrlab.distributions.filters` with their chi-square tests.

* ``box``: w = 1 on [-1/2, 1/2] (radius 0.5): offsets uniform in the pixel;
* ``tent``: w(x) = max(0, 1 - |x| / r), ``radius`` r (default 1);
* ``gaussian``: w(x) = max(0, exp(-x^2 / (2 s^2)) - exp(-r^2 / (2 s^2))) on |x| <= r = 4 s,
  ``stddev`` s (default 0.5).

Filters with negative lobes (``mitchell``, ``catmullrom``, ``lanczos``) have no density to
sample and are refused by the loader (not registered).
"""
from __future__ import annotations

from functools import cached_property

from ... import checks
from ..registry import register
from .base import ReconstructionFilter

__all__ = ["BoxFilter", "GaussianFilter", "TentFilter"]


@register("rfilter", "box")
class BoxFilter(ReconstructionFilter):
    """``box`` (radius 1/2; Mitsuba reads no parameter)."""

    radius = 0.5

    @classmethod
    def from_props(cls, p) -> "BoxFilter":
        return cls()

    @cached_property
    def offsets(self):
        from ...distributions.filters import BoxFilter as Warp

        return Warp(0.5, discretized=False)        # the same filter; its inverse CDF is affine

    def sample_offsets(self, u):
        """The box's inverse CDF: offsets u - 1/2 (what ``offsets.sample`` computes, without its
        checks: the renderer's hot path)."""
        return u - 0.5

    def __repr__(self) -> str:
        return "BoxFilter()"


@register("rfilter", "tent")
class TentFilter(ReconstructionFilter):
    """``tent`` with ``radius`` (default 1, > 0)."""

    def __init__(self, radius: float = 1.0):
        self.radius = checks.real(radius, "radius", low=0, low_open=True, high=64)

    @classmethod
    def from_props(cls, p) -> "TentFilter":
        return cls(p.float("radius", 1.0))

    @cached_property
    def offsets(self):
        from ...distributions.filters import TentFilter as Warp

        return Warp(self.radius)

    def __repr__(self) -> str:
        return f"TentFilter(radius={self.radius})"


@register("rfilter", "gaussian")
class GaussianFilter(ReconstructionFilter):
    """``gaussian`` with ``stddev`` (default 0.5, > 0); radius 4 stddev."""

    def __init__(self, stddev: float = 0.5):
        self.stddev = checks.real(stddev, "stddev", low=0, low_open=True, high=16)
        self.radius = 4.0 * self.stddev

    @classmethod
    def from_props(cls, p) -> "GaussianFilter":
        return cls(p.float("stddev", 0.5))

    @cached_property
    def offsets(self):
        from ...distributions.filters import GaussianFilter as Warp

        return Warp(self.stddev)

    def __repr__(self) -> str:
        return f"GaussianFilter(stddev={self.stddev})"
