"""``as_integrand``: what estimators accept as an integrand, an ``Integrand`` or a catalogue name
(apart from :mod:`vrlab.integrands.base` so that the catalogue, which builds on the base, is
imported by this module only: no import circle)."""
from __future__ import annotations

from typing import Any

from .base import Integrand
from .catalogue import CATALOGUE, get

__all__ = ["as_integrand"]


def as_integrand(integrand: Any, name: str = "integrand") -> Integrand:
    """``integrand`` if it is an :class:`Integrand`; a catalogue name gives that catalogue
    integrand; anything else is a ``TypeError`` that says how to wrap a function."""
    if isinstance(integrand, Integrand):
        return integrand
    if isinstance(integrand, str):
        if integrand not in CATALOGUE:
            raise ValueError(f"{name}: unknown catalogue integrand {integrand!r}; choose from {', '.join(CATALOGUE)}")
        return get(integrand)
    hint = (" (wrap a function with its domain: vrlab.Integrand(f, [(0, 1)]))" if callable(integrand) else "")
    raise TypeError(f"{name}: expected a vrlab.Integrand or a catalogue name, got {type(integrand).__name__}{hint}")
