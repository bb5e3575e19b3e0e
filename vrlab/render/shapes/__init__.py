"""Shape elements, one module per Mitsuba 3 plugin (``rectangle``, ``disk``, ``sphere``,
``cube``, ``cylinder``, ``obj``, ``ply``, ``serialized``, ``shapegroup``, ``instance``) and
vrlab's ``ellipsoid``; the base class :class:`Shape` and the primitive parts the ray tracer
intersects live in :mod:`.base`.  Names are imported from their modules on first use."""
from ..registry import lazy_package

__getattr__, __dir__ = lazy_package(__name__)
