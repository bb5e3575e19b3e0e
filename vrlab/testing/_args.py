"""Argument checks of the chi-square harness (bins, charts, quadrature orders, names).

Every error names the argument; the limits keep a mistyped size from allocating
gigabytes (the harness evaluates the pdf at every quadrature node at once).
"""
from __future__ import annotations

import numbers
from typing import Any

import numpy as np

from .. import checks
from .._rng import as_generator

#: Most quadrature nodes (cells x nodes per cell) evaluated in one ``cell_integrals`` call.
MAX_NODES = 2**24
#: Most Gauss–Legendre nodes per axis and cell.
MAX_QUAD = 100
#: Most samples ``chi2_gof`` draws.
MAX_SAMPLES = 10**8


def bins_tuple(bins: Any, p: int | None = None, name: str = "bins") -> tuple[int, ...]:
    """``bins`` as a tuple of integers >= 1: a sequence, or one integer used on every axis
    (``p`` axes; one axis if ``p`` is None).  ``p`` given: the length must be ``p``."""
    if bins is None or isinstance(bins, (str, bytes, numbers.Number, np.generic)) or \
            (isinstance(bins, np.ndarray) and bins.ndim == 0):
        k = checks.integer(bins, name, low=1)
        out: tuple[int, ...] = (k,) * (p or 1)
    else:
        try:
            items = list(bins)
        except TypeError:
            raise TypeError(f"{name} must be an integer or a sequence of integers, "
                            f"got {checks.describe(bins)}") from None
        if not items:
            raise ValueError(f"{name}: give at least one bin count, got an empty sequence")
        out = tuple(checks.integer(b, f"{name}[{i}]", low=1) for i, b in enumerate(items))
    if p is not None and len(out) != p:
        raise ValueError(f"bins: the chart has {p} parameters, got {len(out)} bin counts {out}")
    if int(np.prod(out, dtype=float)) > MAX_NODES:
        raise ValueError(f"{name}: {out} makes {np.prod(out, dtype=float):.3g} cells, more than {MAX_NODES}")
    return out


def chart_like(chart: Any, name: str = "chart"):
    """``chart`` if it has ``to_param``, ``from_param``, ``jacobian`` and ``p`` in (1, 2)."""
    if not all(callable(getattr(chart, a, None)) for a in ("to_param", "from_param", "jacobian")):
        raise TypeError(f"{name} must be a chart (to_param, from_param, jacobian; see vrlab.testing), "
                        f"got {checks.describe(chart)}")
    p = getattr(chart, "p", None)
    if isinstance(p, (bool, np.bool_)) or p not in (1, 2):
        raise ValueError(f"{name}: the harness handles charts with p = 1 or 2 parameters, got p = {p!r}")
    return chart


def quad_orders(quad: Any, sub: Any) -> tuple[int, int]:
    """``quad`` (nodes per axis, 1..MAX_QUAD) and ``sub`` (sub-intervals per axis, >= 1)."""
    return checks.integer(quad, "quad", low=1, high=MAX_QUAD), checks.integer(sub, "sub", low=1, high=MAX_NODES)


def check_nodes(bins: tuple[int, ...], quad: int, sub: int) -> None:
    """``ValueError`` if the grid has more than ``MAX_NODES`` quadrature nodes."""
    nodes = float(np.prod(bins, dtype=float)) * float(quad * sub) ** len(bins)
    if nodes > MAX_NODES:
        raise ValueError(f"bins, quad, sub: {bins} cells x ({quad} x {sub})^{len(bins)} nodes = {nodes:.3g} "
                         f"quadrature nodes, more than {MAX_NODES}; use fewer bins or a lower quad/sub")


def text(value: Any, name: str) -> str:
    """``value`` if it is a string (``TypeError`` otherwise)."""
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a string, got {checks.describe(value)}")
    return value


def real_values(value: Any, name: str) -> np.ndarray:
    """``value`` as a float array (NaN allowed); ``TypeError`` unless it holds real numbers."""
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):
        a = np.asarray(None)
    if a.dtype.kind not in "biuf":
        raise TypeError(f"{name} must be real numbers, got {checks.describe(value)}")
    return a.astype(float, copy=False)


def draw_uniforms(dist, n: int, rng, points) -> np.ndarray:
    """``n`` rows of uniforms for ``dist``: from ``points.random(n)`` or from ``rng``."""
    gen = as_generator(rng)
    if points is None:
        dim_u = checks.integer(getattr(dist, "dim_u", None), "dist.dim_u", low=1)
        return gen.random((n, dim_u))
    if not callable(getattr(points, "random", None)):
        raise TypeError(f"points must be a point set with random(n) (e.g. vrlab.points.Sobol), "
                        f"got {checks.describe(points)}")
    u = checks.uniforms_array(points.random(n), "points")
    if u.ndim != 2 or u.shape[0] != n:
        raise ValueError(f"points: random({n}) returned shape {u.shape}, expected ({n}, d)")
    return u


def sample_points(dist, u: np.ndarray, n: int, chart) -> np.ndarray:
    """``dist.sample(u)`` as an (n, dim_x) float array (``ValueError`` naming dist otherwise)."""
    x = real_values(dist.sample(u), "dist.sample(u)")
    dim_x = getattr(chart, "dim_x", None)
    want = (n, dim_x) if isinstance(dim_x, (int, np.integer)) else None
    if x.ndim != 2 or x.shape[0] != n or (want is not None and x.shape != want):
        raise ValueError(f"dist: sample(u) returned shape {x.shape}, expected "
                         f"{want if want is not None else (n, 'dim_x')} for this chart")
    return x
