"""``area`` (Mitsuba 3): a diffuse emitter on the surface of the shape that carries it,
radiance L_e(x, w) = ``radiance`` towards the side its normal faces (one-sided); ``radiance``
may be a texture, looked up at the shape's uv as Mitsuba does (light selection by power then
uses its mean).  On a triangle mesh, the ``"light"`` technique picks a triangle by area and
then either a point uniformly on it, converted to solid angle (``triangle_sampling="area"``,
the default, as Mitsuba) or a direction uniformly in the spherical triangle it subtends
(``"spherical"``, Arvo 1995): a vrlab parameter, settable in Python or in the scene file
(which Mitsuba then refuses)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ..registry import register
from ..scene_checks import rgb
from .base import Emitter, weight_param

__all__ = ["AreaEmitter"]


@register("emitter", "area")
class AreaEmitter(Emitter):
    """``AreaEmitter(radiance)``: one number or RGB, finite, >= 0 (stored as ``(3,)``)."""

    is_area = True

    TRIANGLE_SAMPLING = ("area", "spherical")

    def __init__(self, radiance: Any, sampling_weight: float = 1.0, triangle_sampling: str = "area"):
        from ... import checks

        self.radiance = _radiance(radiance)
        self.sampling_weight = weight_param(sampling_weight)
        self.triangle_sampling = checks.choice(triangle_sampling, "triangle_sampling", self.TRIANGLE_SAMPLING)

    @classmethod
    def from_props(cls, p) -> "AreaEmitter":
        return cls(p.texture("radiance", kind="emission"), p.float("sampling_weight", 1.0),
                   p.string("triangle_sampling", "area", cls.TRIANGLE_SAMPLING))

    def validate(self) -> None:
        self.radiance = _radiance(self.radiance)

    @property
    def texture(self):
        """The radiance texture, or None for a constant radiance."""
        from ..textures import Texture

        return self.radiance if isinstance(self.radiance, Texture) else None

    @property
    def mean_radiance(self) -> np.ndarray:
        """The radiance (3,), or its texture's mean over uv."""
        tex = self.texture
        return self.radiance if tex is None else np.asarray(tex.mean(), float)

    def __repr__(self) -> str:
        r = self.radiance if self.texture is not None else np.asarray(self.radiance).tolist()
        return f"AreaEmitter(radiance={r})"


def _radiance(value: Any):
    from ..textures import Texture

    return value if isinstance(value, Texture) else rgb(value, "radiance")
