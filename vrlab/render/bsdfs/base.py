"""BSDF models of the direct-lighting renderer, in the local shading frame (normal = +z).

Conventions (those of Mitsuba 3's ``BSDF.eval``/``sample``):

* ``wo`` is the direction towards the camera (outgoing), ``wi`` the sampled direction
  towards the light; both are unit vectors of shape ``(..., 3)`` that broadcast.
* ``f(wo, wi) -> (..., 3)`` is the BRDF f_r alone (RGB, per steradian);
  ``eval(wo, wi) -> (..., 3)`` is **f_r(wo, wi) * cos(theta_i)** (Mitsuba returns f·cos).
* ``pdf(wo, wi) -> (...)`` is the solid-angle density of ``sample`` on the **whole
  sphere**.  Samplers may produce directions below the horizon (a Phong lobe or a
  microfacet reflection leaning past it); there ``eval`` is 0, so such samples add
  zero and the estimator stays unbiased (the lost mass only costs variance).  On
  wi.z > 0 the pdf equals Mitsuba's; Mitsuba reports 0 below the horizon.
* ``sample(wo, u) -> (wi, weight, pdf)`` with ``u`` of shape ``(..., 2)`` and
  ``weight = eval / pdf`` (0 where the pdf is 0).
* ``distribution(wo)`` is a vrlab distribution (``dim_u = 2``, ``sample(u)``, ``pdf(w)``,
  solid angle) so the estimators (``MonteCarlo``, MIS, ...) can use BSDF sampling.
  ``wo`` broadcasts against the leading shape of ``u``: for per-pixel ``wo`` of shape
  ``(*batch, 3)`` and uniforms ``(*batch, n, 2)`` pass ``wo[..., None, :]``.
* Every reflecting model is one-sided: f = 0 when wo.z <= 0 or wi.z <= 0 (``twosided``
  makes a BSDF two-sided); a transmitting one (``dielectric``...) overrides ``eval`` with
  f |cos(theta_i)| on both sides.
* **Lobes.**  ``LOBES`` names the parts a BSDF samples (``("diffuse",)``, a plastic's
  ``("specular", "diffuse")``...), ``lobe_probabilities(wo) (..., L)`` the probabilities with
  which ``sample`` picks them (Mitsuba's choice), ``lobe(name, wo)`` each as a distribution
  (the shading integrand's techniques ``"bsdf:<name>"``), and ``distribution(wo)`` their
  :class:`~vrlab.distributions.LobeMixture` (the ``"bsdf"`` technique), whose ``pdf`` is
  the BSDF's.  ``DELTA`` names the delta lobes (a smooth mirror or refraction): one
  direction per wo, no density in solid angle; ``delta_value(name, wo) -> (wi, value)``
  gives that direction and the integral of f |cos| over it (RGB), and the mixture's
  ``lobe_probability`` the mass of its atom (the mixed measure of delta lights).
* Every model is a registered scene element (:mod:`vrlab.render.registry`): one module
  per Mitsuba plugin in this package; ``from_props`` reads it from a scene file and the
  constructor takes the same parameters as keyword arguments.
* Constructors check their arguments (``TypeError``/``ValueError`` naming them):
  colours a number or an RGB array ``(..., 3)``, finite and in [0, 1e15]; ``alpha`` in
  (0, 1e4]; ``exponent`` in [0, 1e6]; ``distribution`` ``"ggx"`` or ``"beckmann"``.
  ``f``/``eval``/``pdf``/``sample`` check shapes only (``(..., 3)`` directions,
  ``(..., 2)`` uniforms): they run per ray.

Sources: Walter et al. 2007, "Microfacet Models for Refraction through Rough
Surfaces" (D, Beckmann G1 approximation, sampling); Heitz 2014, "Understanding the
Masking-Shadowing Function in Microfacet-Based BRDFs" (separable Smith G); Lafortune &
Willems 1994, "Using the Modified Phong Reflectance Model for Physically Based
Rendering" (normalised Phong); Mitsuba 3 plugin docs (``diffuse``, ``roughconductor``,
``twosided``).
"""
from __future__ import annotations

import copy
from typing import Any

import numpy as np

from ... import checks
from ..._vec import dot as vdot
from ..._vec import outer3, scale
from ...distributions.base import Distribution, as_points, as_uniforms
from ...distributions.lobes import DeltaDirection, LobeMixture
from ..registry import Element
from ..scene_checks import MAX_ALPHA, MAX_VALUE

INV_PI = 1.0 / np.pi
TWO_PI = 2.0 * np.pi

__all__ = ["BSDFDirections", "BSDFModel", "FRAME_VALUES", "NestedTextures", "alpha_param", "check_lobe_mixture", "color_param", "dirs", "mirror", "plain", "reflect",
           "rgb_param", "shape_of", "times_rgb"]


def reflect(w: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Mirror ``w`` about the unit axis ``m``: 2 (w·m) m - w (invariant under m -> -m)."""
    return scale(m, 2.0 * vdot(w, m)) - w


def mirror(w: np.ndarray) -> np.ndarray:
    """Mirror direction about the local normal +z: (-x, -y, z)."""
    return w * np.array([-1.0, -1.0, 1.0])


def rgb_param(value: Any, name: str) -> np.ndarray:
    """A colour parameter: a number or an RGB array ``(..., 3)``, finite, in [0, MAX_VALUE]."""
    if value is None:
        raise TypeError(f"{name} must be a number or an RGB array, got None")
    v = checks.finite_array(value, name)
    if v.ndim == 0:
        v = np.full(3, float(v))
    if v.shape[-1:] != (3,) or v.size == 0 or np.any(v < 0) or np.any(v > MAX_VALUE):
        raise ValueError(f"{name}: expected a scalar or RGB array (..., 3) in [0, {MAX_VALUE:g}], got {value!r}")
    return v


def alpha_param(value: Any, name: str = "alpha") -> float:
    """A roughness in (0, MAX_ALPHA]."""
    return checks.real(value, name, low=0, high=MAX_ALPHA, low_open=True)


def color_param(value: Any, name: str):
    """A colour parameter that may also be a texture element (returned as it is)."""
    from ..textures import Texture

    if isinstance(value, Texture):
        return value
    return rgb_param(value, name)


def times_rgb(s: np.ndarray, c: np.ndarray, dtype=None) -> np.ndarray:
    """``s[..., None] * c`` for one colour ``c (3,)`` (column by column, fast) or per-row
    colours ``c (..., 3)`` (a textured parameter at its points)."""
    c = np.asarray(c)
    if c.ndim == 1:
        return outer3(s, c, dtype)
    out = np.asarray(s)[..., None] * c
    return out if dtype is None else out.astype(dtype, copy=False)


def plain(value: Any) -> Any:
    """A parameter for ``repr``: arrays as lists, textures as themselves."""
    return value.tolist() if isinstance(value, np.ndarray) else value


def _alpha(value: Any) -> float:
    return checks.real(value, "alpha", low=0, high=MAX_ALPHA, low_open=True)


def dirs(wo: Any, wi: Any) -> tuple[np.ndarray, np.ndarray]:
    """``wo``, ``wi`` as arrays of 3-vectors (shapes checked only)."""
    return as_points(wo, 3, "wo"), as_points(wi, 3, "wi")


class BSDFDirections(Distribution):
    """The sampling distribution of ``bsdf`` for a fixed ``wo``: ``sample(u) -> wi``,
    ``pdf(wi)`` (solid angle, whole sphere).  Built by ``BSDFModel.distribution(wo)``."""

    dim_x = 3
    measure = "solid angle"

    def __init__(self, bsdf: BSDFModel, wo: np.ndarray):
        self.bsdf = bsdf
        self.wo = as_points(wo, 3, "wo")
        self.dim_u = int(bsdf.dim_u)

    def sample(self, u: np.ndarray) -> np.ndarray:
        return self.bsdf._sample_direction(self.wo, as_uniforms(u, self.dim_u))

    def pdf(self, w: np.ndarray) -> np.ndarray:
        return self.bsdf.pdf(self.wo, w)

    def _repr_fields(self) -> dict:
        return {"bsdf": self.bsdf, "wo_shape": self.wo.shape}


class BSDFModel(Element):
    """Base of the BSDF elements: subclasses implement ``f``, ``pdf`` and
    ``_sample_direction`` (and ``from_props`` to be read from a scene file), and may
    override ``diffuse_albedo`` (the k_d of a Lambertian part, for the renderer's
    ``"lambertian"`` control variate) and ``is_black``.  ``twosided`` is True for
    Mitsuba's ``twosided`` adapter: the renderer then shades both sides alike."""

    kind = "bsdf"
    twosided = False
    #: the lobes ``sample`` picks from, by name (techniques ``"bsdf:<name>"`` of the renderer)
    LOBES: tuple = ("reflection",)
    #: the delta lobes among them (one direction per wo: a smooth mirror or refraction)
    DELTA: tuple = ()
    #: the parameters that may be textures (evaluated at the shading points by :meth:`at`)
    TEXTURED: tuple = ()
    #: those of them that are scalars (a texture's ``eval_1``, e.g. a roughness)
    SCALAR_TEXTURES: tuple = ()
    #: textured parameters read as their uv gradient (``eval_1_grad``: a bump map's height)
    GRADIENT_TEXTURES: tuple = ()

    #: uniforms per sample: 2 (a direction; a lobe mixture reuses the rescaled first one), or 3
    #: for a BSDF whose lobe choice depends on the sampled microfacet normal
    dim_u: int = 2
    #: True when the BSDF needs Mitsuba's tangent frame (s along dp/du) at its points: then the
    #: renderer builds the local frame from it and passes the local ``dp_du``, ``dp_dv`` to :meth:`at`
    needs_tangents: bool = False
    #: f(wo, wi) = f(wi, wo) (Helmholtz reciprocity; ``vrlab.testing.check_bsdf`` checks it where True):
    #: False for transmission under radiance transport (the eta^2 of a refraction) and for normal/bump
    #: maps (their frame and side test depend on wo), as in Mitsuba 3
    reciprocal: bool = True
    #: real parameters that may be negative or are clamped (``check_bsdf``'s ``params`` check then
    #: tries only NaN on them)
    SIGNED_PARAMS: tuple = ()

    @property
    def textures(self) -> dict:
        """``{parameter: texture}`` of the parameters given as textures."""
        from ..textures import Texture

        return {a: getattr(self, a) for a in self.TEXTURED if isinstance(getattr(self, a), Texture)}

    def at(self, values: dict) -> "BSDFModel":
        """A copy whose textured parameters are the per-point ``values`` (``{name: (N, 3)}``):
        the BSDF at N points (or rows), evaluated by the same code as a constant one."""
        out = copy.copy(self)
        for name, v in values.items():
            setattr(out, name, v)
        return out

    @property
    def type(self) -> str:
        """The Mitsuba plugin name (``"diffuse"``, ...)."""
        return self.plugin_name

    def diffuse_albedo(self) -> np.ndarray:
        """k_d (RGB) of a Lambertian part k_d / pi of the BSDF (default 0)."""
        return np.zeros(3)

    def is_black(self) -> bool:
        """True when the BSDF reflects nothing (the renderer skips shading it)."""
        return False

    def key(self) -> tuple:
        """Shapes whose BSDFs have equal keys are shaded in one batch (textures by identity)."""
        fields = tuple((k, id(v) if isinstance(v, Element) else repr(v)) for k, v in sorted(self._repr_fields().items()))
        return (type(self), self.twosided, fields)

    def f(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError  # abstract

    def pdf(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError  # abstract

    def _sample_direction(self, wo: np.ndarray, u: np.ndarray) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError  # abstract

    def eval(self, wo: np.ndarray, wi: np.ndarray) -> np.ndarray:
        """f_r(wo, wi) cos(theta_i), RGB (..., 3); zero below either horizon."""
        wo, wi = dirs(wo, wi)
        return scale(self.f(wo, wi), np.clip(wi[..., 2], 0.0, None))

    def distribution(self, wo: np.ndarray) -> Distribution:
        """A vrlab distribution of wi for this ``wo`` (see the module notes on broadcasting):
        one lobe's own, or the :class:`~vrlab.distributions.LobeMixture` of several."""
        if len(self.LOBES) == 1 and not self.DELTA:
            return BSDFDirections(self, wo)
        wo = as_points(wo, 3, "wo")
        return LobeMixture([self.lobe(name, wo) for name in self.LOBES], self.lobe_probabilities(wo))

    # -- lobes (see the module notes) -----------------------------------------------------
    def lobe_probabilities(self, wo: np.ndarray) -> np.ndarray:
        """``(..., L)``: the probability that ``sample`` picks each lobe at ``wo`` (default:
        the one lobe, always)."""
        wo = as_points(wo, 3, "wo")
        return np.ones(wo.shape[:-1] + (len(self.LOBES),))

    def lobe(self, name: str, wo: np.ndarray) -> Distribution:
        """Lobe ``name``'s directions for ``wo`` as a distribution (solid angle, whole
        sphere; a delta lobe: :class:`~vrlab.distributions.DeltaDirection`)."""
        self._check_lobe(name)
        if name in self.DELTA:
            return DeltaDirection(self.delta_value(name, wo)[0])
        if len(self.LOBES) == 1:
            return BSDFDirections(self, wo)
        raise NotImplementedError(f"{type(self).__name__} does not expose its lobe {name!r}")  # pragma: no cover

    def delta_value(self, name: str, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(wi (..., 3), value (..., 3))``: delta lobe ``name``'s direction for ``wo`` and
        the integral of f |cos theta_i| over it (RGB)."""
        raise ValueError(f"lobe: {type(self).__name__} has no delta lobe {name!r}")

    def _check_lobe(self, name: str) -> None:
        if name not in self.LOBES:
            raise ValueError(f"lobe: {type(self).__name__} has lobes {', '.join(map(repr, self.LOBES))}, "
                             f"not {name!r}")

    def sample_lobe(self, wo: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(wi, k)``: a sampled direction and the index (into ``LOBES``) of its lobe."""
        dist = self.distribution(wo)
        u = as_uniforms(u, int(self.dim_u))
        if isinstance(dist, LobeMixture):
            return dist.sample_lobe(u)
        wi = np.asarray(dist.sample(u))
        return wi, np.zeros(wi.shape[:-1], np.int64)

    def sample(self, wo: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(wi, weight, pdf)`` with weight = f |cos| / pdf (RGB; 0 where pdf is 0).  A delta
        lobe's direction has pdf = the lobe's probability P_k and weight = its
        ``delta_value`` / P_k (Mitsuba's convention)."""
        wo = as_points(wo, 3, "wo")
        u = as_uniforms(u, int(self.dim_u))
        if self.DELTA:
            dist = self.distribution(wo)
            wi, k = dist.sample_lobe(u)
            p, val = np.asarray(dist.pdf(wi)), self.eval(wo, wi)
            p, val = np.broadcast_to(p, k.shape).copy(), np.broadcast_to(val, k.shape + (3,)).copy()
            for i, name in enumerate(self.LOBES):
                if name in self.DELTA and np.any(k == i):
                    d = np.broadcast_to(self.delta_value(name, wo)[1], val.shape)
                    p = np.where(k == i, np.broadcast_to(dist.lobe_probability(i), k.shape), p)
                    val = np.where((k == i)[..., None], d, val)
        else:
            wi = self._sample_direction(wo, u)
            p = self.pdf(wo, wi)
            val = self.eval(wo, wi)
        pos = (p > 0)[..., None]
        weight = np.where(pos, val / np.where(pos, p[..., None], 1.0), 0.0)
        return wi, weight, p

    def __repr__(self) -> str:
        fields = ", ".join(f"{k}={v!r}" for k, v in self._repr_fields().items())
        return f"{type(self).__name__}({fields})"

    def _repr_fields(self) -> dict:
        return {}


def shape_of(wo: np.ndarray, u: np.ndarray) -> tuple:
    """The shape ``(..., 3)`` of directions sampled for ``wo`` with uniforms ``u``."""
    return np.broadcast_shapes(wo.shape[:-1], u.shape[:-1]) + (3,)




def check_lobe_mixture(bsdf: BSDFModel, name: str) -> None:
    """Refuse ``bsdf`` as a component of a lobe mixture (``blendbsdf``, ``mask``) when its lobe
    probabilities depend on more than wo (``principled``: on the microfacet normal it draws
    first), naming the argument."""
    try:
        bsdf.lobe_probabilities(np.array([0.0, 0.0, 1.0]))
    except ValueError as exc:
        raise ValueError(f"{name}: a {bsdf.type!r} BSDF cannot be mixed with other lobes here ({exc})") from None


#: per-point values the renderer passes to every BSDF of a point (the tangent frame), not textures
FRAME_VALUES = ("dp_du", "dp_dv", "n_geo")


class NestedTextures:
    """Mixin of the adapters around one nested BSDF ``inner`` (``normalmap``, ``bumpmap``,
    ``mask``): their own textured parameters ``OWN_TEXTURES`` (scalar ones in
    ``OWN_SCALARS``, gradients in ``OWN_GRADIENTS``) and the nested BSDF's as
    ``"inner.<name>"``; :meth:`split_values` hands the nested BSDF its values."""

    OWN_TEXTURES: tuple = ()
    OWN_SCALARS: tuple = ()
    OWN_GRADIENTS: tuple = ()

    @property
    def textures(self) -> dict:
        from ..textures import Texture

        own = {a: getattr(self, a) for a in self.OWN_TEXTURES if isinstance(getattr(self, a), Texture)}
        return {**own, **{f"inner.{k}": v for k, v in self.inner.textures.items()}}

    @property
    def SCALAR_TEXTURES(self) -> tuple:  # noqa: N802
        return self.OWN_SCALARS + tuple(f"inner.{k}" for k in self.inner.SCALAR_TEXTURES)

    @property
    def GRADIENT_TEXTURES(self) -> tuple:  # noqa: N802
        return self.OWN_GRADIENTS + tuple(f"inner.{k}" for k in self.inner.GRADIENT_TEXTURES)

    def nested_at(self, values: dict):
        """The nested BSDF at these points: its own textured values and the frame."""
        inner = {k.split(".", 1)[1]: v for k, v in values.items() if k.startswith("inner.")}
        inner.update({k: v for k, v in values.items() if k in FRAME_VALUES})
        return self.inner.at(inner) if inner else self.inner
