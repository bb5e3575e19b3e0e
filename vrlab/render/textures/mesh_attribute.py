"""``mesh_attribute``: a mesh's per-vertex or per-face attribute as a texture (Mitsuba 3
``mesh_attribute``, src/textures/mesh_attribute.cpp, and ``Mesh::interpolate_attribute``,
include/mitsuba/render/mesh.h).

* ``name`` ``"vertex_<x>"``: interpolated over the triangle hit with its barycentric
  coordinates, value = (1 - b1 - b2) a[f0] + b1 a[f1] + b2 a[f2] for the face
  (f0, f1, f2) = ``faces[prim]`` (Mitsuba computes b1, b2 from the hit point; a
  :class:`.base.SurfacePoints` carries them in ``bary``);
* ``name`` ``"face_<x>"``: the value of the face hit, a[prim];
* the value is multiplied by ``scale`` (default 1).

An attribute has 1 or 3 channels (Mitsuba's ``add_attribute`` sizes that textures read):
``eval`` repeats a one-channel value into RGB, ``eval_1`` needs a one-channel attribute
(Mitsuba raises for a 3-channel one, as here).  Mitsuba's ``mean()`` is not defined for
this texture (it depends on the mesh), nor is it here.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ..registry import register
from .base import Texture, surface_points

__all__ = ["MeshAttribute"]


@register("texture", "mesh_attribute")
class MeshAttribute(Texture):
    """The mesh attribute ``name`` (``"vertex_*"`` or ``"face_*"``) times ``scale``."""

    def __init__(self, name: str, scale: float = 1.0):
        if not isinstance(name, str):
            raise TypeError(f"name must be a string starting with 'vertex_' or 'face_', got {checks.describe(name)}")
        if not (name.startswith("vertex_") or name.startswith("face_")) or name in ("vertex_", "face_"):
            raise ValueError(f"name: {name!r} is not a mesh attribute name; it must start with 'vertex_' "
                             "(interpolated per vertex) or 'face_' (per face)")
        self.name = name
        self.scale = checks.real(scale, "scale")
        self.per_vertex = name.startswith("vertex_")

    @classmethod
    def from_props(cls, p) -> "MeshAttribute":
        return cls(p.string("name"), p.float("scale", 1.0))

    def values(self, si: Any) -> np.ndarray:
        """The attribute at the points ``si`` times ``scale``: ``(N, k)``, k = 1 or 3.

        ``ValueError`` naming ``name`` when ``si.shape`` has no such attribute or one of
        another width, naming ``si.prim`` / ``si.bary`` when those are missing or out of range."""
        si = surface_points(si)
        kind = "vertex" if self.per_vertex else "face"
        attrs = getattr(si.shape, f"{kind}_attributes", None)
        if attrs is None:
            raise ValueError(f"si.shape: mesh_attribute {self.name!r} needs the mesh hit (an object with "
                             f"{kind}_attributes and faces), got {checks.describe(si.shape)}")
        if self.name not in attrs:
            have = ", ".join(sorted(attrs)) or "none"
            raise ValueError(f"name: the mesh has no {kind} attribute {self.name!r} (its {kind} attributes: {have})")
        a = np.asarray(attrs[self.name], dtype=float)
        if a.ndim == 1:
            a = a[:, None]
        faces = np.asarray(si.shape.faces)
        verts = getattr(si.shape, "vertices", None)
        rows = len(faces) if not self.per_vertex else None if verts is None else len(verts)
        if a.ndim != 2 or a.shape[1] not in (1, 3) or (rows is not None and len(a) != rows):
            raise ValueError(f"name: the attribute {self.name!r} has shape {a.shape}; mesh_attribute reads "
                             f"(n, 1) or (n, 3) with one row per {kind}")
        if si.prim is None:
            raise ValueError(f"si.prim: mesh_attribute {self.name!r} needs the index of the triangle hit")
        prim = si.prim
        if len(prim) and (prim.min() < 0 or prim.max() >= len(faces)):
            raise ValueError(f"si.prim: triangle indices must lie in [0, {len(faces) - 1}], "
                             f"got {prim.min()} to {prim.max()}")
        if not self.per_vertex:
            return a[prim] * self.scale
        if si.bary is None:
            raise ValueError(f"si.bary: mesh_attribute {self.name!r} needs the barycentric coordinates of the hit")
        f = faces[prim]
        b1, b2 = si.bary[:, :1], si.bary[:, 1:]
        return ((1 - b1 - b2) * a[f[:, 0]] + b1 * a[f[:, 1]] + b2 * a[f[:, 2]]) * self.scale

    def eval(self, si: Any) -> np.ndarray:
        """RGB ``(N, 3)`` (a one-channel attribute repeated into the three channels)."""
        v = self.values(si)
        return np.repeat(v, 3, axis=1) if v.shape[1] == 1 else v

    def eval_1(self, si: Any) -> np.ndarray:
        """``(N,)`` of a one-channel attribute (``ValueError`` naming ``name`` for three)."""
        v = self.values(si)
        if v.shape[1] != 1:
            raise ValueError(f"name: the attribute {self.name!r} has 3 channels; a scalar (eval_1) lookup "
                             "needs a one-channel attribute, as in Mitsuba")
        return v[:, 0]

    def mean(self) -> np.ndarray:
        """Not defined (``NotImplementedError``), as in Mitsuba: it depends on the mesh."""
        raise NotImplementedError(f"mesh_attribute {self.name!r}: the mean depends on the mesh; "
                                  "Mitsuba 3 does not define it either (Texture::mean)")

    def mean_1(self) -> float:
        """Not defined (``NotImplementedError``), as :meth:`mean`."""
        return float(self.mean()[0])

    def __repr__(self) -> str:
        return f"MeshAttribute(name={self.name!r}, scale={self.scale})"
