"""Estimators: objects holding settings that turn uniforms into an ``Estimate``."""
from .base import BiasWarning, Estimator, point_engine, support_probe, uniform_blocks
from .importance import MonteCarlo

__all__ = ["BiasWarning", "Estimator", "MonteCarlo", "point_engine", "support_probe", "uniform_blocks"]
