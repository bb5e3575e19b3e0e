"""``bumpmap``: a BSDF evaluated in a shading frame tilted by the gradient of a height texture
(Mitsuba 3 ``bumpmap``; Blinn 1978, "Simulation of Wrinkled Surfaces").

With the height h = ``scale`` x the texture's ``eval_1`` and its uv gradient (h_u, h_v)
(:meth:`~vrlab.render.textures.Texture.eval_1_grad`), the surface is displaced along the
shading normal n; its tangents become

    dp_du' = dp_du + (h_u - n . dp_du) n,   dp_dv' = dp_dv + (h_v - n . dp_dv) n

(Mitsuba's form: the tangents' normal components are replaced by the gradient), the tilted
normal is n' = normalize(dp_du' x dp_dv'), turned to the side of the geometric normal, and
the nested BSDF is evaluated in the frame of n' exactly as :mod:`~vrlab.render.bsdfs.normalmap`
does (s' from the local x axis, the side test, the mirrored normal for back-facing views, the terminator
term).  All in the local shading frame, where n = +z: the renderer passes the local dp_du,
dp_dv and geometric normal of every point (``needs_tangents``).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ..registry import register
from .base import BSDFModel
from .normalmap import NormalMap

__all__ = ["BumpMap"]

_X, _Y, _Z = np.eye(3)


@register("bsdf", "bumpmap")
class BumpMap(NormalMap):
    """``BumpMap(bsdf, texture, scale=1)``: ``texture`` a texture with a uv gradient (a
    ``bitmap``; the height), ``scale`` a real (see the module docstring)."""

    TEXTURED = OWN_TEXTURES = OWN_GRADIENTS = ("texture",)
    SIGNED_PARAMS = ("scale",)       # a negative scale turns the bumps into dents

    def __init__(self, bsdf: BSDFModel, texture: Any, scale: float = 1.0):
        from ..textures import Texture

        if not isinstance(bsdf, BSDFModel):
            raise TypeError(f"bsdf must be a vrlab.render BSDF element, got {checks.describe(bsdf)}")
        if not isinstance(texture, Texture):
            raise TypeError(f"texture must be a vrlab.render texture element, got {checks.describe(texture)}")
        self.inner, self.texture = bsdf, texture
        self.scale = checks.real(scale, "scale")
        self.grad = np.zeros(2)                  # the renderer passes each point's gradient (``at``)
        self.dp_du, self.dp_dv, self.n_geo = _X, _Y, _Z

    @classmethod
    def from_props(cls, p) -> "BumpMap":
        inner = p.children("bsdf")
        if len(inner) != 1:
            raise ValueError(f"bsdf: bumpmap needs exactly one nested BSDF, got {len(inner)}")
        textures = p.children("texture")
        if len(textures) != 1:
            raise ValueError(f"texture: bumpmap needs exactly one nested texture, got {len(textures)}")
        return cls(inner[0], textures[0], p.float("scale", 1.0))

    def tilted_normal(self) -> np.ndarray:
        g = self.scale * np.asarray(self.grad, np.float64)
        du, dv = (np.asarray(a, np.float64) for a in (self.dp_du, self.dp_dv))
        du = du + (g[..., 0] - du[..., 2])[..., None] * _Z
        dv = dv + (g[..., 1] - dv[..., 2])[..., None] * _Z
        n = np.cross(du, dv)
        n = n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-30)
        flip = np.sum(n * np.asarray(self.n_geo, np.float64), -1, keepdims=True) < 0
        return np.where(flip, -n, n)

    def at(self, values: dict) -> "BumpMap":
        out = BumpMap.__new__(BumpMap)
        out.inner = self.nested_at(values)
        out.texture, out.scale = self.texture, self.scale
        out.grad = values.get("texture", self.grad)
        out.dp_du, out.dp_dv = values.get("dp_du", self.dp_du), values.get("dp_dv", self.dp_dv)
        out.n_geo = values.get("n_geo", self.n_geo)
        return out

    def key(self) -> tuple:
        return (BumpMap, id(self.texture), self.scale, self.inner.key())

    def _repr_fields(self):
        return {"bsdf": self.inner, "texture": self.texture, "scale": self.scale}
