"""Sensor elements (``perspective``, ``orthographic``) with their films (``hdrfilm``),
reconstruction filters (``box``, ``tent``, ``gaussian``) and samplers (``independent``,
``stratified``, ``multijitter``, ``orthogonal``, ``ldsampler``); bases in :mod:`.base`."""
from .base import Film, ReconstructionFilter, Sampler, Sensor
from .filters import BoxFilter, GaussianFilter, TentFilter
from .hdrfilm import HDRFilm
from .orthographic import OrthographicCamera
from .perspective import PerspectiveCamera
from .samplers import (IndependentSampler, LowDiscrepancySampler, MultijitterSampler, OrthogonalSampler,
                       StratifiedSampler)

__all__ = ["BoxFilter", "Film", "GaussianFilter", "HDRFilm", "IndependentSampler", "LowDiscrepancySampler",
           "MultijitterSampler", "OrthogonalSampler", "OrthographicCamera", "PerspectiveCamera",
           "ReconstructionFilter", "Sampler", "Sensor", "StratifiedSampler", "TentFilter"]
