"""Images: saving linear renders, tone mapping for PNG, and error metrics.

* ``.npy``: the linear float32 (H, W, 3) image, unchanged.
* ``.png``: clamp to [0, 1] after an exposure scale, then the sRGB transfer curve
  (IEC 61966-2-1: 12.92 v for v <= 0.0031308, else 1.055 v^(1/2.4) - 0.055), 8 bits.
* ``.exr``: through the ``OpenEXR`` package when it is installed (not a dependency).
* ``rel_mse(img, ref) = mean((img - ref)^2 / (ref^2 + 0.01))`` (relative MSE as used in
  rendering papers, e.g. Rousselle et al. 2011).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """Linear values in [0, 1] to sRGB-encoded values in [0, 1]."""
    v = np.clip(linear, 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)


def rel_mse(img: np.ndarray, ref: np.ndarray) -> float:
    """mean((img - ref)^2 / (ref^2 + 0.01)) over all pixels and channels."""
    img, ref = np.asarray(img, float), np.asarray(ref, float)
    if img.shape != ref.shape:
        raise ValueError(f"reference: shape {ref.shape} differs from the image's {img.shape}")
    return float(np.mean((img - ref) ** 2 / (ref * ref + 0.01)))


def save_image(path: str | Path, img: np.ndarray, exposure: float = 1.0) -> Path:
    """Save a linear (H, W, 3) image as .npy, .png (tonemapped sRGB) or .exr."""
    path = Path(path)
    img = np.asarray(img, dtype=np.float32)
    if img.ndim != 3 or img.shape[-1] != 3:
        raise ValueError(f"image: expected shape (H, W, 3), got {img.shape}")
    suffix = path.suffix.lower()
    if suffix == ".npy":
        np.save(path, img)
    elif suffix == ".png":
        import matplotlib.image

        matplotlib.image.imsave(path, srgb_encode(np.nan_to_num(img) * exposure))
    elif suffix == ".exr":
        try:
            import OpenEXR  # type: ignore[import-not-found]
        except ImportError:
            raise ValueError("writing .exr needs the OpenEXR package (pip install OpenEXR); "
                             "use .npy for the linear image") from None
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        with OpenEXR.File(header, {"RGB": img}) as f:
            f.write(str(path))
    else:
        raise ValueError(f"output: unknown image format {path.suffix!r}; use .npy, .png or .exr")
    return path
