"""Ranges the renderer supports, and the checks the scene elements share.

Every element (:mod:`vrlab.render.registry`) checks its parameters in its constructor with
these (and ``Scene.validate()`` runs the checks again, as ``render`` does once per call,
after fields were changed in place).  Errors are ``TypeError`` (wrong kind) or
``ValueError`` (bad value) whose message starts with the field's name; the XML loader
turns them into a :class:`~vrlab.render.SceneError` naming the element.

Limits (the renderer intersects and shades in float32, see :mod:`vrlab.render.direct`):

* coordinates: every entry of a ``to_world`` matrix and every mesh vertex within
  +-:data:`MAX_COORD` (1e8); scale factors (singular values of the linear part) within
  :data:`SCALE_RANGE` = [1e-9, 1e8]; shapes are affine (last row ``0 0 0 1``), the
  sensor a rigid motion, a sphere a similarity (uniform scale);
* values: radiance and reflectances finite, >= 0 and <= :data:`MAX_VALUE` (1e15);
  ``alpha`` in (0, 1e4]; the Phong ``exponent`` in [0, 1e6];
* sensor: ``fov`` in (0, 180) degrees (and so is the horizontal fov it implies);
  ``width``, ``height`` in [1, 65536] with at most 2^26 pixels; ``spp`` >= 1;
* integrator: ``emitter_samples``, ``bsdf_samples`` in [0, 1024], not both 0.

The numbers are :mod:`vrlab.limits`' (the one table of limits).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .. import checks

# the bounds are vrlab.limits' (the one table), named here for the elements' checks
from ..limits import (MAX_ALPHA, MAX_COORD, MAX_EXPONENT, MAX_PIXELS, MAX_SAMPLES, MAX_SIDE,  # noqa: E402,F401
                      MAX_VALUE, SCALE_RANGE)


def rgb(value: Any, name: str) -> np.ndarray:
    """A colour as a float array ``(3,)`` from a number or 3 numbers: finite, in [0, MAX_VALUE]."""
    if isinstance(value, np.ndarray) and value.shape == (3,) and value.dtype == np.float64:
        a = value                                      # fast path: already checked before
        lo, hi = a.min(), a.max()
        if lo >= 0 and hi <= MAX_VALUE:
            return a
    if value is None:
        raise TypeError(f"{name} must be a number or 3 numbers (RGB), got None")
    a = checks.finite_array(value, name)
    if a.ndim > 1 or a.size not in (1, 3):
        raise ValueError(f"{name} must be one number or 3 (RGB), got shape {a.shape}")
    a = np.broadcast_to(a.reshape(-1), (3,)).astype(float)
    if np.any(a < 0) or np.any(a > MAX_VALUE):
        raise ValueError(f"{name} must lie in [0, {MAX_VALUE:g}], got {a.tolist()}")
    return a


def matrix4(value: Any, name: str) -> np.ndarray:
    """A finite float ``(4, 4)`` matrix whose entries lie within +-MAX_COORD."""
    m = checks.finite_array(value, name)
    if m.shape != (4, 4):
        raise ValueError(f"{name} must be a 4x4 matrix, got shape {m.shape}")
    if np.abs(m).max() > MAX_COORD:
        raise ValueError(f"{name}: entries must lie within +-{MAX_COORD:g} (the renderer works in "
                         f"float32), got {np.abs(m).max():g}")
    return m.copy()


def affine(m: np.ndarray, name: str) -> None:
    """``m`` maps points affinely (last row 0 0 0 1) with scale factors in SCALE_RANGE."""
    if np.any(m[3] != [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"{name} must be affine (last row 0 0 0 1), got last row {m[3].tolist()}")
    s = np.linalg.svd(m[:3, :3], compute_uv=False)
    low, high = SCALE_RANGE
    if not (s[-1] >= low and s[0] <= high):
        what = "singular" if s[-1] == 0 else "scaled too far"
        raise ValueError(f"{name} is {what}: its scale factors (singular values) must lie in "
                         f"[{low:g}, {high:g}], got {s[-1]:g} to {s[0]:g}")


def rigid(m: np.ndarray, name: str) -> None:
    """``m`` is a rigid motion (rotation or reflection, and translation)."""
    r = m[:3, :3]
    if not np.allclose(r.T @ r, np.eye(3), atol=1e-6) or np.any(m[3] != [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"{name}: the sensor to_world must be a rigid motion (no scale, shear or "
                         "projection), as in Mitsuba; supported: translate, rotate, lookat, "
                         "orthonormal matrix")
