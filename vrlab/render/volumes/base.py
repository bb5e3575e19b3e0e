"""The base of volume elements (Mitsuba 3's ``Volume``, include/mitsuba/render/volume.h).

A volume maps world-space points to values, vectorised over a batch:

* ``eval(p) -> (N, 3)``: the RGB value at points ``p (N, 3)`` (a one-channel volume repeated
  into the three channels, as Mitsuba's RGB variants broadcast a float);
* ``eval_1(p) -> (N,)``: the scalar value (one channel: itself; three: the luminance
  Y = 0.212671 R + 0.715160 G + 0.072169 B);
* ``mean() -> (3,)``: the mean of the data (not a Mitsuba method: what a texture's ``mean``
  falls back to).

``to_world`` (4 x 4, invertible, default identity) places the volume's unit cube [0, 1]^3 in
the world: a point is looked up at p_local = to_world^-1 p (Mitsuba's ``m_to_local``).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ..registry import Element

__all__ = ["Volume"]


class Volume(Element):
    """Base of the volume elements; subclasses implement ``eval``, ``eval_1`` and ``mean``."""

    kind = "volume"

    def __init__(self, to_world: Any = None):
        m = np.eye(4) if to_world is None else checks.finite_array(to_world, "to_world")
        if m.shape != (4, 4):
            raise ValueError(f"to_world must be a 4 x 4 matrix, got shape {m.shape}")
        if abs(np.linalg.det(m)) < 1e-300:
            raise ValueError("to_world must be invertible (a zero scale?)")
        self.to_world = m
        self.to_local = np.linalg.inv(m)

    @property
    def type(self) -> str:
        """The Mitsuba plugin name."""
        return self.plugin_name

    def local(self, p: Any) -> np.ndarray:
        """``(N, 3)``: the points ``p`` in the volume's frame, to_world^-1 p."""
        p = checks.finite_array(p, "p", ndim=2, last=3)
        return p @ self.to_local[:3, :3].T + self.to_local[:3, 3]

    def eval(self, p: Any) -> np.ndarray:   # pragma: no cover - every volume overrides it
        """The RGB value ``(N, 3)`` at world-space points ``p``."""
        raise NotImplementedError

    def eval_1(self, p: Any) -> np.ndarray:   # pragma: no cover - every volume overrides it
        """The scalar value ``(N,)`` at world-space points ``p``."""
        raise NotImplementedError

    def mean(self) -> np.ndarray:   # pragma: no cover - every volume overrides it
        """The mean RGB value ``(3,)`` of the data."""
        raise NotImplementedError
