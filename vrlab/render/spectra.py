"""Colours and indices of refraction as Mitsuba 3's RGB variants (``scalar_rgb``) see them.

A ``<spectrum value="400:0.78, 500:0.3, ...">`` in a scene becomes one linear-sRGB triple when
the scene is loaded (Mitsuba 3, src/core/properties.cpp ``Properties::get_texture_impl``):

* ``kind="reflectance"`` (``get_texture``: albedos, reflectances): integrated against the CIE
  1931 matching functions *times the D65 illuminant*, then clamped to [0, 1];
* ``kind="emission"`` (``get_emissive_texture``: radiance, irradiance, intensity): integrated
  against the matching functions alone (an equal-energy spectrum is the purple-ish sRGB
  ``xyz_to_srgb(1, 1, 1)``), negatives clamped to 0;
* ``kind="unbounded"`` (``get_unbounded_texture``: a conductor's ``eta``/``k`` given as a
  spectrum, ...): with D65 like a reflectance, but only negatives are clamped.

Mitsuba's named conductors (``material="Au"``) go through ``ior_from_file``
(include/mitsuba/render/ior.h), which uses the emission rule (no D65) on the tabulated spectra.
The data (CIE 1931 observer, D65, conductor tables) are text files in ``render/data`` that
cite their sources.  Everything here was checked against mitsuba 3.9.1 (tests/test_spectra.py).
"""
from __future__ import annotations

import functools
import math
import re
import warnings
from pathlib import Path

import numpy as np

__all__ = ["CIE_MIN", "CIE_MAX", "CIE_Y_NORMALIZATION", "CIE_D65_NORMALIZATION", "XYZ_TO_SRGB", "KINDS",
           "GamutWarning", "cie1931_xyz", "cie_d65", "xyz_to_srgb", "parse_spectrum", "load_spd",
           "spectrum_to_rgb", "spectrum_property_rgb", "planck", "blackbody_rgb", "IOR_TABLE", "ior",
           "CONDUCTORS", "conductor_ior"]

DATA_DIR = Path(__file__).with_name("data")

CIE_MIN, CIE_MAX = 360.0, 830.0            # nm, MI_CIE_MIN / MI_CIE_MAX
_CIE_SAMPLES = 95                          # 5 nm steps, MI_CIE_SAMPLES
_STEPS = 1000                              # spectrum_list_to_srgb's quadrature points
CIE_Y_NORMALIZATION = 1.0 / 106.7502593994140625   # MI_CIE_Y_NORMALIZATION
CIE_D65_NORMALIZATION = 1.0 / 98.99741751876255    # MI_CIE_D65_NORMALIZATION

#: XYZ -> linear sRGB (ITU-R BT.709 primaries, D65 white); Mitsuba 3 include/mitsuba/core/spectrum.h
XYZ_TO_SRGB = np.array([[3.240479, -1.537150, -0.498535],
                        [-0.969256, 1.875991, 0.041556],
                        [0.055648, -0.204043, 1.057311]])
XYZ_TO_SRGB.flags.writeable = False

#: kind -> (bounded, weighted by D65), the two flags of Mitsuba's spectrum_list_to_srgb
_RULES = {"reflectance": (True, True), "emission": (False, False), "unbounded": (False, True)}
KINDS = tuple(_RULES)


class GamutWarning(UserWarning):
    """A spectrum's sRGB value was clamped, as Mitsuba logs "Spectrum: clamping out-of-gamut color"."""


def _read_csv(name: str) -> list[list[str]]:
    """Rows (header dropped) of a data file; lines starting with ``#`` are its citation."""
    lines = [ln for ln in (DATA_DIR / name).read_text().splitlines() if ln and not ln.startswith("#")]
    return [ln.split(",") for ln in lines[1:]]


@functools.cache
def _cie_tables() -> tuple[np.ndarray, np.ndarray]:
    """(xbar, ybar, zbar) as (95, 3) and D65 as (95, 1), at 360, 365, ..., 830 nm."""
    xyz = np.array(_read_csv("cie1931.csv"), dtype=float)
    d65 = np.array(_read_csv("cie_d65.csv"), dtype=float)
    grid = CIE_MIN + 5.0 * np.arange(_CIE_SAMPLES)
    assert np.array_equal(xyz[:, 0], grid) and np.array_equal(d65[:, 0], grid), "render/data CIE tables"
    return xyz[:, 1:], d65[:, 1:]


def _real_array(name: str, x) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{name}: expected real numbers, got {type(x).__name__}") from None
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: must be finite (no NaN or infinity)")
    return a


def _lerp_table(table: np.ndarray, wavelengths) -> np.ndarray:
    """Linear interpolation of a 5 nm table at ``wavelengths`` (nm), 0 outside [360, 830]."""
    w = _real_array("wavelengths", wavelengths)
    inside = (w >= CIE_MIN) & (w <= CIE_MAX)
    t = np.where(inside, w - CIE_MIN, 0.0) * ((_CIE_SAMPLES - 1) / (CIE_MAX - CIE_MIN))
    i0 = np.minimum(t.astype(np.intp), _CIE_SAMPLES - 2)
    f = (t - i0)[..., None]
    return np.where(inside[..., None], (1.0 - f) * table[i0] + f * table[i0 + 1], 0.0)


def cie1931_xyz(wavelengths) -> np.ndarray:
    """CIE 1931 2° matching functions ``(xbar, ybar, zbar)`` at ``wavelengths`` (nm), shape (..., 3).

    Linear interpolation of the 5 nm table (ISO/CIE 11664-1, file render/data/cie1931.csv) and 0
    outside [360, 830] nm: Mitsuba 3 convention, include/mitsuba/core/spectrum.h ``cie1931_xyz``.
    """
    return _lerp_table(_cie_tables()[0], wavelengths)


def cie_d65(wavelengths) -> np.ndarray:
    """CIE illuminant D65 at ``wavelengths`` (nm), shape (...): ``D65(λ) / 98.9974…``, so that
    ``∫ ybar·D65 dλ`` over 360-830 nm is about 106.75 (= 1 / CIE_Y_NORMALIZATION).

    Linear interpolation of the 5 nm table (render/data/cie_d65.csv), 0 outside [360, 830] nm:
    Mitsuba 3 convention, include/mitsuba/core/spectrum.h ``cie_d65``.
    """
    return _lerp_table(_cie_tables()[1], wavelengths)[..., 0] * CIE_D65_NORMALIZATION


def xyz_to_srgb(xyz) -> np.ndarray:
    """Linear sRGB (BT.709 primaries) of XYZ tristimulus values (..., 3): ``rgb = M xyz`` with
    Mitsuba 3's matrix :data:`XYZ_TO_SRGB` (include/mitsuba/core/spectrum.h ``xyz_to_srgb``)."""
    xyz = _real_array("xyz", xyz)
    if xyz.shape[-1:] != (3,):
        raise ValueError(f"xyz: the last axis must have length 3, got shape {xyz.shape}")
    return xyz @ XYZ_TO_SRGB.T


_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
_SPLIT = re.compile(r"[,\s]+")
_FORMAT = ('a single number or at least two wavelength:value pairs (nm) separated by commas '
           'or spaces, e.g. "400:0.78, 500:0.3"')


def _number(token: str, text: str, what: str) -> float:
    if not _NUMBER.fullmatch(token):
        try:
            bad = not math.isfinite(float(token))
        except ValueError:
            bad = False
        why = "is not finite (NaN and infinity are not allowed)" if bad else "is not a number"
        raise ValueError(f'text: in <spectrum value="{text}">, the {what} {token!r} {why}; '
                         f"expected {_FORMAT}")
    return float(token)


def parse_spectrum(text: str) -> float | tuple[np.ndarray, np.ndarray]:
    """The ``value`` text of a Mitsuba ``<spectrum>``: a float for a single number (a uniform
    spectrum), else ``(wavelengths_nm, values)``, two float arrays of the ``λ:v`` pairs.

    Mitsuba 3 convention (src/core/properties.cpp ``Properties::Spectrum(string_view)``):
    tokens are separated by commas or white space, a pair is ``wavelength:value``, at least two
    pairs, wavelengths strictly increasing.  NaN and infinities are refused as well.
    """
    if not isinstance(text, str):
        raise TypeError(f"text: expected the <spectrum> value text (str), got {type(text).__name__}")
    tokens = [t for t in _SPLIT.split(text.strip()) if t]
    if not tokens:
        raise ValueError(f'text: <spectrum value="{text}"> is empty; expected {_FORMAT}')
    if len(tokens) == 1 and ":" not in tokens[0]:
        return _number(tokens[0], text, "value")
    wavelengths, values = [], []
    for tok in tokens:
        parts = tok.split(":")
        if len(parts) != 2:
            raise ValueError(f'text: in <spectrum value="{text}">, {tok!r} is not one wavelength:value '
                             f"pair; expected {_FORMAT}")
        wavelengths.append(_number(parts[0], text, "wavelength"))
        values.append(_number(parts[1], text, "value"))
    if len(wavelengths) < 2:
        raise ValueError(f'text: <spectrum value="{text}"> has one wavelength:value pair; expected {_FORMAT}')
    w = np.array(wavelengths)
    bad = np.flatnonzero(np.diff(w) <= 0)
    if bad.size:
        raise ValueError(f'text: in <spectrum value="{text}">, wavelengths must increase strictly, but '
                         f"{tokens[bad[0]]!r} is followed by {tokens[bad[0] + 1]!r}")
    return w, np.array(values)


def _check_pairs(wavelengths, values) -> tuple[np.ndarray, np.ndarray]:
    w = _real_array("wavelengths", wavelengths)
    v = _real_array("values", values)
    if w.ndim != 1 or w.size < 2:
        raise ValueError(f"wavelengths: expected a 1-D array of at least 2 wavelengths (nm), got shape {w.shape}")
    if v.shape != w.shape:
        raise ValueError(f"values: expected one value per wavelength, shape {w.shape}, got {v.shape}")
    if np.any(np.diff(w) <= 0):
        raise ValueError("wavelengths: must increase strictly")
    return w, v


def load_spd(path) -> tuple[np.ndarray, np.ndarray]:
    """``(wavelengths_nm, values)`` of a Mitsuba ``.spd`` file (``<spectrum filename=...>``):
    one ``wavelength value`` pair per line, ``#`` comment lines (Mitsuba 3 convention,
    src/core/properties.cpp ``Properties::Spectrum(const fs::path &)``)."""
    path = Path(path)
    rows = [ln.split() for ln in path.read_text().splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    bad = [r for r in rows if len(r) != 2]
    if bad:
        raise ValueError(f"path: {path} has a line that is not 'wavelength value': {' '.join(bad[0])!r}")
    try:
        a = np.array(rows, dtype=float).reshape(-1, 2)
    except ValueError as e:
        raise ValueError(f"path: {path} holds a non-number ({e})") from None
    return _check_pairs(a[:, 0], a[:, 1])


def _kind(kind: str) -> tuple[bool, bool]:
    if kind not in _RULES:
        raise ValueError(f"kind: expected one of {', '.join(KINDS)}, got {kind!r}")
    return _RULES[kind]


def spectrum_to_rgb(wavelengths, values, *, kind: str = "reflectance", warn: bool = True) -> np.ndarray:
    """Linear sRGB (3,) that Mitsuba 3's RGB variants store for a tabulated spectrum.

    Mitsuba 3 convention, src/core/spectrum.cpp ``spectrum_list_to_srgb(…, bounded, d65)`` as
    called by src/core/properties.cpp (``kind`` picks the flags, see the module docstring)::

        λ_i  = 360 + (i / 999)·470 nm, i = 0…999, keeping only λ_i in [λ_first, λ_last]
        v(λ) = linear interpolation of the pairs (no extrapolation: 0 outside their range)
        XYZ  = (470 / 1000) · CIE_Y_NORMALIZATION · Σ_i xyz̄(λ_i) · v(λ_i) · [D65(λ_i)]
        rgb  = XYZ_TO_SRGB · XYZ

    a Riemann sum (step 470/1000 nm, not 470/999) of ``∫ xyz̄ v [D65] dλ`` over 360-830 nm,
    normalised so that a flat unit spectrum has luminance Y ≈ 1 (the CIE_Y_NORMALIZATION factor is
    in mitsuba 3.9.1's binary, checked; older spectrum.cpp sources lack it); ``[D65(λ)]`` (see
    :func:`cie_d65`) is there for ``"reflectance"`` and ``"unbounded"``.  Then, as Mitsuba does
    (with a logged warning, here a :class:`GamutWarning` if ``warn``): ``"reflectance"`` clips
    to [0, 1] when any channel leaves it; the other kinds only raise negatives to 0.
    """
    bounded, d65 = _kind(kind)
    w, v = _check_pairs(wavelengths, values)
    lam = CIE_MIN + (np.arange(_STEPS) / (_STEPS - 1)) * (CIE_MAX - CIE_MIN)
    lam = lam[(lam >= w[0]) & (lam <= w[-1])]
    i = np.clip(np.searchsorted(w, lam, side="right") - 1, 0, w.size - 2)
    w0, w1 = w[i], w[i + 1]
    y = ((lam - w1) * v[i] + (w0 - lam) * v[i + 1]) / (w0 - w1)
    if d65:
        y = y * cie_d65(lam)
    xyz = (y @ cie1931_xyz(lam)) * ((CIE_MAX - CIE_MIN) / _STEPS * CIE_Y_NORMALIZATION)
    rgb = XYZ_TO_SRGB @ xyz
    out = (rgb < 0) | (rgb > 1) if bounded else rgb < 0
    if np.any(out):
        if warn:
            warnings.warn(f"spectrum_to_rgb: clamping out-of-gamut {kind} color {np.round(rgb, 6).tolist()}",
                          GamutWarning, stacklevel=2)
        rgb = np.clip(rgb, 0.0, 1.0) if bounded else np.maximum(rgb, 0.0)
    return rgb


def spectrum_property_rgb(value, *, kind: str = "reflectance", warn: bool = True) -> np.ndarray:
    """Linear sRGB (3,) that Mitsuba 3's RGB variants give a ``<spectrum>`` property ``value``:
    its text, a number, or ``(wavelengths, values)``.

    Pairs go through :func:`spectrum_to_rgb`.  A single number ``c`` (a uniform spectrum) stays
    ``(c, c, c)`` for ``"reflectance"`` and ``"unbounded"``, and becomes
    ``c · XYZ_TO_SRGB · (1, 1, 1)`` for ``"emission"`` (an equal-energy emitter is not white in
    sRGB): Mitsuba 3 convention, src/core/properties.cpp ``Properties::get_texture_impl``.
    """
    _kind(kind)
    if isinstance(value, str):
        value = parse_spectrum(value)
    if isinstance(value, tuple) and len(value) == 2:
        return spectrum_to_rgb(*value, kind=kind, warn=warn)
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"value: expected <spectrum> text, a number or (wavelengths, values), got {type(value).__name__}")
    c = float(value)
    if not math.isfinite(c):
        raise ValueError(f"value: must be finite, got {c}")
    return c * XYZ_TO_SRGB.sum(axis=1) if kind == "emission" else np.full(3, c)


# Planck's law with Mitsuba 3's constants (src/spectra/blackbody.cpp; CODATA 2014 values)
_C, _H, _K = 2.99792458e8, 6.62607004e-34, 1.38064852e-23


def planck(wavelengths, temperature: float) -> np.ndarray:
    """Black-body spectral radiance in W m⁻² sr⁻¹ nm⁻¹ at ``wavelengths`` (nm):
    ``B(λ, T) = 10⁻⁹ · 2hc² / (λ⁵ (exp(hc / (λ k T)) − 1))`` with λ in metres (Planck's law;
    constants and the per-nm unit as in Mitsuba 3 src/spectra/blackbody.cpp)."""
    temperature = _temperature(temperature)
    lam = _real_array("wavelengths", wavelengths) * 1e-9
    if np.any(lam <= 0):
        raise ValueError("wavelengths: must be positive (nm)")
    with np.errstate(over="ignore"):
        return 1e-9 * 2.0 * _H * _C * _C / (lam ** 5 * np.expm1(_H * _C / (lam * _K * temperature)))


def _temperature(t) -> float:
    if isinstance(t, bool) or not isinstance(t, (int, float, np.integer, np.floating)):
        raise TypeError(f"temperature: expected a number of kelvins, got {type(t).__name__}")
    if not (math.isfinite(t) and t > 0):
        raise ValueError(f"temperature: must be a positive finite number of kelvins, got {t}")
    return float(t)


@functools.cache
def _gauss_nodes(order: int = 8) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes on each 5 nm segment of [360, 830]: (λ, weight, segment, fraction)."""
    x, wt = np.polynomial.legendre.leggauss(order)
    seg = np.repeat(np.arange(_CIE_SAMPLES - 1), order)
    frac = np.tile(0.5 * (x + 1.0), _CIE_SAMPLES - 1)
    return CIE_MIN + 5.0 * (seg + frac), np.tile(2.5 * wt, _CIE_SAMPLES - 1), seg, frac


def blackbody_rgb(temperature: float) -> np.ndarray:
    """Linear sRGB (3,) of a black body at ``temperature`` kelvins, as Mitsuba 3 renders it.

    Mitsuba 3.9.1's RGB variants load ``<spectrum type="blackbody">`` but cannot use it: its
    ``eval`` raises "Not implemented for non-spectral modes" (src/spectra/blackbody.cpp), so a
    scene with it fails to render in ``scalar_rgb``.  This returns what the spectral variants
    render for a surface of radiance :func:`planck` (W m⁻² sr⁻¹ nm⁻¹, zero outside 360-830 nm):
    the film's expected value ``XYZ = CIE_Y_NORMALIZATION · ∫_360^830 xyz̄(λ) B(λ, T) dλ``
    (``spectrum_to_xyz``, wavelengths importance-sampled with weight 1/pdf), then
    ``rgb = XYZ_TO_SRGB · XYZ``, not clamped (negative channels below ~1500 K stay).  The
    integral is exact up to rounding: xyz̄ is linear on each 5 nm segment, B is integrated with
    8-point Gauss–Legendre per segment.  No D65 weight (it is an emission); huge values at
    ordinary temperatures (about 4·10⁴ at 6500 K) because B is in physical units.
    """
    temperature = _temperature(temperature)
    lam, weight, seg, frac = _gauss_nodes()
    xyz_tab = _cie_tables()[0]
    cmf = (1.0 - frac)[:, None] * xyz_tab[seg] + frac[:, None] * xyz_tab[seg + 1]
    xyz = (weight * planck(lam, temperature)) @ cmf * CIE_Y_NORMALIZATION
    return XYZ_TO_SRGB @ xyz


#: Mitsuba 3's named dielectric indices of refraction (include/mitsuba/render/ior.h, after
#: E. Hecht, Optics, 4th ed.: measured at 0-20 °C and about 589 nm); Mitsuba stores them as float32.
IOR_TABLE: dict[str, float] = {
    "vacuum": 1.0, "helium": 1.000036, "hydrogen": 1.000132, "air": 1.000277, "carbon dioxide": 1.00045,
    "water": 1.3330, "acetone": 1.36, "ethanol": 1.361, "carbon tetrachloride": 1.461, "glycerol": 1.4729,
    "benzene": 1.501, "silicone oil": 1.52045, "bromine": 1.661,
    "water ice": 1.31, "fused quartz": 1.458, "pyrex": 1.470, "acrylic glass": 1.49, "polypropylene": 1.49,
    "bk7": 1.5046, "sodium chloride": 1.544, "amber": 1.55, "pet": 1.5750, "diamond": 2.419,
}


def ior(value, name: str = "value") -> float:
    """Index of refraction of ``value``: a name of :data:`IOR_TABLE` (case-insensitive, like
    Mitsuba 3's ``lookup_ior`` in include/mitsuba/render/ior.h) or a positive finite number;
    errors name the parameter ``name`` (e.g. ``"int_ior"``)."""
    if isinstance(value, str):
        try:
            return IOR_TABLE[value.lower()]
        except KeyError:
            raise ValueError(f"{name}: unknown index of refraction {value!r}; give a positive number or one "
                             f"of: {', '.join(IOR_TABLE)}") from None
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name}: expected a positive number or one of the names {', '.join(IOR_TABLE)}, "
                        f"got {type(value).__name__}")
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name}: an index of refraction must be positive and finite, got {value}, or one of "
                         f"the names {', '.join(IOR_TABLE)}")
    return float(value)


#: Mitsuba 3's named conductors: its data/ior/<name>.eta.spd / .k.spd tables (render/data/
#: conductors.csv) and "none" (eta = 0, k = 1, a perfect mirror), src/bsdfs/conductor.cpp.
CONDUCTORS: tuple[str, ...] = (
    "a-C", "Ag", "Al", "AlAs", "AlAs_palik", "AlSb", "AlSb_palik", "Au", "Be", "Be_palik", "Cr", "CsI",
    "CsI_palik", "Cu", "Cu2O", "Cu2O_palik", "CuO", "CuO_palik", "Cu_palik", "d-C", "d-C_palik", "Hg",
    "HgTe", "HgTe_palik", "Hg_palik", "Ir", "Ir_palik", "K", "K_palik", "Li", "Li_palik", "MgO", "MgO_palik",
    "Mo", "Mo_palik", "Na_palik", "Nb", "Nb_palik", "Ni_palik", "Rh", "Rh_palik", "Se", "Se-e", "Se-e_palik",
    "Se_palik", "SiC", "SiC_palik", "SnTe", "SnTe_palik", "Ta", "Ta_palik", "Te", "Te-e", "Te-e_palik",
    "Te_palik", "ThF4", "ThF4_palik", "TiC", "TiC_palik", "TiN", "TiN_palik", "TiO2", "TiO2-e",
    "TiO2-e_palik", "TiO2_palik", "VC", "VC_palik", "VN", "VN_palik", "V_palik", "W", "none",
)


@functools.cache
def _conductor_tables() -> dict[str, np.ndarray]:
    """material -> (n, 3) array of (wavelength_nm, eta, k) rows from render/data/conductors.csv."""
    rows = _read_csv("conductors.csv")
    names = np.array([r[0] for r in rows])
    data = np.array([r[1:4] for r in rows], dtype=float)
    starts = np.flatnonzero(np.r_[True, names[1:] != names[:-1]])
    return {str(names[s]): data[s:e] for s, e in zip(starts, np.r_[starts[1:], len(rows)])}


@functools.cache
def _conductor_rgb(material: str) -> tuple[np.ndarray, np.ndarray]:
    table = _conductor_tables()[material]
    return tuple(spectrum_to_rgb(table[:, 0], table[:, j], kind="emission", warn=False) for j in (1, 2))


def conductor_ior(material: str) -> tuple[np.ndarray, np.ndarray]:
    """``(eta, k)``, each linear sRGB (3,), of Mitsuba 3's named conductor ``material``.

    Mitsuba 3 convention (include/mitsuba/render/ior.h ``complex_ior_from_file``): each of the
    tabulated spectra ``data/ior/<material>.eta.spd`` and ``.k.spd`` goes through
    ``spectrum_list_to_srgb(…, bounded=false, d65=false)``, i.e. :func:`spectrum_to_rgb` with
    ``kind="emission"`` (no D65, negatives raised to 0; Mitsuba then logs a warning, this
    does not).  ``"none"`` is eta = 0, k = 1 (src/bsdfs/conductor.cpp).  Names are
    case-sensitive, as Mitsuba's file names are.
    """
    if not isinstance(material, str):
        raise TypeError(f"material: expected a conductor name (str), got {type(material).__name__}")
    if material == "none":
        return np.zeros(3), np.ones(3)
    if material not in CONDUCTORS:
        hint = [c for c in CONDUCTORS if c.lower() == material.lower()]
        hint = f" (names are case-sensitive: {hint[0]!r})" if hint else ""
        raise ValueError(f"material: unknown conductor {material!r}{hint}; one of: {', '.join(CONDUCTORS)}")
    eta, k = _conductor_rgb(material)
    return eta.copy(), k.copy()
