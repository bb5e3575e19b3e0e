"""Texture elements (Mitsuba 3 ``bitmap``, ``checkerboard``, ``mesh_attribute``), their base
:class:`Texture`, the :class:`SurfacePoints` they are evaluated at, and
:class:`ConstantTexture` (a plain colour as a texture)."""
from .base import LUMINANCE, ConstantTexture, SurfacePoints, Texture, as_texture, surface_points, uv_transform
from .bitmap import BitmapTexture
from .checkerboard import Checkerboard
from .mesh_attribute import MeshAttribute

__all__ = ["LUMINANCE", "BitmapTexture", "Checkerboard", "ConstantTexture", "MeshAttribute", "SurfacePoints",
           "Texture", "as_texture", "surface_points", "uv_transform"]
