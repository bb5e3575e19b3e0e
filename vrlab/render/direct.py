"""Direct lighting at camera-ray hits (Mitsuba 3 ``direct`` integrator, one bounce).

The value of one pixel sample is the one-sided emission of the first hit plus, at a hit
on a non-emitting surface, an estimate of L_d = int f_r L_e cos dw by ``strategy``.
Every estimate is a function of the sample's uniforms ``u`` (see :class:`UniformLayout`),
so strategies share their random numbers and any point set can drive them.  With
``n_b`` = ``bsdf_samples`` and ``n_l`` = ``emitter_samples`` (the scene's integrator
settings, Mitsuba's defaults 1 and 1):

* ``"uniform"`` / ``"cosine"`` / ``"bsdf"``: the mean of n_b samples wi ~ uniform
  hemisphere / cos/pi / ``bsdf.distribution(wo)``, each f L_e / p;
* ``"light"``: the mean of n_l samples: light j with probability P_j
  (``light_selection``: ``"uniform"`` or ``"power"`` = mean radiance x area, an alias
  table; uniform when every emitter is black), a direction towards it (spheres by their cone, other shapes by area converted
  to solid angle over every hit), pdf P_j p_j(w); a sample counts only emission of light
  j itself, so each light's contribution has one sampling density;
* ``"mis-balance"`` / ``"mis-power"``: Veach's multi-sample MIS, n_l light and n_b BSDF
  samples, weights w_i = (n_i p_i)^b / sum_k (n_k p_k)^b (``mis_weights``; b = 1 or 2),
  as Mitsuba's direct integrator does with its power heuristic;
* ``"mixture"``: one sample of the mixture c p_bsdf + (1 - c) sum_j P_j p_j with
  c = n_b / (n_b + n_l) (the Russian lecture's 1/2 BSDF + 1/2 light for 1 and 1);
* ``"ris"``: n_l RIS samples, each resampled from ``ris_candidates`` = M light samples
  with the unshadowed target p̂ = Y(f_r cos) Y(L_e j) (Y = luminance; zero behind a
  one-sided planar light), through :class:`vrlab.estimators.ris.Reservoir`; one
  shadow ray per RIS sample, weight W = (1/M) sum w_i / p̂(y) (Talbot et al. 2005);
* ``"cv"``: light sampling with a control variate (alpha = 1):
  F = G + (f L_e - g) / p, g = (k_d/pi) L_e,j cos theta the unoccluded Lambertian
  part of the integrand, G = (k_d/pi) sum_j L_e,j I_j its closed-form integral
  (:meth:`LightSet.cos_integrals`: Lambert's polygon formula for rectangles, the cone
  formula for spheres).  Where the BSDF has no Lambertian part (k_d = 0) or no closed
  form applies for a light (it crosses the horizon, the point is behind it, other
  shapes), that light's control is 0 and the sample is plain light sampling.  Where
  nothing is occluded the estimate of the Lambertian part is exact.

Rays: camera rays are intersected with the whole scene.  Rays leaving a surface only
need the emitter they reach.  BSDF samples (:meth:`DirectLighting.trace`) intersect the
emitters in full and test the other shapes for a closer hit (distance only) where they
reach one; light samples towards spheres, rectangles and disks
(:meth:`DirectLighting.shadow`) know the light's first point y and only test that no
other shape is in front of it.  A blocker must be closer than the emitter by
``SHADOW_EPS`` = 1e-4 (relative; Mitsuba likewise shortens its shadow rays by a relative
epsilon).

Precision: rays, hit points, frames, BSDF values, MIS weights, sphere-light cones and
rectangle-light samples are float32, as in Mitsuba's scalar variants (NumPy runs float32
2-3x faster; the formulas used are the stable ones, see ``SphereCone`` and ``GGX``); light
selection keeps float64 uniforms, the other lights (cubes, ellipsoids, disks) are sampled
in float64 and rounded, and pixel estimates are accumulated in float64.

Emitting surfaces reflect other lights through their BSDF like any surface, as in
Mitsuba; an emitter without a ``<bsdf>`` is black (Mitsuba's behaviour), and black
diffuse surfaces are skipped.  ``obj`` emitters work with ``"uniform"``, ``"cosine"``
and ``"bsdf"`` only.  ``render`` lives in :mod:`vrlab.render.film`.
"""
from __future__ import annotations

import numpy as np

from .. import checks
from .._vec import dot, scale, side
from ..distributions import CosineHemisphere, Frame, UniformHemisphere, to_local
from ..distributions.base import uniforms32
from ..estimators.base import ratio
from ..estimators.mis import mis_weights
from ..estimators.ris import Reservoir
from ..points.base import check_int
from .bsdfs import BSDFModel, Diffuse, Phong, RoughConductor
from .camera import Camera
from .geometry import Hits, SceneGeometry
from .lights import LIGHT_SELECTIONS, LightSet, luminance
from .pixel_samplers import PIXEL_SAMPLERS  # noqa: F401  (re-exported for the CLI)
from .scene import BSDF, Scene

__all__ = ["DIMS", "STRATEGIES", "DirectLighting", "UniformLayout", "check_sample_counts", "make_bsdf"]

STRATEGIES = ("uniform", "cosine", "bsdf", "light", "mis-balance", "mis-power", "mixture", "ris", "cv")
_BSDF_ONLY = ("uniform", "cosine", "bsdf")
DIMS = 8                      # uniforms per pixel sample with one BSDF and one light sample
F32 = np.float32
SHADOW_EPS = 1e-4             # a blocker must be this much closer (relative) than the emitter
_COSINE = CosineHemisphere()
_UNIFORM = UniformHemisphere()


def make_bsdf(desc: BSDF) -> BSDFModel:
    """The :mod:`vrlab.render.bsdfs` model of a scene ``BSDF`` description."""
    if not isinstance(desc, BSDF):
        raise TypeError(f"desc must be a vrlab.render.BSDF, got {type(desc).__name__}")
    p = desc.params
    if desc.type == "diffuse":
        return Diffuse(p["reflectance"])
    if desc.type == "roughconductor":
        return RoughConductor(p["alpha"], p["distribution"])
    if desc.type == "phong":
        return Phong(p["diffuse_reflectance"], p["specular_reflectance"], p["exponent"])
    raise ValueError(f"bsdf type {desc.type!r} is not supported; allowed: diffuse, roughconductor, phong")


def lambertian_albedo(bsdf: BSDFModel) -> np.ndarray:
    """k_d of the Lambertian part k_d/pi of a BSDF (RGB; 0 for a rough conductor)."""
    if isinstance(bsdf, Diffuse):
        return bsdf.reflectance
    if isinstance(bsdf, Phong):
        return bsdf.kd
    return np.zeros(3)


class UniformLayout:
    """Which uniforms of a pixel sample feed what: ``[0, 2)`` the position in the pixel,
    then a 2D block per BSDF sample, a 3D block (light choice, point) per light sample,
    one mixture-choice uniform, and for ``"ris"`` one block of 4 M per RIS sample
    (M candidates x 3, then M reservoir uniforms).  With one BSDF and one light sample
    the first 8 are the same for every strategy (:data:`DIMS`)."""

    def __init__(self, bsdf_samples: int = 1, emitter_samples: int = 1, ris_candidates: int = 0):
        self.n_b, self.n_l, self.m = max(bsdf_samples, 1), max(emitter_samples, 1), ris_candidates
        self.choice = 2 + 2 * self.n_b + 3 * self.n_l
        self.dims = self.choice + 1 + (self.n_l * 4 * self.m)

    def bsdf(self, k: int) -> slice:
        return slice(2 + 2 * k, 4 + 2 * k)

    def light(self, k: int) -> slice:
        a = 2 + 2 * self.n_b + 3 * k
        return slice(a, a + 3)

    def ris(self, k: int) -> slice:
        a = self.choice + 1 + 4 * self.m * k
        return slice(a, a + 4 * self.m)

    @property
    def groups(self) -> list[tuple[int, ...]]:
        """Dimension pairs a pixel sampler stratifies together."""
        g = [(0, 1)] + [(2 + 2 * k, 3 + 2 * k) for k in range(self.n_b)]
        return g + [(self.light(k).start + 1, self.light(k).start + 2) for k in range(self.n_l)]


def _stack(u: np.ndarray, slices: list[slice]) -> np.ndarray:
    """The column blocks ``slices`` of ``u`` stacked on the row axis (sample k after k-1)."""
    return np.concatenate([u[:, s] for s in slices]) if len(slices) > 1 else u[:, slices[0]]


def _tile(a: np.ndarray, k: int) -> np.ndarray:
    return np.concatenate([a] * k) if k > 1 else a


def _mean_of(values: np.ndarray, k: int) -> np.ndarray:
    return values.reshape((k, -1) + values.shape[1:]).mean(0) if k > 1 else values


def check_sample_counts(strategy: str, emitter_samples: int, bsdf_samples: int) -> None:
    """``ValueError`` naming ``bsdf_samples`` / ``emitter_samples`` when ``strategy`` has
    no sample of the kind it needs (BSDF-only strategies need a BSDF sample; light, ris
    and cv a light sample; every strategy at least one sample)."""
    if strategy in _BSDF_ONLY and bsdf_samples < 1:
        raise ValueError(f"bsdf_samples: strategy {strategy!r} needs bsdf_samples >= 1, got {bsdf_samples}")
    if strategy in ("light", "ris", "cv") and emitter_samples < 1:
        raise ValueError(f"emitter_samples: strategy {strategy!r} needs emitter_samples >= 1, got {emitter_samples}")
    if emitter_samples + bsdf_samples < 1:
        raise ValueError("emitter_samples and bsdf_samples are both 0: nothing to sample")


class DirectLighting:
    """The radiance of camera rays under one strategy (see the module docstring)."""

    def __init__(self, scene: Scene, strategy: str = "mis-power", light_selection: str = "uniform", *,
                 emitter_samples: int | None = None, bsdf_samples: int | None = None,
                 ris_candidates: int = 8):
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a vrlab.render.Scene, got {type(scene).__name__}")
        checks.choice(strategy, "strategy", STRATEGIES)
        checks.choice(light_selection, "light_selection", LIGHT_SELECTIONS)
        integ = scene.integrator
        n_l = check_int("emitter_samples", integ.emitter_samples if emitter_samples is None else emitter_samples, 0)
        n_b = check_int("bsdf_samples", integ.bsdf_samples if bsdf_samples is None else bsdf_samples, 0)
        m = check_int("ris_candidates", ris_candidates, 0)
        check_sample_counts(strategy, n_l, n_b)
        if strategy == "ris" and m < 1:
            raise ValueError(f"ris_candidates must be >= 1, got {ris_candidates!r}")
        self.strategy, self.n_l, self.n_b, self.ris_candidates = strategy, n_l, n_b, m
        self.layout = UniformLayout(n_b, n_l, m if strategy == "ris" else 0)
        self.geometry = SceneGeometry(scene)
        emits = np.array([s.emitter is not None for s in scene.shapes], bool)
        # rays leaving a surface only need the first emitter they meet and whether a
        # non-emitter blocks it: two smaller geometries (see ``trace``)
        self.emitter_geometry = SceneGeometry(scene, np.flatnonzero(emits))
        self.blocker_geometry = SceneGeometry(scene, np.flatnonzero(~emits))
        self.camera = Camera(scene.sensor)
        shapes = scene.shapes
        # shapes with identical BSDFs are shaded together (one batch per distinct BSDF)
        keys = [repr((s.bsdf.type, sorted((k, np.asarray(v).tolist() if not isinstance(v, str) else v)
                                          for k, v in s.bsdf.params.items()), s.bsdf.twosided))
                for s in shapes]
        distinct = list(dict.fromkeys(keys))
        self.group_of_shape = np.array([distinct.index(k) for k in keys], dtype=np.int64)
        first = [keys.index(k) for k in distinct]
        self.bsdfs = [make_bsdf(shapes[i].bsdf) for i in first]      # one model per group
        self.twosided = np.array([shapes[i].bsdf.twosided for i in first], dtype=bool)
        self.is_emitter = np.array([s.emitter is not None for s in shapes])
        black = [s.bsdf.type == "diffuse" and not np.any(np.asarray(s.bsdf.params["reflectance"]) > 0)
                 for s in shapes]
        self.shaded = ~np.array(black, dtype=bool)         # black diffuse reflects nothing
        self.radiance = np.array([s.emitter.radiance if s.emitter is not None else np.zeros(3)
                                  for s in shapes], F32)
        self.eps = 1e-5              # ray offset, relative to 1 + max|p| (float32 hit decisions)
        self.lights: LightSet | None = None
        self.light_of_shape = np.full(len(shapes), -1)
        if strategy not in _BSDF_ONLY and self.is_emitter.any():
            self.lights = LightSet(shapes, light_selection)
            self.light_of_shape = self.lights.light_of_shape

    @property
    def dims(self) -> int:
        """Uniforms per pixel sample."""
        return self.layout.dims

    # ------------------------------------------------------------------ tracing
    def emitted(self, hits, d: np.ndarray) -> np.ndarray:
        """One-sided emitted radiance ``(N, 3)`` seen along ``d`` at ``hits``."""
        front = (hits.shape >= 0) & (dot(hits.n, d) < 0)
        return scale(np.take(self.radiance, np.maximum(hits.shape, 0), axis=0), front)

    def trace(self, p: np.ndarray, n: np.ndarray, w: np.ndarray) -> tuple[Hits, np.ndarray]:
        """The emitter seen by rays leaving surface points ``p`` (normal ``n``) along ``w``
        and its emission: ``(hits, L_e)`` with ``hits`` the first *emitter* hit of each ray
        (shape -1 where there is none or where a non-emitter blocks it, i.e. is closer by
        more than ``SHADOW_EPS`` relative).  Direct lighting needs nothing else from these
        rays, so only the emitters are intersected in full and the blockers only for rays
        that reach an emitter, without their hit data.  The origin is offset off the
        surface to ``w``'s side."""
        o = self._origin(p, n, w)
        hits = self.emitter_geometry.intersect(o, w)
        le = self.emitted(hits, w)
        seen = np.flatnonzero(hits.shape >= 0)
        if len(seen) and self.blocker_geometry.n_shapes:
            if len(seen) < len(o):
                tb = self.blocker_geometry.distance(np.take(o, seen, axis=0), np.take(w, seen, axis=0))
            else:
                tb = self.blocker_geometry.distance(o, w)
            hidden = seen[tb < hits.t[seen] * (1.0 - SHADOW_EPS)]
            hits.shape[hidden] = -1
            le[hidden] = 0.0
        return hits, le

    def _origin(self, p: np.ndarray, n: np.ndarray, w: np.ndarray) -> np.ndarray:
        """Ray origins off the surface points ``p`` (normal ``n``) to ``w``'s side, by
        ``eps`` (1 + max|p_k|) (float32 hit decisions)."""
        a = np.abs(p)
        offset = np.maximum(np.maximum(a[:, 0], a[:, 1]), a[:, 2])
        offset += 1.0
        offset *= self.eps
        offset *= side(dot(w, n))
        return p + scale(n, offset)

    def shadow(self, p: np.ndarray, n: np.ndarray, w: np.ndarray, y: np.ndarray, j: np.ndarray,
               front: np.ndarray) -> np.ndarray:
        """Emission ``(N, 3)`` of light ``j`` seen from ``p`` along ``w`` when ``y`` is the
        light's first point along w (``LightSet.sample`` with ``simple`` lights): L_e,j
        where it faces ``p`` (``front``), no non-emitter is closer than y by more than
        ``SHADOW_EPS`` (relative; a distance query without hit data) and the first
        emitter met is light j itself (decided by index, not distance: near a sphere's
        silhouette its float32 t is too rough to compare)."""
        o = self._origin(p, n, w)
        t_max = dot(y - o, w)
        t_max *= 1.0 - SHADOW_EPS
        visible = front
        if self.blocker_geometry.n_shapes:
            visible = visible & (self.blocker_geometry.distance(o, w) >= t_max)
        if self.emitter_geometry.n_shapes > 1:      # another emitter in front of light j
            te, se = self.emitter_geometry.distance(o, w, with_shape=True)
            visible &= (se == self.lights.shape_of_light[j]) | (te >= t_max)
        return scale(np.take(self.lights.radiance32, j, axis=0), visible)

    def radiance_of(self, o: np.ndarray, d: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Radiance samples ``(N, 3)`` of rays ``(N, 3)`` with their uniforms ``u (N, dims)``."""
        if u.shape[-1] != self.dims:
            raise ValueError(f"u: expected {self.dims} uniforms per sample, got shape {u.shape}")
        o, d = np.asarray(o, F32), np.asarray(d, F32)
        hits = self.geometry.intersect(o, d)
        out = self.emitted(hits, d)
        shape = np.maximum(hits.shape, 0)
        shade = (hits.shape >= 0) & self.shaded[shape]
        group = np.where(shade, self.group_of_shape[shape], -1)
        counts = np.bincount(group + 1, minlength=len(self.bsdfs) + 1)[1:]
        for g in np.flatnonzero(counts):
            if counts[g] == len(out):              # one group everywhere: no gathers
                out += self.direct(g, hits.p, hits.n, -d, u)
                continue
            m = np.flatnonzero(group == g)
            rows = [np.take(a, m, axis=0) for a in (hits.p, hits.n, d, u)]
            out[m] += self.direct(g, rows[0], rows[1], -rows[2], rows[3])
        return out

    # ------------------------------------------------------------------ direct lighting
    def direct(self, k: int, p: np.ndarray, n: np.ndarray, wo: np.ndarray, u: np.ndarray) -> np.ndarray:
        """One estimate ``(m, 3)`` of the direct lighting at points ``p`` whose BSDF is
        ``self.bsdfs[k]`` (BSDF group ``k``, see ``group_of_shape``)."""
        bsdf = self.bsdfs[k]
        if self.twosided[k]:
            n = scale(n, side(dot(wo, n)))
        fr = Frame(n)                                   # one shading frame per point
        wo_l = fr.to_local(wo)
        s, lay, n_b, n_l = self.strategy, self.layout, self.n_b, self.n_l
        if s in _BSDF_ONLY:
            warp = {"uniform": _UNIFORM, "cosine": _COSINE}.get(s)
            u2 = _stack(u, [lay.bsdf(i) for i in range(n_b)])
            f, le, pdf, _, _ = self._bsdf_sample(bsdf, _tile(p, n_b), fr.tile(n_b), _tile(wo_l, n_b), u2, warp)
            return _mean_of(scale(f * le, ratio(1.0, pdf)), n_b)
        if self.lights is None:
            return np.zeros((len(p), 3), F32)
        if s == "mixture":
            return self._mixture(bsdf, p, fr, wo_l, u)
        if s == "ris":
            return self._ris(bsdf, p, n, wo_l, u)
        tl = (_tile(p, n_l), fr.tile(n_l), _tile(wo_l, n_l))
        if n_l:
            f_l, le_l, q_l, wi_l, j = self._light_sample(bsdf, *tl, _stack(u, [lay.light(i) for i in range(n_l)]))
        if s == "light":
            return _mean_of(scale(f_l * le_l, ratio(1.0, q_l)), n_l)
        if s == "cv":
            return self._control_variate(bsdf, p, n, wi_l, j, f_l, le_l, q_l)
        heuristic = "balance" if s == "mis-balance" else "power"
        out = np.zeros((len(p), 3), F32)
        if n_l:
            q_b_at_l = bsdf.pdf(tl[2], wi_l) if n_b else np.zeros_like(q_l)
            w_l = mis_weights(np.stack([n_l * q_l, n_b * q_b_at_l]).T, heuristic)[:, 0]    # (N, 2) views
            out += _mean_of(scale(scale(f_l * le_l, ratio(1.0, q_l)), w_l), n_l)
        if n_b:
            pb = _tile(p, n_b)
            u2 = _stack(u, [lay.bsdf(i) for i in range(n_b)])
            f_b, le_b, q_b, wi_b, hits_b = self._bsdf_sample(bsdf, pb, fr.tile(n_b), _tile(wo_l, n_b), u2)
            q_l_at_b = self.light_pdf(pb, wi_b, hits_b).astype(F32)
            w_b = mis_weights(np.stack([n_l * q_l_at_b, n_b * q_b]).T, heuristic)[:, 1]
            out += _mean_of(scale(scale(f_b * le_b, ratio(1.0, q_b)), w_b), n_b)
        return out

    def _mixture(self, bsdf, p, fr, wo_l, u):
        """One sample of the mixture c p_bsdf + (1 - c) p_light, c = n_b / (n_b + n_l):
        ``u[choice] < c`` takes a BSDF sample, else a light sample; either way f / mixture
        density (the balance heuristic with one sample; Russian lecture 4)."""
        c = self.n_b / (self.n_b + self.n_l)
        lay = self.layout
        out = np.zeros((len(p), 3))
        b = np.flatnonzero(u[:, lay.choice] < c)
        if len(b):
            f_b, le_b, q_b, wi_b, hits_b = self._bsdf_sample(bsdf, p[b], fr.take(b), wo_l[b], u[b, lay.bsdf(0)])
            out[b] = scale(f_b * le_b, ratio(1.0, c * q_b + (1 - c) * self.light_pdf(p[b], wi_b, hits_b)))
        li = np.flatnonzero(u[:, lay.choice] >= c)
        if len(li):
            f_l, le_l, q_l, wi_l, _ = self._light_sample(bsdf, p[li], fr.take(li), wo_l[li], u[li, lay.light(0)])
            out[li] = scale(f_l * le_l, ratio(1.0, (1 - c) * q_l + c * bsdf.pdf(wo_l[li], wi_l)))
        return out

    def _ris(self, bsdf, p, n, wo_l, u):
        """n_l RIS samples from M light candidates each (see the module docstring)."""
        M, n_l, lights = self.ris_candidates, self.n_l, self.lights
        blocks = _stack(u, [self.layout.ris(i) for i in range(n_l)])           # (rows, 4M)
        rows = len(blocks)
        pr, nr, wor = _tile(p, n_l), _tile(n, n_l), _tile(wo_l, n_l)
        cand_ref = np.repeat(pr, M, axis=0)
        j, w, pdf, front, y = lights.sample(cand_ref, blocks[:, :3 * M].reshape(-1, 3))
        # local frames once per shading point, broadcast over its M candidates
        wi_l = to_local(w.reshape(rows, M, 3), nr[:, None, :]).reshape(-1, 3)
        f_c = bsdf.eval(wor[:, None, :], wi_l.reshape(rows, M, 3)).reshape(-1, 3)
        target = luminance(f_c) * luminance(lights.radiance[j])
        target = np.where(front, np.maximum(target, 0.0), 0.0)
        weight = np.divide(target, pdf, out=np.zeros_like(target), where=pdf > 0)
        idx = np.arange(rows * M, dtype=float).reshape(rows, M, 1)
        res = Reservoir.empty((rows,), 1).update(idx, weight.reshape(rows, M), blocks[:, 3 * M:],
                                                 target.reshape(rows, M))
        pick = res.y[:, 0].astype(np.int64)
        le = self._light_emission(pr, nr, w[pick].astype(pr.dtype), j[pick], front[pick], y[pick])
        value = scale(bsdf.eval(wor, wi_l[pick]) * le, res.W)
        return _mean_of(value, n_l)

    def _control_variate(self, bsdf, p, n, wi_l, j, f_l, le_l, q_l):
        """F = G + (f L - g) / p with the Lambertian unoccluded control (module docstring)."""
        kd = lambertian_albedo(bsdf)
        n_l = self.n_l
        if not np.any(kd > 0):
            return _mean_of(scale(f_l * le_l, ratio(1.0, q_l)), n_l)
        integral, valid = self.lights.cos_integrals(p, n)                       # (m, L)
        big_g = (kd / np.pi) * ((integral * valid) @ self.lights.radiance)     # (m, 3)
        ok = _tile(valid, n_l)[np.arange(len(j)), j]
        g = np.where(ok[:, None], (kd / np.pi) * np.clip(wi_l[:, 2:3], 0.0, None) * self.lights.radiance[j], 0.0)
        return big_g + _mean_of(scale(f_l * le_l - g, ratio(1.0, q_l)), n_l)

    def _bsdf_sample(self, bsdf, p, fr, wo_l, u2, warp=None):
        u2 = uniforms32(u2)
        if warp is not None:  # a fixed hemisphere warp (uniform or cosine) instead of the BSDF's
            wi_l = warp.sample(u2)
            pdf = warp.pdf(wi_l)
        else:
            wi_l = np.asarray(bsdf.distribution(wo_l).sample(u2))
            pdf = bsdf.pdf(wo_l, wi_l)
        wi = fr.to_world(wi_l)
        hits, le = self.trace(p, fr.n, wi)
        return bsdf.eval(wo_l, wi_l), le, pdf, wi, hits

    def _light_sample(self, bsdf, p, fr, wo_l, u3):
        j, w, pdf, front, y = self.lights.sample(p, u3)
        pdf = pdf.astype(F32)
        le = self._light_emission(p, fr.n, w, j, front, y)
        wi_l = fr.to_local(w)
        return bsdf.eval(wo_l, wi_l), le, pdf, wi_l, j

    def _light_emission(self, p, n, w, j, front, y) -> np.ndarray:
        """Emission of light j reaching ``p`` along light samples ``w``: a shadow ray to the
        light's first point ``y`` where ``LightSet.sample`` knows it, else a trace that
        counts only light j itself (see the module docstring)."""
        if self.lights.simple:
            return self.shadow(p, n, w, y, j, front)
        hits, le = self.trace(p, n, w)
        hit_light = self.light_of_shape[np.maximum(hits.shape, 0)]
        return scale(le, (hits.shape >= 0) & (hit_light == j))

    def light_pdf(self, p: np.ndarray, w: np.ndarray, hits) -> np.ndarray:
        """P_k p_k(w): selection probability x solid-angle pdf of the light ``hits`` belong to
        (0 where no light is hit)."""
        j = np.where(hits.shape >= 0, self.light_of_shape[np.maximum(hits.shape, 0)], -1)
        return self.lights.pdf(p, w, j, hits.p)


def __getattr__(name: str):
    """``vrlab.render.direct.render`` is :func:`vrlab.render.film.render` (moved there)."""
    if name == "render":
        from .film import render
        return render
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
