"""Mitsuba 3's BSDFs as an oracle for vrlab's, point by point in the local shading frame:
:func:`mitsuba_bsdf` loads one (a plugin dict or XML), :func:`bsdf_eval_pdf` evaluates it and
:func:`bsdf_sample` samples it, for arrays of directions.  Importing this module does not import
Mitsuba; the functions do.

**Directions.**  Both sides work in the local frame (normal = +z) and agree on which way the
vectors point (away from the surface); they differ in names:

=======================================  =====================================
vrlab (:mod:`vrlab.render.bsdfs.base`)     Mitsuba 3 (``BSDF.eval(ctx, si, wo)``)
=======================================  =====================================
``wo``: towards the camera                ``si.wi`` (the SurfaceInteraction's)
``wi``: towards the light (sampled)       ``wo`` (the argument; ``BSDFSample3f.wo``)
``eval(wo, wi)`` = f · cos theta_i          ``eval`` = f · |cos theta_o| (Mitsuba's wo)
=======================================  =====================================

so ``bsdf_eval_pdf(b, wo, wi)`` sets ``si.wi = wo`` and calls ``b.eval_pdf(ctx, si, wi)``.

**Variant.**  The Python loop runs in a scalar RGB variant (``scalar_rgb`` by default): about
4-6 µs per evaluation or sample (1000 in under 10 ms).  Mitsuba's variant is process-wide:
every call here switches to the BSDF's variant for its duration and switches back to the one
that was set before (none set: the BSDF's stays).

**Surface point.**  The SurfaceInteraction has the identity shading frame (``sh_frame`` =
x, y, z; ``n = (0, 0, 1)``) and, if ``uv`` is given, ``si.uv`` per point, which is what
bitmap and checkerboard textures read.  ``mode`` picks Mitsuba's ``TransportMode``
(``"radiance"``, the default, or ``"importance"``: it changes the weight of refraction by
eta^2).
"""
from __future__ import annotations

import contextlib
from typing import Any, NamedTuple

import numpy as np

from .. import checks

__all__ = ["MitsubaBSDF", "BSDFSampleResult", "mitsuba_bsdf", "bsdf_eval_pdf", "bsdf_sample", "flag_names"]

MODES = ("radiance", "importance")


@contextlib.contextmanager
def _variant(name: str):
    """Mitsuba with variant ``name`` set for the block (the previous one restored after)."""
    import mitsuba as mi

    previous = mi.variant()
    if previous != name:
        mi.set_variant(name)
    try:
        yield mi
    finally:
        if previous is not None and previous != name:
            mi.set_variant(previous)


class MitsubaBSDF:
    """A Mitsuba BSDF loaded by :func:`mitsuba_bsdf` and the variant it belongs to.

    ``bsdf`` is the Mitsuba object, ``spec`` what it was loaded from, ``flags`` its
    ``BSDFFlags`` (an int; :func:`flag_names` spells them) and :meth:`parameters` its
    ``mi.traverse`` values as NumPy arrays (e.g. ``"eta.value"``, ``"k.value"`` of a conductor).
    """

    def __init__(self, bsdf: Any, variant: str, spec: Any):
        self.bsdf, self.variant, self.spec = bsdf, variant, spec
        with _variant(variant):
            self.flags = int(bsdf.flags())

    def parameters(self) -> dict[str, np.ndarray]:
        """``{key: value}`` of ``mi.traverse(bsdf)``, values as float arrays (numbers as 0-d)."""
        with _variant(self.variant) as mi:
            params = mi.traverse(self.bsdf)
            out = {}
            for key in params.keys():
                try:
                    out[key] = np.array(params[key], dtype=float)
                except (TypeError, ValueError):
                    continue                       # an object such as a bitmap's storage
            return out

    def __repr__(self) -> str:
        return f"MitsubaBSDF({self.spec!r}, variant={self.variant!r})"


class BSDFSampleResult(NamedTuple):
    """What :func:`bsdf_sample` returns, one entry per sample (vrlab names; see the module notes)."""
    wi: np.ndarray                 #: (..., 3) the sampled direction (Mitsuba's ``bs.wo``)
    weight: np.ndarray             #: (..., 3) eval / pdf as Mitsuba returns it (RGB; 0 for a failed sample)
    pdf: np.ndarray                #: (...) Mitsuba's ``bs.pdf`` (a discrete probability for delta lobes)
    sampled_type: np.ndarray       #: (...) int, the ``BSDFFlags`` of the sampled lobe (:func:`flag_names`)
    sampled_component: np.ndarray  #: (...) int, the index of the sampled component
    eta: np.ndarray                #: (...) relative index of a sampled refraction (1 for reflection)


def _check_variant(variant: Any) -> str:
    import mitsuba as mi

    allowed = [v for v in mi.variants() if v.startswith("scalar_") and "rgb" in v and "polarized" not in v]
    if not isinstance(variant, str) or variant not in allowed:
        raise ValueError(f"variant: expected a scalar RGB variant of Mitsuba ({', '.join(allowed)}), got {variant!r}")
    return variant


def mitsuba_bsdf(spec: Any, *, variant: str = "scalar_rgb") -> MitsubaBSDF:
    """Load a Mitsuba 3 BSDF from ``spec``: a plugin dict (``{"type": "conductor", "material":
    "Au"}``, as ``mi.load_dict`` takes) or an XML string ``<bsdf version="3.0.0" type=...>``
    (``mi.load_string``), in ``variant`` (a scalar RGB one).  Mitsuba's own errors (an unknown
    plugin or parameter) come out as Mitsuba raises them."""
    variant = _check_variant(variant)
    if isinstance(spec, dict):
        if not isinstance(spec.get("type"), str):
            raise ValueError(f"spec: a plugin dict needs a 'type' (str), got {checks.describe(spec)}")
        with _variant(variant) as mi:
            obj = mi.load_dict(spec)
    elif isinstance(spec, str) and spec.lstrip().startswith("<"):
        with _variant(variant) as mi:
            obj = mi.load_string(spec)
    else:
        raise TypeError(f"spec: expected a plugin dict or an XML string, got {checks.describe(spec)}")
    with _variant(variant) as mi:
        if not isinstance(obj, mi.BSDF):
            raise ValueError(f"spec: {checks.describe(spec)} loads a {type(obj).__name__}, not a BSDF")
    return MitsubaBSDF(obj, variant, spec)


def _as_bsdf(bsdf: Any) -> MitsubaBSDF:
    if isinstance(bsdf, MitsubaBSDF):
        return bsdf
    if isinstance(bsdf, (dict, str)):
        return mitsuba_bsdf(bsdf)
    raise TypeError(f"bsdf: expected a MitsubaBSDF (from mitsuba_bsdf) or a plugin dict, got {checks.describe(bsdf)}")


def _mode(mi, mode: Any):
    checks.choice(mode, "mode", MODES)
    return mi.TransportMode.Radiance if mode == "radiance" else mi.TransportMode.Importance


def _points(arrays: dict[str, tuple[Any, int | None]]) -> tuple[tuple, list[np.ndarray]]:
    """Check and broadcast ``{name: (value, last)}`` (last: the length of the last axis, or
    None for a scalar per point); return the common leading shape and the arrays flattened to
    (n, last) or (n,)."""
    arrays = {k: (checks.finite_array(v, k, last=last), last) for k, (v, last) in arrays.items() if v is not None}
    shape = np.broadcast_shapes(*[a.shape[:-1] if last else a.shape for a, last in arrays.values()])
    out = []
    for a, last in arrays.values():
        full = np.broadcast_to(a, shape + ((last,) if last else ()))
        out.append(full.reshape((-1, last) if last else (-1,)))
    return shape, out


def _interaction(mi):
    si = mi.SurfaceInteraction3f()
    si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0), mi.Vector3f(0, 0, 1))
    si.n = mi.Normal3f(0, 0, 1)
    si.dp_du, si.dp_dv = mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0)     # the frame's tangents (normal maps)
    return si


def bsdf_eval_pdf(bsdf: Any, wo: Any, wi: Any, *, uv: Any = None,
                  mode: str = "radiance") -> tuple[np.ndarray, np.ndarray]:
    """``(eval, pdf)`` of a Mitsuba BSDF at the direction pairs ``(wo, wi)`` (..., 3) (vrlab's
    names: ``wo`` towards the camera = Mitsuba's ``si.wi``, ``wi`` towards the light =
    Mitsuba's ``wo``; arrays broadcast, unit vectors in the local frame): ``eval`` (..., 3) is
    Mitsuba's f · |cos theta| of ``wi`` (RGB, float64) and ``pdf`` (...) its solid-angle
    density of sampling ``wi`` (0 for delta lobes, which ``eval`` also misses).  ``uv``
    (..., 2): texture coordinates per point."""
    b = _as_bsdf(bsdf)
    shape, arrs = _points({"wo": (wo, 3), "wi": (wi, 3), "uv": (uv, 2)})
    wo_, wi_ = arrs[0], arrs[1]
    uv_ = arrs[2] if uv is not None else None
    n = wo_.shape[0]
    value, pdf = np.empty((n, 3)), np.empty(n)
    with _variant(b.variant) as mi:
        ctx = mi.BSDFContext(_mode(mi, mode))
        si = _interaction(mi)
        vec, point2, obj = mi.Vector3f, mi.Point2f, b.bsdf
        wo_l, wi_l = wo_.tolist(), wi_.tolist()
        uv_l = uv_.tolist() if uv_ is not None else None
        for j in range(n):
            si.wi = vec(*wo_l[j])
            if uv_l is not None:
                si.uv = point2(*uv_l[j])
            v, p = obj.eval_pdf(ctx, si, vec(*wi_l[j]))
            value[j] = v
            pdf[j] = p
    return value.reshape(shape + (3,)), pdf.reshape(shape)


def bsdf_sample(bsdf: Any, wo: Any, u1: Any, u2: Any, *, uv: Any = None, mode: str = "radiance") -> BSDFSampleResult:
    """Mitsuba's ``BSDF.sample(ctx, si, u1, u2)`` for each point: ``wo`` (..., 3) towards the
    camera (Mitsuba's ``si.wi``), ``u1`` (...) the uniform that picks a lobe, ``u2`` (..., 2)
    the uniforms of the direction (all broadcast; uniforms in [0, 1]).  Returns
    :class:`BSDFSampleResult` (``wi`` is Mitsuba's ``bs.wo``; ``weight`` = eval / pdf, RGB)."""
    b = _as_bsdf(bsdf)
    shape, arrs = _points({"wo": (wo, 3), "u1": (u1, None), "u2": (u2, 2), "uv": (uv, 2)})
    wo_, u1_, u2_ = arrs[:3]
    uv_ = arrs[3] if uv is not None else None
    for name, u in (("u1", u1_), ("u2", u2_)):
        if u.size and (u.min() < 0 or u.max() > 1):
            raise ValueError(f"{name}: uniforms must lie in [0, 1]")
    n = wo_.shape[0]
    wi, weight = np.empty((n, 3)), np.empty((n, 3))
    pdf, eta = np.empty(n), np.empty(n)
    typ, comp = np.empty(n, np.int64), np.empty(n, np.int64)
    with _variant(b.variant) as mi:
        ctx = mi.BSDFContext(_mode(mi, mode))
        si = _interaction(mi)
        vec, point2, obj = mi.Vector3f, mi.Point2f, b.bsdf
        wo_l, u1_l, u2_l = wo_.tolist(), u1_.tolist(), u2_.tolist()
        uv_l = uv_.tolist() if uv_ is not None else None
        for j in range(n):
            si.wi = vec(*wo_l[j])
            if uv_l is not None:
                si.uv = point2(*uv_l[j])
            bs, w = obj.sample(ctx, si, u1_l[j], point2(*u2_l[j]))
            wi[j], weight[j] = bs.wo, w
            pdf[j], eta[j], typ[j], comp[j] = bs.pdf, bs.eta, bs.sampled_type, bs.sampled_component
    return BSDFSampleResult(wi.reshape(shape + (3,)), weight.reshape(shape + (3,)), pdf.reshape(shape),
                            typ.reshape(shape), comp.reshape(shape), eta.reshape(shape))


def flag_names(flags: Any) -> tuple[str, ...]:
    """The names of the single ``mi.BSDFFlags`` bits set in ``flags`` (an int, e.g. a
    ``sampled_type``): ``flag_names(32) == ("DeltaReflection",)``."""
    flags = checks.integer(flags, "flags", low=0)
    import mitsuba as mi

    out = []
    for name in dir(mi.BSDFFlags):
        if name[:1].isupper():
            bit = int(getattr(mi.BSDFFlags, name))
            if bit and bit & (bit - 1) == 0 and flags & bit:
                out.append((bit, name))
    return tuple(name for _, name in sorted(out))
