"""Chi-square goodness-of-fit tests for samplers.

The recipe (as used to validate warps in physically based renderers, e.g. the
tests described in Jakob et al.'s Mitsuba and pbrt's sampling tests; our own code):

1. draw ``n`` samples from the sampler with a fixed seed;
2. histogram them on a regular grid of a chart's parameter space;
3. integrate ``pdf * jacobian`` over each cell (Gauss–Legendre, ``quad`` nodes per
   axis) to get expected counts;
4. pool the cells with small expected counts (ascending, until each pool has at
   least ``min_expected``), so the chi-square approximation holds;
5. Pearson's statistic with ``cells - 1`` degrees of freedom gives a p-value.

Expected counts are *not* renormalised, so a pdf with the wrong constant fails.
Samples landing in cells whose expected count is zero fail immediately (the
sampler produces points where its pdf says it cannot).  Several tests at once
use a Šidák correction: reject when p < 1 - (1 - alpha)^(1/m).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Iterable, Sequence

import numpy as np
from scipy import stats

from .._rng import as_generator
from .charts import Chart


@dataclass
class GofResult:
    """Outcome of one goodness-of-fit test."""

    name: str
    statistic: float
    dof: int
    pvalue: float
    n: int
    expected_total: float
    outside: int = 0
    worst: list = field(default_factory=list)  # [(cell, observed, expected)], largest contributions

    def message(self) -> str:
        lines = [
            f"{self.name}: chi2 = {self.statistic:.1f} on {self.dof} dof, p = {self.pvalue:.3g}, "
            f"n = {self.n}, expected total = {self.expected_total:.1f}"
        ]
        if self.outside:
            lines.append(f"  {self.outside} samples fell where the pdf integrates to zero or outside the domain")
        for cell, o, e in self.worst:
            lines.append(f"  cell {cell}: observed {o}, expected {e:.1f}")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.message()


def sidak_threshold(alpha: float, m: int) -> float:
    """Per-test level that keeps the family-wise error rate at ``alpha`` over ``m`` tests."""
    return 1.0 - (1.0 - alpha) ** (1.0 / max(int(m), 1))


def pooled_chi2(observed: np.ndarray, expected: np.ndarray, min_expected: float = 5.0,
                name: str = "chi2", cells: Sequence | None = None) -> GofResult:
    """Pearson chi-square of counts vs expected counts, pooling small cells.

    Cells are sorted by expected count; consecutive small cells are merged until
    each pooled cell expects at least ``min_expected``.  Samples in cells with
    zero expectation make the test fail outright (p = 0).
    """
    obs = np.asarray(observed, dtype=float).ravel()
    exp = np.asarray(expected, dtype=float).ravel()
    if obs.shape != exp.shape:
        raise ValueError(f"observed and expected differ in size: {obs.shape} vs {exp.shape}")
    if np.any(exp < 0) or not np.all(np.isfinite(exp)):
        raise ValueError("expected counts must be finite and >= 0 (check the pdf for negatives/NaN)")
    n = int(obs.sum())
    zero = exp <= 1e-12 * max(exp.sum(), 1.0)
    outside = int(obs[zero].sum())
    order = np.argsort(exp, kind="stable")
    order = order[~zero[order]]
    o_sorted, e_sorted = obs[order], exp[order]
    groups = _pool_groups(e_sorted, min_expected)
    e_pool = np.bincount(groups, e_sorted, minlength=groups.max(initial=-1) + 1)
    o_pool = np.bincount(groups, o_sorted, minlength=groups.max(initial=-1) + 1)
    contrib = (o_pool - e_pool) ** 2 / e_pool
    stat = float(contrib.sum())
    dof = max(len(e_pool) - 1, 1)
    pvalue = 0.0 if outside else float(stats.chi2.sf(stat, dof))
    # report the worst unpooled cells
    cell_contrib = np.where(zero, np.where(obs > 0, np.inf, 0.0), (obs - exp) ** 2 / np.where(zero, 1, exp))
    worst_idx = np.argsort(cell_contrib)[::-1][:5]
    labels = cells if cells is not None else range(len(obs))
    labels = list(labels)
    worst = [(labels[i], int(obs[i]), float(exp[i])) for i in worst_idx if cell_contrib[i] > 0]
    return GofResult(name, stat, dof, pvalue, n, float(exp.sum()), outside, worst)


def _pool_groups(e_sorted: np.ndarray, min_expected: float) -> np.ndarray:
    """Group ids for ascending expected counts: a group closes once it expects
    ``min_expected``; a final undersized group joins the one before it."""
    groups = np.arange(len(e_sorted))
    n_small = int(np.searchsorted(e_sorted, min_expected))
    g, acc = 0, 0.0
    for i in range(n_small):  # only the small cells need the greedy walk
        groups[i] = g
        acc += e_sorted[i]
        if acc >= min_expected:
            g, acc = g + 1, 0.0
    # an open pool of small cells is absorbed by the first large cell (same id g)
    groups[n_small:] = g + np.arange(len(e_sorted) - n_small)
    if acc > 0 and g > 0 and n_small == len(e_sorted):
        groups[groups == g] = g - 1  # last pool too small and nothing after it
    return groups


def _gauss_cells(bins: Sequence[int], quad: int, sub: int = 1):
    """Quadrature nodes and weights for every cell of a regular grid on [0,1]^p
    (composite Gauss–Legendre: ``sub`` sub-intervals per cell, ``quad`` nodes each)."""
    g, w = np.polynomial.legendre.leggauss(quad)
    g = ((g + 1) / 2 + np.arange(sub)[:, None]).ravel() / sub  # nodes in [0, 1] of one cell
    w = np.tile(w / 2, sub) / sub
    axes_nodes, axes_weights = [], []
    for b in bins:
        lo = np.arange(b) / b
        axes_nodes.append((lo[:, None] + g[None, :] / b))             # (b, q*sub)
        axes_weights.append(np.broadcast_to(w / b, (b, len(w))))      # (b, q*sub)
    return axes_nodes, axes_weights


def cell_integrals(fn: Callable[[np.ndarray], np.ndarray], chart: Chart, bins: Sequence[int],
                   quad: int = 6, sub: int = 1) -> np.ndarray:
    """Integral of ``fn(x)`` (x = chart point) over each cell of a ``bins`` grid.

    Returns an array of shape ``bins``.  ``fn`` must be vectorised over leading axes.
    ``sub > 1`` splits each cell per axis (for densities with edges or kinks inside cells,
    e.g. the solid-angle density of a polygon light at its outline).
    """
    bins = tuple(int(b) for b in np.atleast_1d(bins))
    if len(bins) != chart.p:
        raise ValueError(f"bins: the chart has {chart.p} parameters, got {len(bins)} bin counts")
    nodes, weights = _gauss_cells(bins, quad, sub)
    if chart.p == 1:
        s = nodes[0][..., None]                      # (b, q, 1)
        wt = weights[0]
    else:
        s0 = nodes[0][:, None, :, None]              # (b0, 1, q, 1)
        s1 = nodes[1][None, :, None, :]              # (1, b1, 1, q)
        s = np.stack(np.broadcast_arrays(s0, s1), -1)  # (b0, b1, q, q, 2)
        wt = weights[0][:, None, :, None] * weights[1][None, :, None, :]
    vals = np.asarray(fn(chart.from_param(s)), dtype=float) * chart.jacobian(s)
    vals = np.where(wt > 0, vals, 0.0) * wt
    return vals.sum(axis=(-1,) if chart.p == 1 else (-2, -1))


def histogram(param: np.ndarray, bins: Sequence[int]) -> tuple[np.ndarray, int]:
    """Counts of chart parameters on a regular grid; also how many fell outside [0, 1)^p."""
    bins = tuple(int(b) for b in np.atleast_1d(bins))
    param = np.asarray(param).reshape(-1, len(bins))
    ok = np.all(np.isfinite(param) & (param >= 0) & (param <= 1), -1)
    idx = np.minimum((param[ok] * np.asarray(bins)).astype(np.int64), np.asarray(bins) - 1)
    flat = np.ravel_multi_index(tuple(idx.T), bins)
    counts = np.bincount(flat, minlength=int(np.prod(bins))).reshape(bins)
    return counts, int((~ok).sum())


def chi2_gof(dist, chart: Chart, bins: Sequence[int], *, n: int = 200_000, rng=0, points=None,
             quad: int = 6, sub: int = 1, min_expected: float = 5.0, name: str | None = None) -> GofResult:
    """Goodness of fit of ``dist.sample`` against ``dist.pdf`` on ``chart``'s grid.

    ``points`` may be a point set (anything with ``random(n)``) to draw the
    uniforms; default: independent uniforms from ``rng``.  Samples whose own pdf is
    zero (or that fall off the chart) fail the test outright; ``sub`` refines the
    quadrature of expected counts (see ``cell_integrals``).
    """
    if points is None:
        u = as_generator(rng).random((n, dist.dim_u))
    else:
        u = points.random(n)
    x = dist.sample(u)
    counts, outside = histogram(chart.to_param(x), bins)
    outside += int(np.sum(~(np.asarray(dist.pdf(x)) > 0)))
    expected = n * cell_integrals(dist.pdf, chart, bins, quad, sub)
    # a cell the quadrature sees as empty may still hold a sliver of support: the
    # pdf(x) > 0 check above is the real support test, so give such cells a tiny
    # expectation and let pooling (not an outright failure) judge them
    expected = np.where((expected <= 0) & (counts > 0), 1e-9, expected)
    res = pooled_chi2(counts, expected, min_expected, name or repr(dist),
                      cells=list(np.ndindex(*counts.shape)))
    if outside:
        res.outside += outside
        res.pvalue = 0.0
    return res


def chi2_discrete(indices: np.ndarray, pmf: np.ndarray, *, min_expected: float = 5.0,
                  name: str = "discrete") -> GofResult:
    """Goodness of fit of integer samples against probabilities ``pmf`` (which should sum to 1)."""
    pmf = np.asarray(pmf, dtype=float)
    idx = np.asarray(indices).ravel()
    bad = (idx < 0) | (idx >= len(pmf))
    counts = np.bincount(idx[~bad], minlength=len(pmf))
    res = pooled_chi2(counts, len(idx) * pmf, min_expected, name)
    if bad.any():
        res.outside += int(bad.sum())
        res.pvalue = 0.0
    return res


def integrate(fn: Callable[[np.ndarray], np.ndarray], chart: Chart, bins: Sequence[int] | int = 64,
              quad: int = 8) -> float:
    """Integral of ``fn`` over the chart's whole domain (e.g. a pdf, which should give 1)."""
    if np.ndim(bins) == 0:
        bins = (int(bins),) * chart.p
    return float(cell_integrals(fn, chart, bins, quad).sum())


def assert_gof(results: GofResult | Iterable[GofResult], alpha: float = 0.01, m: int | None = None) -> None:
    """Raise ``AssertionError`` with a readable message if any test rejects at the
    Šidák-corrected level for ``m`` tests (default: the number of results given)."""
    results = [results] if isinstance(results, GofResult) else list(results)
    level = sidak_threshold(alpha, m if m is not None else len(results))
    failed = [r for r in results if not r.pvalue >= level]
    if failed:
        msg = "\n".join(r.message() for r in failed)
        raise AssertionError(f"chi-square test rejected at level {level:.3g} (alpha={alpha}, Šidák):\n{msg}")
