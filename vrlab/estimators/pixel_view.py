"""The pixels of a batched integrand as ReSTIR reads them (:mod:`vrlab.estimators.restir`):
``PixelView`` gives pixel b's integrand and target at points (one integral per element of the
batch grid P) and its neighbours on the periodic grid (``grid_offsets``: the integer offsets
o, 0 < |o| <= radius); the renderer's view with the same interface is
:class:`vrlab.render.reuse.BlockPixels`."""
from __future__ import annotations

import numpy as np

from .. import limits
from ..distributions.base import checked_pdf, checked_sample

__all__ = ["PixelView", "grid_offsets"]


def grid_offsets(shape: tuple, radius: float) -> np.ndarray:
    """Integer offsets o (L, len(shape)) with 0 < |o| <= radius that do not wrap onto the pixel
    itself on a periodic grid of ``shape`` (row-major order); at most ``limits.MAX_OFFSETS``
    candidates (2r+1)^d, r = floor(radius), else a ValueError naming the radius."""
    shape, r = tuple(int(s) for s in shape), int(np.floor(radius))
    if (2 * r + 1) ** len(shape) > limits.MAX_OFFSETS:
        raise ValueError(f"radius: {radius:g} on a {len(shape)}-d pixel grid enumerates "
                         f"{(2 * r + 1) ** len(shape):.3g} neighbour offsets, more than limits.MAX_OFFSETS = "
                         f"{limits.MAX_OFFSETS}")
    o = np.indices((2 * r + 1,) * len(shape)).reshape(len(shape), -1).T - r if shape else np.zeros((0, 0), int)
    keep = (np.sum(o * o, -1) <= radius * radius) & np.any(o % np.array(shape, int) != 0, -1)
    return o[keep]


class PixelView:
    """The integrand and target of a batched integrand read per pixel: ``f(x, pix)`` and
    ``phat(x, pix)`` give pixel pix's value at each point (x (..., k), pix int broadcast to
    x.shape[:-1], flat index on the grid ``shape``); the renderer's is ``reuse.BlockPixels``."""

    def __init__(self, integrand, target, shape: tuple, source=None):
        self.integrand, self.target, self.shape, self.source = integrand, target, tuple(shape), source
        self.B = int(np.prod(self.shape, dtype=int))

    def candidates(self, uc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(x, p, t)``: candidates (N, B, c, k) from ``uc (N, B, c, d)``, density, targets."""
        N, B, c, d = uc.shape
        x = np.asarray(checked_sample(self.source, uc.reshape(N * B * c, d), "source"), dtype=float)
        p = np.asarray(checked_pdf(self.source, x, "source"), dtype=float).reshape(N, B, c)
        x = x.reshape(N, B, c, x.shape[-1])
        return x, p, self.phat(x, np.arange(B)[:, None])

    def neighbours(self, un: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
        """``(nbr, present)`` (N, B, k): flat neighbour indices from one uniform each, a uniform
        offset of the periodic grid (every neighbour present)."""
        if un.shape[-1] == 0:
            return np.zeros(un.shape, int), np.ones(un.shape, bool)
        offs = grid_offsets(self.shape, radius)
        pick = offs[np.minimum((un * len(offs)).astype(int), len(offs) - 1)]         # (N, B, k, nd)
        coords = np.stack(np.unravel_index(np.arange(un.shape[1]), self.shape), -1)[None, :, None, :]
        nb = (coords + pick) % np.array(self.shape)
        return np.ravel_multi_index(tuple(np.moveaxis(nb, -1, 0)), self.shape), np.ones(un.shape, bool)

    @staticmethod
    def nonzero(f) -> np.ndarray:             # where values f (no channel axis in the lab) are not 0
        return np.asarray(f) != 0

    def _pick(self, values, x, pix, who: str) -> np.ndarray:
        v, lead = np.asarray(values, dtype=float), x.shape[:-1]
        if v.shape == lead:                                  # one value shared by every pixel
            return v
        if v.shape != self.shape + lead:
            raise ValueError(f"{who}: expected values of shape {self.shape + lead} (pixels, points) or {lead}, "
                             f"got {v.shape}")
        idx = np.broadcast_to(np.asarray(pix), lead)[None]
        return np.take_along_axis(v.reshape((self.B,) + lead), idx, 0)[0]

    def f(self, x, pix) -> np.ndarray:
        return self._pick(self.integrand(x), x, pix, "integrand")

    def phat(self, x, pix) -> np.ndarray:
        if self.target is None:
            return np.abs(self.f(x, pix))
        t = self._pick(self.target(x), x, pix, "target")
        if np.any(t < 0) or np.any(np.isnan(t)):
            raise ValueError("target: the unnormalised target density must be >= 0 and not NaN")
        return t
