"""Emitter elements, one module per Mitsuba 3 plugin (``area``); the base :class:`Emitter`."""
from .area import AreaEmitter
from .base import Emitter

__all__ = ["AreaEmitter", "Emitter"]
