"""Multi-sample MIS with its own sample count per technique: the path of ``MIS.estimate``
for the two cases that are not a fold of identical sample units.

* ``fractions`` that are not a ratio of whole numbers up to 64 (e.g. ``[0.123, 0.877]``):
  n_i = ``split_counts(n, c)`` samples of technique i, and
  F = sum_i (1/n_i) sum_j w_i(X_ij) f(X_ij) / p_i(X_ij)  (Veach 1997, eq. 9.3);
* ``heuristic="optimal"`` with ``optimal_pilot > 0``: a pilot pass fits the coefficients,
  the main pass uses them (:func:`~vrlab.estimators.optimal.fit_optimal`).

The techniques' sample sets are independent, so Var[F] = sum_i Var_i[w_i f / p_i] / n_i,
reported per technique in ``extra["variance_contributions"]``.  Every other MIS estimate
runs through ``unit_outputs`` -> ``accumulate`` -> ``summarize`` (``MIS.estimate``).
"""
from __future__ import annotations

import time
from typing import Any

import numpy as np

from .. import checks
from .._rng import as_generator
from ..estimate import Estimate, Moments
from ..distributions.base import checked_pdf
from .base import DEFAULT_CHUNK, as_integrand, check_chunk, check_n, point_engine, ratio
from .heuristics import _stack_pdfs, mis_weights, resolve_all, split_counts

__all__ = ["estimate_by_technique", "technique_blocks"]


def technique_blocks(points: Any, dims: list[int], plan: list[tuple[int, int]], gen: np.random.Generator,
                     chunk: int):
    """Yield ``(segment, technique, u)`` blocks for ``plan = [(technique, count), ...]``.

    * ``points`` an array ``(*batch, n, max dim_u)``: consecutive rows per segment,
      the first ``dim_u`` columns;
    * an engine instance (``random``): one engine of dimension max dim_u, consecutive
      rows per segment;
    * None, a class or a name: one fresh engine per segment with that technique's
      ``dim_u``, all seeded from the same generator (independent streams).
    """
    dmax = max(dims[i] for i, _ in plan)
    if isinstance(points, np.ndarray):
        total = sum(c for _, c in plan)
        if points.ndim < 2 or points.shape[-2] != total or points.shape[-1] < dmax:
            raise ValueError(f"points: an array of uniforms must have shape (*batch, {total}, >= {dmax}), "
                             f"got {points.shape}")
        points = checks.uniforms_array(points, "points", d=dmax)
        start = 0
        for s, (i, c) in enumerate(plan):
            yield s, i, points[..., start:start + c, : dims[i]]
            start += c
        return
    shared = point_engine(points, dmax, gen) if callable(getattr(points, "random", None)) else None
    for s, (i, c) in enumerate(plan):
        engine = shared if shared is not None else point_engine(points, dims[i], gen)
        step = chunk if getattr(engine, "extensible", True) else c
        done = 0
        while done < c:
            k = min(step, c - done)
            u = np.asarray(engine.random(k), dtype=float)
            yield s, i, u[..., : dims[i]]
            done += k


def estimate_by_technique(mis, integrand, n: int, *, rng=None, points: Any = None,
                          chunk: int = DEFAULT_CHUNK) -> Estimate:
    """``mis``'s estimate with n_i = ``split_counts(n, fractions)`` samples of technique i
    (after an optimal pilot of ``optimal_pilot`` n samples, if any).  ``points``: None, a
    point-set class or name (one engine per technique, seeded from ``rng``), an engine of
    dimension ``mis.dim_u()`` (consecutive rows per technique), or an array ``(*batch, n,
    mis.dim_u())`` (consecutive row blocks: the pilot first, then technique 0, 1, ...)."""
    integrand, chunk = as_integrand(integrand), check_chunk(chunk)
    mis.check(integrand)
    n = check_n(n)
    gen = as_generator(rng)
    t0 = time.perf_counter()
    dists = resolve_all(mis.distributions, integrand)
    K = len(dists)
    dims = [int(d.dim_u) for d in dists]
    n_pilot = 0
    if mis.heuristic == "optimal" and mis.optimal_pilot > 0:  # >= 2 per technique
        n_pilot = max(int(round(mis.optimal_pilot * n)), 2 * int(np.sum(mis.fractions > 0)))
    pilot_counts = split_counts(n_pilot, mis.fractions) if n_pilot else np.zeros(K, np.int64)
    counts = split_counts(n - int(pilot_counts.sum()), mis.fractions)
    plan = [(i, int(c)) for i, c in enumerate(pilot_counts) if c > 0]
    n_pilot_segments = len(plan)
    plan += [(i, int(c)) for i, c in enumerate(counts) if c > 0]
    blocks = technique_blocks(points, dims, plan, gen, chunk)
    if mis.heuristic == "optimal":
        from .optimal import fit_optimal
        value, contrib, extra = fit_optimal(integrand, dists, blocks, n_pilot_segments, pilot_counts, counts)
    else:
        value, contrib, extra = _weighted(mis, integrand, dists, blocks, counts)
    N = int(counts.sum())
    var_f = contrib.sum(-1)
    scalar = (lambda a: float(a) if np.ndim(a) == 0 else np.asarray(a))
    return Estimate(scalar(value), scalar(np.sqrt(var_f)), N, n, time.perf_counter() - t0,
                    scalar(N * var_f), mis.label,
                    {"counts": counts.tolist(), "pilot_counts": pilot_counts.tolist(),
                     "variance_contributions": contrib, **extra})


def _weighted(mis, integrand, dists, blocks, counts):
    """Per technique the moments of w_i f / p_i; F = sum of their means."""
    K = len(dists)
    moments = [Moments() for _ in range(K)]
    for _, i, u in blocks:
        x = dists[i].sample(u)
        if mis.heuristic == "balance":  # w_i f / p_i = n_i f / sum_k n_k p_k: no stacked weights
            q = 0.0
            for k, d in enumerate(dists):
                if counts[k]:
                    q = q + counts[k] * checked_pdf(d, x, f"distributions[{k}]")
            moments[i].add(ratio(counts[i] * integrand(x), q))
            continue
        P = _stack_pdfs(dists, x)
        w = mis_weights(P * counts, mis.heuristic, beta=mis.beta, alpha=mis.alpha)
        moments[i].add(ratio(w[..., i], P[..., i]) * integrand(x))
    means, contrib = [], []
    for mom, c in zip(moments, counts):
        means.append(np.asarray(mom.mean, float) if c > 0 else np.asarray(0.0))
        contrib.append(np.asarray(mom.variance, float) / c if c > 0 else np.asarray(0.0))
    shape = np.broadcast_shapes(*[np.shape(m) for m in means + contrib])
    value = sum(np.broadcast_to(m, shape) for m in means)
    return value, np.stack([np.broadcast_to(v, shape) for v in contrib], -1), {}
