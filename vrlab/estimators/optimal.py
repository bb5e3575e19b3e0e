"""Optimal multiple importance sampling over whole sample sets (Kondapaneni, Vévoda,
Grittmann, Skřivan, Slusallek & Křivánek 2019, "Optimal Multiple Importance Sampling", ACM
TOG 38(4)).  With c_k = n_k / N and q = sum_k c_k p_k the variance-minimising weights give

    F_o = sum_k a_k + (1/N) sum_{i,j} (f - sum_k a_k p_k)(X_ij) / q(X_ij),   A a = b,
    A_ik = int p_i p_k / q,  b_i = int f p_i / q,

A and b estimated from a pilot, or from the very samples they weight (consistent: an
O(1/N) bias, negligible at the lab's N but not at a pixel's).  ``MIS.estimate`` calls
:func:`fit_optimal` for fractions that are not a ratio of whole numbers and for a pilot;
whole unit counts (and the renderer) use ``MIS.unit_outputs``, a regression on the density
controls cross-fitted over folds of units, unbiased (:mod:`vrlab.estimators.crossfit`).
"""
from __future__ import annotations

import numpy as np

from .base import ratio
from .heuristics import _stack_pdfs
from .regression import CoMoments, regression_estimate

__all__ = ["fit_optimal"]


def _solve_psd(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Batched a = A^+ b for symmetric positive semi-definite A (pseudo-inverse: identical
    or linearly dependent techniques make A singular)."""
    A = 0.5 * (A + np.swapaxes(A, -1, -2))
    A, b = np.broadcast_arrays(A, b[..., None])
    return (np.linalg.pinv(A, rcond=1e-12, hermitian=True) @ b)[..., 0]


def fit_optimal(integrand, all_dists, blocks, n_pilot_segments: int, pilot_counts: np.ndarray,
                counts: np.ndarray):
    """Optimal MIS over whole sample sets (``MIS.estimate`` with ``heuristic="optimal"``).

    ``blocks`` yields ``(segment, technique, u)``: the pilot's ``n_pilot_segments`` segments
    first (``pilot_counts`` samples per technique), then the main pass (``counts``).  Returns
    ``(value, variance contributions (..., K), {"alpha": a})``: F_o = sum a + the mean
    residual per technique, a solving A a = b from the pilot (importance-reweighted to the
    main pass's mixture) or from the main samples' pooled uncentred sums."""
    active = np.flatnonzero(counts > 0)
    dists = [all_dists[i] for i in active]
    c_main = counts[active] / counts.sum()
    c_pilot = pilot_counts[active] / max(pilot_counts.sum(), 1)
    Ka = len(active)
    comoments = {int(i): CoMoments() for i in active}
    G, h, n_fit, pilot = 0.0, 0.0, 0, n_pilot_segments > 0
    for s, i, u in blocks:
        x = all_dists[i].sample(u)
        P = _stack_pdfs(dists, x)                           # (..., m, Ka)
        q = P @ c_main                                      # mixture density of the main pass
        f = integrand(x)
        z = ratio(P, q[..., None])                      # p_k / q
        y = ratio(f, q)                                 # f / q
        if s < n_pilot_segments:                            # pilot: importance weights q / q_pilot
            r = ratio(q, P @ c_pilot)
            G = G + np.swapaxes(z * r[..., None], -1, -2) @ z
            h = h + np.sum((y * r)[..., None] * z, -2)
            n_fit += u.shape[-2]
        else:
            y, z = np.broadcast_arrays(y[..., None], z)
            comoments[int(i)].add(np.concatenate([y[..., :1], z], -1))
    N = int(counts.sum())
    if not pilot:  # fit on the main samples: pooled uncentred sums
        S = sum(cm.second() for cm in comoments.values())
        G, h, n_fit = S[..., 1:, 1:], S[..., 0, 1:], N
    a = _solve_psd(G / n_fit, h / n_fit)                    # (..., Ka)
    beta = np.concatenate([np.ones(a.shape[:-1] + (1,)), -a], -1)
    means, contrib = [], []
    dof = 1.0 if pilot else N / max(N - Ka, 1)
    for k, i in enumerate(active):
        cm = comoments[int(i)]
        mean_r = np.sum(beta * cm.mean, -1)
        var_r = np.einsum("...i,...ij,...j->...", beta, cm.comoment, beta) / (cm.count - 1)
        means.append(c_main[k] * mean_r)
        contrib.append(np.maximum(var_r, 0.0) * dof * c_main[k] ** 2 / cm.count)
    shape = np.broadcast_shapes(a.shape[:-1], *[np.shape(m) for m in means + contrib])
    value = np.broadcast_to(a.sum(-1), shape) + sum(np.broadcast_to(m, shape) for m in means)
    full = np.zeros(shape + (len(counts),))
    full[..., active] = np.stack([np.broadcast_to(v, shape) for v in contrib], -1)
    alpha_full = np.zeros(shape + (len(counts),))
    alpha_full[..., active] = np.broadcast_to(a, shape + (Ka,))
    return value, full, {"alpha": alpha_full}
