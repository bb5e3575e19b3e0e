"""Images: saving and loading linear renders, tone mapping for PNG, and error metrics.

* ``.npy``: the linear float32 (H, W, 3) image, unchanged (NaN kept: the standard error
  of a 1-spp render is NaN).
* ``auto_exposure(img)``: the scale that maps the log-average luminance exp(mean log(1e-4
  + Y)) (Y = 0.2126 R + 0.7152 G + 0.0722 B, Rec. 709) to the mid-grey key 0.18 (Reinhard
  et al. 2002, "Photographic tone reproduction"), lowered where needed so that the
  brightest 3% of the pixels at most reach white: directly seen lights clip, the lit
  scene does not.  Figures
  that compare images use one exposure for all of them.
* ``.png``: clamp to [0, 1] after an exposure scale, then the sRGB transfer curve
  (IEC 61966-2-1: 12.92 v for v <= 0.0031308, else 1.055 v^(1/2.4) - 0.055), rounded to
  8 bits (round(255 v));
  NaN or infinite pixels are an error (they have no colour).
* ``.exr``: through the ``OpenEXR`` package when it is installed (not a dependency).
* ``rel_mse(img, ref) = mean((img - ref)^2 / (ref^2 + 0.01))`` (relative MSE as used in
  rendering papers, e.g. Rousselle et al. 2011).

Checked: the path's type, suffix and folder (``save_image``) or existence
(``load_image``), the image's shape ``(H, W, 3)`` with H, W >= 1 and real values,
``exposure`` finite and > 0 or ``"auto"``; errors name the argument.

``save_image(path, img, exposure=...)`` keeps ``exposure=1.0`` as its default (a PNG
shows the linear values unscaled, so e.g. standard-error images of several renders are
comparable); ``exposure="auto"`` uses ``auto_exposure(img)``.  ``vrlab render -o x.png``
defaults to ``--exposure auto`` and reports the exposure it used.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .. import checks

__all__ = ["auto_exposure", "load_image", "rel_mse", "save_image", "srgb_encode"]

SUFFIXES = (".npy", ".png", ".exr")


def _image(value: Any, name: str, finite: bool) -> np.ndarray:
    """``value`` as a float array ``(H, W, 3)``, H, W >= 1 (finite if ``finite``)."""
    if finite:
        a = checks.finite_array(value, name)
    else:
        try:
            a = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise TypeError(f"{name} must be an array of real numbers, got {type(value).__name__}") from None
    if a.ndim != 3 or a.shape[-1] != 3 or a.size == 0:
        raise ValueError(f"{name}: expected an image of shape (H, W, 3) with H, W >= 1, got {a.shape}")
    return a


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """Linear values to sRGB-encoded values in [0, 1] (clamped to [0, 1] first; NaN is an error)."""
    v = np.asarray(linear)
    if v.dtype.kind not in "fiub":
        raise TypeError(f"linear must be an array of real numbers, got dtype {v.dtype}")
    if np.isnan(v).any():
        raise ValueError("linear: the image has NaN values (no colour to encode)")
    v = np.clip(v.astype(float, copy=False), 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)


def auto_exposure(img: np.ndarray, key: float = 0.18, clip: float = 0.03) -> float:
    """min(key / exp(mean log(1e-4 + Y)), 1 / (the (1 - clip) quantile of Y)) over the finite
    pixels' luminance Y (see the module docstring); 1.0 for an image without light."""
    img = _image(img, "img", False)
    key = checks.real(key, "key", low=0.0, low_open=True)
    clip = checks.real(clip, "clip", low=0.0, high=1.0)
    lum = img.astype(float) @ np.array([0.2126, 0.7152, 0.0722])
    lum = np.maximum(lum[np.isfinite(lum)], 0.0)
    if lum.size == 0 or not np.any(lum > 0):
        return 1.0
    scale = key / float(np.exp(np.mean(np.log(1e-4 + lum))))
    top = float(np.quantile(lum, 1.0 - clip))
    return min(scale, 1.0 / top) if top > 0 else scale


def rel_mse(img: np.ndarray, ref: np.ndarray) -> float:
    """mean((img - ref)^2 / (ref^2 + 0.01)) over all pixels and channels of two finite
    images of the same shape ``(H, W, 3)``."""
    img, ref = _image(img, "img", True), _image(ref, "ref", True)
    if img.shape != ref.shape:
        raise ValueError(f"ref: shape {ref.shape} of the reference differs from the image's {img.shape}")
    from ..metrics import rel_mse as _rel_mse     # the one relMSE (vrlab.metrics)

    return _rel_mse(img, ref)


def save_image(path: str | Path, img: np.ndarray, exposure: float | str = 1.0) -> Path:
    """Save a linear (H, W, 3) image as .npy, .png (sRGB of clamp(exposure x img)) or .exr;
    returns the path.  ``exposure``: a number > 0 (default 1.0) or ``"auto"``
    (:func:`auto_exposure` of ``img``); used by .png only.

    ``ValueError`` for another suffix, a folder that does not exist, a wrong shape, NaN or
    infinite pixels in a PNG, or ``exposure`` not finite and > 0 (``TypeError``: a string
    other than ``"auto"``)."""
    path = checks.file_path(path, "path", SUFFIXES)
    img = _image(img, "img", False).astype(np.float32)
    if isinstance(exposure, str):
        if exposure != "auto":
            raise TypeError(f"exposure must be 'auto' or a number > 0, got {exposure!r}")
    else:
        exposure = checks.real(exposure, "exposure", low=0, low_open=True)
    suffix = path.suffix.lower()
    if suffix == ".npy":
        np.save(path, img)
    elif suffix == ".png":
        bad = ~np.isfinite(img)
        if bad.any():
            i, j, c = (int(k) for k in np.argwhere(bad)[0])
            raise ValueError(f"img: pixel ({i}, {j}) channel {c} is {img[i, j, c]} ({int(bad.sum())} "
                             "non-finite values); a PNG cannot hold it, save as .npy")
        import matplotlib.image

        if exposure == "auto":
            exposure = auto_exposure(img)
        with np.errstate(over="ignore"):
            encoded = srgb_encode(img.astype(float) * exposure)
        # rounded to 8 bits (a plain cast would truncate: 1.055 - 0.055 = 0.99999... -> 254, never white)
        matplotlib.image.imsave(path, np.rint(encoded * 255).astype(np.uint8))
    else:
        try:
            import OpenEXR  # type: ignore[import-not-found]
        except ImportError:
            raise ValueError("path: writing .exr needs the OpenEXR package (pip install OpenEXR); "
                             "use .npy for the linear image") from None
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        with OpenEXR.File(header, {"RGB": img}) as f:
            f.write(str(path))
    return path


def load_image(path: str | Path, name: str = "path") -> np.ndarray:
    """A linear (H, W, 3) float image from ``.npy`` (or ``.exr`` with ``OpenEXR``), e.g. a
    reference for :func:`rel_mse`.  ``ValueError`` naming ``name`` if the file is missing,
    unreadable, not (H, W, 3) or not finite."""
    p = checks.file_path(path, name, SUFFIXES, write=False)
    if p.suffix.lower() == ".png":
        raise ValueError(f"{name}: a .png is tone mapped; load a linear .npy or .exr image")
    if not p.is_file():
        raise ValueError(f"{name}: no such file {str(p)!r}")
    try:
        if p.suffix.lower() == ".npy":
            data = np.load(p, allow_pickle=False)
        else:
            import OpenEXR  # type: ignore[import-not-found]

            with OpenEXR.File(str(p)) as f:
                data = f.channels()["RGB"].pixels
    except ImportError:
        raise ValueError(f"{name}: reading .exr needs the OpenEXR package (pip install OpenEXR)") from None
    except Exception as exc:  # noqa: BLE001 - any unreadable file
        raise ValueError(f"{name}: cannot read image {str(p)!r}: {exc}") from None
    return _image(data, name, True)
