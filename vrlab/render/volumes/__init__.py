"""Volume elements (``gridvolume``, ``constvolume``): 3D data looked up at world-space points,
which the ``volume`` texture (:mod:`vrlab.render.textures.volume`) reads at surface points;
the base :class:`Volume`.  Names are imported from their modules on first use."""
from ..registry import lazy_package

__getattr__, __dir__ = lazy_package(__name__)
