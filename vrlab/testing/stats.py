"""Small statistical helpers for tests of estimators.

* ``std_band(r, alpha)``: for r independent N(0, 1) values the sample standard
  deviation s satisfies (r - 1) s^2 ~ chi^2_{r-1}; the band [sqrt(q_lo), sqrt(q_hi)]
  with q = chi2.ppf([alpha/2, 1 - alpha/2], r - 1) / (r - 1) holds with probability
  1 - alpha.  Used to check that z-scores of an estimator have spread 1 (calibrated stderr).
* ``u_nodes(d, cells, quad)``: composite Gauss–Legendre nodes and weights on [0, 1]^d
  (d = 1, 2), for predicting variances as integrals over the uniforms.
"""
from __future__ import annotations

import numpy as np
from scipy import stats


def std_band(r: int, alpha: float = 1e-3) -> tuple[float, float]:
    """Band for the sample std of ``r`` standard normal values (chi-square, r - 1 dof)."""
    q = stats.chi2.ppf([alpha / 2, 1 - alpha / 2], r - 1) / (r - 1)
    return float(np.sqrt(q[0])), float(np.sqrt(q[1]))


def u_nodes(d: int, cells: int = 96, quad: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss–Legendre nodes (N, d) and weights (N,) on [0, 1]^d (d = 1, 2);
    in 1D ``8 * cells`` cells are used."""
    if d not in (1, 2):
        raise ValueError(f"d must be 1 or 2, got {d}")
    g, w = np.polynomial.legendre.leggauss(quad)
    cells = cells * 8 if d == 1 else cells
    x = ((g[None, :] + 1) / 2 + np.arange(cells)[:, None]).ravel() / cells
    wx = np.tile(w / 2, cells) / cells
    if d == 1:
        return x[:, None], wx
    xx, yy = np.meshgrid(x, x, indexing="ij")
    return np.stack([xx.ravel(), yy.ravel()], -1), np.outer(wx, wx).ravel()
