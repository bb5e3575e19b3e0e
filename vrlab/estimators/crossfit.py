"""Cross-fitted regression: coefficients fitted on units independent of those they weight.

A control-variate (regression) estimate mean(Y) - a.(mean(H) - theta) whose coefficients a
are fitted by least squares on the *same* units is biased by O(1/n), because the fitted a
is correlated with mean(H).  At the sample counts a renderer uses per pixel (4-64) that
bias is not small: per-pixel optimal MIS fitted this way darkened unlit pixels of the
Cornell box to 5 % of their value at 4 spp.

Cross-fitting (the splitting scheme of Avramidis & Wilson 1993, "A splitting scheme for
control variates", Oper. Res. Lett. 14; the cross-fitting of Chernozhukov et al. 2018,
"Double/debiased machine learning", Econometrics J. 21) removes it.  The units are split
into F folds by a rule that looks at unit counts only, never at values (unit j of a block
goes to the fold with the fewest units so far, round robin), and fold f's units are weighted
by a_{-f}, the least-squares fit on the *other* folds:

    I = sum_f (n_f / n) [mean_f(Y) - a_{-f} . mean_f(H - theta)].

a_{-f} is independent of fold f's units and E[H - theta] = 0, so each bracket has
expectation E[Y] = I: the estimate is unbiased at every n.  A fit needs enough units for
its slope to have a finite variance: with k controls and n_fit units the least-squares
slope has tails P(|a| > t) ~ t^-(n_fit - k) (its denominator, a sum of n_fit - 1 squared
deviations, is near 0 with probability ~ eps^((n_fit - k)/2)), so a_{-f} is fitted only
from n_{-f} >= k + 3 units and is 0 otherwise (the plain mean: still unbiased).

The variance reported is that of the residuals r_i = Y_i - a_{-f(i)} . (H_i - theta) over
all units (ddof 1, divided by n), the usual cross-fitting standard error; the folds'
correlation through the fitted coefficients is O(1/n^2).

An optional last column E (the renderer's directly seen light, see
:meth:`vrlab.estimators.MIS.add_emitted`) is added to every residual and kept out of the
fit.  :class:`FoldedCoMoments` is the mergeable statistics object (checkpoints, tiles).
"""
from __future__ import annotations

import numpy as np

from .regression import CoMoments

__all__ = ["FOLDS", "FoldedCoMoments", "crossfit_estimate", "min_fit_units", "statistics_from_state"]

#: Folds of a cross-fitted regression: each fold's coefficients come from 3/4 of the units.
FOLDS = 4


def min_fit_units(k: int) -> int:
    """Units a fit of ``k`` coefficients needs for a slope of finite variance (``k + 3``)."""
    return int(k) + 3


class FoldedCoMoments:
    """:class:`CoMoments` of the columns, kept per fold (``folds``: a list of ``FOLDS``).

    ``add(values (*batch, m, p))`` deals the m units round robin, starting at the fold with
    the fewest units (ties: the lowest index); ``merge`` joins the other statistics' folds
    largest-first to these smallest-first.  Both rules read counts only, so which fold a
    unit lands in never depends on its values (the condition for unbiasedness), the folds
    stay within a unit or so of each other in size, and equal inputs merged in equal order
    give equal results (any worker count, any checkpoint)."""

    def __init__(self, folds: int = FOLDS) -> None:
        self.folds = [CoMoments() for _ in range(int(folds))]

    @property
    def count(self) -> int:
        return sum(f.count for f in self.folds)

    @property
    def mean(self) -> np.ndarray:
        """The mean vector over all units (as :attr:`CoMoments.mean`)."""
        return self.pooled().mean

    def _order(self) -> list[int]:
        return sorted(range(len(self.folds)), key=lambda i: (self.folds[i].count, i))

    def add(self, values: np.ndarray) -> "FoldedCoMoments":
        values = np.asarray(values)
        order = self._order()
        for j, fold in enumerate(order):
            part = values[..., j::len(order), :]
            if part.shape[-2]:
                self.folds[fold].merge(CoMoments().add(part))
        return self

    def merge(self, other: "FoldedCoMoments") -> "FoldedCoMoments":
        """Fold the statistics of another, disjoint set of units into these."""
        if len(other.folds) != len(self.folds):
            raise ValueError(f"other: {len(other.folds)} folds, these have {len(self.folds)}")
        theirs = sorted(range(len(other.folds)), key=lambda i: (-other.folds[i].count, i))
        for mine, their in zip(self._order(), theirs):
            self.folds[mine].merge(other.folds[their])
        return self

    def pooled(self, skip: int | None = None) -> CoMoments:
        """The co-moments of every fold but ``skip`` (a new object)."""
        out = CoMoments()
        for i, f in enumerate(self.folds):
            if i != skip and f.count:
                out.merge(_copy(f))
        return out

    # -- the statistics protocol (checkpoints, tiles), as ``CoMoments`` --------------------
    def state(self) -> dict:
        """``{"kind", "count", "mean", "comoment"}``: per-fold counts ``(F,)``, means
        ``(F, *batch, p)`` and co-moments ``(F, *batch, p, p)`` (zeros for an empty fold)."""
        like = next(f for f in self.folds if f.count)
        return {"kind": type(self).__name__, "count": np.array([f.count for f in self.folds]),
                "mean": np.stack([f.mean if f.count else np.zeros_like(like.mean) for f in self.folds]),
                "comoment": np.stack([f.comoment if f.count else np.zeros_like(like.comoment) for f in self.folds])}

    @classmethod
    def from_state(cls, state: dict) -> "FoldedCoMoments":
        """The statistics of :meth:`state`'s dict (``ValueError`` naming ``state`` if it is not one)."""
        try:
            counts = np.asarray(state["count"]).astype(int)
            means = np.asarray(state["mean"], dtype=float)
            coms = np.asarray(state["comoment"], dtype=float)
            if counts.ndim != 1 or len(means) != len(counts) or len(coms) != len(counts):
                raise ValueError("per-fold arrays of different lengths")
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"state: not the state of a {cls.__name__} ({exc!r})") from None
        out = cls(len(counts))
        for f, c, m, C in zip(out.folds, counts, means, coms):
            if c:
                f.count, f.mean, f.comoment = int(c), m, C
        return out

    @classmethod
    def concat(cls, parts: list, axis: int = 0) -> "FoldedCoMoments":
        """Statistics of disjoint batch elements with the same units joined along batch ``axis``."""
        parts = list(parts)
        if len(parts) == 1:
            return parts[0]
        if len({tuple(f.count for f in p.folds) for p in parts}) != 1:
            raise ValueError("parts: concat joins batch elements with the same units per fold")
        out = cls(len(parts[0].folds))
        for i, fold in enumerate(out.folds):
            if parts[0].folds[i].count:
                out.folds[i] = CoMoments.concat([p.folds[i] for p in parts], axis=axis)
        return out


def _copy(stats: CoMoments) -> CoMoments:
    out = CoMoments()
    out.count, out.mean, out.comoment = stats.count, stats.mean, stats.comoment
    return out


def _fit(stats: CoMoments, k: int, shape: tuple, ridge=0.0) -> np.ndarray:
    """Least-squares coefficients of column 0 on columns 1..k, ``(*batch, k)``: 0 with fewer
    than :func:`min_fit_units` units (pseudo-inverse: a constant control gets 0)."""
    if stats.count < min_fit_units(k):
        return np.zeros(shape + (k,))
    C = stats.comoment
    shh, shy = C[..., 1:k + 1, 1:k + 1] + np.diag(np.broadcast_to(np.asarray(ridge, float), (k,))), C[..., 1:k + 1, 0]
    inv = np.linalg.pinv(shh, rcond=1e-12, hermitian=True)
    return np.broadcast_to((inv @ shy[..., None])[..., 0], shape + (k,))


def crossfit_estimate(stats: FoldedCoMoments, k: int, theta=0.0, ridge=0.0) -> dict:
    """The cross-fitted estimate of columns (Y, H_1..H_k[, E]) (module docstring).

    ``theta``: the controls' known means (broadcastable to ``(*batch, k)``).  Returns
    ``value``, ``stderr``, per-unit residual ``variance``, ``alpha`` (the folds' coefficients
    averaged with weights n_f / n), ``plain_variance`` (of Y [+ E]) and ``variance_factor``
    (residual / plain)."""
    n = stats.count
    full = stats.pooled()
    p = full.mean.shape[-1]
    shape = full.mean.shape[:-1]
    one = np.ones(shape + (1,))
    tail = [one] if p == k + 2 else []                  # the emitted column E: weight 1, not fitted
    folds, means, betas = [], [], []
    for i, fold in enumerate(stats.folds):
        if not fold.count:
            continue
        b = np.concatenate([one, -_fit(stats.pooled(skip=i), k, shape, ridge)] + tail, -1)   # r = b . (Y, H, E)
        d = fold.mean.copy()
        d[..., 1:k + 1] -= theta
        folds.append(fold)
        means.append(np.sum(b * d, -1))
        betas.append(b)
    w = np.array([f.count for f in folds], dtype=float) / n
    value = sum(wi * m for wi, m in zip(w, means))
    # residual sum of squares over all units: within the folds + between their residual means
    rss = 0.0
    for fold, m, b in zip(folds, means, betas):
        rss = rss + np.einsum("...i,...ij,...j->...", b, fold.comoment, b) + fold.count * (m - value) ** 2
    s2 = np.maximum(rss, 0.0) / (n - 1) if n > 1 else np.full(np.shape(value), np.nan)   # one unit: unknown
    plain_b = np.zeros(p)
    plain_b[0] = 1.0
    plain_b[k + 1:] = 1.0
    plain = np.einsum("i,...ij,j->...", plain_b, full.comoment, plain_b) / max(n - 1, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = np.where(plain > 0, s2 / plain, 1.0)
    alpha = -sum(wi * b[..., 1:k + 1] for wi, b in zip(w, betas))
    return {"value": value, "stderr": np.sqrt(s2 / n), "variance": s2, "alpha": alpha,
            "plain_variance": plain, "variance_factor": factor}


def statistics_from_state(state: dict, otherwise):
    """:class:`FoldedCoMoments` of a saved ``state()``, else ``otherwise(state)``.  The
    same-unit co-moments an older vrlab saved for fitted estimators are refused (their fit
    was biased, and they cannot be split into folds), naming ``state``."""
    kind = state.get("kind")
    if kind == FoldedCoMoments.__name__:
        return FoldedCoMoments.from_state(state)
    if kind == CoMoments.__name__:
        raise ValueError("state: co-moments without folds, saved by an older vrlab whose fitted coefficients were "
                         "biased; start this render afresh")
    return otherwise(state)
