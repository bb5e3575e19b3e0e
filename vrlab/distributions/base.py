"""The distribution protocol shared by every warp in vrlab, and its argument checks.

A distribution maps uniforms ``u`` of shape ``(..., dim_u)`` in [0, 1) to points
``x`` of shape ``(..., dim_x)`` and reports the density of what it produces,
``pdf(x) -> (...)``, with respect to the measure named in ``measure``
("length", "area", "solid angle", "counting").  Where the map is invertible,
``invert(x) -> u`` undoes ``sample``.

The protocol is duck-typed: estimators only need ``dim_u``, ``sample`` and
``pdf``.  ``Distribution`` is a convenience base class, not a requirement.

Checks: constructors check every argument (``TypeError`` for a wrong kind,
``ValueError`` for a bad value; the message names the argument).  ``sample(u)``,
``pdf(x)`` and ``invert(x)`` check the kind and the shape of their array, and its
values with two reductions (min and max, which propagate NaN): ``u`` must lie in
[0, 1] (:func:`as_uniforms`), points must be finite (:func:`as_points`); the error
names the argument and its first bad entry.  float32 arrays, the renderer's own
vectors on its hot path, are not re-checked.
"""
from __future__ import annotations

from typing import Any, NoReturn

import numpy as np

from .. import checks
from ..checks import describe as _describe

_NUMERIC = "biuf"  # array kinds read as numbers: bool, signed/unsigned integer, float


class ArgumentTypeError(TypeError, ValueError):
    """A wrong kind of argument (a string for numbers, an object that is not a surface).

    A ``TypeError`` that is also a ``ValueError``: where such input raised ``ValueError``
    before the argument checks (tabulated weights, surfaces), ``except ValueError``
    still catches it."""


def as_float(x: Any, name: str = "x") -> np.ndarray:
    """``x`` as a float64 array, or as it is if it is a float32 array (the renderer's
    vectors are float32; everything else computes in float64).  Values are not checked;
    ``TypeError`` naming ``name`` unless ``x`` holds real numbers (strings, None, complex
    numbers are refused), ``ValueError`` for a ragged nested list."""
    if isinstance(x, np.ndarray):
        a = x
        if a.dtype == np.float32:
            return a
    else:
        try:
            a = np.asarray(x)
        except (TypeError, ValueError):
            raise ValueError(f"{name}: expected a regular (not ragged) array of numbers, got {_describe(x)}") from None
    if a.dtype.kind in _NUMERIC:
        return a if a.dtype == np.float32 else a.astype(np.float64, copy=False)
    if a.dtype.kind == "O" and a.ndim and not any(v is None or isinstance(v, (str, bytes)) for v in a.flat):
        try:  # e.g. a list holding Fractions or Decimals
            return a.astype(np.float64)
        except (TypeError, ValueError):
            pass
    raise TypeError(f"{name} must be an array of real numbers, got {_describe(x)}")


def as_points(x: Any, k: int, name: str = "x", *, finite: bool = True) -> np.ndarray:
    """Check that ``x`` holds points of a ``k``-dimensional domain: shape ``(..., k)``
    (float64, or float32 kept: see :func:`as_float`), every entry finite unless ``finite=False``
    (two reductions, which propagate NaN; a point off the domain is legal and has density 0).
    float32 arrays are the renderer's own vectors and are not re-checked: on its hot path the
    two reductions cost 5 % of a cornell_box render."""
    x = as_float(x, name)
    if x.ndim == 0 or x.shape[-1] != k:
        raise ValueError(f"{name}: expected shape (..., {k}), got {x.shape}")
    if finite and x.dtype != np.float32 and x.size and not (np.isfinite(x.min()) and np.isfinite(x.max())):
        _refuse(f"{name}: points must be finite", x, ~np.isfinite(x))
    return x


def finite_points(x: Any, k: int, name: str) -> np.ndarray:
    """:func:`as_points` whose every entry is finite, float32 too (for constructor arguments)."""
    x = as_points(x, k, name, finite=False)
    bad = ~np.isfinite(x)
    if bad.any():
        _refuse(f"{name} must be finite", x, bad)
    return x


def _refuse(what: str, x: np.ndarray, bad: np.ndarray) -> NoReturn:
    """ValueError ``what``, naming the first entry of ``x`` where ``bad`` holds."""
    where = tuple(int(i) for i in np.argwhere(bad)[0])
    raise ValueError(f"{what}, but entry {where} is {float(x[where])}")


def as_uniforms(u: Any, dim_u: int) -> np.ndarray:
    """Check that ``u`` has shape ``(..., dim_u)`` and values in [0, 1] (NaN refused: two
    reductions, min and max, which propagate NaN).  The closed interval: warps extend
    continuously to u = 1, where float32 rounding of uniforms below 1 lands (the renderer's
    rays are float32) and where the corners of the unit square map to a shape's corners.
    float32 is kept, see :func:`as_float`, and not re-checked (the renderer's own uniforms,
    from its generators; its hot path)."""
    u = as_float(u, "u")
    if u.ndim == 0 or u.shape[-1] != dim_u:
        raise ValueError(f"u: expected uniforms of shape (..., {dim_u}), got {u.shape}")
    if u.dtype != np.float32 and u.size and not (u.min() >= 0 and u.max() <= 1):
        _refuse("u: uniforms must lie in [0, 1]", u, ~((u >= 0) & (u <= 1)))
    return u


def checked_pdf(dist: Any, x: Any, name: str = "distribution") -> np.ndarray:
    """``dist.pdf(x)``, checked for any duck-typed distribution: real numbers, one per point
    (shape ``x.shape[:-1]``, leading batch axes allowed), finite and >= 0.  ``ValueError`` /
    ``TypeError`` name ``name`` and the first bad point.  A float32 array (the renderer's
    own densities, on its hot path) is returned unchecked."""
    p = dist.pdf(x)
    if isinstance(p, np.ndarray) and p.dtype == np.float32:
        return p
    who = f"{name}: pdf"
    a = np.asarray(p)
    if a.dtype.kind not in _NUMERIC:
        raise TypeError(f"{who} must return real numbers, got {a.dtype} values")
    a = a.astype(np.float64, copy=False)
    x = np.asarray(x)
    checks.one_value_per_point(a, x, who)
    if a.size and not (np.min(a) >= 0 and np.max(a) < np.inf):          # NaN fails too
        bad = ~((a >= 0) & (a < np.inf))
        value, point = checks.first_bad_point(a, x, bad)
        raise ValueError(f"{who} returned {value} at x = {point} ({int(bad.sum())} such value(s)); a density "
                         "must be finite and >= 0")
    return a


def checked_sample(dist: Any, u: np.ndarray, name: str = "distribution") -> np.ndarray:
    """``dist.sample(u)`` for uniforms ``u (..., dim_u)``, checked for any duck-typed
    distribution: real points of shape ``u.shape[:-1] + (k,)``, optionally with leading batch
    axes (per-pixel frames) (``ValueError`` / ``TypeError`` naming ``name``); float32 is kept
    (see :func:`as_float`)."""
    x = np.asarray(dist.sample(u))
    if x.dtype.kind not in _NUMERIC:
        raise TypeError(f"{name}: sample must return real points, got {x.dtype} values")
    lead = np.shape(u)[:-1]
    if x.ndim < len(lead) + 1 or x.shape[x.ndim - 1 - len(lead):-1] != lead:
        raise ValueError(f"{name}: sample returned shape {x.shape} for uniforms of shape {np.shape(u)}; it must "
                         f"return one point per row of uniforms, shape {np.shape(u)[:-1] + ('k',)}")
    return x if x.dtype == np.float32 else x.astype(np.float64, copy=False)


def check_broadcast(x: np.ndarray, name: str, shape: tuple, other: str) -> np.ndarray:
    """``x`` if its leading shape ``x.shape[:-1]`` broadcasts with ``shape`` (the leading
    shape of ``other``, e.g. per-pixel axes or reference points), else ``ValueError``."""
    try:
        np.broadcast_shapes(x.shape[:-1], shape)
    except ValueError:
        raise ValueError(f"{name}: leading shape {x.shape[:-1]} does not broadcast with {other}'s {shape} "
                         f"(for {other} of shape (*batch, 3) use {name} of shape (*batch, n, k) and "
                         f"{other}[..., None, :])") from None
    return x


def uniforms32(u: Any) -> np.ndarray:
    """Uniforms in [0, 1) as float32, still in [0, 1): float32 rounding could reach 1."""
    return np.minimum(np.asarray(u, dtype=np.float32), np.nextafter(np.float32(1), np.float32(0)))


def is_distribution(d: Any) -> bool:
    """Whether ``d`` has the protocol's ``dim_u``, ``sample`` and ``pdf``."""
    return hasattr(d, "dim_u") and callable(getattr(d, "sample", None)) and callable(getattr(d, "pdf", None))


def distribution_list(components: Any, name: str = "components") -> list:
    """``components`` as a non-empty list of distributions, each with an integer ``dim_u >= 1``."""
    if isinstance(components, (str, bytes)) or is_distribution(components):
        raise TypeError(f"{name} must be a list of distributions, got {_describe(components)}")
    try:
        out = list(components)
    except TypeError:
        raise TypeError(f"{name} must be a list of distributions, got {_describe(components)}") from None
    if not out:
        raise ValueError(f"{name}: need at least one distribution")
    for j, c in enumerate(out):
        if not is_distribution(c):
            raise TypeError(f"{name}[{j}]: {_describe(c)} is not a distribution (needs dim_u, sample, pdf)")
        checks.integer(c.dim_u, f"{name}[{j}].dim_u", low=1)
    return out


class Distribution:
    """Base class: subclasses set ``dim_u``, ``dim_x``, ``measure`` and implement
    ``sample`` and ``pdf`` (and ``invert`` where the warp is a bijection)."""

    dim_u: int = 1
    dim_x: int = 1
    measure: str = "length"

    def sample(self, u: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError  # abstract

    def pdf(self, x: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError  # abstract

    def sample_pdf(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(x, pdf(x))`` for ``x = sample(u)``; subclasses may share work."""
        x = self.sample(u)
        return x, self.pdf(x)

    def __repr__(self) -> str:
        fields = ", ".join(f"{k}={v!r}" for k, v in self._repr_fields().items())
        return f"{type(self).__name__}({fields})"

    def _repr_fields(self) -> dict:
        return {}


def positive_float(value: Any, name: str) -> float:
    """``value`` as a float if it is a finite real number > 0: ``TypeError`` naming ``name``
    for a non-number, ``ValueError`` for NaN, inf or a value <= 0."""
    return checks.real(value, name, low=0.0, low_open=True)
