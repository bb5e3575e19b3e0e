"""Integrator elements: ``direct``, ``path``/``volpath`` (depth 1 or 2) and ``moment``."""
from .base import Integrator
from .direct import DirectIntegrator
from .moment import MomentIntegrator
from .path import PathIntegrator, VolumetricPathIntegrator

__all__ = ["DirectIntegrator", "Integrator", "MomentIntegrator", "PathIntegrator", "VolumetricPathIntegrator"]
