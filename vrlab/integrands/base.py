"""``Integrand``: a vectorised f, its domain, and what is known about it in closed form.

``f`` receives points of shape ``(..., k)`` and returns ``(...)`` (or ``(*batch, ...)``
for a batched integral, e.g. one integral per pixel).  ``domain`` is a box
``[(a1, b1), ..., (ak, bk)]`` or one of the named domains ``"sphere"``,
``"hemisphere"`` (unit directions, solid angle) and ``"disk"`` (unit disk, area).
``exact`` is the integral; ``f2`` the integral of f^2 over the domain, which gives the
variance of plain uniform sampling, Var[f(X) / p] = |domain| * f2 - exact^2.
"""
from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..distributions import Disk, UniformBox, UniformHemisphere, UniformSphere
from ..distributions.interval import as_bounds

NAMED_DOMAINS = {
    "sphere": (3, 4 * np.pi, UniformSphere),
    "hemisphere": (3, 2 * np.pi, UniformHemisphere),
    "disk": (2, np.pi, Disk),
}


class Integrand:
    """A vectorised integrand over a domain, with optional closed forms.

    Parameters: ``f`` (callable, (..., k) -> (...)), ``domain`` (box or named),
    ``exact`` (the integral, scalar or batch-shaped), ``name``, ``f2`` (integral of
    f^2), ``theory`` (extra closed forms, e.g. golden variances, by key) and
    ``techniques`` (named distributions suited to this integrand, used by MIS
    examples and the lab).
    """

    def __init__(self, f: Callable[[np.ndarray], np.ndarray], domain: Any, exact: Any = None,
                 name: str | None = None, *, f2: float | None = None, theory: dict | None = None,
                 techniques: dict | None = None):
        if not callable(f):
            raise TypeError(f"f must be callable, got {type(f).__name__}")
        self.f = f
        if isinstance(domain, str):
            if domain not in NAMED_DOMAINS:
                raise ValueError(f"domain: unknown name {domain!r}; use a box [(a, b), ...] or one of "
                                 f"{sorted(NAMED_DOMAINS)}")
            self.dim, self.volume, _ = NAMED_DOMAINS[domain]
            self.bounds = None
        else:
            self.bounds = as_bounds(domain, "domain")
            self.dim = len(self.bounds)
            self.volume = float(np.prod(self.bounds[:, 1] - self.bounds[:, 0]))
        self.domain = domain
        self.exact = None if exact is None else (float(exact) if np.ndim(exact) == 0 else np.asarray(exact, float))
        self.name = name or getattr(f, "__name__", "f")
        self.f2 = f2
        self.theory = dict(theory or {})
        self.techniques = dict(techniques or {})

    def __call__(self, x: np.ndarray) -> np.ndarray:
        return np.asarray(self.f(x), dtype=float)

    def uniform(self):
        """The uniform distribution on the domain (the default importance sampler)."""
        if self.bounds is None:
            return NAMED_DOMAINS[self.domain][2]()
        return UniformBox(self.bounds)

    @property
    def uniform_variance(self) -> float | None:
        """Var of one uniform-sampling term f(X)/p = |D| f(X): |D| * f2 - exact^2 (closed form)."""
        if self.f2 is None or self.exact is None or np.ndim(self.exact) != 0:
            return None
        return self.volume * self.f2 - self.exact**2

    def __repr__(self) -> str:
        return f"Integrand({self.name!r}, domain={self.domain!r}, exact={self.exact!r})"
