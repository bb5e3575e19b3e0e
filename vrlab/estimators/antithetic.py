"""Antithetic variates: average each sample with its reflection (lecture 000, "Antithetic Variates").

For uniforms ``u`` in [0, 1)^d the antithetic partner is the reflection ``u' = 1 - u``
(every coordinate), and the pair is ``(x, x') = (sample(u), sample(1 - u))`` for *any*
distribution.  Both are distributed as p, so the unit value

    Y = (f(x) / p(x) + f(x') / p(x')) / 2

is unbiased for I = int f.  With sigma^2 = Var[f(X)/p(X)] and rho = corr(f(x)/p(x),
f(x')/p(x')),

    Var[Y] = sigma^2 (1 + rho) / 2,

and since one pair costs two evaluations, ``n`` evaluations give n/2 pairs and
Var[estimate] = sigma^2 (1 + rho) / n: at equal cost the variance factor against plain
Monte Carlo is ``1 + rho`` (Owen, *Monte Carlo theory, methods and examples*, ch. 8, antithetic sampling).

* Monotone f (through a monotone warp) gives rho < 0: a gain.  For e^x on [0, 1]
  1 + rho = 0.03233; for linear f, rho = -1 and the variance is zero.
* **Failure case**: an even-symmetric integrand, f(x) = f(1 - x) (e.g. sin(pi x) on
  [0, 1]), makes the two members of a pair identical, rho = +1, so at equal cost the
  variance *doubles* (n/2 distinct points instead of n).

For the uniform sphere/hemisphere warps and symmetric boxes the reflection of ``u`` is the
natural antithetic point (point reflection of the box, opposite azimuth and mirrored
height on the sphere).  The standard error is computed from the n/2 pair means, which
are independent, so it is honest whatever rho is.
"""
from __future__ import annotations

import numpy as np

from .. import checks
from ..points.base import ONE_MINUS_EPS
from .base import Estimator, check_technique, resolve_distribution, technique_label
from .importance import MonteCarlo


def reflect(u: np.ndarray) -> np.ndarray:
    """The antithetic uniforms ``1 - u``, kept in [0, 1) (``u = 0`` maps to the largest double < 1)."""
    return np.minimum(1.0 - np.asarray(u, dtype=float), ONE_MINUS_EPS)


class Antithetic(Estimator):
    """Antithetic pairs ``(sample(u), sample(1 - u))``; unit value = mean of the two f/p.

    ``distribution``: the importance distribution (default uniform on the domain).
    ``n`` evaluations make ``n // 2`` pairs (``evals_per_unit = 2``); the standard error
    comes from the pair means.  Batched integrands and distributions work as in
    :class:`~vrlab.estimators.MonteCarlo`.
    """

    evals_per_unit = 2

    def __init__(self, distribution=None, *, probe: bool = True):
        self.distribution = None if distribution is None else check_technique(distribution)
        self.probe = checks.flag(probe, "probe")

    @property
    def label(self) -> str:
        return "Antithetic" if self.distribution is None else f"Antithetic[{technique_label(self.distribution)}]"

    def _mc(self) -> MonteCarlo:
        return MonteCarlo(self.distribution, probe=self.probe)

    def check(self, integrand) -> None:
        self._mc().check(integrand)

    def dim_u(self, integrand) -> int:
        return int(resolve_distribution(self.distribution, integrand).dim_u)

    def unit_values(self, integrand, u: np.ndarray) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        m = u.shape[-2]
        # one call for both members: (*batch, 2m, d) -> f/p (*batch, 2m)
        both = self._mc().unit_values(integrand, np.concatenate([u, reflect(u)], axis=-2))
        return 0.5 * (both[..., :m] + both[..., m:])
