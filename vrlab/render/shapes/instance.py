"""``instance`` (Mitsuba 3): a referenced ``shapegroup`` placed by ``to_world``.  vrlab
places a transformed copy of each of the group's shapes in the scene (x_world =
to_world @ x_group): the image is the same as with Mitsuba's instancing; only the memory of
very large instanced meshes differs."""
from __future__ import annotations

import copy

from ..registry import register
from .base import Shape, shape_matrix
from .shapegroup import ShapeGroup

__all__ = ["Instance"]


@register("shape", "instance")
class Instance(Shape):
    """``Instance(group, to_world=None)``: the shapes of ``group`` (a :class:`ShapeGroup`) under
    ``to_world``."""

    top_level_shape = True

    def __init__(self, group: ShapeGroup, *, to_world=None, id: str | None = None):
        super().__init__(to_world=to_world, id=id)
        if not isinstance(group, ShapeGroup):
            raise TypeError(f"group must be a shapegroup element (a <ref id> to a <shape type=\"shapegroup\">), "
                            f"got {type(group).__name__}")
        self.group = group

    @classmethod
    def from_props(cls, p) -> "Instance":
        groups = p.children("shape")
        if len(groups) != 1:
            raise ValueError(f"group: an instance needs exactly one nested or referenced shapegroup, got {len(groups)}")
        return cls(groups[0], to_world=p.transform("to_world"))

    def scene_shapes(self) -> list:
        """The group's shapes, each a copy under ``to_world`` (checked again)."""
        out = []
        for s in self.group.shapes:
            c = copy.copy(s)
            c.to_world = shape_matrix(self.to_world @ s.to_world)
            c.validate()
            out.append(c)
        return out

    def parts(self) -> list:
        raise ValueError("an instance is placed in a scene through scene_shapes()")

    @property
    def area(self) -> float:
        return float(sum(s.area for s in self.scene_shapes()))
