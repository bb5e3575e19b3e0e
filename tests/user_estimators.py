"""A user's own MIS heuristic and estimator, in an importable module (not a test file), so
worker processes started with the spawn method can unpickle them (tests/test_render_estimators.py)."""
from __future__ import annotations

import numpy as np

from vrlab.estimators import Estimator


def balance(q: np.ndarray) -> np.ndarray:
    """Veach's balance heuristic written by hand: w_k = q_k / sum_i q_i (0 where all q are 0)."""
    total = q.sum(-1, keepdims=True)
    return np.divide(q, total, out=np.zeros_like(q), where=total > 0)


def doubled(q: np.ndarray) -> np.ndarray:
    """A wrong heuristic: balance weights that sum to 2."""
    return 2.0 * balance(q)


class LightBSDFMIS(Estimator):
    """A user's estimator through the documented hook (``dim_u`` + ``unit_values``): one light and
    one BSDF sample per unit, balance heuristic, F = sum_i f(X_i) / (p_l(X_i) + p_b(X_i)).
    ``weight_scale`` != 1 is a deliberate mistake (the weights then sum to it)."""

    evals_per_unit = 2

    def __init__(self, weight_scale: float = 1.0):
        self.weight_scale = weight_scale

    def dim_u(self, integrand) -> int:
        return integrand.technique("light").dim_u + integrand.technique("bsdf").dim_u

    def unit_values(self, integrand, u):
        light, bsdf = integrand.technique("light"), integrand.technique("bsdf")
        total = 0.0
        for tech, cols in ((light, u[..., :3]), (bsdf, u[..., 3:])):
            x = tech.sample(cols)
            q = light.pdf(x) + bsdf.pdf(x)
            f = integrand(x)
            total = total + self.weight_scale * np.divide(f, q, out=np.zeros(np.broadcast_shapes(f.shape, q.shape)),
                                                          where=q > 0)
        return total
