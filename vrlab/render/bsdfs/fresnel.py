"""Fresnel equations, refraction and indices of refraction for the BSDFs, as Mitsuba 3 uses them.

Not a plugin (no ``@register``): helpers for the ``dielectric``, ``plastic`` and ``conductor``
families.  Everything is vectorised NumPy; float32 inputs give float32 results (the dtype is
NumPy's promotion of the arguments, Python numbers being "weak", so ``fresnel_dielectric(
cos32, 1.5)`` is float32), integers become float64.

Conventions (Mitsuba 3, include/mitsuba/render/fresnel.h; the formulas are textbook ones):

* directions are in the local shading frame (normal = +z) and point away from the surface;
  ``cos_theta_i`` is the z of the direction on the incident side: in a BSDF, vrlab's ``wo``
  (towards the camera) = Mitsuba's ``si.wi``, so ``cos_theta_i = wo.z`` (F is reciprocal:
  the same value serves light arriving along that direction);
* a dielectric's ``eta`` is the relative index ``n_inside / n_outside`` (``int_ior /
  ext_ior``): eta > 1 when the normal points into the less dense medium.  ``cos_theta_i < 0``
  means the ray arrives from the inside, where the relative index seen is ``1 / eta``;
* a conductor's index is complex, ``eta + i k`` with ``k >= 0`` (Mitsuba's sign of k).

Sources: M. Born & E. Wolf, *Principles of Optics*, 7th ed., sec. 1.5 (Fresnel amplitudes,
reflectance and transmittance of an interface; complex index for absorbing media, sec. 14.2);
B. Walter et al., "Microfacet Models for Refraction through Rough Surfaces", EGSR 2007,
eqs. 22 and 40 (unpolarised dielectric F, refraction about a microfacet normal);
W. G. Egan & T. W. Hilgeman, *Optical Properties of Inhomogeneous Materials*, Academic Press
1979 (the fit H. W. Jensen et al., "A Practical Model for Subsurface Light Transport", SIGGRAPH
2001, quote for F_dr, in terms of their eta = 1 / Mitsuba's) and
E. d'Eon & G. Irving, "A Quantized-Diffusion Model for Rendering Translucent Materials",
SIGGRAPH 2011: the two polynomial fits of the diffuse Fresnel reflectance that Mitsuba 3's
``fresnel_diffuse_reflectance`` evaluates (coefficients are Mitsuba's, checked against
mitsuba 3.9.1 in tests/test_fresnel.py).

Named indices of refraction (``int_ior="bk7"``) and named conductors (``material="Au"``) come
from :mod:`vrlab.render.spectra`, which holds Mitsuba's tables: :func:`ior_value` wraps
:func:`vrlab.render.spectra.ior` and :func:`conductor_ior` is
:func:`vrlab.render.spectra.conductor_ior` (Mitsuba's ``data/ior/*.spd`` spectra shipped in
render/data/conductors.csv and turned into RGB as scalar_rgb does, by ``spectrum_list_to_srgb``
without D65: Mitsuba's sRGB triples to 2.4e-7 relative at most, the float32 rounding;
tests/test_spectra.py and tests/test_fresnel.py).
"""
from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from ..spectra import IOR_TABLE, conductor_ior
from ..spectra import ior as _named_ior

__all__ = ["DielectricFresnel", "fresnel_dielectric", "fresnel_conductor", "fresnel_diffuse_reflectance",
           "refract", "ior_value", "ior_param", "ior_from_props", "relative_ior", "conductor_ior", "IOR_TABLE"]


def _real(value: Any, name: str) -> np.ndarray:
    """``value`` as a real float array (float32/float64 kept, integers -> float64), finite."""
    if value is None or isinstance(value, (str, bytes, bool, np.bool_)):
        raise TypeError(f"{name}: expected real numbers, got {type(value).__name__}")
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name}: expected real numbers, got {type(value).__name__}") from None
    if a.dtype.kind in "iu":
        a = a.astype(np.float64)
    elif a.dtype.kind != "f":
        raise TypeError(f"{name}: expected real numbers, got an array of {a.dtype}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name}: must be finite (no NaN or infinity)")
    return a


def _dtype(*values: Any) -> np.dtype:
    """NumPy's promotion of the arguments (Python numbers weak), float64 unless floating."""
    dt = np.result_type(*[v if isinstance(v, (int, float)) else np.asarray(v) for v in values])
    return dt if dt.kind == "f" else np.dtype(np.float64)


class DielectricFresnel(NamedTuple):
    """What :func:`fresnel_dielectric` returns (Mitsuba's ``fresnel`` tuple)."""
    F: np.ndarray            #: unpolarised reflectance; 1 - F is transmitted
    cos_theta_t: np.ndarray  #: cosine of the refracted direction, opposite in sign to cos_theta_i; 0 at TIR
    eta_it: np.ndarray       #: relative index along the direction of travel (eta outside, 1/eta inside)
    eta_ti: np.ndarray       #: 1 / eta_it: the factor :func:`refract` applies to the tangential part


def fresnel_dielectric(cos_theta_i: Any, eta: Any) -> DielectricFresnel:
    """Unpolarised Fresnel reflectance of a dielectric interface of relative index ``eta``
    (``int_ior / ext_ior``, > 0) for light along a direction of cosine ``cos_theta_i`` (either
    sign; arrays broadcast).  Returns :class:`DielectricFresnel` ``(F, cos_theta_t, eta_it,
    eta_ti)``.

    With c_i = |cos_theta_i|, ``eta_it = eta`` if cos_theta_i >= 0 (arriving from outside) else
    ``1 / eta``, ``eta_ti = 1 / eta_it``, Snell's law gives
    ``cos^2 theta_t = 1 - eta_ti^2 (1 - c_i^2)``; c_t = sqrt(max(0, cos^2 theta_t)) and the
    Fresnel amplitudes (Born & Wolf 1.5.2, refractive indices 1 and eta_it)::

        r_s = (c_i - eta_it c_t) / (c_i + eta_it c_t),   r_p = (c_t - eta_it c_i) / (c_t + eta_it c_i),
        F   = (r_s^2 + r_p^2) / 2                       (Walter et al. 2007, eq. 22)

    Total internal reflection (cos^2 theta_t < 0) gives c_t = 0, r_s = 1, r_p = -1, F = 1.
    As in Mitsuba 3 (``fresnel``, include/mitsuba/render/fresnel.h): ``F = 0`` when eta == 1
    (index matched), ``F = 1`` at grazing incidence (c_i = 0), and
    ``cos_theta_t = -sign(cos_theta_i) c_t`` (by the sign bit, so -0.0 counts as negative
    there: the refracted ray continues to the other side).  At normal incidence
    F = ((eta - 1) / (eta + 1))^2.
    """
    c = _real(cos_theta_i, "cos_theta_i")
    e = _real(eta, "eta")
    if not (e > 0).all():
        raise ValueError("eta: a relative index of refraction must be > 0")
    dt = _dtype(cos_theta_i, eta)
    c, e = c.astype(dt, copy=False), e.astype(dt, copy=False)
    one = dt.type(1.0)
    outside = c >= 0
    inv = one / e
    eta_it = np.where(outside, e, inv)
    eta_ti = np.where(outside, inv, e)
    cos_t2 = one - eta_ti * eta_ti * (one - c * c)
    ci = np.abs(c)
    ct = np.sqrt(np.maximum(cos_t2, dt.type(0.0)))
    with np.errstate(divide="ignore", invalid="ignore"):
        a_s = (ci - eta_it * ct) / (ci + eta_it * ct)
        a_p = (ct - eta_it * ci) / (ct + eta_it * ci)
    F = dt.type(0.5) * (a_s * a_s + a_p * a_p)
    F = np.where(e == 1, dt.type(0.0), np.where(ci == 0, one, F))
    cos_t = np.copysign(ct, -c)
    return DielectricFresnel(F, cos_t, eta_it, eta_ti)


def fresnel_conductor(cos_theta_i: Any, eta: Any, k: Any) -> np.ndarray:
    """Unpolarised Fresnel reflectance of a conductor of complex relative index ``eta + i k``
    (``eta >= 0``, ``k >= 0``), for light arriving from outside at cos theta_i = |cos_theta_i|.

    The exact formula for an absorbing medium (Born & Wolf 1.5.2 with a complex index,
    sec. 14.2), n = eta + i k, c = |cos theta_i|, s^2 = 1 - c^2, w = sqrt(n^2 - s^2) the
    principal root (Re w >= 0: the transmitted wave decays into the metal)::

        r_s = (c - w) / (c + w),   r_p = (n^2 c - w) / (n^2 c + w),   F = (|r_s|^2 + |r_p|^2) / 2

    evaluated in real arithmetic (three times faster than NumPy's complex square root), with
    A = |w|^2 = |n^2 - s^2| and a = Re w = sqrt((A + eta^2 - k^2 - s^2) / 2) (K. D. Moeller,
    *Optics*, 1988; the form Mitsuba 3's ``fresnel_conductor`` uses)::

        |r_s|^2 = (A + c^2 - 2 a c) / (A + c^2 + 2 a c)
        |r_p|^2 = |r_s|^2 (A c^2 + s^4 - 2 a c s^2) / (A c^2 + s^4 + 2 a c s^2)

    (tests/test_fresnel.py checks it against the complex form).  Mitsuba assumes
    cos_theta_i > 0; for negative values vrlab uses |cos_theta_i| (a conductor is lit from
    outside) where Mitsuba's formula gives other numbers.  F = 1 at grazing incidence (c = 0)
    and F = 0 for an index-matched n = 1; at normal incidence F = ((eta - 1)^2 + k^2) /
    ((eta + 1)^2 + k^2), also for n = 0 (F = 1, the limit, where Mitsuba's formula gives
    0/0 = NaN: AlSb's red channel, whose eta and k both clamp to 0).  eta = 0, k = 1
    (Mitsuba's ``material="none"``) is a perfect mirror, F = 1.

    Shapes: ``cos_theta_i`` is (...); ``eta`` and ``k`` are numbers or arrays whose last axis
    is the colour (an RGB triple (3,), or per-point colours (..., 3)).  With scalar eta and k
    the result has the shape of ``cos_theta_i``; otherwise ``cos_theta_i`` gets a trailing
    axis and the result is (..., 3) (broadcast).
    """
    c = _real(cos_theta_i, "cos_theta_i")
    n = _real(eta, "eta")
    kk = _real(k, "k")
    if not (n >= 0).all():
        raise ValueError("eta: the real part of a conductor's index of refraction must be >= 0")
    if not (kk >= 0).all():
        raise ValueError("k: the extinction coefficient of a conductor must be >= 0")
    dt = _dtype(cos_theta_i, eta, k)
    if n.ndim or kk.ndim:
        c = c[..., None]
    c = np.abs(c.astype(dt, copy=False))
    n, kk = n.astype(dt, copy=False), kk.astype(dt, copy=False)
    c2 = c * c
    s2 = dt.type(1.0) - c2
    re = n * n - kk * kk - s2                               # Re(n^2 - s^2); Im = 2 eta k
    im = dt.type(2.0) * n * kk
    A = np.sqrt(re * re + im * im)                          # (np.hypot is 6x slower)
    two_ac = dt.type(2.0) * c * np.sqrt(np.maximum(dt.type(0.5) * (A + re), dt.type(0.0)))
    num_s, den_s = A + c2 - two_ac, A + c2 + two_ac
    t, u = A * c2 + s2 * s2, two_ac * s2
    with np.errstate(divide="ignore", invalid="ignore"):
        R_s = num_s / den_s
        F = dt.type(0.5) * R_s * (dt.type(1.0) + (t - u) / (t + u))
    # 0/0 at grazing incidence (c = 0 with A = 0) and for n = 0 at normal incidence (t = u = 0):
    # the limits are F = 1; n = 1 (index matched) reflects nothing
    matched = (n == 1) & (kk == 0)
    return np.where(matched, dt.type(0.0), np.where((c == 0) | (t + u == 0), dt.type(1.0), F))


# the two fits of Mitsuba 3's fresnel_diffuse_reflectance (include/mitsuba/render/fresnel.h)
_EGAN_HILGEMAN = (0.0636, 0.6681, 0.7099, -1.4399)        # c_-1 / eta + c_0 + c_1 eta + c_2 eta^2, eta < 1
_DEON_IRVING = (0.919317, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881)   # sum_j d_j eta^-j, eta >= 1


def fresnel_diffuse_reflectance(eta: Any) -> np.ndarray:
    """The diffuse Fresnel reflectance F_dr(eta): the cosine-weighted hemispherical average
    ``2 ∫_0^1 F(mu, eta) mu dmu`` of :func:`fresnel_dielectric` for light arriving from
    outside a dielectric of relative index ``eta`` (> 0), as Mitsuba 3's ``plastic`` and
    ``roughplastic`` use it (``fdr_int = F_dr(1 / eta)``, ``fdr_ext = F_dr(eta)``).

    Mitsuba evaluates two polynomial fits, not the integral (so does this, for equal results):

    * eta < 1, Egan & Hilgeman's fit (as in Jensen et al. 2001, written in Mitsuba's eta)::

          F_dr = 0.0636 / eta + 0.6681 + 0.7099 eta - 1.4399 eta^2

    * eta >= 1, d'Eon & Irving 2011 (a quintic in 1 / eta)::

          F_dr = 0.919317 - 3.4793 / eta + 6.75335 / eta^2 - 7.80989 / eta^3
                 + 4.98554 / eta^4 - 1.36881 / eta^5

    Against the integral (Gauss-Legendre, tests/test_fresnel.py) the fits are within 2e-3
    absolute for eta in [0.5, 2] (they give 0.0017 just below 1 and 0.0002 at 1, where it is 0),
    3e-4 relative in [1.5, 2], 1.4 % relative up to eta = 10 and 10 % at eta = 0.2 (Mitsuba's
    own comments quote smaller figures for the second fit).  float32 stays float32.
    """
    e = _real(eta, "eta")
    if not (e > 0).all():
        raise ValueError("eta: a relative index of refraction must be > 0")
    dt = _dtype(eta)
    e = e.astype(dt, copy=False)
    inv = dt.type(1.0) / e
    cm1, c0, c1, c2 = (dt.type(v) for v in _EGAN_HILGEMAN)
    low = cm1 * inv + c0 + e * (c1 + e * c2)
    high = np.zeros_like(inv)
    for d in reversed(_DEON_IRVING):                          # Horner in 1 / eta
        high = high * inv + dt.type(d)
    return np.where(e < 1, low, high)


def refract(w: Any, cos_theta_t: Any, eta_ti: Any, m: Any = None) -> np.ndarray:
    """The refracted direction (..., 3) of the unit direction ``w`` (pointing away from the
    surface on the incident side: vrlab's ``wo``, Mitsuba's ``si.wi``), given ``cos_theta_t``
    and ``eta_ti`` from :func:`fresnel_dielectric` evaluated at ``w·m``.

    About the local normal (``m`` None): ``(-eta_ti w_x, -eta_ti w_y, cos_theta_t)``; about a
    microfacet normal ``m`` (..., 3) (Walter et al. 2007, eq. 40, with Mitsuba's sign of
    cos_theta_t): ``m (eta_ti (w·m) + cos_theta_t) - eta_ti w``.  The result is a unit vector
    except at total internal reflection (cos_theta_t = 0, F = 1), where nothing is refracted.
    Mirror reflection is :func:`vrlab.render.bsdfs.base.mirror` / ``reflect``.
    """
    w = _real(w, "w")
    if w.shape[-1:] != (3,):
        raise ValueError(f"w: expected directions of shape (..., 3), got {w.shape}")
    ct = _real(cos_theta_t, "cos_theta_t")
    et = _real(eta_ti, "eta_ti")
    dt = _dtype(w, cos_theta_t, eta_ti) if m is None else _dtype(w, cos_theta_t, eta_ti, m)
    w, ct, et = w.astype(dt, copy=False), ct.astype(dt, copy=False)[..., None], et.astype(dt, copy=False)[..., None]
    if m is None:
        out = -et * w
        shape = np.broadcast_shapes(out.shape, ct.shape)
        out = np.broadcast_to(out, shape).copy()
        out[..., 2] = np.broadcast_to(ct, shape)[..., 0]
        return out
    m = _real(m, "m").astype(dt, copy=False)
    if m.shape[-1:] != (3,):
        raise ValueError(f"m: expected normals of shape (..., 3), got {m.shape}")
    wm = np.sum(w * m, axis=-1, keepdims=True)
    return m * (et * wm + ct) - et * w


def ior_value(value_or_name: Any, name: str = "ior") -> float:
    """An index of refraction as a float: a positive finite number, or one of Mitsuba 3's
    names (:data:`IOR_TABLE`: "vacuum", "air", "water", "bk7", "acrylic glass", "polypropylene",
    "diamond", ...; case-insensitive, include/mitsuba/render/ior.h ``lookup_ior``, values after
    Hecht, *Optics*, at about 589 nm).  ``TypeError``/``ValueError`` name the parameter ``name``
    (``"int_ior"``, ``"ext_ior"``) and list the names."""
    if not isinstance(name, str):
        raise TypeError(f"name: expected the parameter's name (str), got {type(name).__name__}")
    return _named_ior(value_or_name, name)


def relative_ior(int_ior: Any, ext_ior: Any) -> float:
    """``eta = int_ior / ext_ior`` of a ``dielectric``/``plastic`` interface, each a number or a
    name (:func:`ior_value`), as Mitsuba 3's plugins compute ``m_eta`` (which refuse negative
    indices; vrlab also refuses 0).  Mitsuba's defaults are plugin-specific (``dielectric``:
    "bk7" inside, "air" outside; ``plastic``: "polypropylene", "air")."""
    return ior_value(int_ior, "int_ior") / ior_value(ext_ior, "ext_ior")


def ior_param(value: Any, name: str) -> Any:
    """An ``int_ior``/``ext_ior`` as given (a positive finite number as a float, or a known
    name as it is), checked by :func:`~vrlab.render.bsdfs.fresnel.ior_value`."""
    ior_value(value, name)
    return value if isinstance(value, str) else float(value)


def ior_from_props(p, name: str, default: str) -> Any:
    """An index of refraction from a scene file: ``<float>`` or ``<string>`` (a name)."""
    if p.has(name) and p.element(name).tag == "string":
        return p.string(name)
    return p.float(name, default) if p.has(name) else default


# -- a conductor's complex index, as the conductor plugins read it ------------------------------
def conductor_index(material: Any = "none", eta: Any = None, k: Any = None) -> tuple[Any, Any]:
    """``(eta, k)`` of a ``conductor``/``roughconductor``: Mitsuba 3's rule
    (src/bsdfs/conductor.cpp): either ``material`` (a name of :data:`~vrlab.render.spectra.CONDUCTORS`;
    ``"none"``, the default, is eta = 0, k = 1: F = 1, a perfect mirror) or explicit ``eta``
    and ``k`` (numbers, RGB or textures; defaults 0 and 1), not both."""
    from .base import color_param

    if not isinstance(material, str):
        raise TypeError(f"material: expected a conductor name (str), got {type(material).__name__}")
    if material != "none" and (eta is not None or k is not None):
        raise ValueError(f"material: give either material={material!r} or eta and k, not both")
    if material != "none":
        return conductor_ior(material)
    return (color_param(0.0 if eta is None else eta, "eta"), color_param(1.0 if k is None else k, "k"))


def conductor_index_from_props(p) -> dict:
    """``{"material", "eta", "k"}`` of a conductor element, as given (None: absent), for its
    constructor (:func:`conductor_index` checks them)."""
    return {"material": p.string("material", "none"),
            "eta": p.texture("eta", kind="unbounded") if p.has("eta") else None,
            "k": p.texture("k", kind="unbounded") if p.has("k") else None}


def interface_iors(int_ior: Any, ext_ior: Any) -> tuple[Any, Any, float]:
    """``(int_ior, ext_ior, eta)`` of an interface element (``roughplastic``,
    ``roughdielectric``): each index a number or a name as given (:func:`ior_param`), eta =
    int / ext; equal indices are refused (no interface), naming both."""
    int_ior, ext_ior = ior_param(int_ior, "int_ior"), ior_param(ext_ior, "ext_ior")
    n_int, n_ext = ior_value(int_ior, "int_ior"), ior_value(ext_ior, "ext_ior")
    if n_int == n_ext:
        raise ValueError(f"int_ior, ext_ior: the interior and exterior indices must differ, got {n_int:g} both")
    return int_ior, ext_ior, n_int / n_ext
