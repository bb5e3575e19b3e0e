"""Multiple importance sampling: Veach's multi-sample and one-sample estimators.

Multi-sample MIS (Veach & Guibas 1995; Veach 1997, ch. 9, eq. 9.3): technique i
draws n_i samples X_ij ~ p_i and

    F = sum_i (1/n_i) sum_j w_i(X_ij) f(X_ij) / p_i(X_ij),

unbiased when sum_i w_i(x) = 1 wherever f(x) != 0 and w_i = 0 wherever p_i = 0.
With q_i(x) = n_i p_i(x) the heuristics are

* ``balance``:  w_i = q_i / sum_k q_k  (then w_i f / p_i = n_i f / sum_k q_k);
* ``power``:    w_i = q_i^beta / sum_k q_k^beta  (beta = 2: Veach's power heuristic);
* ``maximum``:  w_i = 1 for the technique with the largest q_i (ties split equally);
* ``cutoff``:   keep the techniques with q_k >= alpha max_l q_l, balance among them;
* ``optimal``:  Kondapaneni, Vévoda, Grittmann, Skřivan, Slusallek & Křivánek (2019),
  "Optimal Multiple Importance Sampling", ACM TOG 38(4).  With c_k = n_k / N and
  q(x) = sum_k c_k p_k(x), the variance-minimising weights give the estimator

      F_o = sum_k a_k + (1/N) sum_{i,j} (f - sum_k a_k p_k)(X_ij) / q(X_ij),

  where ``a`` solves A a = b, A_ik = int p_i p_k / q, b_i = int f p_i / q.  Per sample
  unit (``estimate`` with whole unit counts, and the renderer per pixel) a is fitted as a
  regression on the density controls, *cross-fitted* (:mod:`~vrlab.estimators.crossfit`):
  each of 4 folds of units is weighted by the a fitted on the other folds, so F_o is
  unbiased at every sample count.  With ``optimal_pilot = t > 0`` a is fitted on a
  separate pilot of t N samples (unbiased too).  Only fractions that are not a ratio of
  whole numbers, without a pilot, fit A and b on the very samples they weight (then the
  correction term is zero and F_o = sum a; consistent, with an O(1/N) bias that is
  negligible at the lab's sample counts, 10^3 and more, but not at a pixel's).
  Its weights may be negative.  Variance: (1/N) int (f - a.p)^2 / q, never above the
  balance heuristic's (plus the O(1/N) cost of fitting a).

Every heuristic also accepts a callable ``heuristic(q) -> w`` (arrays (..., K)).  Its
weights are checked on every batch of samples: finite, shape (..., K), and summing to 1
over the techniques with q_k > 0 wherever some q_k > 0 (Veach's unbiasedness condition;
tolerance 1e-6, 1e-3 for float32 q); otherwise ``ValueError`` naming the heuristic.

One-sample MIS lives in ``onesample.py``.
"""
from __future__ import annotations

import time
from typing import Any, Callable, Sequence

import numpy as np

from .. import checks
from .._rng import RNGLike, as_generator
from ..distributions.base import checked_pdf
from ..estimate import Estimate, Moments
from .base import (DEFAULT_CHUNK, Estimator, _plain, as_integrand, check_chunk, check_n, ratio, support_probe,
                   uniform_blocks)

from .crossfit import FoldedCoMoments, crossfit_estimate, statistics_from_state
from .heuristics import (HEURISTICS, _check_beta_alpha, _check_dims, _check_distributions,  # noqa: F401
                         _check_fractions, _check_heuristic, _stack_pdfs, check_heuristic_weights, mis_weights,
                         resolve_all, split_counts, unit_counts)

# ----------------------------------------------------------------------------------------
# multi-sample MIS
# ----------------------------------------------------------------------------------------
class MIS(Estimator):
    """Veach's multi-sample MIS estimator (see the module docstring for the formulas).

    A sample unit holds ``unit_counts()`` = c_i samples of technique i (the smallest whole
    numbers in the ratio of ``fractions``; c_i = 0 gives weight 0, and the other techniques
    must then cover the support).  ``estimate`` with n evaluations folds m = n //
    sum(c) units, n_i = m c_i, through ``unit_outputs`` -> ``accumulate`` -> ``summarize``,
    the code the renderer runs per pixel.  ``heuristic``: one of ``HEURISTICS`` or a
    callable ``q -> w``; ``beta`` (power), ``alpha`` (cutoff), ``optimal_pilot`` (share of
    n used to fit the optimal weights' coefficients in a separate pass; 0: cross-fitted on
    the units themselves), ``optimal_ridge`` (the per-unit fit's ridge penalty, in phantom
    units at the edge of the controls' range: see :meth:`_regression`; the renderer's preset
    uses 1).

    The techniques' samples are independent, so Var[F] = sum_i Var_i[w_i f / p_i] / n_i;
    ``estimate`` reports that per technique in ``extra["variance_contributions"]`` (last
    axis: technique), with ``extra["counts"]``; for ``optimal``, ``extra["alpha"]`` (the
    fitted coefficients).  ``Estimate.variance`` is N Var[F] (per-sample equivalent) and
    ``n`` = N samples.  Fractions that are not a ratio of whole numbers up to 64, and an
    optimal pilot, allocate n_i = ``split_counts(n, c)`` per technique instead
    (:mod:`~vrlab.estimators.mis_by_technique`).  Works batched (integrand values
    (*batch, n), distributions broadcasting over leading axes, or uniforms (*batch, m, d)).
    """

    def __init__(self, distributions: Sequence, fractions: Sequence[float] | None = None,
                 heuristic: str | Callable = "balance", *, beta: float = 2.0, alpha: float = 0.1,
                 optimal_pilot: float = 0.0, optimal_ridge: float = 0.0, probe: bool = True):
        self.distributions = _check_distributions(distributions)
        self.fractions = _check_fractions(fractions, len(self.distributions), "fractions")
        self._unit = unit_counts(fractions, self.fractions)
        _check_heuristic(heuristic, HEURISTICS)
        self.heuristic = heuristic
        self.beta, self.alpha = _check_beta_alpha(beta, alpha)
        pilot = checks.real(optimal_pilot, "optimal_pilot", low=0.0, high=1.0, high_open=True)
        if pilot > 0 and heuristic != "optimal":
            raise ValueError("optimal_pilot: only used with heuristic='optimal'")
        self.optimal_pilot = pilot
        ridge = checks.real(optimal_ridge, "optimal_ridge", low=0.0)
        if ridge > 0 and heuristic != "optimal":
            raise ValueError("optimal_ridge: only used with heuristic='optimal'")
        self.optimal_ridge = ridge
        self.probe = checks.flag(probe, "probe")

    @property
    def label(self) -> str:
        name = self.heuristic if isinstance(self.heuristic, str) else getattr(self.heuristic, "__name__", "custom")
        return f"MIS[{name}]"

    def counts(self, n: int) -> np.ndarray:
        """Samples per technique for ``n`` evaluations (without an optimal pilot)."""
        return split_counts(check_n(n), self.fractions)

    def check(self, integrand) -> None:
        dists = resolve_all(self.distributions, integrand)
        _check_dims(dists, integrand)
        active = [d for d, c in zip(dists, self.fractions) if c > 0]
        if integrand.atoms:      # point masses (imported here: the renderer needs none)
            from .atoms import check_atoms
            check_atoms(integrand, active, [f"distributions[{i}]" for i, c in enumerate(self.fractions) if c > 0],
                        self.label)
        if self.probe and integrand.dim <= 3:
            support_probe(integrand, active, label=f"{self.label} (techniques with samples)")

    def dim_u(self, integrand=None) -> int:
        """Uniforms per row of an array ``points``: the largest technique's ``dim_u``
        (``unit_dim`` for the uniforms of one sample unit)."""
        return max(int(d.dim_u) for d in resolve_all(self.distributions, integrand))

    def weights(self, x: np.ndarray, counts: np.ndarray, integrand=None) -> np.ndarray:
        """w_k(x) (..., K) of the non-optimal heuristics for sample counts ``counts``."""
        return mis_weights(_stack_pdfs(resolve_all(self.distributions, integrand), x) * counts, self.heuristic,
                           beta=self.beta, alpha=self.alpha)

    # -- one sample unit: unit_counts()[i] samples of technique i (the renderer's view) --
    def unit_counts(self) -> np.ndarray:
        """Samples per technique in one sample unit (see :func:`unit_counts`)."""
        if self._unit is None:
            raise ValueError(f"fractions: {self.fractions.tolist()} is not a ratio of whole numbers up to 64; "
                             "per-unit MIS (the renderer) needs whole sample counts, e.g. fractions=[1, 1]")
        return self._unit

    @property
    def evals_per_unit(self) -> int:  # type: ignore[override]
        return 1 if self._unit is None else int(self._unit.sum())

    def unit_dim(self, integrand=None) -> int:
        """Uniforms of one sample unit: sum_i unit_counts_i dim_u_i (technique after technique)."""
        dists = resolve_all(self.distributions, integrand)
        return int(sum(c * int(d.dim_u) for c, d in zip(self.unit_counts(), dists)))

    def _unit_samples(self, integrand, u: np.ndarray):
        """Yield ``(i, c_i, x)``: technique i's c_i samples of each of the m units in ``u
        (*batch, m, unit_dim)`` (columns of technique 0's c_0 samples first, then technique
        1's, ...), as points ``(*batch, m c_i, dim)``, unit after unit."""
        dists = resolve_all(self.distributions, integrand)
        counts = self.unit_counts()
        u = np.asarray(u, dtype=float)
        if u.ndim < 2 or u.shape[-1] != self.unit_dim(integrand):
            raise ValueError(f"u: expected uniforms (..., m, {self.unit_dim(integrand)}), got shape {u.shape}")
        m, col = u.shape[-2], 0
        for i, dist in enumerate(dists):
            c, d = int(counts[i]), int(dist.dim_u)
            if c == 0:
                continue
            ui = u[..., col:col + c * d].reshape(u.shape[:-2] + (m * c, d))   # unit after unit
            col += c * d
            yield i, c, dist.sample(ui)

    @staticmethod
    def _per_unit(v: np.ndarray, c: int, axis: int = -1) -> np.ndarray:
        """Sum the c consecutive samples of each unit along ``axis`` (m c -> m)."""
        if c == 1:
            return v
        v = np.moveaxis(v, axis, -1)
        return np.moveaxis(v.reshape(v.shape[:-1] + (v.shape[-1] // c, c)).sum(-1), -1, axis)

    def unit_terms(self, integrand, u: np.ndarray):
        """Yield ``(i, T_i)``: technique i's term T_i = (1/c_i) sum_j w_i(X_ij) f(X_ij) /
        p_i(X_ij) of each unit ``(*batch, m)`` (eq. 9.3 with n_i = c_i), from uniforms ``u
        (*batch, m, unit_dim)``; the unit value is their sum.  Techniques without samples
        are skipped.  The terms of different techniques are independent (disjoint uniforms),
        so Var[unit] = sum_i Var[T_i]: ``estimate`` reports those per technique."""
        if self.heuristic == "optimal":
            raise ValueError("heuristic: 'optimal' fits its weights over all units and has no unit values; "
                             "its unit_outputs are the balance value and the density controls")
        dists = resolve_all(self.distributions, integrand)
        counts = self.unit_counts()
        for i, c, x in self._unit_samples(integrand, u):
            f = integrand(x)
            if self.heuristic == "balance":  # (1/c_i) w_i f / p_i = f / sum_k c_k p_k
                q = 0.0
                for k, other in enumerate(dists):
                    if counts[k]:
                        pk = checked_pdf(other, x, f"distributions[{k}]")
                        q = q + pk.dtype.type(counts[k]) * pk       # float32 densities stay float32
                        if k == i:
                            own = pk
                # where p_i(x) = 0 technique i cannot have drawn x (rounding, or a pdf that does not
                # match its sampler): the sample counts 0, as ratio() makes it for other heuristics
                v = ratio(f, np.where(own > 0, q, 0))
            else:
                P = _stack_pdfs(dists, x)
                w = mis_weights(P * counts.astype(P.dtype), self.heuristic, beta=self.beta, alpha=self.alpha)
                v = ratio(w[..., i], P.dtype.type(c) * P[..., i]) * f
            yield i, self._per_unit(v, c)

    @staticmethod
    def _add_up(terms):
        """The sum of the terms, technique after technique (one order for the lab and the renderer)."""
        total = 0.0
        for v in terms:
            if isinstance(total, np.ndarray) and total.shape == v.shape:
                total += v
            else:
                total = total + v
        return total

    def unit_values(self, integrand, u: np.ndarray) -> np.ndarray:
        """Unit values sum_i T_i (:meth:`unit_terms`) from uniforms ``u (*batch, m,
        unit_dim)``: columns of technique 0's c_0 samples first, then technique 1's, ...  Not
        for ``optimal``, whose estimate is a regression over units (:meth:`unit_outputs`)."""
        return self._add_up(v for _, v in self.unit_terms(integrand, u))

    # -- optimal MIS per unit (the renderer's view): a regression on density controls ------
    @property
    def min_units(self) -> int:  # type: ignore[override]
        """Units one fold needs: 1; ``optimal`` 2 (no unit values, residuals need two units).
        It cross-fits its coefficients and uses a = 0 (the balance heuristic) for a fold whose
        other folds have too few units for a fit, so every count >= 2 is unbiased."""
        return 2 if self.heuristic == "optimal" else 1

    def unit_outputs(self, integrand, u: np.ndarray) -> np.ndarray:
        """Per unit, ``(*batch, m, c)``.  For the explicit heuristics one column, the unit value.

        For ``optimal``, Kondapaneni et al.'s F_o = sum_k a_k + (1/N) sum (f - a.p) / q as a
        control-variate estimate over units: with the unit counts c_k and q = sum_k c_k p_k,
        column 0 is the balance value Y = sum_s f(X_s) / q(X_s) over the unit's samples, and
        columns 1.. are H_k - 1 with H_k = sum_s p_k(X_s) / q(X_s) for the first K - 1 active
        techniques.  E[H_k] = sum_i c_i int p_i p_k / q = int p_k = 1 for every normalised
        density p_k (the last control is redundant: sum_k c_k H_k = sum_k c_k), so
        :meth:`summarize`'s mean(Y) - a.(mean(H) - 1) is F_o, with a cross-fitted over folds
        of units (:func:`~vrlab.estimators.crossfit.crossfit_estimate`): unbiased at every
        m.  Densities must integrate to 1 over what their techniques sample (the
        renderer's do: a sample wasted below the horizon keeps its density)."""
        if self.heuristic != "optimal":
            return super().unit_outputs(integrand, u)
        if self.optimal_pilot > 0:
            raise ValueError("optimal_pilot: per unit (the renderer) the optimal weights are fitted on the units "
                             "themselves; use optimal_pilot=0")
        dists = resolve_all(self.distributions, integrand)
        counts = self.unit_counts()
        active = [k for k in range(len(dists)) if counts[k]]
        y = h = 0.0
        for _, c, x in self._unit_samples(integrand, u):
            f = integrand(x)
            P = _stack_pdfs([dists[k] for k in active], x)                    # (..., m c, K)
            q = P @ counts[active].astype(P.dtype)
            y = y + self._per_unit(ratio(f, q), c)
            h = h + self._per_unit(ratio(P[..., :-1], q[..., None]), c, axis=-2)
        y, h = np.asarray(y), np.asarray(h) - 1.0
        shape = np.broadcast_shapes(y.shape, h.shape[:-1])          # (RGB, ...) integrand batches lead
        return np.concatenate([np.broadcast_to(y, shape)[..., None], np.broadcast_to(h, shape + h.shape[-1:])], -1)

    def add_emitted(self, outputs: np.ndarray, emitted: np.ndarray) -> np.ndarray:
        """``optimal``: the renderer's emitted term goes into a last column, kept out of the
        fit (a pixel on the edge of a bright emitter would otherwise drive the coefficient:
        measured on Veach's plates, a 28 % excess on such pixels at 256 spp)."""
        if self.heuristic != "optimal":
            return super().add_emitted(outputs, emitted)
        emitted = np.broadcast_to(emitted, outputs.shape[:-1])[..., None]
        return np.concatenate([outputs, emitted.astype(outputs.dtype, copy=False)], -1)

    def accumulate(self, outputs: np.ndarray):
        """``optimal``: the :class:`~vrlab.estimators.crossfit.FoldedCoMoments` of the columns
        (Y, H - 1 [, emitted]); otherwise the moments of the unit values."""
        if self.heuristic != "optimal":
            return super().accumulate(outputs)
        return FoldedCoMoments().add(np.asarray(outputs))

    def summarize(self, stats) -> tuple[np.ndarray, np.ndarray]:
        """``optimal``: the cross-fitted regression of Y on the controls and its standard error."""
        if not isinstance(stats, FoldedCoMoments):
            return super().summarize(stats)
        r = self._regression(stats)
        return r["value"], r["stderr"]

    def details(self, stats) -> dict:
        if not isinstance(stats, FoldedCoMoments):
            return super().details(stats)
        r = self._regression(stats)
        return {"variance": r["variance"], "alpha": r["alpha"], "variance_factor": r["variance_factor"]}

    def _regression(self, stats: FoldedCoMoments) -> dict:
        """The cross-fit of Y on the K - 1 controls; an emitted column E (the renderer's, see
        :meth:`add_emitted`) is added to every residual and kept out of the fit.

        With ``optimal_ridge = r`` the fit is a ridge regression with penalty r R_k^2 on
        control k, R_k = (sum_i c_i) / c_k the width of H_k's range (each sample's p_k / q
        lies in [0, 1 / c_k]): r phantom units at the edge of that range, on the balance
        heuristic's line (a = 0).  It matters at a pixel's few units, not at the lab's
        thousands (there r = 0 recovers the zero-variance weights exactly).  Without it,
        a fold whose fit saw no rare sample of high leverage (on the Cornell box a BSDF sample
        that hits the light: H = 1 where the other units have H = -0.01) extrapolates a slope
        of -8.5 to a fold that holds one, and per-pixel optimal MIS had 3x the balance
        heuristic's variance at 16-64 spp; with r = 1 (the ``mis-optimal`` preset), the same
        as balance there (where the optimal and balance weights nearly agree), while the fit
        still follows where the controls spread over their range.  The penalty is fixed in
        advance, so the estimate stays unbiased."""
        with np.errstate(invalid="ignore", divide="ignore"):
            c = self.unit_counts()
            c = c[c > 0]
            return crossfit_estimate(stats, len(c) - 1, 0.0, ridge=self.optimal_ridge * (c.sum() / c[:-1]) ** 2)

    def statistics_from_state(self, state: dict):
        return statistics_from_state(state, super().statistics_from_state)

    def estimate(self, integrand, n: int, *, rng: RNGLike = None, points: Any = None,
                 chunk: int = DEFAULT_CHUNK) -> Estimate:
        """Estimate ``integrand``'s integral with ``n`` evaluations: m = n // ``evals_per_unit``
        sample units of ``unit_counts()`` samples per technique (n_i = m c_i), through
        :meth:`unit_outputs` -> :meth:`accumulate` -> :meth:`summarize`, the renderer's code.
        ``extra``: ``counts`` (n_i), ``variance_contributions`` (Var[T_i] / m per technique,
        last axis; not for ``optimal``, which reports ``alpha``, the fitted coefficients of the
        controls H_k - 1 of the first K - 1 techniques: beta_k = a_k - a_K c_k / c_K in the
        paper's a).  ``n`` of the result counts samples, and ``variance`` is per sample (N
        Var[F]), so stderr^2 = variance / n.

        ``points``: None or a point-set class, name or engine of dimension ``unit_dim()``
        (one row per unit), or an array ``(*batch, m, unit_dim())``.  Fractions that are not
        a ratio of whole numbers, and an optimal pilot, allocate n_i per technique instead
        (:func:`~vrlab.estimators.mis_by_technique.estimate_by_technique`)."""
        if self._unit is None or self.optimal_pilot > 0:
            from .mis_by_technique import estimate_by_technique
            return estimate_by_technique(self, integrand, n, rng=rng, points=points, chunk=chunk)
        integrand, chunk = as_integrand(integrand), check_chunk(chunk)
        self.check(integrand)
        m = self.units_for(n)
        gen = as_generator(rng) if not isinstance(rng, np.random.Generator) else rng
        t0 = time.perf_counter()
        stats, terms = None, {}
        for u in uniform_blocks(points, self.unit_dim(integrand), m, gen, chunk):
            if self.heuristic == "optimal":
                out = self.unit_outputs(integrand, u)
            else:
                parts = dict(self.unit_terms(integrand, u))
                for i, v in parts.items():
                    terms.setdefault(i, Moments()).add(v)
                out = self._add_up(parts.values())[..., None]
            block = self.accumulate(out)
            stats = block if stats is None else stats.merge(block)
        est = self.to_estimate(stats, time.perf_counter() - t0, points)
        E = self.evals_per_unit
        est.n, est.n_evals = m * E, m * E
        if est.variance is not None:
            est.variance = _plain(np.asarray(est.variance) * E)
        est.extra["counts"] = (m * self.unit_counts()).tolist()
        est.extra["pilot_counts"] = [0] * len(self.fractions)
        if terms:                                     # Var[T_i] / m; 0 for techniques without samples
            var = [np.asarray(terms[i].variance) / m if i in terms else np.zeros(()) for i in range(len(self.fractions))]
            est.extra["variance_contributions"] = np.stack(np.broadcast_arrays(*var), -1)
        return est
