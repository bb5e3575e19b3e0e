"""Metropolis--Hastings sampling of an unnormalised density on a box (Metropolis et al. 1953; Hastings 1970).

A chain x_0, x_1, ... proposes y from x and accepts it with probability

    a(x -> y) = min(1, pi(y) q(y -> x) / (pi(x) q(x -> y))) = min(1, pi(y) / pi(x))

for the symmetric proposals used here, so that pi (known only up to its integral b) is
the chain's stationary density.  Two mutations, as in Metropolis light transport
(Veach & Guibas 1997) and primary-sample-space MLT (Kelemen et al. 2002):

* **small step** (probability 1 - ``large_step_prob``): y = x + N(0, (step * width)^2)
  per axis.  At the boundary the proposal either **wraps** around the box (``"wrap"``,
  default; a Gaussian on the torus, still symmetric) or is **rejected** (``"reject"``;
  pi = 0 outside, so the move is refused and x repeats).
* **large step** (probability ``large_step_prob``): y uniform on the box, independent of
  x; q(x -> y) = q(y -> x) = 1/|box|, symmetric too.  Large steps make the chain ergodic
  on densities whose support is disconnected, which small steps alone cannot cross.

The mixture of two symmetric kernels is symmetric, so a = min(1, pi(y)/pi(x)).  Every step
consumes k + 2 uniforms (step kind, acceptance, k for the proposal; the Gaussian via the
inverse normal CDF), so a run is a deterministic function of its uniforms (:meth:`chain`);
C independent chains advance together (a loop over steps, arrays over chains).

Normalisation: MH draws samples *proportional* to pi, so it estimates expectations
E_pi[g] = int pi g / b (:meth:`expectation`), not b.  An integral int f = b E_pi[f / pi]
needs b from elsewhere -- known (a normalised pdf: b = 1) or estimated separately, as
Veach's MLT does with a bootstrap estimate of b from independent samples.  :meth:`estimate`
does that (``normalization=None``: plain Monte Carlo of pi on the box with another n
uniforms) and combines the errors with the delta method.  MH estimates are consistent,
not unbiased: the chains start from uniform points, so ``burn_in`` steps are discarded.

Standard errors are batch means: each chain's kept trajectory is cut into ``batches``
consecutive batches; chains are independent, so with batches much longer than the
autocorrelation time the C x batches batch means are nearly i.i.d. (with ``batches=1``,
the default, they are the chain means, exactly independent).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Sequence

import numpy as np

from .. import checks
from .._rng import RNGLike, as_generator, spawn
from ..distributions.interval import as_bounds
from ..estimate import Estimate, Moments
from ..points.base import check_int
from .base import (DEFAULT_CHUNK, Estimator, as_integrand, check_chunk, check_n, ratio, support_probe,
                   uniform_blocks)

BOUNDARIES = ("wrap", "reject")
_TINY = 1e-300


@dataclass
class MHRun:
    """Result of :meth:`MetropolisHastings.run`: ``samples (T, C, k)`` after burn-in, the target at
    them ``(T, C)``, and acceptance rates over the kept steps (all, small and large steps)."""

    samples: np.ndarray
    target: np.ndarray
    acceptance: float
    acceptance_small: float
    acceptance_large: float
    burn_in: int


def sample_histogram(samples: np.ndarray, bins: int | Sequence[int] = 32,
                     domain: Sequence = ((0.0, 1.0), (0.0, 1.0))) -> tuple[np.ndarray, list]:
    """Normalised histogram of points ``(..., k)`` on a box: a density (integrates to 1).

    Returns ``(density, edges)``; ``density[i, j, ...]`` is indexed by the bin along
    x, then y, ... (``numpy.histogramdd`` order -- the transpose of an image ``[iy, ix]``).
    """
    b = as_bounds(domain, "domain")
    x = np.asarray(samples, float).reshape(-1, b.shape[0])
    counts, edges = np.histogramdd(x, bins=bins, range=[tuple(r) for r in b])
    widths = np.prod([np.diff(e)[0] for e in edges])
    return counts / (x.shape[0] * widths), edges


class MetropolisHastings(Estimator):
    """Metropolis--Hastings with small Gaussian and large uniform steps on a box.

    Parameters
    ----------
    target : unnormalised density pi, a callable ``(..., k) -> (...)`` >= 0 (e.g.
        ``PiecewiseConstant2D(image).pdf``).
    step : small-step standard deviation as a fraction of each axis' width (> 0).
    large_step_prob : probability of a large (uniform) step, in [0, 1].
    domain : the box ``[(a1, b1), ..., (ak, bk)]`` (default the unit square).
    boundary : ``"wrap"`` (default) or ``"reject"`` for small steps leaving the box.
    n_chains, burn_in, batches : defaults for :meth:`expectation` and :meth:`estimate`.
    normalization : b = int pi if known (e.g. 1 for a pdf); ``None`` estimates it in
        :meth:`estimate`.
    """

    per_unit = False

    def __init__(self, target: Callable[[np.ndarray], np.ndarray], *, step: float = 0.05,
                 large_step_prob: float = 0.1, domain: Sequence = ((0.0, 1.0), (0.0, 1.0)),
                 boundary: str = "wrap", n_chains: int = 64, burn_in: int = 256, batches: int = 1,
                 normalization: float | None = None):
        if not callable(target):
            raise TypeError(f"target: expected a callable density pi(x), got {type(target).__name__}")
        step_f = checks.real(step, "step", low=0.0, low_open=True)
        p = checks.real(large_step_prob, "large_step_prob", low=0.0, high=1.0)
        checks.choice(boundary, "boundary", BOUNDARIES)
        if normalization is not None:
            normalization = checks.real(normalization, "normalization", low=0.0, low_open=True)
        self.target = target
        self.step = step_f
        self.large_step_prob = p
        self.domain = domain
        self.boundary = boundary
        self.n_chains = check_int("n_chains", n_chains, 1)
        self.burn_in = check_int("burn_in", burn_in, 0)
        self.batches = check_int("batches", batches, 1)
        self.normalization = normalization
        b = as_bounds(domain, "domain")
        self._lo, self._hi = b[:, 0], b[:, 1]
        self._width = self._hi - self._lo

    # -- the chain ------------------------------------------------------------------------
    @property
    def k(self) -> int:
        """Dimension of the box."""
        return len(self._lo)

    @property
    def dim_step(self) -> int:
        """Uniforms per chain and step: step kind, acceptance, k proposal coordinates."""
        return self.k + 2

    def _pi(self, x: np.ndarray) -> np.ndarray:
        v = np.asarray(self.target(x), dtype=float)
        if v.shape != x.shape[:-1]:
            raise ValueError(f"target: expected values of shape {x.shape[:-1]} for points {x.shape}, got {v.shape}")
        if not (v >= 0).all():
            raise ValueError("target: the density must be >= 0 (got negative or NaN values)")
        return v

    def _walk(self, x: np.ndarray, blocks: Iterator[np.ndarray], n_steps: int, burn_in: int) -> MHRun:
        """Advance chains at ``x (C, k)`` through ``burn_in + n_steps`` steps of uniforms, given as
        blocks ``(b, C, k + 2)`` (proposals are prepared per block, the loop is over steps)."""
        lo, width = self._lo, self._width
        C, k = x.shape
        wrap = self.boundary == "wrap"
        pi_x = self._pi(x)
        out = np.empty((n_steps, C, k))
        pis = np.empty((n_steps, C))
        total = burn_in + n_steps
        accepted = np.zeros((total, C), bool)
        larges = np.zeros((total, C), bool)
        t = 0
        for v in blocks:
            b = v.shape[0]
            if t + b > total:
                raise ValueError(f"u: expected {total} steps of uniforms, got more")
            large = v[..., 0] < self.large_step_prob                          # (b, C)
            prop = v[..., 2:]
            delta = (self.step * width) * _ndtri(np.clip(prop, _TINY, 1 - 1e-16))
            jump = lo + width * prop
            for i in range(b):
                y = x + delta[i]
                if wrap:
                    y = lo + np.mod(y - lo, width)
                    inside = None
                else:
                    inside = np.all((y >= lo) & (y < lo + width), -1) | large[i]
                y = np.where(large[i][:, None], jump[i], y)
                if inside is None:
                    pi_y = self._pi(y)
                else:
                    pi_y = np.zeros(C)
                    pi_y[inside] = self._pi(y[inside])
                with np.errstate(divide="ignore", invalid="ignore"):
                    a = np.where(pi_x > 0, pi_y / np.where(pi_x > 0, pi_x, 1.0), 1.0)
                accept = v[i, :, 1] < a              # a >= 1 always accepts (u < 1)
                if inside is not None:
                    accept &= inside
                x = np.where(accept[:, None], y, x)
                pi_x = np.where(accept, pi_y, pi_x)
                if t >= burn_in:
                    out[t - burn_in], pis[t - burn_in] = x, pi_x
                accepted[t], larges[t] = accept, large[i]
                t += 1
        if t != total:
            raise ValueError(f"u: expected {total} steps of uniforms, got {t}")
        if n_steps and not (pis > 0).any():
            raise ValueError("target: the density is 0 at every kept state of every chain; pi must be > 0 "
                             "somewhere in the domain (and the chains must find it: try large steps)")
        acc, lg = accepted[burn_in:], larges[burn_in:]
        n_large = np.count_nonzero(lg)
        n_small = lg.size - n_large
        with np.errstate(invalid="ignore", divide="ignore"):
            rate_small = np.count_nonzero(acc & ~lg) / n_small if n_small else np.nan
            rate_large = np.count_nonzero(acc & lg) / n_large if n_large else np.nan
        return MHRun(out, pis, float(acc.mean()), float(rate_small), float(rate_large), burn_in)

    def _start(self, x0, first: np.ndarray | None, n_chains: int) -> np.ndarray:
        if x0 is None:
            return self._lo + self._width * first[:, : self.k]
        try:
            arr = np.asarray(x0, dtype=float)
        except (TypeError, ValueError):
            raise TypeError(f"x0: expected starting points, numbers of shape ({self.k},) or ({n_chains}, {self.k}), "
                            f"got {type(x0).__name__}") from None
        try:
            x = np.array(np.broadcast_to(arr, (n_chains, self.k)))
        except ValueError:
            raise ValueError(f"x0: shape {arr.shape} does not fit {n_chains} chains in {self.k} dimensions; give "
                             f"({self.k},) (one point for every chain) or ({n_chains}, {self.k})") from None
        if not np.all(np.isfinite(x)):
            raise ValueError("x0: starting points must be finite (got NaN or inf)")
        if np.any(x < self._lo) or np.any(x > self._hi):
            raise ValueError("x0: starting points must lie in the domain")
        return x

    def chain(self, u: np.ndarray, *, x0: Any = None, burn_in: int = 0) -> MHRun:
        """Run chains on given uniforms ``u (1 + burn_in + T, C, k + 2)`` (a deterministic function of u).

        Row 0 gives the starting points (its last k columns, uniform on the box) unless
        ``x0 (C, k)`` is given (then row 0 is not used); every further row is one step.
        """
        u = np.asarray(u, float)
        if u.ndim != 3 or u.shape[-1] != self.dim_step or u.shape[0] < 2:
            raise ValueError(f"u: expected shape (1 + steps, chains, {self.dim_step}), got {u.shape}")
        burn_in = check_int("burn_in", burn_in, 0)
        steps = u.shape[0] - 1 - burn_in
        if steps < 1:
            raise ValueError(f"burn_in: {burn_in} leaves no steps out of {u.shape[0] - 1}")
        x = self._start(x0, u[0, :, 2:], u.shape[1])
        return self._walk(x, iter([u[1:]]), steps, burn_in)

    def run(self, n_steps: int, n_chains: int | None = None, rng: RNGLike = None, burn_in: int | None = None, *,
            x0: Any = None) -> MHRun:
        """Run ``n_chains`` chains for ``burn_in + n_steps`` steps; keep the last ``n_steps``.

        Identical to ``chain(rng.random((1 + burn_in + n_steps, n_chains, k + 2)), x0=x0,
        burn_in=burn_in)`` but draws the uniforms step by step (bounded memory).
        """
        n_steps = check_int("n_steps", n_steps, 1)
        C = self.n_chains if n_chains is None else check_int("n_chains", n_chains, 1)
        burn = self.burn_in if burn_in is None else check_int("burn_in", burn_in, 0)
        gen = as_generator(rng)
        first = gen.random((C, self.dim_step))
        x = self._start(x0, first[:, 2:], C)
        total = burn + n_steps

        def blocks():
            done = 0
            while done < total:
                k = min(max(1, (1 << 16) // C), total - done)   # ~64k chain-steps per block
                yield gen.random((k, C, self.dim_step))
                done += k
        return self._walk(x, blocks(), n_steps, burn)

    # -- estimates ------------------------------------------------------------------------
    def _batch_means(self, values: np.ndarray, batches: int) -> np.ndarray:
        T = values.shape[0]
        if T < batches:
            raise ValueError(f"batches: {batches} batches need at least as many steps, got {T}")
        L = T // batches
        v = values[T - L * batches:]                         # drop the oldest remainder
        return v.reshape(batches, L, *values.shape[1:]).mean(axis=1).reshape(-1)

    def expectation(self, g: Callable[[np.ndarray], np.ndarray], n_steps: int, n_chains: int | None = None,
                    rng: RNGLike = None, burn_in: int | None = None, *, batches: int | None = None,
                    x0: Any = None) -> Estimate:
        """E_pi[g] = int pi g / int pi from the chains, with a batch-means standard error.

        ``g`` maps points ``(..., k)`` to ``(...)``.  ``Estimate.n`` is the number of batch
        means (C x batches), ``n_evals`` the kept chain states at which g was evaluated.
        """
        B = self.batches if batches is None else check_int("batches", batches, 1)
        t0 = time.perf_counter()
        res = self.run(n_steps, n_chains, rng, burn_in, x0=x0)
        vals = np.asarray(g(res.samples), float)
        if vals.shape != res.samples.shape[:-1]:
            raise ValueError(f"g: expected values of shape {res.samples.shape[:-1]}, got {vals.shape}")
        units = self._batch_means(vals, B)
        if units.size < 2:
            raise ValueError("n_chains: need at least 2 batch means (chains x batches) for a standard error")
        mom = Moments().add(units)
        return Estimate.from_moments(mom, vals.size, time.perf_counter() - t0, "MetropolisHastings",
                                     acceptance=res.acceptance, acceptance_small=res.acceptance_small,
                                     acceptance_large=res.acceptance_large, batches=B,
                                     n_chains=res.samples.shape[1], burn_in=res.burn_in)

    def dim_u(self, integrand=None) -> int:
        """Uniforms per chain and step (``dim_step``)."""
        return self.dim_step

    def unit_values(self, integrand, u):  # pragma: no cover - a Markov chain, not i.i.d. units
        raise TypeError("MetropolisHastings has no i.i.d. unit values; call estimate() or expectation()")

    def normalizer(self, n: int, *, rng: RNGLike = None, points: Any = None) -> Estimate:
        """Plain Monte Carlo estimate of b = int pi over the box from ``n`` uniform points."""
        vol = float(np.prod(self._width))
        mom = Moments()
        for u in uniform_blocks(points, self.k, check_n(n), as_generator(rng), DEFAULT_CHUNK):
            mom.add(vol * self._pi(self._lo + self._width * u))
        return Estimate.from_moments(mom, mom.count, 0.0, "normalization")

    def estimate(self, integrand, n: int, *, rng: RNGLike = None, points: Any = None,
                 chunk: int = DEFAULT_CHUNK) -> Estimate:
        """int f = b E_pi[f / pi] with ``n`` kept chain states (f evaluated n times).

        ``b`` is ``normalization`` or, if ``None``, estimated from ``n`` independent
        uniform points (``points`` is their point set); the error of b enters by the delta
        method: Var = E^2 Var[b_hat] + b^2 Var[E_hat].  Requires pi > 0 where f != 0.
        """
        integrand, chunk = as_integrand(integrand), check_chunk(chunk)
        n = check_n(n)
        box = np.stack([self._lo, self._hi], 1)
        bounds = getattr(integrand, "bounds", None)
        if bounds is None or bounds.shape != box.shape or not np.allclose(bounds, box):
            raise ValueError(f"integrand: its domain must be the sampler's box {box.tolist()}")
        if integrand.atoms:
            raise ValueError(f"integrand: {integrand.name!r} has point masses (atoms at "
                             f"{integrand.atom_points[:, 0].tolist()}); the random-walk chains have a density "
                             "w.r.t. length and never visit an atom: use importance sampling or MIS with "
                             "vrlab.distributions.PointMasses")
        support_probe(integrand, [_TargetDensity(self._pi)], label="target (the MH density pi)")
        C = self.n_chains
        steps = n // C
        if steps < self.batches:
            raise ValueError(f"n: need n >= n_chains x batches = {C * self.batches}, got {n}")
        t0 = time.perf_counter()
        g_rng, b_rng = spawn(rng, 2)

        def f_over_pi(x):
            f = integrand(x)
            p = self._pi(x)
            return ratio(f, p)

        e = self.expectation(f_over_pi, steps, C, g_rng)
        if self.normalization is None:
            b_est = self.normalizer(n, rng=b_rng, points=points)
            b, b_se, b_evals = b_est.value, b_est.stderr, b_est.n_evals
            if not b > 0:
                raise ValueError(f"target: its integral b was estimated as 0 from {n} uniform points (pi = 0 at "
                                 "all of them); give normalization=b or a target that is > 0 where f is")
        else:
            b, b_se, b_evals = float(self.normalization), 0.0, 0
        value = b * e.value
        stderr = float(np.sqrt((e.value * b_se) ** 2 + (b * e.stderr) ** 2))
        return Estimate(float(value), stderr, e.n, e.n_evals, time.perf_counter() - t0, stderr**2 * e.n,
                        "MetropolisHastings", {"expectation": e.value, "expectation_stderr": e.stderr,
                                               "normalization": b, "normalization_stderr": b_se,
                                               "normalization_evals": b_evals, "acceptance": e.extra["acceptance"]})


class _TargetDensity:
    """The target pi seen as a density by ``support_probe`` (only ``pdf`` is used)."""

    dim_u = 0

    def __init__(self, pi):
        self.pdf = pi

    def sample(self, u):  # pragma: no cover - never sampled
        raise NotImplementedError


def _ndtri(p: np.ndarray) -> np.ndarray:
    """Inverse standard normal CDF (``scipy.special.ndtri``, imported on first use)."""
    from scipy import special

    return special.ndtri(p)
