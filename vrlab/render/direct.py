"""Vectorised direct-lighting renderer (Mitsuba 3 ``direct`` integrator, one bounce).

``render(scene, spp, strategy, rng=...)`` returns ``(image, stderr)``, both ``(H, W, 3)``
float32: the per-pixel mean of ``spp`` independent samples and its standard error.

One pixel sample uses 8 uniforms ``u`` (drawn for all strategies, so strategies share
their random numbers for the same seed): ``u[0:2]`` the position in the pixel (box
filter), ``u[2:4]`` a BSDF/cosine direction, ``u[4]`` the light choice, ``u[5:7]`` a
point on that light (``u[7]`` is unused).  Its value is

* the emitted radiance of the first hit, one-sided: emitters emit on their normal's
  side only (``flip_normals`` turns them around);
* plus, at a hit on a non-emitting surface, one estimate of the direct lighting
  ``int f_r L_e cos dw`` with ``strategy``:

  - ``"cosine"``: wi ~ cos/pi (CosineHemisphere about the normal);
  - ``"bsdf"``: wi ~ ``bsdf.distribution(wo)``;
  - ``"light"``: light j with probability P_j (``light_selection``: ``"uniform"`` or
    ``"power"`` = mean radiance x area, an AliasTable), then wi towards a point of j
    sampled by area (SolidAngleFromArea: p_w = sum over hits of p_A d^2/|cos|; spheres
    use SphereCone), pdf P_j p_j(wi);
  - ``"mis-balance"``/``"mis-power"``: one light sample + one BSDF sample combined with
    ``vrlab.estimators.mis.mis_weights`` (n_i = 1).  The light density of a BSDF-sampled
    direction is P_k p_k(wi) for the light k it hits; the BSDF density of a light
    direction is ``bsdf.pdf``.

  Every direction is traced to its closest hit; the sample counts the one-sided
  emission found there (for ``"light"`` only if the hit belongs to the chosen light, so
  that each light's contribution has exactly one sampling density).

Emitting surfaces are not shaded (their BSDF is ignored; Mitsuba would add their
reflection of other lights).  Lights may be rectangles, cubes, disks, spheres and
ellipsoids; ``obj`` emitters work with ``"cosine"`` and ``"bsdf"`` only.
"""
from __future__ import annotations

import numpy as np

from .._rng import RNGLike, as_generator
from ..distributions import (
    AliasTable,
    BoxSurface,
    CosineHemisphere,
    UniformHemisphere,
    EllipsoidSurface,
    RectangleSurface,
    SphereCone,
    to_local,
    to_world,
)
from ..distributions.surfaces import Surface
from ..estimate import Moments
from ..estimators.mis import mis_weights
from .bsdfs import BSDFModel, Diffuse, Phong, RoughConductor
from .camera import Camera
from .pixel_samplers import PIXEL_SAMPLERS, PixelSampler  # noqa: F401  (re-exported for the CLI)
from .geometry import SceneGeometry
from .scene import BSDF, Scene, Shape

__all__ = ["STRATEGIES", "DirectLighting", "make_bsdf", "render"]

STRATEGIES = ("uniform", "cosine", "bsdf", "light", "mis-balance", "mis-power", "mixture")
LIGHT_SELECTIONS = ("uniform", "power")
DIMS = 8                      # uniforms per pixel sample
_RAYS_PER_CHUNK = 1 << 16
_COSINE = CosineHemisphere()
_UNIFORM = UniformHemisphere()


def make_bsdf(desc: BSDF) -> BSDFModel:
    """The :mod:`vrlab.render.bsdfs` model of a scene ``BSDF`` description."""
    p = desc.params
    if desc.type == "diffuse":
        return Diffuse(p["reflectance"])
    if desc.type == "roughconductor":
        return RoughConductor(p["alpha"], p["distribution"])
    if desc.type == "phong":
        return Phong(p["diffuse_reflectance"], p["specular_reflectance"], p["exponent"])
    raise ValueError(f"bsdf type {desc.type!r} is not supported; allowed: diffuse, roughconductor, phong")


def _safe_ratio(num: np.ndarray, pdf: np.ndarray) -> np.ndarray:
    """num / pdf[..., None], 0 where the pdf is 0 or not finite."""
    ok = (pdf > 0) & np.isfinite(pdf)
    return np.where(ok[..., None], num / np.where(ok, pdf, 1.0)[..., None], 0.0)


class _DiskSurface(Surface):
    """Uniform points on the disk c + M (x, y, 0), x^2 + y^2 <= 1 (affine maps keep uniformity)."""

    max_hits = 1

    def __init__(self, shape: Shape):
        self.center, self.a1, self.a2, self.unit_normal = shape.disk()
        self.minv = np.linalg.inv(shape.to_world[:3, :3])
        self.area = float(np.pi * np.linalg.norm(np.cross(self.a1, self.a2)))

    def bounding_sphere(self):
        return self.center, float(max(np.linalg.norm(self.a1), np.linalg.norm(self.a2)))

    def sample(self, u):
        r, phi = np.sqrt(u[..., 0:1]), 2 * np.pi * u[..., 1:2]
        return self.center + r * np.cos(phi) * self.a1 + r * np.sin(phi) * self.a2

    def pdf(self, x):
        return np.full(np.shape(x)[:-1], 1.0 / self.area)

    def normal(self, x):
        return np.broadcast_to(self.unit_normal, np.shape(x)).copy()

    def intersect(self, origin, direction, t_min=None):
        o, d = self._rays(origin, direction)
        ol, dl = (o - self.center) @ self.minv.T, d @ self.minv.T
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -ol[..., 2] / dl[..., 2]
        ok = np.isfinite(t) & (t > self._t_min(t_min))
        x = ol[..., :2] + np.where(ok, t, 0.0)[..., None] * dl[..., :2]
        ok &= np.sum(x * x, -1) <= 1.0
        return np.where(ok, t, np.inf)[..., None]


class _Light:
    """An emitting shape as a direction sampler from reference points."""

    def __init__(self, shape: Shape):
        self.radiance = np.asarray(shape.emitter.radiance, float)
        self.sphere = None
        if shape.type == "sphere":
            self.sphere = shape.sphere()
            self.area = 4 * np.pi * self.sphere[1] ** 2
            return
        if shape.type == "rectangle":
            self.surface = RectangleSurface.from_matrix(shape.to_world, shape.flip_normals)
        elif shape.type == "cube":
            self.surface = BoxSurface.from_matrix(shape.to_world)
        elif shape.type == "ellipsoid":
            self.surface = EllipsoidSurface.from_matrix(shape.to_world)
        elif shape.type == "disk":
            self.surface = _DiskSurface(shape)
        else:
            raise ValueError(f"light sampling of {shape.type!r} emitters is not supported; use "
                             "strategy 'cosine' or 'bsdf', or rectangle/cube/disk/sphere/ellipsoid lights")
        self.area = self.surface.area

    def sample(self, ref: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Directions ``(m, 3)`` from ``ref (m, 3)`` and their solid-angle pdf ``(m,)``."""
        if self.sphere is not None:
            cone = SphereCone(self.sphere[0], self.sphere[1], ref)
            w = cone.sample(u)
            return w, cone.pdf(w)
        s = self.surface.solid_angle_from(ref).sample_point(u)
        return s.w, s.pdf

    def pdf(self, ref: np.ndarray, w: np.ndarray) -> np.ndarray:
        if self.sphere is not None:
            return SphereCone(self.sphere[0], self.sphere[1], ref).pdf(w)
        return self.surface.solid_angle_from(ref).pdf(w)


class DirectLighting:
    """The radiance of camera rays under one strategy (see the module docstring)."""

    def __init__(self, scene: Scene, strategy: str = "mis-power", light_selection: str = "uniform"):
        if strategy not in STRATEGIES:
            raise ValueError(f"strategy: unknown {strategy!r}; allowed: {', '.join(STRATEGIES)}")
        if light_selection not in LIGHT_SELECTIONS:
            raise ValueError(f"light_selection: unknown {light_selection!r}; allowed: "
                             f"{', '.join(LIGHT_SELECTIONS)}")
        self.strategy = strategy
        self.geometry = SceneGeometry(scene)
        self.camera = Camera(scene.sensor)
        shapes = scene.shapes
        self.bsdfs = [make_bsdf(s.bsdf) for s in shapes]
        self.twosided = np.array([s.bsdf.twosided for s in shapes])
        self.is_emitter = np.array([s.emitter is not None for s in shapes])
        self.radiance = np.array([s.emitter.radiance if s.emitter is not None else np.zeros(3)
                                  for s in shapes], float)
        self.eps = 1e-7
        self.light_of_shape = np.full(len(shapes), -1)
        self.lights: list[_Light] = []
        if strategy in ("cosine", "bsdf") or not self.is_emitter.any():
            return
        for k, s in enumerate(shapes):
            if s.emitter is not None:
                self.light_of_shape[k] = len(self.lights)
                self.lights.append(_Light(s))
        if light_selection == "uniform":
            weights = np.ones(len(self.lights))
        else:
            weights = np.array([max(l.radiance.mean(), 0.0) * l.area for l in self.lights])
        self.selection = AliasTable(weights)

    # ------------------------------------------------------------------ tracing
    def emitted(self, hits, d: np.ndarray) -> np.ndarray:
        """One-sided emitted radiance ``(N, 3)`` seen along ``d`` at ``hits``."""
        front = (hits.shape >= 0) & (np.sum(hits.n * d, -1) < 0)
        return np.where(front[:, None], self.radiance[np.maximum(hits.shape, 0)], 0.0)

    def trace(self, p: np.ndarray, n: np.ndarray, w: np.ndarray):
        """Closest hits of rays leaving surface points ``p`` (normal ``n``) along ``w``,
        and the emission seen; the origin is offset off the surface to ``w``'s side."""
        side = np.where(np.sum(w * n, -1) < 0, -1.0, 1.0)
        offset = self.eps * (1.0 + np.max(np.abs(p), -1)) * side
        hits = self.geometry.intersect(p + offset[:, None] * n, w)
        return hits, self.emitted(hits, w)

    def radiance_of(self, o: np.ndarray, d: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Radiance samples ``(N, 3)`` of rays ``(N, 3)`` with their uniforms ``u (N, DIMS)``."""
        hits = self.geometry.intersect(o, d)
        out = self.emitted(hits, d)
        shade = (hits.shape >= 0) & ~self.is_emitter[np.maximum(hits.shape, 0)]
        for k in np.unique(hits.shape[shade]):
            m = np.flatnonzero(hits.shape == k)
            out[m] += self.direct(k, hits.p[m], hits.n[m], -d[m], u[m])
        return out

    # ------------------------------------------------------------------ direct lighting
    def direct(self, k: int, p: np.ndarray, n: np.ndarray, wo: np.ndarray, u: np.ndarray) -> np.ndarray:
        """One estimate ``(m, 3)`` of the direct lighting at points ``p`` of shape ``k``."""
        bsdf = self.bsdfs[k]
        if self.twosided[k]:
            n = np.where((np.sum(wo * n, -1) < 0)[:, None], -n, n)
        wo_l = to_local(wo, n)
        s = self.strategy
        if s in ("uniform", "cosine", "bsdf"):
            warp = {"uniform": _UNIFORM, "cosine": _COSINE}.get(s)
            f, le, pdf, _, _ = self._bsdf_sample(bsdf, p, n, wo_l, u[:, 2:4], warp=warp)
            return _safe_ratio(f * le, pdf)
        if not self.lights:
            return np.zeros((len(p), 3))
        if s == "mixture":
            return self._mixture(bsdf, p, n, wo_l, u)
        f_l, le_l, q_l, wi_l = self._light_sample(bsdf, p, n, wo_l, u[:, 4:7])
        if s == "light":
            return _safe_ratio(f_l * le_l, q_l)
        heuristic = "balance" if s == "mis-balance" else "power"
        q_b_at_l = bsdf.pdf(wo_l, wi_l)
        w_l = mis_weights(np.stack([q_l, q_b_at_l], -1), heuristic)[:, 0]
        f_b, le_b, q_b, wi_b, hits_b = self._bsdf_sample(bsdf, p, n, wo_l, u[:, 2:4])
        q_l_at_b = self.light_pdf(p, wi_b, hits_b)
        w_b = mis_weights(np.stack([q_l_at_b, q_b], -1), heuristic)[:, 1]
        return (w_l[:, None] * _safe_ratio(f_l * le_l, q_l)
                + w_b[:, None] * _safe_ratio(f_b * le_b, q_b))

    def _mixture(self, bsdf, p, n, wo_l, u):
        """One-sample mixture (Russian lecture 4): with probability 1/2 a BSDF sample, else a
        light sample (uniform ``u[:, 7]`` decides); either way divide by the mixture density
        p(w) = 1/2 p_bsdf(w) + 1/2 sum_j P_j p_j(w) (the balance heuristic, one sample)."""
        out = np.zeros((len(p), 3))
        b = np.flatnonzero(u[:, 7] < 0.5)
        if len(b):
            f_b, le_b, q_b, wi_b, hits_b = self._bsdf_sample(bsdf, p[b], n[b], wo_l[b], u[b, 2:4])
            out[b] = _safe_ratio(f_b * le_b, 0.5 * q_b + 0.5 * self.light_pdf(p[b], wi_b, hits_b))
        li = np.flatnonzero(u[:, 7] >= 0.5)
        if len(li):
            f_l, le_l, q_l, wi_l = self._light_sample(bsdf, p[li], n[li], wo_l[li], u[li, 4:7])
            out[li] = _safe_ratio(f_l * le_l, 0.5 * q_l + 0.5 * bsdf.pdf(wo_l[li], wi_l))
        return out

    def _bsdf_sample(self, bsdf, p, n, wo_l, u2, warp=None):
        if warp is not None:  # a fixed hemisphere warp (uniform or cosine) instead of the BSDF's
            wi_l = warp.sample(u2)
            pdf = warp.pdf(wi_l)
        else:
            wi_l = np.asarray(bsdf.distribution(wo_l).sample(u2))
            pdf = bsdf.pdf(wo_l, wi_l)
        wi = to_world(wi_l, n)
        hits, le = self.trace(p, n, wi)
        return bsdf.eval(wo_l, wi_l), le, pdf, wi, hits

    def _light_sample(self, bsdf, p, n, wo_l, u3):
        j = self.selection.sample(u3[:, 0])
        w = np.zeros_like(p)
        pdf = np.zeros(len(p))
        for i in np.unique(j):
            m = np.flatnonzero(j == i)
            w[m], pdf[m] = self.lights[i].sample(p[m], u3[m, 1:3])
        pdf = pdf * self.selection.pmf(j)
        hits, le = self.trace(p, n, w)
        hit_light = self.light_of_shape[np.maximum(hits.shape, 0)]
        le = np.where(((hits.shape >= 0) & (hit_light == j))[:, None], le, 0.0)
        wi_l = to_local(w, n)
        return bsdf.eval(wo_l, wi_l), le, pdf, wi_l

    def light_pdf(self, p: np.ndarray, w: np.ndarray, hits) -> np.ndarray:
        """P_k p_k(w): selection probability x solid-angle pdf of the light ``hits`` belong to
        (0 where no light is hit)."""
        j = np.where(hits.shape >= 0, self.light_of_shape[np.maximum(hits.shape, 0)], -1)
        out = np.zeros(len(p))
        for i in np.unique(j[j >= 0]):
            m = np.flatnonzero(j == i)
            out[m] = self.selection.pmf(i) * self.lights[i].pdf(p[m], w[m])
        return out


def render(scene: Scene, spp: int | None = None, strategy: str = "mis-power", *, rng: RNGLike = None,
           pixel_sampler: str = "independent", chunk_pixels: int | None = None,
           light_selection: str = "uniform") -> tuple[np.ndarray, np.ndarray]:
    """Render ``scene`` with direct lighting: ``(image, stderr)``, both ``(H, W, 3)`` float32.

    ``spp`` samples per pixel (default: the scene's sampler ``sample_count``); ``strategy``
    one of :data:`STRATEGIES`; ``rng`` seeds everything.  Pixels are processed in blocks of
    ``chunk_pixels`` (default: about 65536 rays per block); the uniforms are drawn
    pixel after pixel from one stream, so the image does not depend on the block size.
    ``stderr`` is the per-pixel standard error sqrt(s^2 / spp) (NaN when spp = 1).
    """
    spp = scene.sensor.spp if spp is None else int(spp)
    if spp < 1:
        raise ValueError(f"spp must be >= 1, got {spp}")
    if chunk_pixels is None:
        chunk_pixels = max(1, _RAYS_PER_CHUNK // spp)
    if int(chunk_pixels) < 1:
        raise ValueError(f"chunk_pixels must be >= 1, got {chunk_pixels}")
    chunk_pixels = int(chunk_pixels)
    gen = as_generator(rng)
    # uniforms per sample: pixel position (0, 1), direction (2, 3), light choice (4), light point (5, 6)
    sampler = PixelSampler(pixel_sampler, spp, DIMS, gen, groups=[(0, 1), (2, 3), (5, 6)])
    integrator = DirectLighting(scene, strategy, light_selection)
    height, width = scene.sensor.height, scene.sensor.width
    rows, cols = np.divmod(np.arange(height * width), width)
    pixels = np.stack([rows, cols], -1)
    mean = np.zeros((height * width, 3))
    stderr = np.zeros((height * width, 3))
    for a in range(0, height * width, chunk_pixels):
        pix = pixels[a:a + chunk_pixels]
        u = sampler.draw(len(pix))
        o, d = integrator.camera.pixel_rays(pix[:, None, :], u[..., :2])
        values = integrator.radiance_of(o.reshape(-1, 3), d.reshape(-1, 3), u.reshape(-1, DIMS))
        mom = Moments().add(np.moveaxis(values.reshape(len(pix), spp, 3), 1, -1))
        mean[a:a + len(pix)] = mom.mean
        with np.errstate(invalid="ignore"):
            stderr[a:a + len(pix)] = np.sqrt(mom.variance / spp)
    shape = (height, width, 3)
    return mean.reshape(shape).astype(np.float32), stderr.reshape(shape).astype(np.float32)
