"""``shapegroup`` (Mitsuba 3): shapes defined once (with an ``id``) and placed by ``instance``
shapes; the group itself is not part of the scene.  Its shapes keep their BSDFs; emitters
inside a group are refused (Mitsuba does not instance emitters either)."""
from __future__ import annotations

from ..registry import register
from .base import Shape

__all__ = ["ShapeGroup"]


@register("shape", "shapegroup")
class ShapeGroup(Shape):
    """``ShapeGroup(shapes)``: a list of shape elements (not groups, not emitters)."""

    top_level_shape = False

    def __init__(self, shapes: list, id: str | None = None):
        super().__init__(id=id)
        shapes = list(shapes)
        if not shapes:
            raise ValueError("shapes: a shapegroup needs at least one nested <shape>")
        for k, s in enumerate(shapes):
            if not isinstance(s, Shape) or isinstance(s, ShapeGroup):
                raise TypeError(f"shapes[{k}] must be a shape element (not a shapegroup), got {type(s).__name__}")
            if s.emitter is not None:
                raise ValueError(f"shapes[{k}]: a shapegroup cannot hold emitters (as in Mitsuba)")
        self.shapes = shapes

    @classmethod
    def from_props(cls, p) -> "ShapeGroup":
        return cls(p.children("shape"))

    def scene_shapes(self) -> list:
        return []

    def parts(self) -> list:
        return []

    @property
    def area(self) -> float:
        return float(sum(s.area for s in self.shapes))
