"""ReSTIR: per-pixel RIS reservoirs with spatial reuse (Bitterli, Wyman, Pharr, Shirley,
Lefohn & Jarosz 2020, "Spatiotemporal reservoir resampling for real-time ray tracing with
dynamic direct lighting", SIGGRAPH), weighted as generalized RIS (Lin, Kettunen, Bitterli,
Pantaleoni, Yuksel & Wyman 2022, "Generalized Resampled Importance Sampling: Foundations of
ReSTIR", SIGGRAPH; GRIS below) so that it stays unbiased.

Pixels.  In the lab the pixels are the elements of a batched integrand: f(x) returns
(*P, ...) for points (..., k), f_b one integral per pixel b of the grid P (1-D or 2-D), all
on one domain.  Each pixel has a target p̂_b (``target``: None = |f_b|, a callable (x) ->
(*P, ...) or (...), or a target name of the integrand; typically the unshadowed f_b) and all
draw candidates from one ``source`` p (default the domain's uniform distribution).

One unit = one pass over every pixel:

1. RIS: pixel b streams ``candidates`` c draws X_j ~ p with weights p̂_b(X_j) / p(X_j) into a
   reservoir (``Reservoir``): sample y_b, W_b = w_sum / (c p̂_b(y_b)), M_b = c.
2. Visibility reuse (Bitterli et al. 2020, sec. 5): f_b(y_b) is evaluated (a shadow ray);
   where it is 0 (occluded) W_b = 0.  The reservoir then holds samples only where
   q_b(x) = p̂_b(x) 1[f_b(x) != 0] > 0, the *visibility-aware target*: W_b is an unbiased
   contribution weight (UCW) for y_b on supp q_b, E[h(y_b) W_b] = int_{q_b > 0} h.
3. ``passes`` rounds of spatial reuse: pixel c draws ``neighbours`` k pixels uniformly
   among the grid offsets o != 0 with |o| <= ``radius`` (the grid wraps around, so every
   pixel has k neighbours and the counts M stay equal), and resamples among its own
   (canonical) sample and theirs.  Contributor s (s = 0 the canonical one) brings x_s from
   pixel s, shifted to c by T_{s->c} (``shift``; identity in the lab, J = 1; the renderer's
   reconnection shift has a solid-angle J), y_s = T_{s->c}(x_s), J_s = |dT_{s->c}/dx|(x_s):

       w_s = m_s(y_s) q_c(y_s) W_s J_s,   pick Y = y_s with probability w_s / sum w,
       W_c = sum_s w_s / q_c(Y),   M_c = sum_s M_s,

   the target **re-evaluated at the receiving pixel c** (with its visibility: one shadow ray
   per neighbour).  By GRIS, E[f_c(Y) W_c] = sum_s int m_s(y) f_c(y) dy over where s can
   bring y: unbiased when the m_s(y) sum to 1 wherever q_c(y) > 0 and m_s(y) = 0 where s
   cannot bring y.  With p̂_{<-t}(y) = q_t(T_{c->t} y) |dT_{c->t}/dy|, pixel t's target read
   in c's domain (zero exactly where t's reservoir cannot land, visibility included):

   - ``mis="balance"``: generalized balance heuristic over the contributing pixels
     (Lin et al. 2022, eq. 23), m_s(y) = M_s p̂_{<-s}(y) / sum_t M_t p̂_{<-t}(y);
     k (k + 1) target (and shadow-ray) evaluations per pixel.
   - ``mis="pairwise"``: Bitterli's pairwise MIS (Bitterli 2022, PhD thesis "Correlations
     and reuse for fast and accurate physically based light transport", ch. 9.1; Lin et al.
     2022, sec. 7): k two-technique balance heuristics, canonical against neighbour t, the
     canonical counted with weight a = M_c / C, C = sum_{t>0} M_t, averaged with weights M_t / C:
         m_s(y) = (M_s / C) p̂_{<-s}(y) / (p̂_{<-s}(y) + a q_c(y))                  (s > 0)
         m_0(y) = sum_{t>0} (M_t / C) a q_c(y) / (p̂_{<-t}(y) + a q_c(y))
     (equal M: Bitterli's 1/k form); sums to 1 where q_c > 0, 2k evaluations per pixel.
   - ``mis="1/M"``: m_s = M_s / sum_t M_t, the naive normalisation W = w_sum / (M p̂(Y)) of
     Bitterli et al. 2020, Alg. 4.  **Biased** wherever a neighbour's reservoir cannot land
     where the receiving pixel's target is positive (occlusion at the neighbour, other
     supports): sum_{s can bring y} M_s / M < 1 there, the image darkens (the lecture's point).
     Kept for contrast; unbiased only when every contributor covers supp q_c.

4. The unit value of pixel c: f_c(Y) W_c (f_c(Y) is the receiving evaluation, no new ray).

Kernels.  Where the view carries ``kernels = "numba"`` (the renderer's, when the render plan
resolved the compiled kernels: :mod:`vrlab.kernels`), the RIS streaming and, per reuse
round, the MIS weights, resampling weights and the pick run as compiled loops
(:mod:`vrlab.estimators.restir_kernel`) on the same evaluations (targets, Jacobians,
back-reads, all still the view's NumPy code), in the same floating-point order as the NumPy
lines here, which stay the oracle: the same picks and weights.

Statistics.  Passes use disjoint uniforms, so units are independent and the per-pixel
mean and standard error over passes are honest.  Within a pass the pixels are *correlated*
(a pixel's sample is reused by its neighbours): the standard error of an image mean is not
the pixels' errors combined as if independent; take it over passes (mean per pass first).

Uniforms of a unit (B pixels, d = source.dim_u), all randomness from them, so a unit is a
deterministic function of its uniforms (bit-identical for any chunking, worker count or
executor): ``[0, B c d)`` the candidates (pixel-major), ``[B c d, B c (d+1))`` the RIS
selection uniforms, then per pass ``B k`` neighbour choices and ``B`` final selections
(inverse CDF, one uniform): ``dim_u = B c (d + 1) + passes B (k + 1)``.

Costs: ``n`` counts unit values per pixel (one f(Y) W per pass); ``candidates_per_unit`` = c
target evaluations without a ray; ``traced_per_unit()`` the shadow rays per pixel per pass:
1 (visibility reuse) + passes x (k for "1/M", 2k "pairwise", k (k + 1) "balance").  In the lab
a batched integrand returns every pixel's value at a point, so evaluating pixel b alone costs
B values: memory and time grow as B^2 per pass (fine for rows of tens of pixels).  The
renderer (``spatial = True``, :mod:`vrlab.render.reuse`) runs the same ``run`` on its view.
"""
from __future__ import annotations

import copy
from typing import Any

import numpy as np

from .. import checks, limits
from .._rng import RNGLike
from ..estimate import Estimate
from ..kernels import load_kernel
from .base import DEFAULT_CHUNK, Estimator, check_chunk, check_technique, ratio, resolve_distribution
from .pixel_view import PixelView, grid_offsets
from .ris import ABS_TARGET, KERNEL_MODULE, Reservoir, as_kernel_array, kernels_of

__all__ = ["ReSTIR", "PixelView", "grid_offsets", "MIS_MODES"]

MIS_MODES = ("pairwise", "balance", "1/M")


class ReSTIR(Estimator):
    """Per-pixel RIS reservoirs with spatial reuse across the pixels of a batched integrand
    (module docstring: weights, visibility, uniforms).  Settings: ``candidates`` c per pixel,
    ``neighbours`` k per reuse pass, ``radius`` (pixel units), ``passes`` of spatial reuse,
    ``mis`` in "pairwise", "balance" (unbiased), "1/M" (biased, for contrast); ``source``
    (None: uniform on the domain, a distribution or a technique name), ``target`` (None: |f_b|,
    a callable, or a target name) and ``shift`` (None: identity; else a picklable callable
    ``shift(x, src, dst) -> (x', J)`` mapping points of pixel src to pixel dst, J = |dx'/dx|).
    """

    evals_per_unit = 1
    spatial = True      #: the renderer runs it on every pixel of a block at once (spatial reuse)
    #: the compiled helpers a render with kernels "numba" loads before its workers start
    kernel_module = KERNEL_MODULE

    def __init__(self, candidates: int = 32, neighbours: int = 5, radius: float = 3.0, passes: int = 1,
                 mis: str = "pairwise", *, source: Any = None, target: Any = None, shift: Any = None):
        self.candidates = checks.integer(candidates, "candidates", low=1, high=limits.MAX_CANDIDATES)
        self.neighbours = checks.integer(neighbours, "neighbours", low=0, high=64)
        self.radius = checks.real(radius, "radius", low=0.0, low_open=True, high=limits.MAX_RADIUS)
        self.passes = checks.integer(passes, "passes", low=1, high=16)
        self.mis = checks.choice(mis, "mis", MIS_MODES)
        self.source = None if source is None else check_technique(source, "source")
        if not (target is None or callable(target) or (isinstance(target, str) and target)):
            raise TypeError(f"target must be None (|f| per pixel), callable or a target's name, "
                            f"got {type(target).__name__}")
        self.target = target
        if shift is not None and not callable(shift):
            raise TypeError(f"shift must be None (identity) or callable (x, src, dst) -> (x', J), "
                            f"got {type(shift).__name__}")
        self.shift = shift

    # -- protocol -------------------------------------------------------------------------
    @property
    def candidates_per_unit(self) -> int:  # type: ignore[override]
        """The c RIS candidates of a pixel: target evaluations that trace no ray."""
        return self.candidates

    def traced_per_unit(self) -> int:
        k = self.neighbours
        per_pass = {"1/M": k, "pairwise": 2 * k, "balance": k * (k + 1)}[self.mis]
        return 1 + self.passes * per_pass

    @property
    def label(self) -> str:
        return f"ReSTIR[{self.mis}, c={self.candidates}, k={self.neighbours}, r={self.radius:g}, passes={self.passes}]"

    def source_for(self, integrand):
        return resolve_distribution(self.source, integrand, "source")

    def target_for(self, integrand):
        if isinstance(self.target, str):
            if self.target == ABS_TARGET and ABS_TARGET not in getattr(integrand, "targets", {}):
                return None
            return integrand.target(self.target, "target")
        return self.target

    def pixel_shape(self, integrand) -> tuple:
        """The pixel grid P: the batch shape of the integrand's values (probed at one point)."""
        try:
            dist = integrand.uniform()
            x0 = np.asarray(dist.sample(np.full((1, int(dist.dim_u)), 0.5)), dtype=float)
            return tuple(np.shape(integrand(x0))[:-1])
        except (ValueError, TypeError, AttributeError) as exc:
            raise ValueError(f"integrand: ReSTIR reads its pixel grid (the batch shape of f) from the values at one "
                             f"point of the domain, and evaluating f there failed: {exc}") from None

    def view(self, integrand) -> PixelView:
        return PixelView(integrand, self.target_for(integrand), self.pixel_shape(integrand),
                         self.source_for(integrand))

    def check(self, integrand) -> None:
        self.source_for(integrand)
        if integrand.atoms:
            raise ValueError(f"integrand: {integrand.name!r} has point masses; {self.label} samples a density")
        view = self.view(integrand)
        if self.neighbours and not len(grid_offsets(view.shape, self.radius)):
            raise ValueError(f"neighbours: integrand {integrand.name!r} has pixel grid {view.shape} with no other "
                             f"pixel within radius {self.radius:g}; ReSTIR reuses across the elements of a batched "
                             "integrand (one integral per pixel): use neighbours=0 or a batched integrand")
        x0 = np.asarray(integrand.uniform().sample(np.full((2, int(integrand.uniform().dim_u)), 0.5)))
        view.phat(x0, 0)

    def dim_u(self, integrand=None) -> int:
        if integrand is None:
            raise ValueError("integrand: ReSTIR's uniforms per unit depend on the pixel count; pass the integrand")
        B = int(np.prod(self.pixel_shape(integrand), dtype=int))
        d = int(self.source_for(integrand).dim_u)
        return B * self.candidates * (d + 1) + self.passes * B * (self.neighbours + 1)

    # -- hooks (a renderer's shift / a test's mutation overrides these) ----------------------
    def shift_map(self, x: np.ndarray, src: np.ndarray, dst: np.ndarray):
        """``(x', J)``: points x of pixel src moved to pixel dst and |dx'/dx| (identity: J = 1)."""
        if self.shift is None:
            return x, np.ones(x.shape[:-1])
        z, J = self.shift(x, src, dst)
        return np.asarray(z, dtype=float), np.broadcast_to(np.asarray(J, dtype=float), x.shape[:-1])

    @staticmethod
    def pixel_target(view: PixelView, x, pix, f_at_pix) -> np.ndarray:
        """q_pix(x) = p̂_pix(x) 1[f_pix(x) != 0]: the visibility-aware target."""
        return np.where(view.nonzero(f_at_pix), view.phat(x, pix), 0.0)

    def receiving_target(self, view: PixelView, y, src, dst, f_dst) -> np.ndarray:
        """The target at the receiving pixel dst of samples y shifted there from src: q_dst(y)."""
        return self.pixel_target(view, y, dst, f_dst)

    # -- the work ----------------------------------------------------------------------------
    def unit_values(self, integrand, u):
        u = np.asarray(u, dtype=float)
        view = self.view(integrand)
        B, c, k, d = view.B, self.candidates, self.neighbours, int(view.source.dim_u)
        D = B * c * (d + 1) + self.passes * B * (k + 1)
        if u.ndim < 2 or u.shape[-1] != D:
            raise ValueError(f"u: expected shape (..., n, {D}) ({B} pixels), got {u.shape}")
        lead = u.shape[:-1]
        N = int(np.prod(lead, dtype=int))
        u = u.reshape(N, D)
        at = B * c * (d + 1)
        rounds = [(u[:, a: a + B * k].reshape(N, B, k), u[:, a + B * k: a + B * (k + 1)])
                  for a in range(at, D, B * (k + 1))]
        out = self.run(view, u[:, : B * c * d].reshape(N, B, c, d), u[:, B * c * d: at].reshape(N, B, c), rounds)
        return np.moveaxis(out.reshape(lead + (B,)), -1, 0).reshape(view.shape + lead)

    def run(self, view, uc: np.ndarray, us: np.ndarray, rounds: list) -> np.ndarray:
        """f_c(Y_c) W_c ``(*channels, N, B)`` of N independent units over the B pixels of ``view``:
        RIS from ``uc (N, B, c, d)``, ``us (N, B, c)``, visibility reuse, one spatial reuse per
        ``rounds`` entry (neighbour uniforms (N, B, k), final selections (N, B)); axis 0 of
        every point array is the unit (the renderer's view tells its pixel samples apart by it)."""
        N, B = us.shape[:2]
        pix = np.arange(B)
        kernels = kernels_of(view)
        x, p, t = view.candidates(uc)
        if np.any(t < 0) or np.any(np.isnan(t)):
            raise ValueError("target: the unnormalised target density must be >= 0 and not NaN")
        res = Reservoir.empty((N, B), x.shape[-1]).update(x, ratio(t, p), us, t, kernels=kernels)
        # visibility reuse: keep the sample only where f_b(y_b) != 0
        y, M, f = res.y, res.M, view.f(res.y, pix)
        vis = view.nonzero(f)
        W, q = np.where(vis, res.W, 0.0), np.where(vis, res.target, 0.0)
        for un, uf in rounds:
            nbr, present = view.neighbours(un, self.radius)
            y, W, M, q, f = self._reuse(view, y, W, M, q, nbr, present, uf, kernels)
        return np.where(W > 0, f * W, 0.0)

    def _reuse(self, view, y, W, M, q, nbr, present, us, kernels: str = "numpy"):
        """One round of spatial reuse (GRIS) at every pixel; returns the new (y, W, M, q, f).
        Absent neighbours (``present`` False: outside the renderer's block) count M = 0.
        ``kernels="numba"``: the MIS weights, resampling weights and the pick in one compiled
        loop (:func:`vrlab.estimators.restir_kernel.combine`) from the same evaluations."""
        N, B = W.shape
        own = np.broadcast_to(np.arange(B)[None, :, None], (N, B, 1))
        src = np.concatenate([own, np.where(present, nbr, own)], -1)                  # (N, B, S)
        dst = np.broadcast_to(np.arange(B)[None, :, None], src.shape)
        n = np.arange(N)[:, None, None]
        ys, J = self.shift_map(y[n, src], src, dst)
        fc = view.f(ys, dst)
        qc = self.receiving_target(view, ys, src, dst, fc)
        Ms = M[n, src] * np.concatenate([np.ones((N, B, 1), bool), present], -1)
        if kernels == "numba" and type(self)._mis_weights is ReSTIR._mis_weights:
            s, total = self._combine(view, ys, q[n, src], J, src, dst, Ms, qc, W[n, src], us)
        else:
            m = self._mis_weights(view, ys, ratio(q[n, src], J), src, dst, Ms, qc)
            w = m * qc * W[n, src] * J
            cum = np.cumsum(w, -1)
            total = cum[..., -1]
            s = np.minimum(np.sum(cum <= (us * total)[..., None], -1), src.shape[-1] - 1)[..., None]
        y_new = np.take_along_axis(ys, s[..., None], -2)[..., 0, :]
        q_new = np.take_along_axis(qc, s, -1)[..., 0]
        f_new = np.take_along_axis(fc, np.broadcast_to(s, np.shape(fc)[:-1] + (1,)), -1)[..., 0]
        return y_new, ratio(total, q_new), Ms.sum(-1), q_new, f_new

    def _read_at(self, view, yc, dst, src_t):
        """p̂_{<-t}(y) = q_t(T_{c->t} y) |dT_{c->t}/dy|: pixel t's target read in c's domain."""
        z, Jz = self.shift_map(yc, dst, src_t)
        return self.pixel_target(view, z, src_t, view.f(z, src_t)) * Jz

    def _balance_matrix(self, view, ys, src, dst, qc):
        """P[s, t] = p̂_{<-t}(y_s) (N, B, S, S); column 0 the receiving pixel itself: q_c(y_s)."""
        S = src.shape[-1]
        yst = np.broadcast_to(ys[..., :, None, :], ys.shape[:-1] + (S - 1, ys.shape[-1]))
        P = self._read_at(view, yst, np.broadcast_to(dst[..., :1, None], yst.shape[:-1]),
                          np.broadcast_to(src[..., None, 1:], yst.shape[:-1]))
        return np.concatenate([qc[..., None], P], -1)

    def _back(self, view, ys, src, dst):
        """p̂_{<-t}(y_0) (N, B, S - 1): each neighbour t's target read at the canonical sample."""
        y0 = np.broadcast_to(ys[..., :1, :], ys[..., 1:, :].shape)
        return self._read_at(view, y0, dst[..., 1:], src[..., 1:])

    def _combine(self, view, ys, q_src, J, src, dst, Ms, qc, W_src, us):
        """The compiled pick: ``(s (N, B, 1), total (N, B))`` as the NumPy lines of :meth:`_reuse`
        (the views' evaluations, back-reads and balance matrix, stay NumPy)."""
        N, B, S = src.shape
        mode = 0 if self.mis == "1/M" or S == 1 else 1 if self.mis == "pairwise" else 2
        R = N * B
        back = self._back(view, ys, src, dst) if mode == 1 else np.zeros((N, B, 0))
        P = self._balance_matrix(view, ys, src, dst, qc) if mode == 2 else np.zeros((N, B, 0, 0))

        def rows(a, tail=0):                  # (R, ...) contiguous float64
            a = as_kernel_array(a)
            return a.reshape((R,) + a.shape[a.ndim - 1 - tail:])

        pick, total = np.empty(R, np.int64), np.empty(R)
        load_kernel(KERNEL_MODULE, "combine")(mode, rows(q_src), rows(J), rows(qc), rows(back), rows(P, 1),
                                              rows(Ms), rows(W_src), rows(us, -1), pick, total)
        return pick.reshape(N, B, 1), total.reshape(N, B)

    def _mis_weights(self, view, ys, own, src, dst, Ms, qc):
        """m_s(y_s) (N, B, S) of the contributors; ``own`` = p̂_{<-s}(y_s) = q_s(x_s) / J_s."""
        S = src.shape[-1]
        if self.mis == "1/M" or S == 1:
            return ratio(Ms, Ms.sum(-1, keepdims=True))
        if self.mis == "balance":
            P = self._balance_matrix(view, ys, src, dst, qc)
            return ratio(Ms * np.diagonal(P, 0, -2, -1), np.sum(Ms[..., None, :] * P, -1))
        C = Ms[..., 1:].sum(-1, keepdims=True)
        a = ratio(Ms[..., :1], C)
        share = ratio(Ms[..., 1:], C)
        m_nc = share * ratio(own[..., 1:], own[..., 1:] + a * qc[..., 1:])
        back = self._back(view, ys, src, dst)                                    # p̂_{<-t}(y_0), t > 0
        aq = a * qc[..., :1]
        m_c = np.sum(share * ratio(aq, back + aq), -1, keepdims=True)
        m_c = np.where(C > 0, m_c, 1.0)                 # no neighbour present: the canonical alone
        return np.concatenate([m_c, m_nc], -1)

    # -- the renderer (spatial protocol: vrlab.render.reuse) ------------------------------------
    def spatial_check(self, integrand) -> None:
        """Renderer settings: ``"light"`` candidates, ``"unshadowed"`` target, its own shift."""
        if self.source not in (None, "light"):
            raise ValueError(f"source: in the renderer {self.label} draws its candidates with the 'light' technique "
                             f"(samples are light points, reconnected between pixels); use None or 'light', "
                             f"got {self.source!r}")
        if self.target not in (None, "unshadowed"):
            raise ValueError(f"target: in the renderer {self.label} resamples towards the unshadowed contribution; "
                             f"use None or 'unshadowed', got {self.target!r}")
        if self.shift is not None:
            raise ValueError("shift: the renderer shifts samples between pixels by reconnection to the same light "
                             "point (with its solid-angle Jacobian); leave shift=None")
        integrand.technique("light", "source")

    def spatial_dim(self, integrand) -> int:
        """c (d + 1) + passes (k + 1) (d: the light technique's uniforms per candidate)."""
        d = int(integrand.technique("light", "source").dim_u)
        return self.candidates * (d + 1) + self.passes * (self.neighbours + 1)

    def spatial_outputs(self, view, u: np.ndarray) -> np.ndarray:
        """``(3, N, B, 1)``: f_c(Y_c) W_c of N units over the B pixels of ``view``
        (:class:`vrlab.render.reuse.BlockPixels`); per pixel ``u``: ``[0, c d)`` candidates,
        ``[c d, c (d + 1))`` their selection, per pass k neighbours and one final selection.
        The view's reconnection is ``self.shift`` of a shallow copy (``shift_map`` sees it)."""
        u = np.asarray(u, dtype=float)
        c, k = self.candidates, self.neighbours
        N, B, D = u.shape
        d = (D - self.passes * (k + 1)) // c - 1
        if d < 1 or D != c * (d + 1) + self.passes * (k + 1):
            raise ValueError(f"u: expected (N, B, c (d + 1) + passes (k + 1)) uniforms, got {u.shape}")
        est, at = copy.copy(self), c * (d + 1)
        est.shift = view.shift
        rounds = [(u[..., a: a + k], u[..., a + k]) for a in range(at, D, k + 1)]
        return est.run(view, u[..., : c * d].reshape(N, B, c, d), u[..., c * d: at], rounds)[..., None]

    def estimate(self, integrand, n: int, *, rng: RNGLike = None, points: Any = None,
                 chunk: int = DEFAULT_CHUNK) -> Estimate:
        """As ``Estimator.estimate``: n passes (one f(Y) W per pixel each); ``chunk`` counts
        pixel-candidate evaluations, a block holds max(1, chunk // (B^2 max(c, (k+1)^2))) passes.
        ``extra``: ``target_evals`` (= n c per pixel), ``shadow_rays`` (per pixel), ``candidates``."""
        from ..integrands.lookup import as_integrand

        integrand = as_integrand(integrand)
        B = int(np.prod(self.pixel_shape(integrand), dtype=int))
        per_unit = B * B * max(self.candidates, (self.neighbours + 1) ** 2)
        est = super().estimate(integrand, n, rng=rng, points=points, chunk=max(1, check_chunk(chunk) // per_unit))
        est.method = self.label
        est.extra.update(target_evals=est.n * self.candidates, shadow_rays=est.n * self.traced_per_unit(),
                         candidates=self.candidates)
        return est
