"""``checkerboard``: two colours in alternating unit-half cells of uv (Mitsuba 3
``checkerboard``, src/textures/checkerboard.cpp).

After ``to_uv`` (uv' = A uv + t, :func:`.base.uv_transform`), with fu = u' - floor(u') and
fv = v' - floor(v'): the point has ``color0`` where (fu > 1/2) == (fv > 1/2) (the cells
[0, 1/2]^2 and (1/2, 1)^2 of every unit square, boundaries included in the lower half) and
``color1`` elsewhere.  ``eval_1`` returns ``color0``'s ``eval_1`` in the *other* cells,
(fu > 1/2) != (fv > 1/2), and ``color1``'s in these: Mitsuba 3 (3.9.1) swaps the test
between its ``eval`` and ``eval_1``, and vrlab follows it so that scalar uses (a
roughness, an opacity) give Mitsuba's values.
``mean`` is (mean(color0) + mean(color1)) / 2 (and ``mean_1`` likewise), whatever
``to_uv``, as Mitsuba's.  Defaults: ``color0`` 0.4, ``color1`` 0.2; a colour is a number,
an RGB triple (from ``<rgb>``, ``<float>`` or ``<spectrum>`` in a scene file, converted as
Mitsuba's RGB variants do for a reflectance) or a nested texture.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..registry import register
from .base import Texture, apply_uv, as_texture, surface_points, take, uv_transform

__all__ = ["Checkerboard"]


@register("texture", "checkerboard")
class Checkerboard(Texture):
    """Checkerboard of ``color0`` and ``color1`` (see the module docstring)."""

    def __init__(self, color0: Any = 0.4, color1: Any = 0.2, to_uv: Any = None):
        self.color0 = as_texture(color0, "color0")
        self.color1 = as_texture(color1, "color1")
        uv_transform(to_uv)                            # checks the shape
        self.to_uv = None if to_uv is None else np.asarray(to_uv, float)

    @classmethod
    def from_props(cls, p) -> "Checkerboard":
        return cls(p.texture("color0", 0.4), p.texture("color1", 0.2), p.transform("to_uv"))

    def validate(self) -> None:
        """Check the colours again after a change in place."""
        self.color0 = as_texture(self.color0, "color0")
        self.color1 = as_texture(self.color1, "color1")
        for tex in (self.color0, self.color1):
            tex.validate()

    def first(self, uv: np.ndarray) -> np.ndarray:
        """``(N,)`` bool: where ``color0`` is shown at texture coordinates ``uv`` (N, 2)."""
        t = apply_uv(uv_transform(self.to_uv), uv)
        upper = (t - np.floor(t)) > 0.5
        return upper[:, 0] == upper[:, 1]

    def _pick(self, si: Any, method: str, width: int | None) -> np.ndarray:
        si = surface_points(si)
        first = self.first(si.uv)
        if width is None:
            first = ~first                # Mitsuba's eval_1 tests (fu > 1/2) != (fv > 1/2)
        out = np.empty((len(first),) if width is None else (len(first), width))
        for mask, tex in ((first, self.color0), (~first, self.color1)):
            if mask.any():
                out[mask] = getattr(tex, method)(take(si, mask))
        return out

    def eval(self, si: Any) -> np.ndarray:
        """RGB ``(N, 3)``: ``color0``'s or ``color1``'s value by cell."""
        return self._pick(si, "eval", 3)

    def eval_1(self, si: Any) -> np.ndarray:
        """``(N,)``: ``color0``'s ``eval_1`` where ``eval`` shows ``color1``, and the reverse
        (Mitsuba 3's rule, see the module docstring)."""
        return self._pick(si, "eval_1", None)

    def mean(self) -> np.ndarray:
        """(mean(color0) + mean(color1)) / 2, ``(3,)``."""
        return 0.5 * (self.color0.mean() + self.color1.mean())

    def mean_1(self) -> float:
        """Mitsuba's ``mean()``: (color0.mean_1() + color1.mean_1()) / 2."""
        return 0.5 * (self.color0.mean_1() + self.color1.mean_1())

    def __repr__(self) -> str:
        return f"Checkerboard(color0={self.color0!r}, color1={self.color1!r})"
