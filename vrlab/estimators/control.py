"""Control variates and the defensive mixture with its components as controls.

Control variates (lecture 000, "Control Variates"; Owen, *Monte Carlo theory, methods
and examples*, ch. 8, control variates and regression estimators).  With X ~ p,
Y = f(X)/p(X) and controls H_j = h_j(X)/p(X) whose integrals int h_j = theta_j are known,

    I_hat = mean(Y) - alpha^T (mean(H) - theta)

is unbiased for any fixed alpha, with Var = (sigma_Y^2 - 2 alpha^T S_HY + alpha^T S_HH alpha) / n.
The minimum is at alpha* = S_HH^{-1} S_HY (one control: alpha* = Cov(Y, H) / Var(H)),
where the variance factor against plain Monte Carlo is 1 - rho^2 (1 - R^2 for several
controls).  ``alpha = 1`` (plain difference) only helps when corr(Y, H) > sigma_H / (2 sigma_Y),
i.e. corr > 1/2 for equal variances at equal n (the lecture's corr > 3/4 also charges the
evaluations of h, comparing with plain Monte Carlo on 2N samples).

``alpha="optimal"`` fits alpha by least squares, cross-fitted
(:mod:`~vrlab.estimators.crossfit`; Avramidis & Wilson 1993): the units are split into 4
folds by their index, and each fold is weighted by the alpha fitted on the other three.
That alpha is independent of the fold's samples, so the estimate is unbiased at every n
(fitting on the same samples, the classical regression estimator, is biased by O(1/n):
the fitted alpha is correlated with mean(H) - theta).  A fold whose other folds hold fewer
than K + 3 units uses alpha = 0.  The standard error is that of the cross-fitted residuals.
Batched integrands get one alpha per batch element.  The fitted alpha (averaged over the
folds) and the estimated variance factor are reported in ``Estimate.extra`` (``"alpha"``,
``"variance_factor"``).

Defensive mixture (Owen & Zhou 2000, "Safe and effective importance sampling", JASA 95;
Hesterberg 1995 for defensive mixtures): sample from q = sum_k c_k p_k, one of the p_k
being the nominal (uniform) density, and use the mixture components as controls: each
p_k integrates to 1, so with H_k = p_k(X)/q(X)

    I_hat = mean(f/q - sum_k beta_k (p_k/q - 1)),   beta by regression.

Because sum_k c_k H_k = 1, one control is redundant and is dropped.  With the optimal
beta its variance is never above min_k sigma_k^2 / c_k, where sigma_k^2 is the variance of
importance sampling from p_k alone (Owen & Zhou 2000): it is never much worse than the
best single component, and the defensive component bounds f/q by f / (c_0 p_0).
"""
from __future__ import annotations

from typing import Any, Callable, Sequence

import numpy as np

from .. import checks
from ..integrands.base import checked_values
from .atoms import check_atoms
from ..distributions.base import checked_pdf
from .base import Estimator, check_technique, ratio, resolve_distribution, support_probe
from .importance import MonteCarlo
from .crossfit import FoldedCoMoments, crossfit_estimate, statistics_from_state
from .regression import CoMoments, regression_estimate  # noqa: F401  (public here too)


def _scalar(a):
    a = np.asarray(a, dtype=float)
    return float(a) if a.ndim == 0 else a



class _Regression(Estimator):
    """Shared driver: accumulate co-moments of the columns (Y, H_1 - theta_1, ...) over
    chunks (``unit_outputs``), then regress (``fold``)."""

    evals_per_unit = 1

    def _columns(self, integrand, u) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError  # abstract: (*batch, m, 1 + K), controls centred (mean 0)

    def _alpha(self):
        return "optimal"

    def _n_controls(self) -> int:  # pragma: no cover - interface
        raise NotImplementedError  # abstract

    @property
    def min_units(self) -> int:
        """Sample units one fold needs: 1 with a fixed alpha (a mean of unit values); 2 with a
        fitted one, which has no unit values and needs two units for its residuals.  Fitted
        coefficients are cross-fitted (:mod:`~vrlab.estimators.crossfit`): with too few
        units for a fit a fold uses alpha = 0, so every n >= 2 stays unbiased."""
        return 2 if self._fitted() else 1

    def _fitted(self) -> bool:
        return isinstance(self._alpha(), str) and self._n_controls() > 0

    def unit_outputs(self, integrand, u: np.ndarray) -> np.ndarray:
        """Columns ``(*batch, m, 1 + K)``: Y = f/p and the centred controls h_j/p - theta_j."""
        return self._columns(integrand, u)

    def accumulate(self, outputs: np.ndarray):
        """With a fitted alpha: the :class:`~vrlab.estimators.crossfit.FoldedCoMoments` of the
        columns (mergeable, per fold); with a fixed one, the moments of the unit values
        Y - alpha^T (H - theta)."""
        outputs = np.asarray(outputs)
        a = self._alpha()
        if not isinstance(a, str) or outputs.shape[-1] == 1:
            if outputs.shape[-1] > 1:
                want = outputs.shape[:-2] + (outputs.shape[-1] - 1,)
                try:
                    a = np.broadcast_to(np.asarray(a, float), want)
                except ValueError:
                    raise ValueError(f"alpha: shape {np.shape(a)} does not broadcast to the estimate's "
                                     f"(*batch, K) = {want}") from None
                outputs = (outputs[..., 0] - np.sum(a[..., None, :] * outputs[..., 1:], -1))[..., None]
            return super().accumulate(outputs)
        return FoldedCoMoments().add(outputs)

    def _crossfit(self, stats) -> dict:
        with np.errstate(invalid="ignore", divide="ignore"):
            return crossfit_estimate(stats, self._n_controls(), 0.0)

    def summarize(self, stats) -> tuple[np.ndarray, np.ndarray]:
        """The cross-fitted regression estimate and its standard error (a fixed alpha: mean and
        sqrt(s^2 / m))."""
        if not isinstance(stats, FoldedCoMoments):
            return super().summarize(stats)
        r = self._crossfit(stats)
        return r["value"], r["stderr"]

    def unit_values(self, integrand, u: np.ndarray) -> np.ndarray:
        """Y - alpha^T (H - theta) per unit: only for a fixed ``alpha`` (a fitted one is a
        function of the other folds' samples, see :meth:`fold`)."""
        a = self._alpha()
        if self._fitted():
            raise ValueError(f"alpha: {self.label} fits alpha over all samples, so it has no per-unit values; "
                             "give a fixed alpha for them (its fold fits alpha per set of units)")
        cols = self._columns(integrand, u)
        if cols.shape[-1] == 1:
            return cols[..., 0]
        return cols[..., 0] - np.sum(np.atleast_1d(np.asarray(a, float))[..., None, :] * cols[..., 1:], -1)

    def details(self, stats) -> dict:
        """``variance`` (residual, per unit), the fitted (averaged over the folds) or fixed
        ``alpha`` and, with fitted coefficients, the ``variance_factor`` against plain sampling
        and its ``plain_variance``."""
        if not isinstance(stats, FoldedCoMoments):
            out = super().details(stats)
            if self._n_controls():
                out["alpha"] = _scalar(self.alpha)
            return out
        r = self._crossfit(stats)
        alpha = r["alpha"][..., 0] if getattr(self, "_single", False) else r["alpha"]
        return {"variance": r["variance"], "alpha": _scalar(alpha), "variance_factor": _scalar(r["variance_factor"]),
                "plain_variance": _scalar(r["plain_variance"])}

    def statistics_from_state(self, state: dict):
        """:class:`FoldedCoMoments` (fitted coefficients) or ``Moments`` (fixed ones), by the state's kind."""
        return statistics_from_state(state, super().statistics_from_state)


class ControlVariate(_Regression):
    """Control variates: mean(f/p - alpha^T (h/p - theta)) with known theta = int h.

    Parameters
    ----------
    control : a callable ``h(x)`` (same point/batch conventions as the integrand), the
        name of one of the integrand's controls (:meth:`vrlab.Integrand.control`, which
        gives h and theta, e.g. the renderer's closed-form ``"lambertian"``), or a list
        of these (several controls at once).
    control_integral : the known integral(s) theta of the control(s): a number (one
        control) or one value per control (each scalar or batch-shaped); ``None`` for
        named controls.
        On an integrand with point masses theta is the integral w.r.t. the same mixed measure:
        h's value at an atom a_k counts as a point mass there, theta = int h dx + sum_k h(a_k)
        (:mod:`vrlab.distributions.point_masses`).
    alpha : ``"optimal"`` (default; least squares, cross-fitted over 4 folds: unbiased),
        or fixed coefficients: a number (used for every control) or one per control
        (last axis K, may carry batch axes); ``alpha=1`` is the plain difference estimator.
    distribution : importance distribution p (default uniform on the domain).

    ``n`` counts evaluations of f (each also evaluates the controls, assumed cheap).
    """

    closed_form_per_unit = True     # the renderer's named controls are closed forms per shading point

    def __init__(self, control: Callable | str | Sequence[Callable | str], control_integral: Any = None,
                 alpha: Any = "optimal", distribution=None, *, probe: bool = True):
        self._single = callable(control) or isinstance(control, str)
        controls = [control] if self._single else list(control) if isinstance(control, (list, tuple)) else None
        if not controls or not all(callable(h) or (isinstance(h, str) and h) for h in controls):
            raise TypeError("control: expected a callable h(x), a control's name or a non-empty list of these, "
                            f"got {control!r}")
        K = len(controls)
        named = [isinstance(h, str) for h in controls]
        if any(named) and not all(named):
            raise TypeError("control: give either callables or names of the integrand's controls, not both")
        if all(named):
            if control_integral is not None:
                raise ValueError("control_integral: named controls bring their integral; leave it None")
            ints = [0.0] * K
        elif control_integral is None:
            raise TypeError("control_integral: required for callable controls (the known integral of h)")
        elif self._single:
            ints = [control_integral]
        elif isinstance(control_integral, (list, tuple, np.ndarray)) and len(control_integral) == K:
            ints = list(control_integral)
        else:
            raise ValueError(f"control_integral: expected {K} values, one per control, got {control_integral!r}")
        try:
            theta = [np.asarray(t, dtype=float) for t in ints]
        except (TypeError, ValueError):
            raise TypeError(f"control_integral: expected numbers, got {control_integral!r}") from None
        if not all(np.all(np.isfinite(t)) for t in theta):
            raise ValueError(f"control_integral: must be finite, got {control_integral!r}")
        if isinstance(alpha, str):
            if alpha != "optimal":
                raise ValueError(f"alpha: expected 'optimal' or numbers, got {alpha!r}")
        else:
            if isinstance(alpha, (bool, np.bool_)):
                raise TypeError(f"alpha: expected 'optimal' or numbers, got {alpha!r}")
            try:
                a = np.asarray(alpha, dtype=float)
            except (TypeError, ValueError):
                raise TypeError(f"alpha: expected 'optimal' or numbers, got {alpha!r}") from None
            if not self._single and a.ndim > 0 and a.shape[-1] != K:
                raise ValueError(f"alpha: expected a number or an array whose last axis has one value per "
                                 f"control (K = {K}), got shape {a.shape}")
            if not np.all(np.isfinite(a)):
                raise ValueError(f"alpha: must be finite, got {alpha!r}")
        self.control = control
        self.control_integral = control_integral
        self.alpha = alpha
        self.distribution = None if distribution is None else check_technique(distribution)
        self.probe = checks.flag(probe, "probe")
        self._controls = controls
        self._named = all(named)
        self._theta_list = theta

    @property
    def label(self) -> str:
        return "ControlVariate" if isinstance(self.alpha, str) else f"ControlVariate[alpha={self.alpha!r}]"

    def _n_controls(self) -> int:
        return len(self._controls)

    def _alpha(self):
        if isinstance(self.alpha, str):
            return self.alpha
        a = np.asarray(self.alpha, float)
        # one control given as a bare callable: a batch-shaped alpha gets its K = 1 axis here
        return a[..., None] if (self._single and a.ndim >= 1 and a.shape[-1] != 1) else a

    def controls_for(self, integrand) -> list[tuple[Callable, Any]]:
        """``[(h_j, theta_j)]``: the callables with their integrals, or the integrand's named controls."""
        if self._named:
            return [integrand.control(h, f"control[{j}]") for j, h in enumerate(self._controls)]
        return list(zip(self._controls, self._theta_list))

    def check(self, integrand) -> None:
        MonteCarlo(self.distribution, probe=self.probe).check(integrand)  # same sampling, same checks

    def dim_u(self, integrand) -> int:
        return MonteCarlo(self.distribution).dim_u(integrand)

    def _columns(self, integrand, u):
        dist = resolve_distribution(self.distribution, integrand)
        x = dist.sample(u)
        p = np.asarray(checked_pdf(dist, x), dtype=float)
        y = ratio(integrand(x), p)
        cols = [y]
        xd, inside = integrand.on_domain(x)      # h is integrated over the domain too: 0 off it
        for j, (h, t) in enumerate(self.controls_for(integrand)):
            hv = checked_values(h(xd), xd, f"control[{j}]")
            hv = ratio(hv if inside is None else np.where(inside, hv, 0.0), p)
            t = np.asarray(t)
            try:
                batch = np.broadcast_shapes(y.shape, hv.shape)[:-1]     # the estimate's batch shape
            except ValueError:
                raise ValueError(f"control[{j}]: values of shape {hv.shape} do not broadcast with the integrand's "
                                 f"{y.shape}") from None
            try:
                fits = np.broadcast_shapes(t.shape, batch) == batch
            except ValueError:
                fits = False
            if not fits:
                name = "control_integral" if self._single else f"control_integral[{j}]"
                raise ValueError(f"{name}: shape {t.shape} does not fit the estimate's batch shape {batch} (the "
                                 "integrand's and control's leading axes); give one value, or one per batch element")
            cols.append(hv - t[..., None])
        return np.stack(np.broadcast_arrays(*cols), -1)


class DefensiveMixture(_Regression):
    """Owen & Zhou (2000) mixture importance sampling with the components as control variates.

    Parameters
    ----------
    distributions : the importance densities p_1..p_J (each with dim_u, sample, pdf).
    probabilities : their mixture weights (default equal); normalised.
    defensive : probability c_0 of the defensive component, the nominal density (uniform
        on the integrand's domain unless ``nominal`` is given); the others are scaled by
        1 - c_0.  ``defensive=0`` adds no component.  Default 0.1.
    nominal : the defensive density (default: uniform on the domain).
    controls : use the components as control variates (default True); False gives plain
        defensive mixture importance sampling (Hesterberg 1995), for comparison.

    Sampling uses :class:`vrlab.distributions.Mixture` (one uniform picks the component
    and is reused).  ``Estimate.extra["alpha"]`` holds the fitted beta of the first J
    controls (the last component's control is dropped: sum_k c_k p_k / q = 1).
    """

    def __init__(self, distributions: Sequence, probabilities: Sequence[float] | None = None, *,
                 defensive: float = 0.1, nominal=None, controls: bool = True):
        dists = list(distributions) if isinstance(distributions, (list, tuple)) else None
        if not dists:
            raise TypeError(f"distributions: expected a non-empty list of distributions, got {distributions!r}")
        for j, dist in enumerate(dists):
            check_technique(dist, f"distributions[{j}]")
        if nominal is not None:
            check_technique(nominal, "nominal")
        if probabilities is not None:
            pr = checks.finite_array(probabilities, "probabilities")
            if pr.shape != (len(dists),) or np.any(pr <= 0):
                raise ValueError(f"probabilities: expected {len(dists)} finite values > 0, got {probabilities!r}")
        checks.real(defensive, "defensive", low=0.0, high=1.0, high_open=True)
        self.distributions = distributions
        self.probabilities = probabilities
        self.defensive = defensive
        self.nominal = nominal
        self.controls = checks.flag(controls, "controls")

    @property
    def label(self) -> str:
        return "DefensiveMixture" if self.controls else "DefensiveMixture[no controls]"

    def mixture(self, integrand):
        """The sampling mixture q (a :class:`vrlab.distributions.Mixture`) for ``integrand``."""
        from ..distributions import Mixture

        comps = [resolve_distribution(c, integrand, f"distributions[{j}]") for j, c in enumerate(self.distributions)]
        pr = (np.full(len(comps), 1.0 / len(comps)) if self.probabilities is None
              else np.asarray(self.probabilities, float) / np.sum(self.probabilities))
        d = float(self.defensive)
        if d > 0:
            comps = [resolve_distribution(self.nominal, integrand, "nominal")] + comps
            pr = np.concatenate([[d], (1 - d) * pr])
        return Mixture(comps, pr)

    def _n_controls(self) -> int:
        k = len(self.distributions) + (float(self.defensive) > 0)
        return k - 1 if self.controls else 0

    def check(self, integrand) -> None:
        check_atoms(integrand, [self.mixture(integrand)], ["distributions"], self.label)
        if integrand.dim <= 3:
            support_probe(integrand, [self.mixture(integrand)], label="the mixture")

    def dim_u(self, integrand) -> int:
        return int(self.mixture(integrand).dim_u)

    def _columns(self, integrand, u):
        mix = self.mixture(integrand)
        x = mix.sample(u)
        pk = mix.component_pdfs(x)                       # (..., m, K)
        q = pk @ mix.probabilities
        y = ratio(integrand(x), q)
        if not self.controls:
            return y[..., None]
        h = ratio(pk[..., :-1], q[..., None]) - 1.0     # centred; drop the redundant last control
        shape = np.broadcast_shapes(y.shape, h.shape[:-1])
        return np.concatenate([np.broadcast_to(y, shape)[..., None],
                               np.broadcast_to(h, shape + h.shape[-1:])], -1)
