"""Tabulated piecewise-constant densities in 1D and 2D (inverse-CDF sampling).

* ``PiecewiseConstant1D(values, domain)``: cell i of n has probability
  v_i / sum(v); inside the cell the point is uniform.  Sampling finds the cell by
  binary search on the CDF (O(log n)) and rescales u within it, so the warp is a
  monotone bijection and ``invert`` exists.  Measure: length.
* ``PiecewiseConstant2D(image, domain)``: sample the row (y) from the marginal
  (row sums), then the column (x) from that row's conditional CDF (Pharr et al.,
  PBRT 3rd ed. 13.6.7, used to sample environment maps by luminance).  ``image[iy, ix]``;
  points are (x, y).  Measure: area.
Cells with zero value are never sampled.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .base import Distribution, as_points, as_uniforms
from .interval import as_bounds


def check_weights(values, name: str, ndim: int) -> np.ndarray:
    """Non-negative finite values with positive total, else ValueError naming the problem."""
    v = np.asarray(values, dtype=float)
    if v.ndim != ndim or v.size == 0:
        raise ValueError(f"{name}: expected a non-empty {ndim}-D array, got shape {v.shape}")
    if np.isnan(v).any():
        raise ValueError(f"{name}: contains NaN at index {tuple(np.argwhere(np.isnan(v))[0])}")
    if not np.isfinite(v).all():
        raise ValueError(f"{name}: contains an infinite value at index {tuple(np.argwhere(~np.isfinite(v))[0])}")
    if (v < 0).any():
        raise ValueError(f"{name}: contains a negative value at index {tuple(np.argwhere(v < 0)[0])}")
    if not v.sum() > 0:
        raise ValueError(f"{name}: all values are zero (zero total mass)")
    return v


def _cdf(v: np.ndarray) -> np.ndarray:
    """Normalised CDF along the last axis with a leading 0 (rows of zero mass stay 0)."""
    c = np.cumsum(v, axis=-1)
    total = c[..., -1:]
    c = np.where(total > 0, c / np.where(total > 0, total, 1.0), 0.0)
    c[..., -1] = np.where(total[..., 0] > 0, 1.0, 0.0)
    return np.concatenate([np.zeros(v.shape[:-1] + (1,)), c], axis=-1)


class PiecewiseConstant1D(Distribution):
    """Piecewise-constant density on ``domain = (a, b)`` from ``values`` (length)."""

    dim_u = dim_x = 1
    measure = "length"

    def __init__(self, values: Sequence[float], domain=(0.0, 1.0)):
        self.values = check_weights(values, "values", 1)
        (self.a, self.b), = as_bounds([domain], "domain")
        self.n = len(self.values)
        self.cdf = _cdf(self.values)
        self.cell = (self.b - self.a) / self.n
        self.density = self.values / (self.values.sum() * self.cell)  # p in each cell
        self.edges = self.a + np.arange(self.n + 1) * self.cell
        self.edges[-1] = self.b

    def _locate(self, u):
        i = np.searchsorted(self.cdf, u, side="right") - 1
        i = np.clip(i, 0, self.n - 1)
        lo, hi = self.cdf[i], self.cdf[i + 1]
        frac = np.where(hi > lo, (u - lo) / np.where(hi > lo, hi - lo, 1.0), 0.0)
        return i, frac

    def sample(self, u):
        i, frac = self._locate(as_uniforms(u, 1)[..., 0])
        x = self.edges[i] + frac * self.cell
        # stay strictly inside the chosen cell, so pdf(sample(u)) > 0 even at u -> 1
        return np.clip(x, self.edges[i], np.nextafter(self.edges[i + 1], -np.inf))[..., None]

    def pdf(self, x):
        x = as_points(x, 1)[..., 0]
        i = np.clip(np.searchsorted(self.edges, x, side="right") - 1, 0, self.n - 1)
        inside = (x >= self.a) & (x <= self.b)
        return np.where(inside, self.density[i], 0.0)

    def invert(self, x):
        x = as_points(x, 1)[..., 0]
        t = (x - self.a) / self.cell
        i = np.clip(np.floor(t).astype(np.int64), 0, self.n - 1)
        return (self.cdf[i] + (t - i) * (self.cdf[i + 1] - self.cdf[i]))[..., None]


class PiecewiseConstant2D(Distribution):
    """Piecewise-constant density on a rectangle from an image ``image[iy, ix]`` (area).

    Marginal p(y) from row sums, conditional p(x | y) from the row; the joint density
    in cell (iy, ix) is image[iy, ix] / (sum(image) * cell_area).
    """

    dim_u = dim_x = 2
    measure = "area"

    def __init__(self, image, domain=((0.0, 1.0), (0.0, 1.0))):
        img = np.asarray(image, dtype=float)
        if img.ndim == 3:  # an RGB(A) image: sample its luminance (Rec. 709 weights)
            img = img[..., :3] @ np.array([0.2126, 0.7152, 0.0722])
        self.image = check_weights(img, "image", 2)
        b = as_bounds(domain, "domain")
        if b.shape != (2, 2):
            raise ValueError(f"domain: expected ((x0, x1), (y0, y1)), got {domain!r}")
        self.lo, self.hi = b[:, 0], b[:, 1]
        self.ny, self.nx = self.image.shape
        self.cell = (self.hi - self.lo) / np.array([self.nx, self.ny])
        self.marginal = _cdf(self.image.sum(axis=1))            # (ny + 1,)
        self.conditional = _cdf(self.image)                     # (ny, nx + 1)
        # row iy's CDF shifted into [iy, iy + 1]: one searchsorted serves every row
        self._flat = (self.conditional[:, :-1] + np.arange(self.ny)[:, None]).ravel()
        self.density = self.image / (self.image.sum() * np.prod(self.cell))
        self.xedges = self.lo[0] + np.arange(self.nx + 1) * self.cell[0]
        self.yedges = self.lo[1] + np.arange(self.ny + 1) * self.cell[1]
        self.xedges[-1], self.yedges[-1] = self.hi

    def sample(self, u):
        u = as_uniforms(u, 2)
        iy = np.clip(np.searchsorted(self.marginal, u[..., 1], side="right") - 1, 0, self.ny - 1)
        lo, hi = self.marginal[iy], self.marginal[iy + 1]
        fy = (u[..., 1] - lo) / (hi - lo)  # rows that are chosen have hi > lo
        k = np.searchsorted(self._flat, iy + u[..., 0], side="right") - 1
        ix = np.clip(k - iy * self.nx, 0, self.nx - 1)
        clo, chi = self.conditional[iy, ix], self.conditional[iy, ix + 1]
        fx = np.where(chi > clo, (u[..., 0] - clo) / np.where(chi > clo, chi - clo, 1.0), 0.0)
        x = np.clip(self.xedges[ix] + fx * self.cell[0], self.xedges[ix], np.nextafter(self.xedges[ix + 1], -np.inf))
        y = np.clip(self.yedges[iy] + fy * self.cell[1], self.yedges[iy], np.nextafter(self.yedges[iy + 1], -np.inf))
        return np.stack([x, y], -1)

    def _cells(self, x):
        x = as_points(x, 2)
        t = (x - self.lo) / self.cell
        inside = np.all((x >= self.lo) & (x <= self.hi), -1)
        ix = np.clip(np.searchsorted(self.xedges, x[..., 0], side="right") - 1, 0, self.nx - 1)
        iy = np.clip(np.searchsorted(self.yedges, x[..., 1], side="right") - 1, 0, self.ny - 1)
        return t, ix, iy, inside

    def pdf(self, x):
        _, ix, iy, inside = self._cells(x)
        return np.where(inside, self.density[iy, ix], 0.0)

    def invert(self, x):
        t, ix, iy, _ = self._cells(x)
        uy = self.marginal[iy] + (t[..., 1] - iy) * (self.marginal[iy + 1] - self.marginal[iy])
        ux = self.conditional[iy, ix] + (t[..., 0] - ix) * (self.conditional[iy, ix + 1] - self.conditional[iy, ix])
        return np.stack([ux, uy], -1)
