"""The sampling techniques of the shading integrand (:mod:`vrlab.render.shading`): each an
ordinary distribution of points x = (w, j, k + 1) with its exact density.

* ``_Directional``: ``"bsdf"`` (the BSDF's lobe mixture, delta lobes as atoms of probability
  P_k(wo)), ``"cosine"`` and ``"uniform"`` (hemisphere warps); j found by a traced ray;
* ``_Lobe``: ``"bsdf:<lobe>"``, one lobe alone (no sample where the point's BSDF lacks it);
* ``_LightTechnique``: ``"light"``, light j ~ P_j, then a direction towards it.

Not public: the integrand builds them on access (see ``ShadingIntegrand.techniques``); each
holds its ``ShadingIntegrand`` as ``s``.
"""
from __future__ import annotations

import numpy as np

from ..distributions import CosineHemisphere, UniformHemisphere
from ..distributions.base import uniforms32

F32 = np.float32
NO_SAMPLE = -2          #: the lobe code of a sample from a lobe the point's BSDF does not have
_WARPS = {"cosine": CosineHemisphere(), "uniform": UniformHemisphere()}


class _Directional:
    """``"bsdf"`` (warp None), ``"cosine"`` or ``"uniform"``: w from a local warp, j traced."""

    dim_x, measure = 5, "solid angle x lights"

    def __init__(self, shading, warp: str | None):
        self.s, self.warp = shading, warp
        self.key = warp or "bsdf"
        # the scene's BSDF sample size (2, or 3 if some BSDF needs a third uniform): the same for
        # every group, so a pixel's uniforms have one layout
        self.dim_u = 2 if warp is not None else int(shading.lighting.bsdf_dim_u)

    def __repr__(self) -> str:
        return f"ShadingTechnique({self.key!r})"

    @property
    def samples_bsdf(self) -> bool:
        """Whether the technique draws from the BSDF (a counted BSDF sample, vrlab.render.cost)."""
        return self.warp is None

    def _bsdf(self, rows: int):
        """The BSDF for ``rows`` sample rows (m samples per shading point: ``bsdf_for(m)``)."""
        return self.s.bsdf_for(rows // max(len(self.s.p), 1) or 1)

    def _local_pdf(self, wo_l: np.ndarray, wl: np.ndarray, lobe: np.ndarray | None) -> np.ndarray:
        """The density at continuous points; at a delta lobe's atom (``lobe`` >= 0) the
        BSDF's probability of that lobe (the other warps: 0)."""
        if self.warp is not None:
            p = np.asarray(_WARPS[self.warp].pdf(wl), F32)
            return p if lobe is None else np.where(lobe != -1, F32(0), p)
        bsdf = self._bsdf(len(wl))
        if lobe is None:
            return bsdf.pdf(wo_l, wl)
        dist = bsdf.distribution(wo_l)
        p = np.broadcast_to(np.asarray(dist.pdf(wl), F32), lobe.shape)
        k = np.maximum(lobe, 0)
        mass = np.take_along_axis(np.broadcast_to(dist.probabilities, lobe.shape + dist.probabilities.shape[-1:]),
                                  k[:, None], -1)[:, 0]
        return np.where(lobe >= 0, mass, np.where(lobe == NO_SAMPLE, 0, p)).astype(F32)

    def _draw(self, wo_l: np.ndarray, u2: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Local directions and their delta lobes (None: all continuous)."""
        if self.warp is not None:
            return np.asarray(_WARPS[self.warp].sample(u2), F32), None
        bsdf = self._bsdf(len(u2))
        u2 = u2[:, :bsdf.dim_u]
        if not bsdf.DELTA:
            return np.asarray(bsdf.distribution(wo_l).sample(u2)), None
        wl, k = bsdf.sample_lobe(wo_l, u2)
        delta = np.isin(np.asarray(bsdf.LOBES)[k], bsdf.DELTA)
        return np.asarray(wl), np.where(delta, k, -1)

    def sample(self, u: np.ndarray) -> np.ndarray:
        s, lit = self.s, self.s.lighting
        u = np.asarray(u)
        shape = u.shape[:-1]
        u2 = uniforms32(u.reshape(-1, self.dim_u))
        wo_l = s.rep(s.wo_l, u)
        wl, lobe = self._draw(wo_l, u2)
        w = s.rep_frame(shape[-1]).to_world(wl)
        hits, le = lit.trace(s.rep(s.p, u), s.rep(s.n, u), w, cost=s.cost)
        j = lit.light_hit(hits)
        x, r = s.new_points(w, j, shape, lobe)
        if self.samples_bsdf:
            s.cost.bsdf_samples += len(j)
            r.bsdf_done = True
        s.count_light(r)                       # the radiance of the light each ray reached
        r.wl, r.le, r.hit_p, r.hit_prim = wl, le, hits.p, hits.prim
        r.first, r.front = np.ones(len(j), bool), lit.facing(hits, w)
        r.pdfs[self.key] = self._local_pdf(wo_l, wl, r.lobe)
        return x

    def pdf(self, x: np.ndarray) -> np.ndarray:
        """p(w) [j is the first thing seen along w]."""
        s = self.s
        r = s.rows(x)
        if self.key not in r.pdfs:
            if self.samples_bsdf:
                s.count_bsdf(r)
            ok = s.first_seen(r)
            lights = s.lighting.lights
            if lights is not None and lights.is_delta.any():       # no direction sample hits a delta light
                ok = ok & ~lights.is_delta[np.maximum(r.j, 0)]
            r.pdfs[self.key] = np.where(ok, self._local_pdf(s.rep(s.wo_l, x), r.wl, r.lobe), 0.0)
        return r.pdfs[self.key].reshape(x.shape[:-1])


class _Lobe(_Directional):
    """``"bsdf:<name>"``: the BSDF's lobe ``name`` alone (a delta lobe: its one direction,
    density 1 at its atom and 0 elsewhere; a continuous lobe: 0 at every atom).  At points
    whose BSDF has no such lobe (another BSDF of the scene has) the technique has density 0:
    its samples are marked as no sample (lobe code ``NO_SAMPLE``: f = 0 and every density 0
    there), and the other techniques must cover those points (MIS weights give them
    everything there)."""

    def __init__(self, shading, name: str):
        super().__init__(shading, None)
        self.name, self.key = name, f"bsdf:{name}"
        bsdf = shading.bsdf
        self.absent = name not in bsdf.LOBES
        self.index = None if self.absent else bsdf.LOBES.index(name)
        self.delta = name in bsdf.DELTA

    @property
    def samples_bsdf(self) -> bool:
        return not self.absent

    def _local_pdf(self, wo_l, wl, lobe):
        if self.absent:
            return np.zeros(len(wl), F32)
        if self.delta:
            return np.zeros(len(wl), F32) if lobe is None else (lobe == self.index).astype(F32)
        bsdf = self._bsdf(len(wl))
        p = np.asarray(bsdf.lobe(self.name, wo_l).pdf(wl), F32)
        return p if lobe is None else np.where(lobe != -1, F32(0), p)

    def _draw(self, wo_l, u2):
        if self.absent:                  # no sample: a point of no technique's, where f = 0
            return np.broadcast_to(np.array([0.0, 0.0, 1.0], F32), (len(u2), 3)), np.full(len(u2), NO_SAMPLE)
        bsdf = self._bsdf(len(u2))
        dist = bsdf.lobe(self.name, wo_l)
        wl = np.broadcast_to(np.asarray(dist.sample(u2[:, :int(dist.dim_u)])), (len(u2), 3))
        return wl, (np.full(len(u2), self.index) if self.delta else None)


class _LightTechnique:
    """``"light"``: light j ~ P (one uniform), w towards it (two uniforms)."""

    dim_u, dim_x, measure = 3, 5, "solid angle x lights"

    def __init__(self, shading):
        self.s = shading

    def __repr__(self) -> str:
        return "ShadingTechnique('light')"

    def sample(self, u: np.ndarray) -> np.ndarray:
        s, lit = self.s, self.s.lighting
        u = np.asarray(u)
        shape = u.shape[:-1]
        p = s.rep(s.p, u)
        if lit.lights is None:                        # no emitters: nothing to sample (density 0)
            x, r = s.new_points(s.rep(s.n, u), np.full(len(p), -1), shape)
            r.pdfs["light"], r.first, r.front = np.zeros(len(p), F32), np.zeros(len(p), bool), np.zeros(len(p), bool)
            return x
        j, w, pdf, front, y, le, tri = lit.lights.sample(p, u.reshape(-1, 3), s.rep(s.n, u), triangles=True)
        s.cost.emitter_samples += len(j)
        if lit.lights.tree is not None:
            s.cost.light_walks += len(j)
        x, r = s.new_points(w, j, shape)
        r.light_done = True
        r.pdfs["light"], r.front, r.y, r.le_raw, r.tri = pdf.astype(F32), front, y, le, tri
        return x

    def pdf(self, x: np.ndarray) -> np.ndarray:
        s = self.s
        return s.light_pdf(s.rows(x)).reshape(x.shape[:-1])
