"""The emitters of a scene as direction samplers from shading points (the light set over all
of them, with light selection, is :mod:`vrlab.render.light_set`).

* :class:`Light`: one emitting shape, the area emitter's sampler
  (:class:`vrlab.render.emitters.area.AreaLight`).  Spheres are sampled by the cone they
  subtend (``SphereCone``), other shapes by area (their ``surface()`` distribution), converted
  to solid angle over every hit (``SolidAngleFromArea``: p_w = sum_k p_A d_k^2 /
  |cos theta_k|); split mesh lights also triangle by triangle (``sample_triangle``).
  ``power``: the flux of a one-sided Lambertian emitter, pi x mean radiance x area
  (``lambertian_flux``).
* :class:`EmitterLight`: an emitter that is not a shape (point, spot, directional,
  constant, envmap, ...) with the same calling conventions.
"""
from __future__ import annotations

import numpy as np

from .._vec import scale
from .emitters.area import AreaLight as Light
from .emitters.area import lambertian_flux

__all__ = ["EmitterLight", "Light", "lambertian_flux"]


class EmitterLight:
    """An emitter that is not a shape (point, spot, directional, constant, envmap, ...) in
    the light set: its ``sample``/``pdf``/``radiance`` (:mod:`vrlab.render.emitters.base`)
    with the light set's calling conventions.  Delta lights have density 1 in the counting
    measure (times P_j); ``y`` is the light's point (far along w for lights at infinity)."""

    FAR = 1e30                   # the distance used for lights at infinity (finite in float32)

    def __init__(self, emitter, radius: float):
        self.emitter, self.shape = emitter, None
        self.sphere, self.planar, self.sign, self.textured = None, True, 1.0, False
        self.directions: dict = {}
        self.is_delta, self.is_infinite = emitter.is_delta, emitter.is_infinite
        self.power = float(emitter.power(radius))
        self.radiance = np.zeros(3)          # no constant radiance: ``le`` comes with each sample

    def sample(self, ref, u):
        w, pdf, le, dist = self.emitter.sample(ref, u)
        w = np.asarray(w, ref.dtype)
        y = ref + scale(w, np.where(np.isfinite(dist), dist, self.FAR).astype(ref.dtype))
        return w, np.where(self.is_delta, 1.0, pdf), np.ones(len(ref), bool), y, le

    def first_point(self, ref, w):
        """The light's point along ``w`` from ``ref`` (far along w for lights at infinity)."""
        dist = self.emitter.sample(ref, np.zeros((len(ref), 2)))[3]
        return ref + scale(w, np.where(np.isfinite(dist), dist, self.FAR).astype(ref.dtype))

    def pdf(self, ref, w, hit_p=None):
        if self.is_delta:                    # counting measure: the light's one direction
            return np.ones(len(ref))
        return self.emitter.pdf(ref, w)

    def cos_integral(self, ref, n):
        return np.zeros(len(ref)), np.zeros(len(ref), bool)
