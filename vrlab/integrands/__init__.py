"""Integrands: the ``Integrand`` type and a catalogue of lab integrands with closed forms."""
from .base import Integrand, checked_values
from .lookup import as_integrand
from .catalogue import CATALOGUE, GlossyLight, get, names
from .theory import mc_variance

__all__ = ["CATALOGUE", "GlossyLight", "Integrand", "as_integrand", "checked_values", "get", "mc_variance", "names"]
