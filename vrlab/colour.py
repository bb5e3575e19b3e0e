"""Colour constants shared by every layer: the one definition of luminance.

``LUMINANCE`` are Mitsuba 3's weights of linear sRGB (Rec. 709 primaries, D65 white),
include/mitsuba/core/spectrum.h: Y = 0.212671 R + 0.715160 G + 0.072169 B.  Environment
maps' sampling tables, grey lookups of RGB textures, power-based light selection and the
tone mapper's auto exposure all weigh colours with them.
"""
from __future__ import annotations

import numpy as np

__all__ = ["LUMINANCE", "luminance"]

#: Mitsuba 3's luminance weights of linear sRGB (float64; read-only)
LUMINANCE = np.array([0.212671, 0.715160, 0.072169])
LUMINANCE.setflags(write=False)


def luminance(rgb) -> np.ndarray:
    """Y = :data:`LUMINANCE` . rgb of ``(..., 3)`` values, in float64."""
    return np.asarray(rgb, float) @ LUMINANCE
