"""Sensor elements (``perspective``, ``thinlens``, ``orthographic``) with their films (``hdrfilm``),
reconstruction filters (``box``, ``tent``, ``gaussian``) and samplers (``independent``,
``stratified``, ``multijitter``, ``orthogonal``, ``ldsampler``); bases in :mod:`.base`.
Names are imported from their modules on first use."""
from ..registry import lazy_package

__getattr__, __dir__ = lazy_package(__name__)
