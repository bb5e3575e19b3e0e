"""``normalmap``: a BSDF evaluated in a shading frame tilted by a normal map (Mitsuba 3
``normalmap``).

The texture ``normalmap`` (a ``bitmap`` read with ``raw=true``) holds, per point, a normal
in the local shading frame (s along dp/du, t = n x s, n), encoded as c = (n' + 1) / 2.  The
tilted frame is

    n' = normalize(2 c - 1),  s' = normalize(x - n' (n' . x)),  t' = n' x s',

with x = (1, 0, 0) the shading frame's own s (dp/du made orthogonal to the shading normal):
Mitsuba 3.9.1's ``PerturbedBSDF::frames`` (src/bsdfs/perturbed_bsdf.h) builds s' from the
local x axis, not from the world dp/du (measured through its Python API: changing
``si.dp_du`` leaves its values unchanged).  Only anisotropic nested BSDFs see s'; reading the
world dp/du as local coordinates (Mitsuba 2's frame, vrlab's before) made an anisotropic
rough conductor up to 8 % too bright.

and the nested BSDF is evaluated with both directions expressed in it.  Light arriving from
the other side of the true surface than of the tilted one is cut, as Mitsuba does: eval is 0
unless wi.z and wi'.z have the same sign; where the camera direction lies below the tilted
surface, n' is mirrored about the true normal, (-n'x, -n'y, n'z).  Mitsuba 3.9.1 also multiplies the value by a
shadowing term for the light direction (measured through its Python API: it depends on wi.z
and the tilt only, and is the microfacet-based terminator fix of Conty Estevez, Lecocq &
Stein, "A Microfacet-Based Shadowing Function to Solve the Bump Terminator Problem", Ray
Tracing Gems, 2019, ch. 12):

    G = 2 / (1 + sqrt(1 + alpha^2 tan^2 theta_i)),  alpha^2 = min(1, tan^2(theta_d) / 8),

theta_i the angle of wi to the true normal and theta_d the tilt (angle between n' and +z);
G = 1 without tilt.  The pdf is not scaled (what is sampled does not change).  Sampling draws from the nested BSDF in the tilted
frame and rotates back: a rotation keeps solid angle, so the density of the sampled wi is
the nested pdf at wi' on the whole sphere (vrlab's convention: what the sampler produces,
including directions the side test then cuts; Mitsuba reports 0 there).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ...distributions.base import as_points
from ...distributions.frames import Frame, Oriented, tangent_towards
from ...distributions.lobes import DeltaDirection, LobeMixture
from ..registry import register
from .base import BSDFModel, NestedTextures, color_param, dirs, scale

__all__ = ["NormalMap"]

_X = np.array([1.0, 0.0, 0.0])


@register("bsdf", "normalmap")
class NormalMap(NestedTextures, BSDFModel):
    """``NormalMap(bsdf, normalmap)``: ``normalmap`` a texture (or a constant RGB) of encoded
    normals (see the module docstring)."""

    needs_tangents = True
    reciprocal = False               # the tilted frame depends on wo, the side test on wi
    TEXTURED = OWN_TEXTURES = ("normalmap",)

    def __init__(self, bsdf: BSDFModel, normalmap: Any):
        if not isinstance(bsdf, BSDFModel):
            raise TypeError(f"bsdf must be a vrlab.render BSDF element, got {checks.describe(bsdf)}")
        self.inner = bsdf
        self.normalmap = color_param(normalmap, "normalmap")

    @classmethod
    def from_props(cls, p) -> "NormalMap":
        inner = p.children("bsdf")
        if len(inner) != 1:
            raise ValueError(f"bsdf: normalmap needs exactly one nested BSDF, got {len(inner)}")
        if not p.has("normalmap"):
            raise ValueError("normalmap: the normal map texture is required")
        return cls(inner[0], p.texture("normalmap", kind="unbounded"))

    # -- the tilted frame ---------------------------------------------------------------
    def frame(self, wo: np.ndarray, shape: tuple | None = None) -> Frame:
        """The tilted frames (local coordinates) for camera directions ``wo``, broadcast to
        ``shape`` (default ``wo``'s leading axes).  Where wo lies below the tilted surface,
        the tilted normal is mirrored about the true one, n' -> (-n'x, -n'y, n'z), as Mitsuba
        3.9.1 does (measured through its Python API)."""
        shape = wo.shape[:-1] if shape is None else shape
        n = np.broadcast_to(self.tilted_normal(), shape + (3,))
        below = np.sum(np.asarray(wo, np.float64) * n, -1) <= 0
        if np.any(below):
            n = np.where(below[..., None], n * np.array([-1.0, -1.0, 1.0]), n)
        s = tangent_towards(n, _X)
        t = np.cross(n, s)
        return Frame._trusted(*(np.broadcast_to(a, shape + (3,)) for a in (n, s, t)))

    def tilted_normal(self) -> np.ndarray:
        """The unit tilted normal n' (local coordinates; per point or one for all)."""
        n = 2.0 * np.asarray(self.normalmap, np.float64) - 1.0
        return n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-30)

    def shadowing(self, wi: np.ndarray) -> np.ndarray:
        """The terminator term G of light directions ``wi`` (see the module docstring)."""
        n = self.tilted_normal()
        cos_d2 = n[..., 2] ** 2 / np.maximum(np.sum(n * n, -1), 1e-300)
        alpha2 = np.minimum(1.0, 0.125 * (1.0 - cos_d2) / np.maximum(cos_d2, 1e-300))
        z2 = np.asarray(wi, np.float64)[..., 2] ** 2
        tan2 = (1.0 - z2) / np.maximum(z2, 1e-300)
        return 2.0 / (1.0 + np.sqrt(1.0 + alpha2 * tan2))

    def _tilted(self, wo, wi=None):
        shape = wo.shape[:-1] if wi is None else np.broadcast_shapes(wo.shape[:-1], wi.shape[:-1])
        fr = self.frame(wo, shape)
        return fr, fr.to_local(wo).astype(wo.dtype, copy=False), \
            None if wi is None else fr.to_local(wi).astype(wi.dtype, copy=False)

    # -- values ---------------------------------------------------------------------------
    def eval(self, wo, wi):
        wo, wi = dirs(wo, wi)
        _, wo_t, wi_t = self._tilted(wo, wi)
        v = self.inner.eval(wo_t, wi_t)
        return scale(v, (wi[..., 2] * wi_t[..., 2] > 0) * self.shadowing(wi)).astype(v.dtype, copy=False)

    def f(self, wo, wi):
        wo, wi = dirs(wo, wi)
        c = np.abs(wi[..., 2])
        return scale(self.eval(wo, wi), 1.0 / np.where(c > 0, c, 1.0))

    def pdf(self, wo, wi):
        wo, wi = dirs(wo, wi)
        _, wo_t, wi_t = self._tilted(wo, wi)
        return self.inner.pdf(wo_t, wi_t)

    def _sample_direction(self, wo, u):
        return self.distribution(wo).sample(u)

    @property
    def dim_u(self) -> int:
        return int(self.inner.dim_u)

    # -- lobes: the nested BSDF's, turned into the tilted frame ----------------------------
    @property
    def LOBES(self) -> tuple:  # noqa: N802
        return self.inner.LOBES

    @property
    def DELTA(self) -> tuple:  # noqa: N802
        return self.inner.DELTA

    def lobe_probabilities(self, wo):
        wo = as_points(wo, 3, "wo")
        return self.inner.lobe_probabilities(self._tilted(wo)[1])

    def lobe(self, name, wo):
        self._check_lobe(name)
        wo = as_points(wo, 3, "wo")
        if name in self.DELTA:
            return DeltaDirection(self.delta_value(name, wo)[0])
        fr, wo_t, _ = self._tilted(wo)
        return Oriented(self.inner.lobe(name, wo_t), fr)

    def distribution(self, wo):
        wo = as_points(wo, 3, "wo")
        if (len(self.LOBES) == 1 or self.inner.dim_u == 3) and not self.DELTA:
            # one lobe, or a BSDF that picks its lobe after its microfacet normal: its own sampler, turned
            fr, wo_t, _ = self._tilted(wo)
            return Oriented(self.inner.distribution(wo_t), fr)
        return LobeMixture([self.lobe(name, wo) for name in self.LOBES], self.lobe_probabilities(wo))

    def delta_value(self, name, wo):
        self._check_lobe(name)
        wo = as_points(wo, 3, "wo")
        fr, wo_t, _ = self._tilted(wo)
        wi_t, value = self.inner.delta_value(name, wo_t)
        wi = fr.to_world(wi_t)
        return wi, scale(value, (wi[..., 2] * wi_t[..., 2] > 0) * self.shadowing(wi))

    # -- the rest: the nested BSDF's ----------------------------------------------------
    def is_black(self) -> bool:
        return self.inner.is_black()

    def at(self, values: dict) -> "NormalMap":
        out = NormalMap.__new__(NormalMap)
        out.inner = self.nested_at(values)
        out.normalmap = values.get("normalmap", self.normalmap)
        return out

    def key(self) -> tuple:
        return (NormalMap, id(self.normalmap) if not isinstance(self.normalmap, np.ndarray)
                else repr(self.normalmap), self.inner.key())

    def validate(self) -> None:
        self.inner.validate()

    def _repr_fields(self):
        return {"bsdf": self.inner, "normalmap": self.normalmap}
