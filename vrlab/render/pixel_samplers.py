"""Pixel samplers: the uniforms ``u (pixels, spp, d)`` of every pixel's samples.

The pixel value is an integral over primary sample space [0, 1)^d (sub-pixel position,
direction, light choice, point on the light), so any point set can drive it:

* ``independent``: i.i.d. uniforms.
* ``stratified``: "padded" jittered sampling (Pharr et al., PBRT 3rd ed. 7.3): each
  pair of dimensions (sub-pixel position, direction, light point) gets its own jittered
  2D grid of spp cells (``balanced_strata``), single dimensions a jittered 1D grid; the
  samples of each group are shuffled independently per pixel so the groups do not
  correlate.  With spp = 4 this is the student report's "4 sub-pixel strata".
* ``sobol`` / ``halton``: one scrambled ``spp``-point set in d dimensions shared by all
  pixels, with an independent Cranley–Patterson shift per pixel (randomised QMC: each
  pixel's estimate is unbiased, pixels are independent).

Every pixel's randomness is drawn in one call per block of pixels, pixel after pixel,
so images do not depend on the block size.  The per-pixel standard error from the
i.i.d. formula is only valid for ``independent`` (it overestimates for the others).

``PixelSampler`` checks its arguments (``name`` among :data:`PIXEL_SAMPLERS`, ``spp``
and ``d`` integers >= 1, ``gen`` a NumPy ``Generator``, ``groups`` tuples of distinct
dimensions in [0, d)); ``draw`` checks ``npix`` (an integer >= 0).
"""
from __future__ import annotations

import numpy as np

from .. import checks


PIXEL_SAMPLERS = ("independent", "stratified", "sobol", "halton")


class PixelSampler:
    """Draws ``(pixels, spp, d)`` uniforms for blocks of pixels from one generator.

    ``groups``: the dimension groups that are stratified together (e.g. ``[(0, 1), (2, 3)]``).
    """

    def __init__(self, name: str, spp: int, d: int, gen: np.random.Generator, groups):
        self.name = checks.choice(name, "pixel_sampler", PIXEL_SAMPLERS)
        self.spp, self.d = checks.integer(spp, "spp", low=1), checks.integer(d, "d", low=1)
        if not isinstance(gen, np.random.Generator):
            raise TypeError(f"gen must be a numpy.random.Generator, got {type(gen).__name__}")
        self.gen = gen
        try:
            self.groups = [tuple(checks.integer(k, "groups", low=0, high=self.d - 1) for k in g) for g in groups]
        except TypeError:
            raise TypeError(f"groups must be a list of tuples of dimension indices, got {groups!r}") from None
        covered = sorted(k for g in self.groups for k in g)
        if len(covered) != len(set(covered)) or any(len(g) == 0 for g in self.groups):
            raise ValueError(f"groups must be non-empty tuples of distinct dimensions, got {groups!r}")
        self.singles = [k for k in range(self.d) if k not in covered]
        if name in ("sobol", "halton"):
            from ..points import Halton, Sobol         # imported on first use (import time)
            cls = Sobol if name == "sobol" else Halton
            seed = int(gen.integers(2**63))  # the shared set's scrambling, drawn once
            self.base = cls(self.d, scramble=True, rng=seed).random(self.spp)
        if name == "stratified":
            from ..points import balanced_strata
            self.grids = {}
            for g in self.groups:
                counts = balanced_strata(self.spp, len(g))
                cells = np.stack(np.unravel_index(np.arange(self.spp), counts), -1)  # (spp, len(g))
                self.grids[g] = (cells, np.asarray(counts, float))

    def draw(self, npix: int, gen: np.random.Generator | None = None) -> np.ndarray:
        """Uniforms ``(npix, spp, d)`` of the next ``npix`` pixels from ``gen`` (default:
        the generator given at construction)."""
        npix = checks.integer(npix, "npix", low=0)
        spp, d = self.spp, self.d
        gen = self.gen if gen is None else gen
        if self.name == "independent":
            return gen.random((npix, spp, d))
        if self.name in ("sobol", "halton"):
            shift = gen.random((npix, 1, d))
            return np.mod(self.base[None] + shift, 1.0)
        # stratified: jitter (d values) + one shuffle key per group and per single dimension
        groups = self.groups + [(k,) for k in self.singles]
        r = gen.random((npix, spp, d + len(groups)))
        u = np.empty((npix, spp, d))
        for j, g in enumerate(groups):
            if len(g) == 1:
                cells, counts = np.arange(spp)[:, None], np.array([float(spp)])
            else:
                cells, counts = self.grids[g]
            strata = (cells[None] + r[..., list(g)]) / counts                # (npix, spp, len(g))
            order = np.argsort(r[..., d + j], axis=1)                       # shuffle per pixel
            u[..., list(g)] = np.take_along_axis(strata, order[..., None], axis=1)
        return np.minimum(u, np.nextafter(1.0, 0.0))
