"""``blendbsdf``: a linear blend of two BSDFs (Mitsuba 3 ``blendbsdf``).

    f = (1 - w) f_0 + w f_1,   w = ``weight`` in [0, 1] (a number or a texture),

sampled as the mixture it is: BSDF 1 with probability w, BSDF 0 with 1 - w, then that BSDF's
own lobe choice, so the blend's lobes are the nested ones, named ``"0.<lobe>"`` and
``"1.<lobe>"`` (techniques ``"bsdf:0.diffuse"``...), with probabilities w_i P_ik(wo) and

    p(wi) = (1 - w) p_0(wi) + w p_1(wi)

(a :class:`~vrlab.distributions.LobeMixture` of the nested lobes).  A nested delta lobe's
value is scaled by its BSDF's blend weight.  As in Mitsuba, the lobe uniform u0 picks BSDF 1
when u0 <= w and BSDF 0 otherwise; Mitsuba passes a third uniform on for the direction,
vrlab reuses the rescaled u0 (as every :class:`~vrlab.distributions.LobeMixture`: two
uniforms per BSDF sample), so the same uniforms give different directions but the same
distribution.  Mitsuba's ``sample`` reports the nested BSDF's own pdf and weight; vrlab
reports the blend's, the density of what is sampled, which MIS needs (Mitsuba's ``pdf`` is
the blend's too).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ...distributions.base import as_points
from ..registry import register
from .base import FRAME_VALUES, BSDFModel, check_lobe_mixture, dirs

__all__ = ["BlendBSDF"]


def _weight(value: Any):
    from ..textures import Texture

    if isinstance(value, Texture):
        return value
    w = checks.finite_array(value, "weight")
    if np.any(w < 0) or np.any(w > 1):
        raise ValueError(f"weight: expected values in [0, 1], got {value!r}")
    return float(w) if w.ndim == 0 else w


@register("bsdf", "blendbsdf")
class BlendBSDF(BSDFModel):
    """``BlendBSDF(bsdf0, bsdf1, weight=0.5)`` (see the module docstring)."""

    def __init__(self, bsdf0: BSDFModel, bsdf1: BSDFModel, weight: Any = 0.5):
        for name, b in (("bsdf0", bsdf0), ("bsdf1", bsdf1)):
            if not isinstance(b, BSDFModel):
                raise TypeError(f"{name} must be a vrlab.render BSDF element, got {checks.describe(b)}")
            if b.twosided:
                raise ValueError(f"{name}: a twosided BSDF inside blendbsdf is not supported; make the blend twosided")
            check_lobe_mixture(b, name)
        self.bsdf0, self.bsdf1 = bsdf0, bsdf1
        self.weight = _weight(weight)

    @classmethod
    def from_props(cls, p) -> "BlendBSDF":
        nested = p.children("bsdf")
        if len(nested) != 2:
            raise ValueError(f"bsdf: blendbsdf needs exactly two nested BSDFs, got {len(nested)}")
        return cls(nested[0], nested[1], p.scalar("weight", 0.5))

    # -- the nested BSDFs' lobes, in sampling order: BSDF 1's first (u0 <= w picks it) ------
    @property
    def parts(self) -> tuple:
        return ((1, self.bsdf1), (0, self.bsdf0))

    @property
    def LOBES(self) -> tuple:  # noqa: N802 - the class constant of the other BSDFs
        return tuple(f"{i}.{name}" for i, b in self.parts for name in b.LOBES)

    @property
    def DELTA(self) -> tuple:  # noqa: N802
        return tuple(f"{i}.{name}" for i, b in self.parts for name in b.DELTA)

    def _split(self, name: str) -> tuple[BSDFModel, str, int]:
        self._check_lobe(name)
        i, inner = name.split(".", 1)
        return (self.bsdf1 if i == "1" else self.bsdf0), inner, int(i)

    def _w(self, shape: tuple) -> np.ndarray:
        """The blend weight broadcast to the directions' leading shape."""
        return np.broadcast_to(np.asarray(self.weight, float), shape)

    def lobe_probabilities(self, wo):
        wo = as_points(wo, 3, "wo")
        w = self._w(wo.shape[:-1])[..., None]
        return np.concatenate([w * self.bsdf1.lobe_probabilities(wo), (1 - w) * self.bsdf0.lobe_probabilities(wo)], -1)

    def lobe(self, name, wo):
        bsdf, inner, _ = self._split(name)
        return bsdf.lobe(inner, wo)

    def delta_value(self, name, wo):
        bsdf, inner, i = self._split(name)
        wi, value = bsdf.delta_value(inner, wo)
        w = self._w(np.shape(value)[:-1])[..., None]
        return wi, value * (w if i == 1 else 1 - w)

    # -- values ---------------------------------------------------------------------------
    def f(self, wo, wi):
        wo, wi = dirs(wo, wi)
        w = self._w(np.broadcast_shapes(wo.shape[:-1], wi.shape[:-1]))[..., None]
        return (1 - w) * self.bsdf0.f(wo, wi) + w * self.bsdf1.f(wo, wi)

    def eval(self, wo, wi):
        wo, wi = dirs(wo, wi)
        w = self._w(np.broadcast_shapes(wo.shape[:-1], wi.shape[:-1]))[..., None]
        return ((1 - w) * self.bsdf0.eval(wo, wi) + w * self.bsdf1.eval(wo, wi)).astype(wo.dtype, copy=False)

    def pdf(self, wo, wi):
        wo, wi = dirs(wo, wi)
        w = self._w(np.broadcast_shapes(wo.shape[:-1], wi.shape[:-1]))
        return ((1 - w) * self.bsdf0.pdf(wo, wi) + w * self.bsdf1.pdf(wo, wi)).astype(wo.dtype, copy=False)

    def _sample_direction(self, wo, u):
        return self.distribution(wo).sample(u)

    def distribution(self, wo):
        from ...distributions.lobes import LobeMixture

        wo = as_points(wo, 3, "wo")
        return LobeMixture([self.lobe(name, wo) for name in self.LOBES], self.lobe_probabilities(wo))

    def sample(self, wo, u):
        if self.DELTA:
            return super().sample(wo, u)
        wo = as_points(wo, 3, "wo")
        wi = self._sample_direction(wo, u)
        p, val = self.pdf(wo, wi), self.eval(wo, wi)
        pos = (p > 0)[..., None]
        return wi, np.where(pos, val / np.where(pos, p[..., None], 1.0), 0.0), p

    def diffuse_albedo(self):
        if not isinstance(self.weight, float):
            return np.zeros(3)
        return (1 - self.weight) * np.asarray(self.bsdf0.diffuse_albedo()) + \
            self.weight * np.asarray(self.bsdf1.diffuse_albedo())

    def is_black(self) -> bool:
        return self.bsdf0.is_black() and self.bsdf1.is_black()

    # -- textures: the weight's and the nested BSDFs' (as "0.<name>", "1.<name>") ----------
    @property
    def textures(self) -> dict:
        from ..textures import Texture

        out = {"weight": self.weight} if isinstance(self.weight, Texture) else {}
        for i, b in ((0, self.bsdf0), (1, self.bsdf1)):
            out.update({f"{i}.{k}": v for k, v in b.textures.items()})
        return out

    @property
    def SCALAR_TEXTURES(self) -> tuple:  # noqa: N802
        return ("weight",) + tuple(f"{i}.{k}" for i, b in ((0, self.bsdf0), (1, self.bsdf1))
                                   for k in b.SCALAR_TEXTURES)

    @property
    def reciprocal(self) -> bool:
        return self.bsdf0.reciprocal and self.bsdf1.reciprocal

    @property
    def needs_tangents(self) -> bool:
        return self.bsdf0.needs_tangents or self.bsdf1.needs_tangents

    @property
    def dim_u(self) -> int:
        return max(int(self.bsdf0.dim_u), int(self.bsdf1.dim_u))

    @property
    def GRADIENT_TEXTURES(self) -> tuple:  # noqa: N802
        return tuple(f"{i}.{k}" for i, b in ((0, self.bsdf0), (1, self.bsdf1)) for k in b.GRADIENT_TEXTURES)

    def at(self, values: dict) -> "BlendBSDF":
        own = {k: v for k, v in values.items() if "." not in k}
        frame = {k: v for k, v in own.items() if k in FRAME_VALUES}   # both nested BSDFs' frame
        nested = [{**frame, **{k.split(".", 1)[1]: v for k, v in values.items() if k.startswith(f"{i}.")}}
                  for i in (0, 1)]
        out = BlendBSDF(self.bsdf0.at(nested[0]) if nested[0] else self.bsdf0,
                        self.bsdf1.at(nested[1]) if nested[1] else self.bsdf1, self.weight)
        if "weight" in own:
            out.weight = np.clip(np.asarray(own["weight"], float), 0.0, 1.0)
        return out

    def key(self) -> tuple:
        return (BlendBSDF, repr(self.weight) if isinstance(self.weight, float) else id(self.weight),
                self.bsdf0.key(), self.bsdf1.key())

    def validate(self) -> None:
        self.bsdf0.validate()
        self.bsdf1.validate()

    def _repr_fields(self):
        return {"bsdf0": self.bsdf0, "bsdf1": self.bsdf1, "weight": self.weight}
