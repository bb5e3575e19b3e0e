"""Texture elements (``bitmap``, ``checkerboard``, ``mesh_attribute``, ``rawconstant``, ``volume``); the base
:class:`Texture`, the :class:`SurfacePoints` they are evaluated at, and
:class:`ConstantTexture` (a plain colour as a texture).  Names are imported from their
modules on first use."""
from ..registry import lazy_package

__getattr__, __dir__ = lazy_package(__name__)
