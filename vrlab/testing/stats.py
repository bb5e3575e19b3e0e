"""Small statistical helpers for tests of estimators.

* ``std_band(r, alpha)``: the chi-square band of the sample standard deviation of r
  standard normal values (defined in :mod:`vrlab.significance`, which the lab's trust flags
  share).  Used to check that z-scores of an estimator have spread 1 (calibrated stderr).
* ``u_nodes(d, cells, quad)``: composite Gauss–Legendre nodes and weights on [0, 1]^d
  (d = 1, 2), for predicting variances as integrals over the uniforms.

Arguments are checked (errors name them): ``r >= 2``, ``alpha`` in (0, 1), ``d`` in {1, 2},
``cells`` and ``quad`` integers >= 1 with at most 2^24 nodes in all.
"""
from __future__ import annotations

import numpy as np

from .. import checks
from ..distributions.quadrature import MAX_NODES, MAX_QUAD
from ..significance import std_band

__all__ = ["std_band", "u_nodes"]


def u_nodes(d: int, cells: int = 96, quad: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss–Legendre nodes (N, d) and weights (N,) on [0, 1]^d (d = 1, 2);
    in 1D ``8 * cells`` cells are used."""
    d = checks.integer(d, "d", low=1, high=2)
    cells = checks.integer(cells, "cells", low=1)
    quad = checks.integer(quad, "quad", low=1, high=MAX_QUAD)
    if float(cells * (8 if d == 1 else 1) * quad) ** d > MAX_NODES:
        raise ValueError(f"cells, quad: {cells} cells x {quad} nodes in {d}D make more than {MAX_NODES} nodes")
    g, w = np.polynomial.legendre.leggauss(quad)
    cells = cells * 8 if d == 1 else cells
    x = ((g[None, :] + 1) / 2 + np.arange(cells)[:, None]).ravel() / cells
    wx = np.tile(w / 2, cells) / cells
    if d == 1:
        return x[:, None], wx
    xx, yy = np.meshgrid(x, x, indexing="ij")
    return np.stack([xx.ravel(), yy.ravel()], -1), np.outer(wx, wx).ravel()
