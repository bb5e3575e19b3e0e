"""BSDF elements, one module per Mitsuba 3 plugin (``diffuse``, ``conductor``,
``roughconductor``, ``plastic``, ``roughplastic``, ``dielectric``, ``roughdielectric``,
``thindielectric``, ``principled``, ``principledthin``, ``blendbsdf``, ``mask``, ``normalmap``,
``bumpmap``, ``twosided``) and vrlab's
``phong``; the base class :class:`BSDFModel` and the shared
conventions (local frame, ``eval`` = f cos, ``pdf`` on the whole sphere) are in
:mod:`.base`.  Names are imported from their modules on first use."""
from ..registry import lazy_package

__getattr__, __dir__ = lazy_package(__name__)
