"""Composite Gauss–Legendre quadrature over the cells of a chart's regular grid.

``cell_integrals(fn, chart, bins, quad, sub)`` integrates ``fn`` over each cell of a
``bins`` grid of a chart's parameter square (or interval): the integral over a cell C is
int_C fn(from_param(s)) jacobian(s) ds, computed with ``sub`` sub-intervals per cell and axis
and ``quad`` Gauss–Legendre nodes on each (exact for polynomials of degree 2 quad - 1 in s;
Abramowitz & Stegun 25.4.29).  Two higher layers use it: the chi-square harness of
:mod:`vrlab.testing` (expected counts) and :func:`vrlab.integrands.mc_variance` (predicted
variances); :mod:`vrlab.testing.chisquare` re-exports it.

The argument checks here (``bins_tuple``, ``chart_like``, ``quad_orders``, ``check_nodes``,
``real_values``) are shared with the harness.  Every error names the argument; the limits keep
a mistyped size from allocating gigabytes (the pdf is evaluated at every node at once).
"""
from __future__ import annotations

import numbers
from typing import Any, Callable, Sequence

import numpy as np

from .. import checks

__all__ = ["MAX_NODES", "MAX_QUAD", "bins_tuple", "cell_integrals", "chart_like", "check_nodes", "gauss_cells",
           "quad_orders", "real_values"]

#: Most quadrature nodes (cells x nodes per cell) evaluated in one ``cell_integrals`` call.
MAX_NODES = 2**24
#: Most Gauss–Legendre nodes per axis and cell.
MAX_QUAD = 100


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


def real_values(value: Any, name: str) -> np.ndarray:
    """``value`` as a float array (NaN allowed); ``TypeError`` unless it holds real numbers."""
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):
        a = np.asarray(None)
    if a.dtype.kind not in "biuf":
        raise TypeError(f"{name} must be real numbers, got {checks.describe(value)}")
    return a.astype(float, copy=False)


def gauss_cells(bins: Sequence[int], quad: int, sub: int = 1):
    """Quadrature nodes and weights for every cell of a regular grid on [0,1]^p
    (composite Gauss–Legendre: ``sub`` sub-intervals per cell, ``quad`` nodes each): per axis,
    nodes and weights of shape ``(b, quad * sub)``.  Arguments unchecked (see ``cell_integrals``)."""
    g, w = np.polynomial.legendre.leggauss(quad)
    g = ((g + 1) / 2 + np.arange(sub)[:, None]).ravel() / sub  # nodes in [0, 1] of one cell
    w = np.tile(w / 2, sub) / sub
    axes_nodes, axes_weights = [], []
    for b in bins:
        lo = np.arange(b) / b
        axes_nodes.append((lo[:, None] + g[None, :] / b))             # (b, q*sub)
        axes_weights.append(np.broadcast_to(w / b, (b, len(w))))      # (b, q*sub)
    return axes_nodes, axes_weights


def cell_integrals(fn: Callable[[np.ndarray], np.ndarray], chart, bins: Sequence[int],
                   quad: int = 6, sub: int = 1, *, name: str = "fn") -> np.ndarray:
    """Integral of ``fn(x)`` (x = chart point) over each cell of a ``bins`` grid.

    Returns an array of shape ``bins``.  ``fn`` must be vectorised over leading axes
    and return one real value per point (NaN is refused; +-inf gives an infinite cell).
    ``sub > 1`` splits each cell per axis (for densities with edges or kinks inside cells,
    e.g. the solid-angle density of a polygon light at its outline).  ``bins``: one
    integer >= 1 per chart parameter (or one for all); at most ``2**24`` nodes in all.
    ``name`` is what errors about ``fn``'s values call it (the harness passes ``"dist.pdf"``).
    """
    if not callable(fn):
        raise TypeError(f"{name} must be callable (x -> values), got {checks.describe(fn)}")
    chart = chart_like(chart)
    bins = bins_tuple(bins, chart.p)
    quad, sub = quad_orders(quad, sub)
    check_nodes(bins, quad, sub)
    nodes, weights = gauss_cells(bins, quad, sub)
    if chart.p == 1:
        s = nodes[0][..., None]                      # (b, q, 1)
        wt = weights[0]
    else:
        s0 = nodes[0][:, None, :, None]              # (b0, 1, q, 1)
        s1 = nodes[1][None, :, None, :]              # (1, b1, 1, q)
        s = np.stack(np.broadcast_arrays(s0, s1), -1)  # (b0, b1, q, q, 2)
        wt = weights[0][:, None, :, None] * weights[1][None, :, None, :]
    x = chart.from_param(s)
    jac = np.asarray(chart.jacobian(s), dtype=float)
    vals = real_values(fn(x), f"{name}(x)")
    try:
        same = np.broadcast_shapes(vals.shape, jac.shape) == jac.shape
    except ValueError:
        same = False
    if not same:
        raise ValueError(f"{name} must return one value per point: shape {jac.shape} for points {np.shape(x)}, "
                         f"got {vals.shape}")
    if np.isnan(vals).any():
        where = tuple(int(i) for i in np.argwhere(np.isnan(np.broadcast_to(vals, jac.shape)))[0])
        raise ValueError(f"{name} returned NaN at the point {np.asarray(x)[where].tolist()}")
    vals = np.where(wt > 0, vals * jac, 0.0) * wt
    out = vals.sum(axis=(-1,) if chart.p == 1 else (-2, -1))
    if np.isnan(out).any():
        raise ValueError(f"{name}: the cell integrals are NaN (+inf and -inf values in one cell)")
    return out
