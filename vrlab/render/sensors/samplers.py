"""Mitsuba 3's samplers as vrlab point sets of the pixels' primary sample space.

Every sampler gives the sensor its ``sample_count`` (spp).  The sample pattern is a
variance choice, not an image choice (every one is unbiased), so vrlab plays each part
with a point set of its own (:class:`vrlab.points.SetSampler`), used by ``render`` when
no ``points=`` is given:

=================  ==============================================================
Mitsuba            vrlab point set
=================  ==============================================================
``independent``    i.i.d. uniforms (``None``)
``stratified``     ``"stratified"``: padded jittered strata per pair of dimensions
``multijitter``    ``"stratified"`` (Mitsuba's correlated multi-jitter is also a
                   jittered grid per dimension pair)
``orthogonal``     ``"lhs"``: Latin hypercube copies (an orthogonal array of
                   strength 1 is a Latin hypercube)
``ldsampler``      ``"sobol"``: shifted copies of a Sobol' set (Mitsuba's is a
                   scrambled (0, 2)-sequence per dimension pair)
=================  ==============================================================

``seed`` is read and checked; vrlab's randomness comes from ``render(rng=...)``.
Mitsuba's ``jitter`` (stratified, multijitter) and ``strength`` (orthogonal) are read.
"""
from __future__ import annotations

from ..registry import register
from .base import Sampler

__all__ = ["IndependentSampler", "LowDiscrepancySampler", "MultijitterSampler", "OrthogonalSampler",
           "StratifiedSampler"]


@register("sampler", "independent")
class IndependentSampler(Sampler):
    """``independent``: i.i.d. uniforms."""


class _Jittered(Sampler):
    @classmethod
    def from_props(cls, p) -> Sampler:
        p.bool("jitter", True)
        return super().from_props(p)


@register("sampler", "stratified")
class StratifiedSampler(_Jittered):
    """``stratified``: padded jittered strata."""
    points = "stratified"


@register("sampler", "multijitter")
class MultijitterSampler(_Jittered):
    """``multijitter``: padded jittered strata."""
    points = "stratified"


@register("sampler", "orthogonal")
class OrthogonalSampler(Sampler):
    """``orthogonal``: Latin hypercube copies."""
    points = "lhs"

    @classmethod
    def from_props(cls, p) -> Sampler:
        p.bool("jitter", True)
        strength = p.int("strength", 2)
        if strength < 1:
            raise ValueError(f"strength must be >= 1, got {strength}")
        return super().from_props(p)


@register("sampler", "ldsampler")
class LowDiscrepancySampler(Sampler):
    """``ldsampler``: shifted Sobol' copies."""
    points = "sobol"
