"""One-sample MIS (Veach 1997, 9.2.4).

Pick technique I with probability c_I, draw X ~ p_I and use
F = w_I(X) f(X) / (c_I p_I(X)).  With the balance heuristic this is importance
sampling from the mixture sum_k c_k p_k (the Russian lecture 4's
p(w) = 1/2 p_cos(w) + 1/(2N) sum_i p_i(w)).  Weights: ``mis.mis_weights``.
"""
from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from .. import checks
from .atoms import check_atoms
from .base import Estimator, ratio, support_probe
from .mis import (HEURISTICS, _check_beta_alpha, _check_dims, _check_distributions, _check_fractions,
                  _check_heuristic, _stack_pdfs, mis_weights, resolve_all)


class OneSampleMIS(Estimator):
    """One-sample MIS: technique I ~ c, X ~ p_I, F = w_I(X) f(X) / (c_I p_I(X)) (Veach 1997, 9.2.4).

    The first uniform picks I and is rescaled and reused, as in
    ``vrlab.distributions.Mixture`` (``dim_u`` = the largest technique's).  With the
    balance heuristic F = f / sum_k c_k p_k: importance sampling from the mixture,
    value for value.  Heuristics: balance, power (``beta``), maximum, cutoff
    (``alpha``) or a callable ``q -> w`` with q_k = c_k p_k.  Distributions may be
    technique names of the integrand (``["bsdf", "light"]``).
    """

    def __init__(self, distributions: Sequence, probabilities: Sequence[float] | None = None,
                 heuristic: str | Callable = "balance", *, beta: float = 2.0, alpha: float = 0.1,
                 probe: bool = True):
        from ..distributions import Mixture

        self.distributions = _check_distributions(distributions)
        self.probabilities = _check_fractions(probabilities, len(self.distributions), "probabilities")
        if heuristic == "optimal":
            raise ValueError("heuristic: 'optimal' needs the multi-sample estimator (MIS); allowed here: "
                             f"{', '.join(HEURISTICS[:4])} or a callable q -> w")
        _check_heuristic(heuristic, HEURISTICS[:4])
        self.heuristic = heuristic
        self.beta, self.alpha = _check_beta_alpha(beta, alpha)
        self.probe = checks.flag(probe, "probe")
        named = any(isinstance(d, str) for d in self.distributions)
        self._mixture = None if named else Mixture(self.distributions, self.probabilities)

    def mixture(self, integrand=None):
        """The sampling mixture sum_k c_k p_k (techniques resolved for ``integrand``)."""
        if self._mixture is not None:
            return self._mixture
        from ..distributions import Mixture

        return Mixture(resolve_all(self.distributions, integrand), self.probabilities)

    def traced_per_unit(self) -> int:
        """One direction per unit, weighed by every technique with a non-zero probability: the
        renderer evaluates (traces) it once per such technique."""
        return int(np.count_nonzero(self.probabilities))

    @property
    def label(self) -> str:
        name = self.heuristic if isinstance(self.heuristic, str) else getattr(self.heuristic, "__name__", "custom")
        return f"OneSampleMIS[{name}]"

    def check(self, integrand) -> None:
        dists = resolve_all(self.distributions, integrand)
        _check_dims(dists, integrand)
        active = [d for d, c in zip(dists, self.probabilities) if c > 0]
        check_atoms(integrand, active, [f"distributions[{i}]" for i, c in enumerate(self.probabilities) if c > 0],
                    self.label)
        if self.probe and integrand.dim <= 3:
            support_probe(integrand, active, label=f"{self.label} (techniques with probability > 0)")

    def dim_u(self, integrand=None) -> int:
        return int(self.mixture(integrand).dim_u)

    def unit_values(self, integrand, u):
        mix = self.mixture(integrand)
        x = mix.sample(u)
        P = _stack_pdfs(mix.components, x)
        c = mix.probabilities
        f = integrand(x)
        if self.heuristic == "balance":  # f / (sum_k c_k p_k), exactly as MonteCarlo(Mixture)
            return ratio(f, P @ c)
        k, _ = mix.choose(np.asarray(u, float)[..., 0])
        shape = np.broadcast_shapes(P.shape[:-1], k.shape)
        P = np.broadcast_to(P, shape + P.shape[-1:])
        k = np.broadcast_to(k, shape)[..., None]
        w = mis_weights(P * c, self.heuristic, beta=self.beta, alpha=self.alpha)
        w_k = np.take_along_axis(np.broadcast_to(w, P.shape), k, -1)[..., 0]
        cp_k = np.take_along_axis(P * c, k, -1)[..., 0]
        return ratio(w_k, cp_k) * f
