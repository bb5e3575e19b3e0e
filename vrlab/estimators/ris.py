"""Resampled importance sampling (Talbot, Cline & Egbert 2005, "Importance Resampling
for Global Illumination", EGSR; the RIS section of the CT5202 lecture notes).

For each output sample draw m candidates Y_1..Y_m ~ p (the ``source``, easy to
sample), give them resampling weights w_j = p̂(Y_j) / p(Y_j) with an unnormalised
``target`` p̂ (ideally close to |f|, e.g. the unshadowed contribution), select one,
Y = Y_J, with probability w_J / sum_j w_j, and use

    F = f(Y) W,   W = (1 / p̂(Y)) (1/m) sum_j w_j   (the "unbiased contribution weight").

Unbiased when p > 0 wherever p̂ > 0 and p̂ > 0 wherever f != 0.  As m grows Y is
distributed more and more like p̂ / int p̂; with m = 1 it is plain IS from p.
If p̂ = k f exactly (f > 0), F = (1/m) sum_j f(Y_j) / p(Y_j): IS with m samples,
Var = Var_p[f/p] / m per output sample.

Selection uses weighted reservoir sampling (Chao 1982), the streaming form ReSTIR
builds on (Bitterli et al. 2020): a ``Reservoir`` keeps one sample, the running sum
of weights and the number of candidates seen; candidate j replaces the kept sample
with probability w_j / (w_sum after adding w_j), one uniform per candidate, so the
result is a deterministic function of the uniforms.  Two reservoirs over disjoint
candidate sets merge into one over the union (``Reservoir.merge``).

Kernels: where the integrand carries ``kernels = "numba"`` (a render whose plan resolved the
compiled kernels, :mod:`vrlab.kernels`) the streaming runs as one compiled loop per
reservoir (:mod:`vrlab.estimators.restir_kernel`), the same additions and comparisons in
the same order as the NumPy code here, which stays the oracle.

Cost convention: ``n`` counts evaluations of f, one per output sample.  The m
candidate evaluations of p̂ (and draws/pdfs of p) per output sample are counted
separately in ``Estimate.extra["target_evals"]`` (= n m), so comparisons at total
cost can add them with their own price.
"""
from __future__ import annotations

from typing import Any, Callable

import numpy as np

from .. import checks
from .._rng import RNGLike
from ..distributions.base import checked_pdf, checked_sample
from ..estimate import Estimate
from ..integrands.base import checked_values
from ..kernels import load_kernel
from .atoms import check_atoms
from .base import DEFAULT_CHUNK, Estimator, check_chunk, check_technique, ratio, resolve_distribution, support_probe


#: the compiled helpers of reservoir streaming and reuse (loaded when kernels are "numba")
KERNEL_MODULE = "vrlab.estimators.restir_kernel"


def kernels_of(integrand) -> str:
    """The kernels an estimator runs on ``integrand``: its ``kernels`` attribute (a renderer's
    integrand carries the render plan's resolved choice, which loaded the compiled helpers
    before any worker started), "numpy" where it has none (the lab's integrands)."""
    kernels = getattr(integrand, "kernels", "numpy")
    return "numba" if isinstance(kernels, str) and kernels == "numba" else "numpy"


def as_kernel_array(a, dtype=np.float64) -> np.ndarray:
    """``a`` as a C-contiguous, writeable array of ``dtype`` (a copy only where needed): the
    layout the compiled helpers' ``SIGNATURES`` name (a read-only view, e.g. from
    ``np.broadcast_to``, would make numba compile another specialisation)."""
    a = np.ascontiguousarray(a, dtype=dtype)
    return a if a.flags.writeable else a.copy()


class Reservoir:
    """A batch of weighted reservoirs (one per leading index).

    ``y`` (*shape, k): kept sample; ``w_sum`` (*shape): sum of the resampling weights
    seen; ``M`` (*shape): number of candidates seen; ``target`` (*shape): p̂(y).
    Methods return new reservoirs (the arrays are not modified).
    """

    def __init__(self, y: np.ndarray, w_sum: np.ndarray, M: np.ndarray, target: np.ndarray):
        self.y = np.asarray(y, dtype=float)
        self.w_sum = np.asarray(w_sum, dtype=float)
        self.M = np.asarray(M, dtype=float)
        self.target = np.asarray(target, dtype=float)

    @classmethod
    def empty(cls, shape: tuple = (), dim_x: int = 1) -> "Reservoir":
        """Reservoirs that have seen nothing (W = 0)."""
        shape = tuple(int(s) for s in shape) if isinstance(shape, (tuple, list)) else (int(shape),)
        return cls(np.zeros(shape + (dim_x,)), np.zeros(shape), np.zeros(shape), np.zeros(shape))

    @property
    def shape(self) -> tuple:
        return self.w_sum.shape

    @property
    def W(self) -> np.ndarray:
        """Unbiased contribution weight w_sum / (M p̂(y)) (0 for an empty reservoir)."""
        return ratio(self.w_sum, self.M * self.target)

    def _stream(self, x, weights, u, target, count, kernels: str = "numpy") -> "Reservoir":
        """Process candidates (*s, m, k) with weights/uniforms/targets (*s, m) in order
        (``kernels="numba"``: the compiled loop, :func:`vrlab.estimators.restir_kernel.stream`)."""
        x, weights, u, target = (np.asarray(a, dtype=float) for a in (x, weights, u, target))
        if np.any(weights < 0) or np.any(np.isnan(weights)):
            raise ValueError("weights: resampling weights must be >= 0 and not NaN (check the target)")
        shape = np.broadcast_shapes(self.shape + (1,), weights.shape, u.shape, target.shape, x.shape[:-1])
        m = shape[-1]
        lead = shape[:-1]
        M = np.broadcast_to(self.M, lead) + np.sum(np.broadcast_to(count, shape), -1)
        if kernels == "numba":
            R, k = int(np.prod(lead, dtype=int)), x.shape[-1]

            def rows(a, tail=()):           # (R, m, *tail) contiguous float64 (a copy where broadcast)
                return as_kernel_array(np.broadcast_to(a, shape + tail)).reshape((R, m) + tail)

            y = np.array(np.broadcast_to(self.y, lead + (k,)), dtype=float).reshape(R, k)
            w_sum = np.array(np.broadcast_to(self.w_sum, lead), dtype=float).reshape(R)
            t = np.array(np.broadcast_to(self.target, lead), dtype=float).reshape(R)
            load_kernel(KERNEL_MODULE, "stream")(rows(x, (k,)), rows(weights), rows(u), rows(target), y, w_sum, t)
            return Reservoir(y.reshape(lead + (k,)), w_sum.reshape(lead), M, t.reshape(lead))
        # running sums in the sequential order: ((w_sum + w_1) + w_2) + ...
        w = np.broadcast_to(weights, shape)
        cum = np.cumsum(np.concatenate([np.broadcast_to(self.w_sum, lead)[..., None], w], -1), -1)[..., 1:]
        accept = np.broadcast_to(u, shape) * cum < w          # u_j < w_j / cum_j
        any_acc = accept.any(-1)
        last = (m - 1 - np.argmax(accept[..., ::-1], -1))[..., None]
        xb = np.broadcast_to(x, shape + x.shape[-1:])
        y_new = np.take_along_axis(xb, last[..., None], -2)[..., 0, :]
        t_new = np.take_along_axis(np.broadcast_to(target, shape), last, -1)[..., 0]
        y = np.where(any_acc[..., None], y_new, np.broadcast_to(self.y, lead + self.y.shape[-1:]))
        t = np.where(any_acc, t_new, np.broadcast_to(self.target, lead))
        return Reservoir(y, cum[..., -1], M, t)

    def update(self, x: np.ndarray, weights: np.ndarray, u: np.ndarray, target: np.ndarray, *,
               kernels: str = "numpy") -> "Reservoir":
        """Stream candidates ``x`` (*shape, m, k) with resampling weights, one uniform
        each and their target values p̂(x) (all (*shape, m)).  Candidate j is kept with
        probability w_j / (w_sum + w_1 + ... + w_j), replacing any earlier choice.
        ``kernels``: "numpy" (the oracle) or "numba" (a compiled loop, the same selections
        and sums; the caller resolves the switch, :mod:`vrlab.kernels`)."""
        return self._stream(x, weights, u, target, 1.0, checks.choice(kernels, "kernels", ("numpy", "numba")))

    def merge(self, other: "Reservoir", u: np.ndarray, target_at_other: np.ndarray | None = None
              ) -> "Reservoir":
        """Combine with ``other`` (disjoint candidates): keep other's sample with probability
        w_other / (w_sum + w_other), sum the weights and the counts M.

        ``w_other`` = other.w_sum (same target).  For reuse across different targets
        (ReSTIR), pass ``target_at_other`` = this reservoir's p̂ at other.y: then
        w_other = p̂(other.y) W_other M_other (Bitterli et al. 2020, Alg. 4, their biased
        combination unless the supports agree).
        """
        if target_at_other is None:
            w_other, t_other = other.w_sum, other.target
        else:
            t_other = np.asarray(target_at_other, dtype=float)
            w_other = t_other * other.W * other.M
        return self._stream(other.y[..., None, :], np.asarray(w_other)[..., None], np.asarray(u)[..., None],
                            np.asarray(t_other)[..., None], np.asarray(other.M)[..., None])


#: the target name meaning |f| of the integrand at hand (a recipe's RIS stays picklable)
ABS_TARGET = "|f|"


class _AbsValue:
    """p̂(x) = |f(x)| for an integrand f, summed over a batched integrand's batch axes (one
    target shared by every batch element, positive wherever one of them is not zero); a
    module-level class, picklable with its integrand."""

    def __init__(self, integrand):
        self.integrand = integrand

    def __call__(self, x):
        v = np.abs(self.integrand(x))
        extra = v.ndim - (np.ndim(x) - 1)
        return v.sum(axis=tuple(range(extra))) if extra > 0 else v


class RIS(Estimator):
    """Resampled importance sampling with ``m`` candidates from ``source`` per output sample,
    resampled towards the unnormalised ``target`` p̂ (callable, points (..., k) -> (...)).
    ``source`` may name one of the integrand's techniques and ``target`` one of its
    targets (:meth:`vrlab.Integrand.target`; the renderer's ``"unshadowed"``).

    Uniforms per output sample: ``dim_u = m (source.dim_u + 1)``: columns
    ``[j d, (j + 1) d)`` make candidate j (d = source.dim_u), the last m columns are the
    reservoir's selection uniforms.  Candidates travel on the sample axis while they are
    drawn, so a source or target that broadcasts over leading batch axes (per-pixel
    frames, ``(*batch, n, k)``) works unchanged.  ``chunk`` in ``estimate`` counts
    candidates: a block holds max(1, chunk // m) output samples.
    """

    evals_per_unit = 1
    #: the compiled helpers a render with kernels "numba" loads before its workers start
    kernel_module = KERNEL_MODULE

    def __init__(self, source, target: Callable[[np.ndarray], np.ndarray] | str, m: int, *, probe: bool = True):
        if not isinstance(source, str):
            for attr in ("dim_u", "sample", "pdf"):
                if not hasattr(source, attr):
                    raise TypeError(f"source: {source!r} has no {attr!r} (needs dim_u, sample, pdf)")
        check_technique(source, "source")
        if not (callable(target) or (isinstance(target, str) and target)):
            raise TypeError("target must be callable (points -> unnormalised density) or a target's name, "
                            f"got {type(target).__name__}")
        self.source = source
        self.target = target
        self.m = checks.integer(m, "m (candidates per sample)", low=1)
        self.probe = checks.flag(probe, "probe")

    @property
    def candidates_per_unit(self) -> int:  # type: ignore[override]
        """The m candidates of a unit: target evaluations that trace no ray."""
        return self.m

    @property
    def label(self) -> str:
        return f"RIS[m={self.m}]"

    def source_for(self, integrand=None):
        """The source distribution (a technique name resolved for ``integrand``)."""
        if isinstance(self.source, str):
            if integrand is None:
                raise ValueError("source: a technique name is resolved per integrand; pass the integrand")
            return resolve_distribution(self.source, integrand, "source")
        return self.source if integrand is None else resolve_distribution(self.source, integrand, "source")

    def target_for(self, integrand=None):
        """The target p̂ (a target name resolved for ``integrand``; ``"|f|"``, unless the
        integrand names a target so, is |f| itself: Talbot et al.'s ideal unshadowed target)."""
        if isinstance(self.target, str):
            if integrand is None:
                raise ValueError("target: a target name is resolved per integrand; pass the integrand")
            if self.target == ABS_TARGET and ABS_TARGET not in getattr(integrand, "targets", {}):
                return _AbsValue(integrand)
            return integrand.target(self.target, "target")
        return self.target

    def check(self, integrand) -> None:
        source = self.source_for(integrand)
        dx = getattr(source, "dim_x", None)
        if dx is not None and dx != integrand.dim:
            raise ValueError(f"source: points of dimension {dx}, but the integrand's domain has dimension "
                             f"{integrand.dim}")
        check_atoms(integrand, [source], ["source"], self.label)
        if integrand.atoms:
            t = np.asarray(self.target_for(integrand)(integrand.atom_points), dtype=float)
            bad = (integrand.atom_weights != 0) & ~np.all(t.reshape(-1, len(integrand.atom_weights)) > 0, 0)
            if bad.any():
                k = int(np.argmax(bad))
                raise ValueError(f"target: it is 0 at the atom x = {integrand.atom_points[k, 0]:g} of integrand "
                                 f"{integrand.name!r}, which has a point mass there: RIS never keeps that "
                                 "candidate and misses the atom (read on the mixed measure, a target's value "
                                 "at an atom is its weight there, as the integrand's)")
        if self.probe and integrand.dim <= 3:
            support_probe(integrand, [_Support(source, self.target_for(integrand))],
                          label=f"{self.label} (source pdf x target)")

    def dim_u(self, integrand=None) -> int:
        return self.m * (int(self.source_for(integrand).dim_u) + 1)

    def reservoirs(self, u: np.ndarray, integrand=None) -> Reservoir:
        """The reservoirs (*batch, n) after streaming the m candidates of each output sample
        from uniforms ``u`` (*batch, n, dim_u); ``integrand`` resolves named sources/targets."""
        u = np.asarray(u, dtype=float)
        source, target = self.source_for(integrand), self.target_for(integrand)
        m, d = self.m, int(source.dim_u)
        if u.ndim < 2 or u.shape[-1] != m * (d + 1):
            raise ValueError(f"u: expected shape (..., n, {m * (d + 1)}), got {u.shape}")
        lead, n = u.shape[:-2], u.shape[-2]
        cand = u[..., : m * d].reshape(lead + (n * m, d))      # candidates on the sample axis
        x = checked_sample(source, cand, "source")
        p = np.asarray(checked_pdf(source, x, "source"), dtype=float)
        t = checked_values(target(x), x, "target")
        if np.any(t < 0):
            raise ValueError("target: the unnormalised target density must be >= 0")
        w = ratio(t, p)

        def split(a, tail=()):  # (..., n m, *tail) -> (..., n, m, *tail)
            return a.reshape(a.shape[: a.ndim - 1 - len(tail)] + (n, m) + tail)

        xs = split(x, (x.shape[-1],))
        # nothing seen yet (W = 0); y starts at the first candidate, a point of the domain, so
        # that f can be evaluated at y even where every weight is 0 (e.g. a scene without lights)
        empty = Reservoir(xs[..., 0, :], 0.0, 0.0, 0.0)
        return empty.update(xs, split(w), u[..., m * d:], split(t), kernels=kernels_of(integrand))

    def unit_values(self, integrand, u):
        res = self.reservoirs(u, integrand)
        f = integrand(res.y)
        W = res.W
        return np.where(W > 0, f * W, 0.0)

    def estimate(self, integrand, n: int, *, rng: RNGLike = None, points: Any = None,
                 chunk: int = DEFAULT_CHUNK) -> Estimate:
        """As ``Estimator.estimate`` (n output samples = n evaluations of f); also reports
        ``extra["target_evals"]`` = n m and ``extra["candidates"]`` = m."""
        est = super().estimate(integrand, n, rng=rng, points=points, chunk=max(1, check_chunk(chunk) // self.m))
        est.method = self.label
        est.extra.update(target_evals=est.n * self.m, candidates=self.m)
        return est


class _Support:
    """Positive exactly where source pdf and target both are (for ``support_probe``)."""

    dim_u = 0

    def __init__(self, source, target):
        self.source, self.target = source, target

    def sample(self, u):  # pragma: no cover - never sampled
        raise TypeError("this object only evaluates the unnormalised target density; sample with RIS")

    def pdf(self, x):
        p = np.asarray(checked_pdf(self.source, x, "source"), dtype=float)
        t = checked_values(self.target(x), x, "target")
        return np.where(p > 0, t, 0.0)
