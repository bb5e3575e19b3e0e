"""Mixtures of BSDF lobes: per-sample lobe probabilities, and delta (specular) lobes.

A BSDF with several lobes samples one of them, lobe k with probability P_k(wo) that depends
on the outgoing direction (a plastic chooses its specular coating by the Fresnel reflectance
at wo), then a direction from that lobe.  The density of the result is

    p(wi) = sum_k P_k(wo) p_k(wi)      (solid angle, over the continuous lobes),

the one-sample mixture of the lectures (Veach 1997, 9.2.4) with weights that vary from
point to point.  A *delta* lobe (a smooth mirror or refraction) produces one direction
per wo: it has no density in solid angle, only a probability mass P_k(wo) at that
direction.  Such directions are atoms of the mixed measure (solid angle + counting over
the atoms), as delta lights are: :class:`DeltaDirection`'s ``pdf`` in solid angle is 0,
``is_delta`` is True, and the mass of its atom is 1 (the renderer's shading integrand marks
each sample with its lobe and gives the atom's probability, P_k, to MIS).

``LobeMixture(components, probabilities)``: ``probabilities (..., K)`` broadcast against the
uniforms' leading axes (one set per shading point).  Sampling uses one uniform to pick the
lobe by its CDF, rescales it to [0, 1) and passes it on (as :class:`~.mixture.Mixture`), so
stratification carries over.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .base import Distribution, as_points, as_uniforms

__all__ = ["DeltaDirection", "LobeMixture"]


class DeltaDirection(Distribution):
    """The one direction ``direction (..., 3)`` (a delta lobe): ``sample(u)`` returns it,
    broadcast against ``u``'s leading axes; ``pdf(w)`` is 0 (no density in solid angle; the
    atom's mass, 1, is counted separately); ``invert`` does not exist (no uniform maps to
    a unique value)."""

    dim_u, dim_x, measure = 2, 3, "solid angle"
    is_delta = True

    def __init__(self, direction: np.ndarray):
        self.direction = as_points(direction, 3, "direction")

    def sample(self, u):
        u = as_uniforms(u, 2)
        return np.broadcast_to(self.direction, np.broadcast_shapes(self.direction.shape[:-1], u.shape[:-1]) + (3,))

    def pdf(self, w):
        w = as_points(w, 3, "w")
        return np.zeros(np.broadcast_shapes(w.shape[:-1], self.direction.shape[:-1]), w.dtype)

    def _repr_fields(self):
        return {"direction_shape": self.direction.shape}


class LobeMixture(Distribution):
    """Lobe k with probability ``probabilities[..., k]``, then a direction from ``components[k]``.

    ``components``: distributions of directions (``dim_u`` <= 2 each; delta lobes are
    :class:`DeltaDirection`); ``probabilities``: ``(..., K)``, finite, >= 0, normalised here
    along the last axis (rows of zeros stay zero: such points sample nothing, density 0).
    ``sample`` returns directions; ``sample_lobe`` also the chosen lobe's index;
    ``pdf`` is the continuous density sum_k P_k p_k (delta lobes add none);
    ``lobe_probability(k)`` is P_k, the mass of lobe k's atom when it is a delta lobe.
    """

    dim_x, measure = 3, "solid angle"

    def __init__(self, components: Sequence, probabilities):
        self.components = list(components)
        if not self.components:
            raise ValueError("components: expected at least one lobe")
        p = np.asarray(probabilities, dtype=float)
        if p.ndim == 0 or p.shape[-1] != len(self.components):
            raise ValueError(f"probabilities: expected (..., {len(self.components)}), got shape {p.shape}")
        if not np.all(np.isfinite(p)) or np.any(p < 0):
            raise ValueError("probabilities: must be finite and >= 0")
        total = p.sum(-1, keepdims=True)
        self.probabilities = np.divide(p, total, out=np.zeros_like(p), where=total > 0)
        self.dim_u = max(2, max(int(c.dim_u) for c in self.components))
        self.delta = np.array([bool(getattr(c, "is_delta", False)) for c in self.components])

    def lobe_probability(self, k: int) -> np.ndarray:
        """P_k (...,): the probability of lobe k (the mass of its atom for a delta lobe)."""
        return self.probabilities[..., k]

    def sample_lobe(self, u) -> tuple[np.ndarray, np.ndarray]:
        """``(wi (..., 3), k (...))``: the lobe chosen by u0 and a direction from it."""
        u = as_uniforms(u, self.dim_u)
        cdf = np.cumsum(self.probabilities, -1)
        u0 = u[..., 0]
        k = np.minimum(np.sum(u0[..., None] >= cdf, -1), len(self.components) - 1)
        # the empty lobes' intervals have zero width: a u0 on their edge moves to the next lobe
        width = np.take_along_axis(np.broadcast_to(self.probabilities, k.shape + (len(self.components),)),
                                   k[..., None], -1)[..., 0]
        lo = np.take_along_axis(np.broadcast_to(cdf, k.shape + (len(self.components),)), k[..., None], -1)[..., 0] - width
        u0 = np.clip((u0 - lo) / np.where(width > 0, width, 1.0), 0.0, np.nextafter(1.0, 0.0)).astype(u.dtype)
        u = np.concatenate([u0[..., None], u[..., 1:]], -1)
        out = None
        for i, c in enumerate(self.components):
            sel = k == i
            if not sel.any():
                continue
            x = np.asarray(c.sample(u[..., : c.dim_u]))
            out = np.where(sel[..., None], x, 0.0 if out is None else out)
        if out is None:
            out = np.zeros(k.shape + (3,), u.dtype)
        return out, k

    def sample(self, u):
        return self.sample_lobe(u)[0]

    def pdf(self, w):
        w = as_points(w, 3, "w")
        total = 0.0
        for i, c in enumerate(self.components):
            if not self.delta[i]:
                total = total + self.probabilities[..., i] * np.asarray(c.pdf(w))
        return np.broadcast_to(total, np.broadcast_shapes(np.shape(total), w.shape[:-1], self.probabilities.shape[:-1]))

    def _repr_fields(self):
        return {"components": self.components, "probabilities_shape": self.probabilities.shape}
