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

The charts and the cell quadrature (``cell_integrals``) live in the warps layer
(:mod:`vrlab.distributions.charts`, :mod:`vrlab.distributions.quadrature`) and ``sidak_threshold``
in :mod:`vrlab.significance`; this module re-exports them.

Every entry point checks its arguments (``TypeError``/``ValueError`` naming them): ``n``
and bin counts are integers >= 1, ``alpha`` lies in (0, 1), ``min_expected > 0``, and a
test needs at least 2 pooled cells (else too few samples for any verdict).  A sampler
that returns NaN/inf or points off the chart fails (p = 0) with a message counting them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Iterable, Sequence

import numpy as np
from scipy import stats

from .. import checks
from ..distributions.charts import Chart
from ..distributions.quadrature import (bins_tuple, cell_integrals, chart_like, check_nodes, quad_orders,
                                       real_values)
from ..significance import sidak_threshold
from ._args import MAX_SAMPLES, draw_uniforms, sample_points, text

__all__ = ["GofResult", "assert_gof", "cell_integrals", "chi2_discrete", "chi2_gof", "histogram", "integrate",
           "pooled_chi2", "sidak_threshold"]


@dataclass
class GofResult:
    """Outcome of one goodness-of-fit test (fields checked on construction)."""

    name: str
    statistic: float
    dof: int
    pvalue: float
    n: int
    expected_total: float
    outside: int = 0
    worst: list = field(default_factory=list)  # [(cell, observed, expected)], largest contributions
    nonfinite: int = 0  # samples that were NaN or infinite (also counted in ``outside``)

    def __post_init__(self):
        self.name = text(self.name, "name")
        self.statistic = checks.real(self.statistic, "statistic", low=0.0, finite=False)
        self.dof = checks.integer(self.dof, "dof", low=1)
        self.pvalue = checks.real(self.pvalue, "pvalue", low=0.0, high=1.0)
        self.n = checks.integer(self.n, "n", low=0)
        self.expected_total = checks.real(self.expected_total, "expected_total", low=0.0)
        self.outside = checks.integer(self.outside, "outside", low=0)
        self.nonfinite = checks.integer(self.nonfinite, "nonfinite", low=0)
        if not isinstance(self.worst, list):
            raise TypeError(f"worst must be a list of (cell, observed, expected), got {type(self.worst).__name__}")

    def message(self) -> str:
        lines = [
            f"{self.name}: chi2 = {self.statistic:.1f} on {self.dof} dof, p = {self.pvalue:.3g}, "
            f"n = {self.n}, expected total = {self.expected_total:.6g}"
        ]
        if self.outside:
            lines.append(f"  {self.outside} samples fell where the pdf integrates to zero or outside the domain")
        if self.nonfinite:
            lines.append(f"  ({self.nonfinite} of them were NaN or infinite)")
        for cell, o, e in self.worst:
            lines.append(f"  cell {cell}: observed {o}, expected {e:.3g}")      # 0.005 stays 0.005, not 0.0
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.message()


class _TooFewCells(ValueError):
    """Fewer than 2 pooled cells: no test (callers rephrase it with their argument names)."""

    def __init__(self, pools: int, total: float, min_expected: float):
        self.pools, self.total = pools, total
        super().__init__(f"expected, min_expected: the expected counts (total {total:.3g}) pool into {pools} "
                         f"cell(s) of at least min_expected = {min_expected:g}; a chi-square test needs at "
                         "least 2 (more samples n, or a lower min_expected)")


def pooled_chi2(observed: np.ndarray, expected: np.ndarray, min_expected: float = 5.0,
                name: str = "chi2", cells: Sequence | None = None) -> GofResult:
    """Pearson chi-square of counts vs expected counts, pooling small cells.

    Cells are sorted by expected count; consecutive small cells are merged until
    each pooled cell expects at least ``min_expected``.  Samples in cells with
    zero expectation make the test fail outright (p = 0).  Checked: ``observed`` and
    ``expected`` finite, >= 0, of one size; ``min_expected > 0``; at least 2 pooled cells
    unless only one cell has a non-zero expectation (``ValueError``: too few samples).
    """
    obs = checks.finite_array(observed, "observed").ravel()
    exp = checks.finite_array(expected, "expected").ravel()
    if obs.shape != exp.shape:
        raise ValueError(f"observed and expected differ in size: {obs.shape} vs {exp.shape}")
    if obs.size == 0:
        raise ValueError("observed, expected: no cells (empty arrays)")
    if np.any(obs < 0):
        raise ValueError(f"observed: counts must be >= 0, got {obs[obs < 0][0]:g}")
    if np.any(exp < 0):
        raise ValueError("expected counts must be finite and >= 0 (check the pdf for negatives/NaN)")
    min_expected = checks.real(min_expected, "min_expected", low=0.0, low_open=True)
    name = text(name, "name")
    if cells is not None and (not hasattr(cells, "__len__") or len(cells) != obs.size):
        raise ValueError(f"cells: need one label per cell ({obs.size}), got {checks.describe(cells)}")
    n = int(obs.sum())
    zero = exp <= 1e-12 * max(exp.sum(), 1.0)
    outside = int(obs[zero].sum())
    order = np.argsort(exp, kind="stable")
    order = order[~zero[order]]
    o_sorted, e_sorted = obs[order], exp[order]
    groups = _pool_groups(e_sorted, min_expected)
    e_pool = np.bincount(groups, e_sorted, minlength=groups.max(initial=-1) + 1)
    o_pool = np.bincount(groups, o_sorted, minlength=groups.max(initial=-1) + 1)
    if len(e_pool) < 2 and len(e_sorted) != 1:   # several cells merged into one: too few samples
        raise _TooFewCells(len(e_pool), float(exp.sum()), min_expected)
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


def histogram(param: np.ndarray, bins: Sequence[int]) -> tuple[np.ndarray, int]:
    """Counts of chart parameters on a regular grid; also how many fell outside [0, 1]^p
    (NaN included).  ``param``: real numbers of shape ``(n, p)`` (any shape if p = 1), n >= 1."""
    bins = bins_tuple(bins)
    a = real_values(param, "param")
    p = len(bins)
    if (p > 1 and (a.ndim == 0 or a.shape[-1] != p)) or (p == 1 and a.ndim > 1 and a.shape[-1] != 1):
        raise ValueError(f"param: expected shape (n, {p}) for {p} bin counts, got {a.shape}")
    if a.size == 0:
        raise ValueError("param: no points to count (an empty array)")
    return _histogram(a, bins)


def _histogram(param: np.ndarray, bins: tuple[int, ...]) -> tuple[np.ndarray, int]:
    param = np.asarray(param, dtype=float).reshape(-1, len(bins))
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
    zero, that fall off the chart or are NaN/inf fail the test outright; ``sub`` refines
    the quadrature of expected counts (see ``cell_integrals``).  Checked: ``n`` an integer
    in [1, 10^8], ``bins`` one integer >= 1 per chart parameter, ``quad``/``sub`` integers
    >= 1, ``min_expected > 0``, ``dist`` with ``sample`` and ``pdf``; too few samples for
    2 pooled cells is a ``ValueError`` (no verdict), not a pass.
    """
    if not (callable(getattr(dist, "sample", None)) and callable(getattr(dist, "pdf", None))):
        raise TypeError(f"dist must be a distribution with sample(u) and pdf(x), got {checks.describe(dist)}")
    chart = chart_like(chart)
    bins = bins_tuple(bins, chart.p)
    if np.prod(bins) < 2:
        raise ValueError(f"bins: a test needs at least 2 cells, got {bins}")
    n = checks.integer(n, "n", low=1, high=MAX_SAMPLES)
    quad, sub = quad_orders(quad, sub)
    min_expected = checks.real(min_expected, "min_expected", low=0.0, low_open=True)
    name = repr(dist) if name is None else text(name, "name")
    check_nodes(bins, quad, sub)
    x = sample_points(dist, draw_uniforms(dist, n, rng, points), n, chart)
    finite = np.all(np.isfinite(x), -1)
    nonfinite = int(n - finite.sum())
    xf = x if not nonfinite else x[finite]
    bad = np.zeros(len(xf), bool)               # per finite sample: off the chart or pdf <= 0
    if len(xf):
        prm = real_values(chart.to_param(xf), "chart.to_param(x)")
        if prm.size != len(xf) * chart.p:
            raise ValueError(f"chart: to_param(x) returned shape {prm.shape} for {len(xf)} points")
        prm = prm.reshape(len(xf), chart.p)
        bad |= ~np.all(np.isfinite(prm) & (prm >= 0) & (prm <= 1), -1)
        dens = real_values(dist.pdf(xf), "dist.pdf(x)")
        try:
            dens = np.broadcast_to(dens, (len(xf),))
        except ValueError:
            raise ValueError(f"dist: pdf(x) must return one value per point ({len(xf)}), "
                             f"got shape {dens.shape}") from None
        bad |= ~(dens > 0)
    else:
        prm = np.empty((0, chart.p))
    counts, _ = _histogram(prm, bins)
    outside = int(bad.sum()) + nonfinite
    expected = n * cell_integrals(dist.pdf, chart, bins, quad, sub, name="dist.pdf")
    if not np.all(np.isfinite(expected) & (expected >= 0)):
        raise ValueError("dist: pdf integrates to a negative or infinite value on some cells "
                         f"(min {np.min(expected):.3g}, max {np.max(expected):.3g}); check dist.pdf")
    # a cell the quadrature sees as empty may still hold a sliver of support: the
    # pdf(x) > 0 check above is the real support test, so give such cells a tiny
    # expectation and let pooling (not an outright failure) judge them
    expected = np.where((expected <= 0) & (counts > 0), 1e-9, expected)
    try:
        res = pooled_chi2(counts, expected, min_expected, name, cells=list(np.ndindex(*counts.shape)))
    except _TooFewCells as exc:
        if not outside:
            raise ValueError(f"n, bins, min_expected: {n} samples on {counts.size} cells expect {exc.total:.3g} "
                             f"in all and pool into {exc.pools} cell(s) of at least {min_expected:g}; a "
                             "chi-square test needs at least 2: raise n (or lower min_expected)") from None
        res = GofResult(name, np.inf, 1, 0.0, int(counts.sum()), float(expected.sum()))
    res.outside += outside
    res.nonfinite = nonfinite
    if outside:
        res.pvalue = 0.0
    return res


def chi2_discrete(indices: np.ndarray, pmf: np.ndarray, *, min_expected: float = 5.0,
                  name: str = "discrete") -> GofResult:
    """Goodness of fit of integer samples against probabilities ``pmf`` (which should sum to 1).

    ``pmf``: finite, >= 0, not all zero (not renormalised: a wrong total fails);
    ``indices``: at least one sample.  Samples that are no valid index (negative, too large,
    NaN or fractional) fail the test (p = 0).
    """
    pmf = checks.finite_array(pmf, "pmf", ndim=1)
    if pmf.size == 0 or np.any(pmf < 0) or not pmf.sum() > 0:
        raise ValueError(f"pmf must be a non-empty vector of probabilities >= 0, not all zero, got {pmf[:8]}")
    idx = real_values(indices, "indices").ravel()
    if idx.size == 0:
        raise ValueError("indices: no samples (an empty array)")
    min_expected = checks.real(min_expected, "min_expected", low=0.0, low_open=True)
    name = text(name, "name")
    with np.errstate(invalid="ignore"):
        bad = ~((idx >= 0) & (idx < len(pmf)) & (idx == np.floor(idx)))
    counts = np.bincount(idx[~bad].astype(np.int64), minlength=len(pmf))
    try:
        res = pooled_chi2(counts, len(idx) * pmf, min_expected, name)
    except _TooFewCells as exc:
        if not bad.any():
            raise ValueError(f"indices, min_expected: {len(idx)} samples expect {exc.total:.3g} in all and pool "
                             f"into {exc.pools} cell(s) of at least {min_expected:g}; a chi-square test needs at "
                             "least 2: give more samples (or lower min_expected)") from None
        res = GofResult(name, np.inf, 1, 0.0, int(counts.sum()), float(len(idx) * pmf.sum()))
    if bad.any():
        res.outside += int(bad.sum())
        res.nonfinite = int((~np.isfinite(idx)).sum())
        res.pvalue = 0.0
    return res


def integrate(fn: Callable[[np.ndarray], np.ndarray], chart: Chart, bins: Sequence[int] | int = 64,
              quad: int = 8) -> float:
    """Integral of ``fn`` over the chart's whole domain (e.g. a pdf, which should give 1).

    Arguments as for ``cell_integrals``; a non-finite integral is a ``ValueError``."""
    total = float(cell_integrals(fn, chart, bins, quad).sum())
    if not np.isfinite(total):
        raise ValueError(f"fn: the integral over the chart is not finite ({total})")
    return total


def assert_gof(results: GofResult | Iterable[GofResult], alpha: float = 0.01, m: int | None = None) -> None:
    """Raise ``AssertionError`` with a readable message if any test rejects at the
    Šidák-corrected level for ``m`` tests (default: the number of results given).

    Checked: ``results`` one or more ``GofResult``; ``alpha`` in (0, 1); ``m`` an integer
    >= the number of results.  A result without samples (n = 0) fails.
    """
    if isinstance(results, GofResult):
        results = [results]
    elif isinstance(results, (str, bytes)) or not hasattr(results, "__iter__"):
        raise TypeError(f"results must be a GofResult or a list of them, got {checks.describe(results)}")
    results = list(results)
    if not results:
        raise ValueError("results: no test results given (an empty list passes nothing)")
    for k, r in enumerate(results):
        if not isinstance(r, GofResult):
            raise TypeError(f"results[{k}] must be a GofResult (from chi2_gof, chi2_discrete, pooled_chi2), "
                            f"got {checks.describe(r)}")
    alpha = checks.real(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
    m = len(results) if m is None else checks.integer(m, "m", low=len(results))
    level = sidak_threshold(alpha, m)
    failed = [r for r in results if not (r.pvalue >= level and r.n > 0)]
    if failed:
        msg = "\n".join(r.message() for r in failed)
        raise AssertionError(f"chi-square test rejected at level {level:.3g} (alpha={alpha}, Šidák):\n{msg}")
