"""Running co-moments of several columns and the regression (control-variate) estimate.

``CoMoments`` keeps the count, the mean vector and the co-moment matrix of ``p`` columns,
batched, merged by the matrix form of Chan, Golub & LeVeque (1979).  ``regression_estimate``
turns the co-moments of (Y, H_1 - theta_1, ..., H_K - theta_K) into the control-variate
estimate with fitted or fixed coefficients (Owen, *Monte Carlo theory, methods and
examples*, ch. 8): see :mod:`vrlab.estimators.control`.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..estimate import check_merged, check_spread

__all__ = ["CoMoments", "regression_estimate"]


class CoMoments:
    """Running count, mean vector and co-moment matrix of ``p`` columns (batched).

    ``add(values)`` takes ``values (*batch, m, p)``; blocks merge with the matrix form
    of Chan, Golub & LeVeque (1979): C = C_a + C_b + delta delta^T n_a n_b / n.
    ``covariance`` is the unbiased (ddof = 1) covariance matrix ``(*batch, p, p)``.
    """

    def __init__(self) -> None:
        self.count = 0
        self.mean: np.ndarray | None = None
        self.comoment: np.ndarray | None = None

    def add(self, values: np.ndarray) -> "CoMoments":
        single = getattr(values, "dtype", None) == np.float32
        v = np.asarray(values, dtype=float)
        m = v.shape[-2]
        if m == 0:
            return self
        with np.errstate(over="ignore", under="ignore", invalid="ignore"):
            mean_b = v.mean(axis=-2)
            dev = v - mean_b[..., None, :]
            com_b = np.swapaxes(dev, -1, -2) @ dev
        if not single:      # float32 samples' squares cannot leave float64's range
            check_spread(v, -2, mean_b, np.diagonal(com_b, 0, -2, -1))
        return self._fold(m, mean_b, com_b)

    def merge(self, other: "CoMoments") -> "CoMoments":
        """Fold the co-moments of another, disjoint set of units into these (Chan et al.)."""
        if other.count == 0:
            return self
        return self._fold(other.count, other.mean, other.comoment)

    def _fold(self, m: int, mean_b: np.ndarray, com_b: np.ndarray) -> "CoMoments":
        if self.count == 0:
            self.count, self.mean, self.comoment = m, mean_b, com_b
            return self
        n = self.count + m
        delta = mean_b - self.mean
        with np.errstate(over="ignore", under="ignore", invalid="ignore"):
            com = self.comoment + com_b + (delta[..., :, None] * delta[..., None, :]) * (self.count * m / n)
        check_merged(np.diagonal(com, 0, -2, -1), (self.comoment, com_b), delta, n)
        self.comoment = com
        self.mean = self.mean + delta * (m / n)
        self.count = n
        return self

    # -- the statistics protocol (checkpoints, tiles), as ``vrlab.estimate.Moments`` ----------
    def state(self) -> dict:
        """``{"kind", "count", "mean", "comoment"}`` as plain arrays (see :meth:`from_state`)."""
        return {"kind": type(self).__name__, "count": np.asarray(self.count),
                "mean": np.asarray(self.mean), "comoment": np.asarray(self.comoment)}

    @classmethod
    def from_state(cls, state: dict) -> "CoMoments":
        """The accumulator of :meth:`state`'s dict (``ValueError`` naming ``state`` if it is not one)."""
        out = cls()
        try:
            out.count = int(np.asarray(state["count"]))
            out.mean = np.asarray(state["mean"], dtype=float)
            out.comoment = np.asarray(state["comoment"], dtype=float)
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"state: not the state of a {cls.__name__} ({exc!r})") from None
        return out

    @classmethod
    def concat(cls, parts: list, axis: int = 0) -> "CoMoments":
        """Co-moments of disjoint batch elements with the same units joined along batch ``axis``."""
        parts = list(parts)
        if len(parts) == 1:
            return parts[0]
        if len({p.count for p in parts}) != 1:
            raise ValueError("parts: concat joins batch elements with the same number of units")
        out = cls()
        out.count = parts[0].count
        out.mean = np.concatenate([p.mean for p in parts], axis=axis)
        out.comoment = np.concatenate([p.comoment for p in parts], axis=axis)
        return out

    def second(self) -> np.ndarray:
        """Sum over units of v v^T (uncentred)."""
        return self.comoment + self.count * self.mean[..., :, None] * self.mean[..., None, :]

    @property
    def covariance(self) -> np.ndarray:
        if self.count < 2:
            return np.full(np.shape(self.comoment), np.nan)
        return self.comoment / (self.count - 1)


def regression_estimate(mom: CoMoments, theta: np.ndarray, alpha: Any = "optimal") -> dict:
    """Control-variate estimate from co-moments of columns ``(Y, H_1..H_K)``.

    ``theta`` (broadcastable to ``(*batch, K)``): the controls' known means;
    ``alpha``: ``"optimal"`` (least squares) or fixed coefficients broadcastable to
    ``(*batch, K)``.  Returns value, stderr, per-unit residual variance, alpha,
    plain variance of Y and the variance factor (residual / plain).
    """
    n = mom.count
    mu, C = mom.mean, mom.comoment
    K = mu.shape[-1] - 1
    mu_y, syy = mu[..., 0], C[..., 0, 0]
    if K == 0:
        a = np.zeros(mu.shape[:-1] + (0,))
        rss, dof, extra_var = syy, n - 1, 0.0
        value = mu_y
    else:
        shh, shy = C[..., 1:, 1:], C[..., 1:, 0]
        d = mu[..., 1:] - np.broadcast_to(theta, mu[..., 1:].shape)
        if isinstance(alpha, str):
            # pinv: a constant control or an all-zero batch element gives alpha = 0, no NaN
            inv = np.linalg.pinv(shh, rcond=1e-12, hermitian=True)
            a = (inv @ shy[..., None])[..., 0]
            rss = np.maximum(syy - np.sum(a * shy, -1), 0.0)
            dof = n - 1 - K
            extra_var = np.einsum("...i,...ij,...j->...", d, inv, d)  # O(1/n) intercept term
        else:
            try:
                a = np.broadcast_to(np.asarray(alpha, float), mu[..., 1:].shape)
            except ValueError:
                raise ValueError(f"alpha: shape {np.shape(alpha)} does not broadcast to the estimate's "
                                 f"(*batch, K) = {mu[..., 1:].shape}") from None
            rss = np.maximum(syy - 2 * np.sum(a * shy, -1) + np.einsum("...i,...ij,...j->...", a, shh, a), 0.0)
            dof, extra_var = n - 1, 0.0
        value = mu_y - np.sum(a * d, -1)
    s2 = rss / dof
    plain = syy / (n - 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = np.where(plain > 0, s2 / plain, 1.0)
    stderr = np.sqrt(s2 * (1.0 / n + extra_var))
    return {"value": value, "stderr": stderr, "variance": s2, "alpha": a, "plain_variance": plain,
            "variance_factor": factor}
