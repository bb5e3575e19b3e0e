"""Argument checks shared by every layer: each error names the argument and what is allowed.

Public entry points call these once, at the boundary, so that bad input gives a
``TypeError`` (wrong kind: ``"abc"`` for a number) or a ``ValueError`` (right kind,
bad value: NaN, out of range, wrong shape) whose message starts with the argument's
name.  Hot loops (a warp's ``sample(u)`` inside an estimator) do not call them.

* :func:`real` - one finite real number, optionally within bounds;
* :func:`integer` - one integer (``16.7`` and ``True`` are refused, ``16.0`` too);
* :func:`choice` - one of a fixed set of strings;
* :func:`finite_array` - a float array of finite values with an optional shape check;
* :func:`uniforms_array` - an array of uniforms: finite, in [0, 1), last axis ``d``;
* :func:`flag` - a bool; :func:`distribution` - an object with dim_u, sample, pdf;
* :func:`file_path` - a path with an allowed suffix (and, to write, an existing folder).
"""
from __future__ import annotations

import numbers
import os
from pathlib import Path
from typing import Any, Iterable

import numpy as np


def describe(value: Any) -> str:
    """``repr(value)`` (cut at 60 characters) and its type, for error messages."""
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({type(value).__name__})"


def _bound_text(low, high, low_open, high_open) -> str:
    parts = []
    if low is not None:
        parts.append(f"> {low}" if low_open else f">= {low}")
    if high is not None:
        parts.append(f"< {high}" if high_open else f"<= {high}")
    return " and ".join(parts)


def real(value: Any, name: str, *, low: float | None = None, high: float | None = None,
         low_open: bool = False, high_open: bool = False, finite: bool = True) -> float:
    """``value`` as a Python float.

    ``TypeError`` unless it is a real number (a Python or NumPy number, or a 0-d
    array; strings, ``None``, booleans and complex numbers are refused);
    ``ValueError`` if it is NaN, infinite (with ``finite=True``) or outside
    ``[low, high]`` (open ends with ``low_open`` / ``high_open``).
    """
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.floating, np.integer)):
        raise TypeError(f"{name} must be a real number, got {describe(value)}")
    x = float(value)
    if np.isnan(x) or (finite and not np.isfinite(x)):
        raise ValueError(f"{name} must be a finite number, got {x}")
    ok = True
    if low is not None:
        ok &= x > low if low_open else x >= low
    if high is not None:
        ok &= x < high if high_open else x <= high
    if not ok:
        raise ValueError(f"{name} must be {_bound_text(low, high, low_open, high_open)}, got {x:g}")
    return x


def integer(value: Any, name: str, *, low: int | None = None, high: int | None = None) -> int:
    """``value`` as a Python int: ``TypeError`` unless it is an integer (floats such as
    16.7 or 16.0 and booleans are refused), ``ValueError`` outside ``[low, high]``."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral, np.integer)):
        raise TypeError(f"{name} must be an integer, got {describe(value)}")
    k = int(value)
    if (low is not None and k < low) or (high is not None and k > high):
        raise ValueError(f"{name} must be {_bound_text(low, high, False, False)}, got {k}")
    return k


def choice(value: Any, name: str, allowed: Iterable[str]) -> str:
    """``value`` if it is one of the strings ``allowed``; else ``ValueError`` listing them
    (``TypeError`` for a non-string)."""
    allowed = tuple(allowed)
    if not isinstance(value, str):
        raise TypeError(f"{name} must be one of {', '.join(map(repr, allowed))}; got {describe(value)}")
    if value not in allowed:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, allowed))}; got {value!r}")
    return value


def finite_array(value: Any, name: str, *, ndim: int | None = None, last: int | None = None,
                 dtype=float) -> np.ndarray:
    """``value`` as a float array whose every entry is finite.

    ``TypeError`` if it cannot be read as numbers; ``ValueError`` naming the first
    non-finite entry, or if ``ndim`` / the last axis length ``last`` do not match.
    """
    if value is None or isinstance(value, (str, bytes)):
        raise TypeError(f"{name} must be an array of real numbers, got {describe(value)}")
    try:
        a = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be an array of real numbers, got {describe(value)}") from None
    if ndim is not None and a.ndim != ndim:
        raise ValueError(f"{name} must have {ndim} dimension(s), got shape {a.shape}")
    if last is not None and (a.ndim == 0 or a.shape[-1] != last):
        raise ValueError(f"{name} must have shape (..., {last}), got {a.shape}")
    bad = ~np.isfinite(a)
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(f"{name} must be finite, but entry {where} is {a[where]}")
    return a


def uniforms_array(value: Any, name: str = "points", *, d: int | None = None) -> np.ndarray:
    """An array of uniforms ``(..., d)``: finite float values in [0, 1).

    Estimators call this once on a user's ``points=`` array; ``ValueError`` names the
    first value outside [0, 1) or the wrong last axis.
    """
    a = finite_array(value, name)
    if a.ndim < 2:
        raise ValueError(f"{name}: an array of uniforms needs shape (..., n, d), got {a.shape}")
    if d is not None and a.shape[-1] < d:
        raise ValueError(f"{name}: an array of uniforms needs shape (..., n, {d}), got {a.shape}")
    out = (a < 0) | (a >= 1)
    if out.any():
        where = tuple(int(i) for i in np.argwhere(out)[0])
        raise ValueError(f"{name}: uniforms must lie in [0, 1), but entry {where} is {float(a[where])}")
    return a


def flag(value: Any, name: str) -> bool:
    """``value`` as a bool: only ``True``/``False`` (or NumPy booleans) are accepted, so that
    ``probe="no"`` is a ``TypeError`` rather than a truthy string."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {describe(value)}")
    return bool(value)


def distribution(value: Any, name: str = "distribution"):
    """``value`` if it has the distribution protocol (``dim_u``, ``sample``, ``pdf``), else
    ``TypeError`` naming the missing attribute."""
    for attr in ("dim_u", "sample", "pdf"):
        if not hasattr(value, attr):
            raise TypeError(f"{name}: {value!r} is not a distribution: it has no {attr!r} "
                            "(a distribution needs dim_u, sample(u) and pdf(x))")
    return value


def file_path(value: Any, name: str, suffixes: Iterable[str], *, write: bool = True) -> Path:
    """``value`` as a ``Path`` whose suffix (case-insensitive) is one of ``suffixes``
    (``".png"``...).  ``TypeError`` unless it is a str or ``os.PathLike``; ``ValueError``
    for an empty name or another suffix, and, with ``write``, for a path that is a folder
    or whose folder does not exist (checked before any work, so nothing is lost)."""
    if not isinstance(value, (str, os.PathLike)) or isinstance(value, bytes):
        raise TypeError(f"{name} must be a file path (str or os.PathLike), got {describe(value)}")
    path = Path(value)
    if str(value) == "" or path.name == "":
        raise ValueError(f"{name}: give a file name, got {str(value)!r}")
    suffixes = tuple(s.lower() for s in suffixes)
    if path.suffix.lower() not in suffixes:
        raise ValueError(f"{name}: the suffix of {str(path)!r} must be one of {', '.join(suffixes)}")
    if write:
        if path.is_dir():
            raise ValueError(f"{name}: {str(path)!r} is a folder, not a file name")
        if not path.parent.is_dir():
            raise ValueError(f"{name}: the folder {str(path.parent)!r} does not exist (create it first)")
    return path


def one_value_per_point(out: np.ndarray, x: np.ndarray, who: str) -> None:
    """``ValueError`` naming ``who`` unless ``out`` holds one value per point of ``x (..., k)``:
    shape ``x.shape[:-1]``, optionally with leading batch axes (an integrand's or a density's
    values)."""
    want = x.shape[:-1]
    try:
        fits = np.broadcast_shapes(out.shape, want) == out.shape
    except ValueError:
        fits = False
    if out.ndim < len(want) or (want and out.shape[-1] != want[-1]) or not fits:
        what = "one scalar" if out.ndim == 0 else f"shape {out.shape}"
        raise ValueError(f"{who}: returned {what} for points of shape {x.shape}; it must return one value per "
                         f"point, shape {want} (optionally with leading batch axes)")


def first_bad_point(values: np.ndarray, x: np.ndarray, bad: np.ndarray) -> tuple[float, list]:
    """``(value, point)`` of the first entry of ``values`` (one per point of ``x (..., k)``,
    leading batch axes allowed) where ``bad`` holds: for the error messages of value checks."""
    idx = tuple(int(i) for i in np.argwhere(bad)[0])
    lead = x.ndim - 1
    xi = x[idx[values.ndim - lead:]] if lead else x
    return values[idx], np.round(np.asarray(xi, float), 6).tolist()

