"""Integrator elements: ``direct``, ``path``/``volpath`` (depth 1 or 2) and ``moment``.
Names are imported from their modules on first use."""
from ..registry import lazy_package

__getattr__, __dir__ = lazy_package(__name__)
