"""Emitter elements, one module per Mitsuba 3 plugin: ``area`` (on a shape), ``point``,
``spot``, ``directional``, ``constant``, ...; the base :class:`Emitter` documents how delta
lights and lights at infinity enter the direct-lighting integral.  Names are imported from
their modules on first use."""
from ..registry import lazy_package

__getattr__, __dir__ = lazy_package(__name__)
