"""Importance sampling: F = (1/N) sum f(X_i) / p(X_i), X_i ~ p (Russian lecture 4; Veach 1997, 2.5).

Unbiased whenever p > 0 wherever f != 0; Var[F] = (int f^2/p - I^2) / N, zero for
p* = |f| / int |f| when f has one sign (which needs the answer, I, to normalise).
"""
from __future__ import annotations

import numpy as np

from .. import checks
from .base import Estimator, ratio, resolve_distribution, support_probe


class MonteCarlo(Estimator):
    """Importance sampling with any distribution (``None``: uniform on the domain).

    Works batched: a distribution may broadcast over leading axes (per-pixel frames)
    and the integrand may return ``(*batch, n)``.
    """

    def __init__(self, distribution=None, *, probe: bool = True):
        self.distribution = None if distribution is None else checks.distribution(distribution)
        self.probe = checks.flag(probe, "probe")

    @property
    def label(self) -> str:
        return "MonteCarlo" if self.distribution is None else f"MonteCarlo[{type(self.distribution).__name__}]"

    def check(self, integrand) -> None:
        dist = resolve_distribution(self.distribution, integrand)
        if self.probe and self.distribution is not None and integrand.dim <= 3:
            support_probe(integrand, [dist], label=repr(dist))

    def dim_u(self, integrand) -> int:
        return int(resolve_distribution(self.distribution, integrand).dim_u)

    def unit_values(self, integrand, u):
        dist = resolve_distribution(self.distribution, integrand)
        x = dist.sample(u)
        p = np.asarray(dist.pdf(x), dtype=float)
        f = integrand(x)
        return ratio(f, p)
