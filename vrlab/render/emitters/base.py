"""The base of emitter elements."""
from __future__ import annotations

from ..registry import Element

__all__ = ["Emitter"]


class Emitter(Element):
    """Base of the emitter elements.  ``is_area``: attached to a shape (``area``)."""

    kind = "emitter"
    is_area = False

    @property
    def type(self) -> str:
        """The Mitsuba plugin name."""
        return self.plugin_name
