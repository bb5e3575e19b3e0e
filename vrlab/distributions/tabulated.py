"""Tabulated piecewise-constant densities in 1D and 2D (inverse-CDF sampling).

* ``PiecewiseConstant1D(values, domain)``: cell i of n has probability
  v_i / sum(v); inside the cell the point is uniform.  Sampling finds the cell by
  binary search on the CDF (O(log n)) and rescales u within it, so the warp is a
  monotone bijection and ``invert`` exists.  Measure: length.
* ``PiecewiseConstant2D(image, domain)``: sample the row (y) from the marginal
  (row sums), then the column (x) from that row's conditional CDF (Pharr et al.,
  PBRT 3rd ed. 13.6.7, used to sample environment maps by luminance).  ``image[iy, ix]``;
  points are (x, y).  Measure: area.
Cells with zero value are never sampled.  Checked: the values are finite, >= 0, not
all zero (``TypeError`` for non-numbers, ``ValueError`` naming the first bad entry);
``domain`` as in ``UniformBox``; the densities must be finite.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from ..colour import LUMINANCE

from .base import Distribution, as_float, as_points, as_uniforms
from .interval import as_bounds


def check_weights(values, name: str, ndim: int) -> np.ndarray:
    """Non-negative finite values with positive total (float64, ``ndim`` axes), else
    ``TypeError`` (not numbers) or ``ValueError`` naming ``name`` and the problem.
    Values whose sum overflows are scaled by a power of two (exact)."""
    v = np.array(as_float(values, name), dtype=np.float64)
    if v.ndim != ndim or v.size == 0:
        raise ValueError(f"{name}: expected a non-empty {ndim}-D array, got shape {v.shape}")
    for bad, what in ((np.isnan(v), "NaN"), (~np.isfinite(v), "an infinite value"), (v < 0, "a negative value")):
        if bad.any():
            where = tuple(int(i) for i in np.argwhere(bad)[0])
            raise ValueError(f"{name}: contains {what} at index {where}; values must be finite and >= 0")
    with np.errstate(over="ignore"):
        total = v.sum()
    if not total > 0:
        raise ValueError(f"{name}: all values are zero (zero total mass)")
    if not np.isfinite(total):  # huge values: scale down exactly so that sums stay finite
        v = np.ldexp(v, -int(np.frexp(v.max())[1]) - int(np.ceil(np.log2(v.size))))
    return v


def _cdf(v: np.ndarray) -> np.ndarray:
    """Normalised CDF along the last axis with a leading 0 (rows of zero mass stay 0)."""
    c = np.cumsum(v, axis=-1)
    total = c[..., -1:]
    c = np.where(total > 0, c / np.where(total > 0, total, 1.0), 0.0)
    c[..., -1] = np.where(total[..., 0] > 0, 1.0, 0.0)
    return np.concatenate([np.zeros(v.shape[:-1] + (1,)), c], axis=-1)


def _domain(domain, k: int) -> np.ndarray:
    """``domain`` as k intervals (a, b), checked by ``as_bounds``."""
    b = as_bounds([as_float(domain, "domain")] if k == 1 else domain, "domain")
    if b.shape != (k, 2):
        want = "(a, b)" if k == 1 else "((x0, x1), (y0, y1))"
        raise ValueError(f"domain: expected {want}, got {domain!r}")
    return b


def _density(values: np.ndarray, cell: float) -> np.ndarray:
    """values / (sum * cell), checked finite (a tiny or huge domain could overflow it)."""
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        density = values / (values.sum() * cell)
    if not np.all(np.isfinite(density)):
        raise ValueError("domain: the cells are too small (or the values too uneven): the density overflows")
    return density


class PiecewiseConstant1D(Distribution):
    """Piecewise-constant density on ``domain = (a, b)`` from ``values`` (length)."""

    dim_u = dim_x = 1
    measure = "length"

    def __init__(self, values: Sequence[float], domain=(0.0, 1.0)):
        self.values = check_weights(values, "values", 1)
        (self.a, self.b), = _domain(domain, 1)
        self.n = len(self.values)
        self.cdf = _cdf(self.values)
        self.cell = (self.b - self.a) / self.n
        self.density = _density(self.values, self.cell)  # p in each cell
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
        img = as_float(image, "image")
        if img.ndim == 3:  # an RGB(A) image: sample its luminance (vrlab.colour)
            if img.shape[-1] not in (3, 4):
                raise ValueError(f"image: expected (ny, nx), (ny, nx, 3) or (ny, nx, 4), got shape {img.shape}")
            img = check_weights(img, "image", 3)[..., :3] @ LUMINANCE
        self.image = check_weights(img, "image", 2)
        b = _domain(domain, 2)
        self.lo, self.hi = b[:, 0], b[:, 1]
        self.ny, self.nx = self.image.shape
        self.cell = (self.hi - self.lo) / np.array([self.nx, self.ny])
        self.marginal = _cdf(self.image.sum(axis=1))            # (ny + 1,)
        self.conditional = _cdf(self.image)                     # (ny, nx + 1)
        # row iy's CDF shifted into [iy, iy + 1]: one searchsorted serves every row
        self._flat = (self.conditional[:, :-1] + np.arange(self.ny)[:, None]).ravel()
        self.density = _density(self.image, np.prod(self.cell))
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
