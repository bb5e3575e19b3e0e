"""Stratified sampling with per-stratum variances (Owen, *Monte Carlo theory, methods and examples*, ch. 8 and 10).

The uniforms' cube [0, 1)^d (primary sample space) is cut into a grid of H = m_1 ... m_d
equal cells (strata); with the default uniform distribution on a box domain these are
exactly the cells of the box.  Stratum h has probability w_h = 1/H and receives n_h >= 2
independent uniform points; with Y = f(X)/p(X) (X = sample(u)),

    I_hat = sum_h w_h mean_h(Y),     Var[I_hat] = sum_h w_h^2 sigma_h^2 / n_h,

estimated with the within-stratum sample variances s_h^2 (unbiased, so at least two
samples per stratum are needed).  Allocations:

* ``"proportional"``: n_h proportional to w_h; then Var = (1/n) sum_h w_h sigma_h^2
  <= sigma^2 / n: never worse than plain Monte Carlo (the between-strata variance
  sum_h w_h (mu_h - I)^2 is removed).
* ``"neyman"``: n_h proportional to w_h sigma_h (Neyman 1934), the optimum
  Var = (sum_h w_h sigma_h)^2 / n.  sigma_h is unknown, so a pilot run of ``pilot``
  points per stratum estimates it.  **The pilot's evaluations count toward n** and are
  *not* reused in the estimate (reusing them would make n_h depend on the same data as
  the stratum means, a small bias); every stratum keeps at least 2 main-run points.
  A pilot can see no variation in a stratum where f does vary (a thin sliver of an
  edge, a rare bright spot): pure Neyman then starves it, and its two-point variance is
  usually 0, so the error is underestimated.  The ``defensive`` share lambda (default
  0.1) guards against that: n_h proportional to w_h ((1 - lambda) sigma_h / sigma_bar + lambda),
  sigma_bar = sum_h w_h sigma_h (lambda = 0: pure Neyman, 1: proportional).
  For a batched integrand one allocation serves all batch elements, with sigma_h the
  root mean square over the batch.

With one point per stratum (n = H, jittered sampling) the estimator is still unbiased
and better, but no unbiased per-stratum variance exists; this class then raises and
points to ``MonteCarlo().estimate(..., points=vrlab.points.Stratified)`` (the value) and
``RQMC(replicates=R)`` with ``points=Stratified`` (independent replicates give the error).
"""
from __future__ import annotations

import time
from typing import Any, Sequence

import numpy as np

from .. import checks
from .._rng import RNGLike, as_generator
from ..estimate import LOW_VARIANCE, Estimate, moments_finite, unrepresentable
from ..points.base import ONE_MINUS_EPS, check_int
from .base import DEFAULT_CHUNK, Estimator, as_integrand, check_chunk, check_n, point_engine, resolve_distribution
from .importance import MonteCarlo

ALLOCATIONS = ("proportional", "neyman")


def default_grid(cells: int, d: int) -> tuple[int, ...]:
    """Per-axis counts (largest first) with product <= ``cells``, as balanced as possible."""
    cells = max(int(cells), 1)
    m = max(int(np.floor(cells ** (1.0 / d) + 1e-9)), 1)
    while (m + 1) ** d <= cells:
        m += 1
    while m > 1 and m**d > cells:
        m -= 1
    counts = [m] * d
    for j in range(d):  # raise axes one by one while the product still fits
        if np.prod(counts) // counts[j] * (counts[j] + 1) <= cells:
            counts[j] += 1
    return tuple(counts)


def allocate(total: int, weights: np.ndarray, minimum: int = 2) -> np.ndarray:
    """Integer n_h >= ``minimum`` summing to ``total``, the surplus proportional to ``weights``
    (largest-remainder rounding; all-zero weights: spread evenly)."""
    w = np.asarray(weights, float)
    H = w.size
    spare = total - minimum * H
    if spare < 0:
        raise ValueError(f"n: {total} evaluations cannot give {minimum} per stratum to {H} strata")
    if not np.any(w > 0):
        w = np.ones(H)
    ideal = spare * w / w.sum()
    n_h = np.floor(ideal).astype(np.int64)
    left = spare - int(n_h.sum())
    if left:
        order = np.argsort(-(ideal - n_h), kind="stable")
        n_h[order[:left]] += 1
    return n_h + minimum


def _check_strata(y: np.ndarray, offsets: np.ndarray, counts: np.ndarray, mu: np.ndarray, var: np.ndarray) -> None:
    """Refuse per-stratum samples ``y`` (``counts`` per stratum from ``offsets``) whose means or
    variances float64 cannot carry (see :func:`vrlab.estimate.check_spread`): overflow, or a
    variance below ``LOW_VARIANCE`` in a stratum whose samples are not all equal."""
    if not moments_finite(y, mu, var):
        return
    low = var < LOW_VARIANCE
    if y.dtype != np.float32 and np.any(low):
        # a stratum of equal values (all 0 where f vanishes) is fine; otherwise one of tiny values
        # (|y| < ~1e-130: above that, values this close are equal in float64) lost its variance
        small = np.add.reduceat(np.abs(y), offsets, axis=-1)
        bad = low & (small > 0) & (small < 1e-130 * counts)
        if np.any(bad):
            raise unrepresentable(f"samples as small as {np.max(small[bad]):.3g} (a stratum's sum) that are not all "
                                  "equal: the squares of their deviations underflow float64")


class Stratified(Estimator):
    """Stratified sampling of the uniforms' cube with proportional or Neyman allocation.

    Parameters
    ----------
    strata : cells per axis: an int (the same on every axis), a sequence of d ints, or
        ``None`` (default): chosen from n -- about n/2 cells (two points each) for
        ``"proportional"``, about n / (3 (pilot + 2)) for ``"neyman"``, spread over the
        axes as evenly as possible.
    allocation : ``"proportional"`` (default) or ``"neyman"``.
    pilot : points per stratum in the Neyman pilot run (>= 2; they count toward n).
    defensive : share lambda in [0, 1] of proportional allocation mixed into Neyman's
        (default 0.1; see the module docstring).
    distribution : importance distribution p (default uniform on the domain); the strata
        live in its uniforms' space.

    ``Estimate.n`` is the number of main-run points, ``n_evals`` all evaluations (pilot
    included); ``variance`` is n x stderr^2, comparable with the per-sample variance of
    plain Monte Carlo.  ``points`` may only be ``None`` or independent points (the
    in-stratum offsets must be independent for the variance formula).
    """

    per_unit = False

    def __init__(self, strata: int | Sequence[int] | None = None, allocation: str = "proportional",
                 pilot: int = 4, distribution=None, *, defensive: float = 0.1, probe: bool = True):
        if strata is not None:
            if np.ndim(strata) == 0:
                check_int("strata", strata, 1)
            else:
                if len(strata) == 0:
                    raise ValueError("strata: expected an int >= 1 or a non-empty sequence of ints >= 1")
                for s in strata:
                    check_int("strata", s, 1)
        checks.choice(allocation, "allocation", ALLOCATIONS)
        check_int("pilot", pilot, 2)
        checks.real(defensive, "defensive", low=0.0, high=1.0)
        checks.flag(probe, "probe")
        if distribution is not None:
            checks.distribution(distribution)
        self.defensive = defensive
        self.strata = strata
        self.allocation = allocation
        self.pilot = pilot
        self.distribution = distribution
        self.probe = probe

    @property
    def label(self) -> str:
        return f"Stratified[{self.allocation}]"

    def dim_u(self, integrand) -> int:
        return int(resolve_distribution(self.distribution, integrand).dim_u)

    def check(self, integrand) -> None:
        MonteCarlo(self.distribution, probe=self.probe).check(integrand)

    def grid(self, n: int, d: int) -> tuple[int, ...]:
        """The strata per axis used for ``n`` evaluations in ``d`` uniform dimensions."""
        if self.strata is None:
            per = 2 if self.allocation == "proportional" else 3 * (self.pilot + 2)
            return default_grid(n // per, d)
        if np.ndim(self.strata) == 0:
            return (int(self.strata),) * d
        if len(self.strata) != d:
            raise ValueError(f"strata: expected {d} counts (one per uniform dimension), got {self.strata!r}")
        return tuple(int(s) for s in self.strata)

    def unit_values(self, integrand, u):
        return MonteCarlo(self.distribution, probe=False).unit_values(integrand, u)

    def _stats(self, integrand, grid, counts, engine, chunk):
        """Per-stratum means and unbiased variances of f/p, ``(*batch, H)`` each."""
        H = counts.size
        ends = np.cumsum(counts)
        means, variances = [], []
        h0 = 0
        while h0 < H:
            start = ends[h0] - counts[h0]
            # strata h0..h1-1: at least one, at most ~chunk points
            h1 = max(int(np.searchsorted(ends, start + chunk, side="right")), h0 + 1)
            c = counts[h0:h1]
            cell = np.repeat(np.arange(h0, h1), c)
            corner = np.stack(np.unravel_index(cell, grid), -1)
            u = np.minimum((corner + np.asarray(engine.random(cell.size), float)) / np.asarray(grid), ONE_MINUS_EPS)
            y = self.unit_values(integrand, u)
            offsets = np.concatenate([[0], np.cumsum(c)[:-1]])
            with np.errstate(over="ignore", under="ignore", invalid="ignore"):
                mu = np.add.reduceat(y, offsets, axis=-1) / c
                dev = y - np.repeat(mu, c, axis=-1)
                var = np.add.reduceat(dev * dev, offsets, axis=-1) / (c - 1)
            _check_strata(y, offsets, c, mu, var)
            means.append(mu)
            variances.append(var)
            h0 = h1
        return np.concatenate(means, -1), np.concatenate(variances, -1)

    def estimate(self, integrand, n: int, *, rng: RNGLike = None, points: Any = None,
                 chunk: int = DEFAULT_CHUNK) -> Estimate:
        """Stratified estimate with ``n`` evaluations (pilot included)."""
        from ..points import Independent

        integrand, chunk = as_integrand(integrand), check_chunk(chunk)
        n = check_n(n)
        self.check(integrand)
        d = self.dim_u(integrand)
        grid = self.grid(n, d)
        H = int(np.prod(grid))
        pilot = self.pilot if self.allocation == "neyman" else 0
        need = (pilot + 2) * H
        if n < need:
            if n == H:
                raise ValueError(
                    f"n: n = {n} equals the number of strata {H} (one point per stratum, jittered sampling): "
                    "no unbiased per-stratum variance exists.  Use MonteCarlo().estimate(..., "
                    "points=vrlab.points.Stratified) for the estimate, and RQMC(replicates=R) with "
                    "points=vrlab.points.Stratified for an error estimate from independent replicates")
            what = "pilot + 2 main-run" if pilot else "2"
            raise ValueError(f"n: {H} strata {grid} need at least {what} points per stratum, i.e. n >= {need}, "
                             f"got {n}; use fewer strata or a larger n")
        if isinstance(points, np.ndarray):
            raise ValueError("points: Stratified places its own points in the strata; arrays of uniforms are not "
                             "accepted (use MonteCarlo for a given point array)")
        gen = as_generator(rng)
        engine = point_engine(points, d, gen)
        if not isinstance(engine, Independent):
            raise ValueError(
                f"points: Stratified needs independent offsets inside the strata (None or Independent), got "
                f"{engine!r}; for jittered or QMC point sets use MonteCarlo or RQMC with points=...")
        t0 = time.perf_counter()
        w = 1.0 / H
        extra: dict = {"strata": grid, "allocation": self.allocation}
        if self.allocation == "neyman":
            _, v_pilot = self._stats(integrand, grid, np.full(H, pilot, np.int64), engine, chunk)
            sigma = np.sqrt(np.mean(np.reshape(v_pilot, (-1, H)), axis=0))
            lam = float(self.defensive)
            sbar = float(np.sum(w * sigma))
            share = (1 - lam) * sigma / sbar + lam if sbar > 0 else np.ones(H)
            counts = allocate(n - pilot * H, w * share)
            extra["n_pilot"] = pilot * H
        else:
            counts = allocate(n, np.full(H, w))
        mu, var = self._stats(integrand, grid, counts, engine, chunk)
        value = w * mu.sum(-1)
        v_hat = np.sum(w * w * var / counts, axis=-1)
        n_main = int(counts.sum())
        extra["counts"] = counts
        scal = (lambda a: float(a) if np.ndim(a) == 0 else np.asarray(a))
        return Estimate(scal(value), scal(np.sqrt(v_hat)), n_main, n_main + pilot * H, time.perf_counter() - t0,
                        scal(v_hat * n_main), self.label, extra)
