"""The one relative MSE of vrlab (renderer, ``--compare``, experiments, benchmarks).

relMSE(img, ref) = mean over pixels and channels of (img - ref)^2 / (ref^2 + eps), with
eps = :data:`REL_MSE_EPS` = 0.01 so that dark pixels do not dominate (the relative MSE of
Rousselle et al. 2011 and of the gradient-domain and denoising literature since; Mitsuba's
and pbrt's test scripts use the same form).  :func:`relative_squared_error` is the per-pixel
term, for maps and for expected errors (a variance over spp in place of the squared error).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from . import checks

__all__ = ["REL_MSE_EPS", "image_mean", "rel_mse", "relative_squared_error"]

#: eps of the relative MSE's denominator ref^2 + eps
REL_MSE_EPS = 0.01


def relative_squared_error(squared_error: Any, ref: Any) -> np.ndarray:
    """squared_error / (ref^2 + eps), element-wise, in float64."""
    ref = np.asarray(ref, dtype=np.float64)
    return np.asarray(squared_error, dtype=np.float64) / (ref * ref + REL_MSE_EPS)


def rel_mse(img: Any, ref: Any, *, ref_err: Any = None, mask: Any = None, axis: Any = None):
    """mean((img - ref)^2 / (ref^2 + eps)) over ``axis`` (default all) of the pixels selected by
    ``mask`` (over the leading axes; default all).  ``ref_err``: the reference's standard error,
    whose variance is subtracted from the squared error (independent reference noise).  A float
    when reduced over all axes, else an array."""
    img, ref = checks.finite_array(img, "img"), checks.finite_array(ref, "ref")
    if img.shape != ref.shape or img.size == 0:
        raise ValueError(f"img, ref: expected two non-empty arrays of one shape, got {img.shape} and {ref.shape}")
    d2 = (img - ref) ** 2
    if ref_err is not None:
        err = checks.finite_array(ref_err, "ref_err")
        if err.shape != ref.shape:
            raise ValueError(f"ref_err: expected the shape of ref, {ref.shape}, got {err.shape}")
        d2 = d2 - err ** 2
    r = relative_squared_error(d2, ref)
    if mask is not None:
        m = np.asarray(mask)
        if m.dtype != bool or m.shape != img.shape[:m.ndim] or m.ndim == 0:
            raise ValueError(f"mask: expected a boolean array of the leading shape of img {img.shape}, got shape "
                             f"{m.shape} and dtype {m.dtype}")
        if not m.any():
            raise ValueError("mask: selects no pixel; the mean of nothing is undefined")
        r = r[m]
    out = np.mean(r, axis=axis)
    return float(out) if np.ndim(out) == 0 else out


def image_mean(value: Any, stderr: Any) -> tuple[np.ndarray, np.ndarray]:
    """Per-channel mean of an image ``(..., C)`` and its standard error sqrt(sum stderr^2) / P
    over the P pixels (independent pixel estimates, e.g. an ``Estimate``'s ``value`` and
    ``stderr``)."""
    v = np.asarray(value, float)
    e = np.asarray(stderr, float)
    if v.shape != e.shape or v.ndim < 1:
        raise ValueError(f"value, stderr: expected images of one shape (..., C), got {v.shape} and {e.shape}")
    v, e = v.reshape(-1, v.shape[-1]), e.reshape(-1, e.shape[-1])
    return v.mean(0), np.sqrt((e ** 2).sum(0)) / len(v)
