"""``rawconstant``: a constant value that is not read as a colour (Mitsuba 3 ``rawconstant``).

A ``<rgb>`` parameter becomes a colour (in Mitsuba's spectral variants it is upsampled to a
reflectance spectrum, and :mod:`vrlab.render.spectra` converts ``<spectrum>`` values as a
reflectance); ``rawconstant`` keeps its ``value`` as it is, which is what a constant normal
map (``normalmap`` reads c = (n + 1) / 2 per channel) or any other non-colour data needs.

* ``value``: a real number (``<float>``) or a 3-vector (``<vector>``/``<point>``); Mitsuba
  3.9.1 refuses an ``<rgb>`` here, and so does the scene reader.  Values may lie outside [0, 1]
  (raw data) but must be finite (Mitsuba would carry NaN through; vrlab refuses it, naming
  ``value``).
* ``eval`` = the value in every channel (a number is repeated: Mitsuba's ``eval_3``);
  ``eval_1`` = the number for a one-dimensional value and, as Mitsuba's, an error for a
  3-vector; ``mean`` = the value per channel and ``mean_1`` = the mean of the channels (what
  Mitsuba's ``Texture::mean()`` returns for both).  No uv gradient (Mitsuba's
  ``eval_1_grad`` is not implemented for it, so ``bumpmap`` cannot use it).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ..registry import register
from .base import Texture, surface_points

__all__ = ["RawConstant"]


@register("texture", "rawconstant")
class RawConstant(Texture):
    """``RawConstant(value)``: ``value`` a finite number or 3-vector (see the module docstring)."""

    is_constant = True

    def __init__(self, value: Any):
        if value is None:
            raise TypeError("value must be a number or a 3-vector, got None")
        v = checks.finite_array(value, "value")
        if v.ndim == 1 and v.shape == (1,):
            v = v.reshape(())
        if v.ndim != 0 and v.shape != (3,):
            raise ValueError(f"value must be a number or a 3-vector, got shape {v.shape}")
        self.value = v
        self.channels = 1 if v.ndim == 0 else 3

    @classmethod
    def from_props(cls, p) -> "RawConstant":
        el = p.element("value")
        if el is not None and el.tag in ("float", "integer"):
            return cls(p.float("value"))
        return cls(p.vector("value"))

    def validate(self) -> None:
        """Check ``value`` again after a change in place."""
        self.__init__(self.value)

    def eval(self, si: Any) -> np.ndarray:
        n = len(surface_points(si).uv)
        return np.broadcast_to(self.mean(), (n, 3)).copy()

    def eval_1(self, si: Any) -> np.ndarray:
        if self.channels != 1:
            raise ValueError("texture: eval_1 is not defined for a 3-vector rawconstant (as in Mitsuba); "
                             "give a <float> value for a scalar parameter")
        return np.full(len(surface_points(si).uv), float(self.value))

    def mean(self) -> np.ndarray:
        return np.broadcast_to(self.value, (3,)).astype(float)

    def mean_1(self) -> float:
        return float(self.mean().mean())

    def __repr__(self) -> str:
        return f"RawConstant(value={self.value.tolist()})"
