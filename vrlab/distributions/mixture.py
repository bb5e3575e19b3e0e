"""A mixture of distributions: p(x) = sum_k c_k p_k(x).

One uniform picks the component by its CDF and is then rescaled to [0, 1) and
reused (u0' = (u0 - C_{k-1}) / c_k), so the mixture consumes
``max(dim_u of the components)`` uniforms and stratification carries over.
This is the one-sample "mixture" estimator's density of the Russian lecture 4,
p(w) = 1/2 p_cos(w) + 1/(2N) sum_i p_i(w), and of defensive importance sampling
(Hesterberg 1995).  All components are evaluated for every sample and the chosen
one kept with a select: that keeps broadcasting (batched frames) intact and costs
the same order as ``pdf``, which needs every component anyway.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .base import Distribution, as_uniforms, checked_pdf, distribution_list
from .tabulated import check_weights


class Mixture(Distribution):
    """Mixture of ``components`` chosen with ``probabilities`` (default equal).

    Checked: ``components`` is a non-empty list of distributions (``TypeError``
    otherwise) with one point dimension and one measure; ``probabilities`` has one
    finite value >= 0 per component, not all zero (they are normalised).
    """

    def __init__(self, components: Sequence, probabilities: Sequence[float] | None = None):
        self.components = distribution_list(components)
        k = len(self.components)
        probs = np.full(k, 1.0 / k) if probabilities is None else check_weights(probabilities, "probabilities", 1)
        if len(probs) != k:
            raise ValueError(f"probabilities: expected {k} values, got {len(probs)}")
        self.probabilities = probs / probs.sum()
        self.cdf = np.concatenate([[0.0], np.cumsum(self.probabilities)])
        self.cdf[-1] = 1.0
        self.dim_u = max(int(c.dim_u) for c in self.components)
        dims = {getattr(c, "dim_x", None) for c in self.components} - {None}
        if len(dims) > 1:
            raise ValueError(f"components: points of different dimensions {sorted(dims)}")
        self.dim_x = dims.pop() if dims else None
        measures = {getattr(c, "measure", None) for c in self.components} - {None}
        if len(measures) > 1:
            raise ValueError(f"components: densities in different measures {sorted(measures)}")
        self.measure = measures.pop() if measures else "unknown"

    def choose(self, u0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Component index for each uniform and the rescaled leftover uniform."""
        k = np.clip(np.searchsorted(self.cdf, u0, side="right") - 1, 0, len(self.components) - 1)
        lo, width = self.cdf[k], self.probabilities[k]
        return k, np.clip((u0 - lo) / np.where(width > 0, width, 1.0), 0.0, np.nextafter(1.0, 0.0))

    def sample(self, u):
        u = as_uniforms(u, self.dim_u)
        k, u0 = self.choose(u[..., 0])
        u = np.concatenate([u0[..., None], u[..., 1:]], -1)
        out = None
        for i, c in enumerate(self.components):
            if self.probabilities[i] == 0:
                continue
            x = np.asarray(c.sample(u[..., : c.dim_u]))
            sel = (k == i)[..., None] if x.ndim > k.ndim else (k == i)
            out = np.where(sel, x, 0.0 if out is None else out)
        return out

    def component_pdfs(self, x) -> np.ndarray:
        """p_k(x) for every component, stacked on a last axis of size K."""
        return np.stack([checked_pdf(c, x, f"components[{k}]") for k, c in enumerate(self.components)], -1)

    def pdf(self, x):
        return self.component_pdfs(x) @ self.probabilities

    def _repr_fields(self):
        return {"components": self.components, "probabilities": self.probabilities.round(6).tolist()}
