"""Importance sampling: F = (1/N) sum f(X_i) / p(X_i), X_i ~ p (Russian lecture 4; Veach 1997, 2.5).

Unbiased whenever p > 0 wherever f != 0; Var[F] = (int f^2/p - I^2) / N, zero for
p* = |f| / int |f| when f has one sign (which needs the answer, I, to normalise).
"""
from __future__ import annotations

import numpy as np

from .. import checks
from ..distributions.base import checked_pdf
from .atoms import check_atoms
from .base import Estimator, check_technique, ratio, resolve_distribution, support_probe, technique_label


class MonteCarlo(Estimator):
    """Importance sampling with any distribution (``None``: uniform on the domain; a name:
    the integrand's technique of that name, e.g. the renderer's ``"light"``).

    Works batched: a distribution may broadcast over leading axes (per-pixel frames)
    and the integrand may return ``(*batch, n)``.
    """

    def __init__(self, distribution=None, *, probe: bool = True):
        self.distribution = None if distribution is None else check_technique(distribution)
        self.probe = checks.flag(probe, "probe")

    @property
    def label(self) -> str:
        return "MonteCarlo" if self.distribution is None else f"MonteCarlo[{technique_label(self.distribution)}]"

    def check(self, integrand) -> None:
        dist = resolve_distribution(self.distribution, integrand)
        check_atoms(integrand, [dist], ["distribution"], self.label)
        if self.probe and self.distribution is not None and integrand.dim <= 3:
            support_probe(integrand, [dist], label=repr(dist))

    def dim_u(self, integrand) -> int:
        return int(resolve_distribution(self.distribution, integrand).dim_u)

    def unit_values(self, integrand, u):
        dist = resolve_distribution(self.distribution, integrand)
        x = dist.sample(u)
        p = checked_pdf(dist, x)      # float32 densities (the renderer's) stay float32
        if p.dtype != np.float32 and p.size >= 64 and not p.any():
            raise ValueError(f"distribution: {technique_label(self.distribution or dist)}'s pdf is 0 at all "
                             f"{p.size} of its own samples: its pdf does not describe its sample method")
        f = integrand(x)
        return ratio(f, p)
