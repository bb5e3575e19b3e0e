"""BSDF elements, one module per Mitsuba 3 plugin (``diffuse``, ``roughconductor``,
``twosided``) and vrlab's ``phong``; the base class :class:`BSDFModel` and the shared
conventions (local frame, ``eval`` = f cos, ``pdf`` on the whole sphere) are in
:mod:`.base`."""
from .base import BSDFDirections, BSDFModel, mirror, reflect
from .diffuse import Diffuse
from .phong import Phong
from ...distributions import Beckmann
from .roughconductor import RoughConductor
from .twosided import TwoSided

__all__ = ["BSDFDirections", "BSDFModel", "Beckmann", "Diffuse", "Phong", "RoughConductor", "TwoSided", "mirror",
           "reflect"]
