"""The scene side of direct lighting: geometry, BSDFs, lights and the rays between them.

:class:`DirectLighting` holds what every shading point needs (Mitsuba 3's ``direct``
integrator, one bounce): the scene's geometry, one BSDF model per group of shapes with the
same material, the lights (:class:`~vrlab.render.light_set.LightSet`, selection ``"uniform"``,
``"power"`` or ``"bvh"``) and the two kinds of rays leaving a surface.  It holds no estimator: the
integral over directions at shading points is :class:`~vrlab.render.shading.ShadingIntegrand`,
and the estimator objects of :mod:`vrlab.estimators` act on it (:mod:`vrlab.render.pixels`).

Rays: camera rays are intersected with the whole scene.  Rays leaving a surface only
need the emitter they reach.  Directional samples (:meth:`DirectLighting.trace`) intersect
the emitters in full and test the other shapes for a closer hit (distance only) where
they reach one; light samples towards spheres, rectangles and disks
(:meth:`DirectLighting.unblocked`) know the light's first point y and only test that no
other shape is in front of it.  A blocker must be closer than the emitter by
``SHADOW_EPS`` = 1e-4 (relative; Mitsuba likewise shortens its shadow rays by a relative
epsilon).

Precision: rays, hit points, frames, BSDF values, sphere-light cones and
rectangle-light samples are float32, as in Mitsuba's scalar variants (NumPy runs float32
2-3x faster; the formulas used are the stable ones, see ``SphereCone`` and ``GGX``); light
selection keeps float64 uniforms, the other lights (cubes, ellipsoids, disks) are sampled
in float64 and rounded, and pixel estimates are accumulated in float64.

Emitting surfaces reflect other lights through their BSDF like any surface, as in
Mitsuba; an emitter without a ``<bsdf>`` is black (Mitsuba's behaviour), and black
BSDFs are skipped.  The camera is the scene's sensor element (its ``pixel_rays``).  ``obj`` emitters cannot be sampled by the ``"light"``
technique (the techniques ``"bsdf"``, ``"cosine"`` and ``"uniform"`` reach them).
``render`` lives in :mod:`vrlab.render.film`.
"""
from __future__ import annotations

import numpy as np

from .. import checks
from .._vec import dot, rows_by_key, scale, side
from .accel.geometry import Hits, SceneGeometry
from .light_set import LIGHT_SELECTIONS, LightSet
from .scene import Scene

__all__ = ["DirectLighting"]

F32 = np.float32
SHADOW_EPS = 1e-4             # a blocker must be this much closer (relative) than the emitter


class DirectLighting:
    """A scene's geometry, camera, BSDF groups and lights, and the rays of direct lighting.

    ``light_selection``: how the ``"light"`` technique picks a light (``"uniform"``,
    ``"power"`` or ``"bvh"``); ``kernels``: ``"numpy"`` or ``"numba"``, the ray queries' and the
    light BVH walk's (:mod:`vrlab.kernels`).  ``lights`` is None when the scene has no emitters;
    ``light_error`` says why light sampling is unavailable (no emitters, or ``obj`` emitters), for the
    ``"light"`` technique to report.
    """

    def __init__(self, scene: Scene, light_selection: str = "uniform", kernels: str = "numpy"):
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a vrlab.render.Scene, got {type(scene).__name__}")
        checks.choice(light_selection, "light_selection", LIGHT_SELECTIONS)
        self.light_selection = light_selection
        #: the kernels of the per-sample path (the render plan's resolved choice: "numpy" or "numba")
        self.kernels = kernels
        # hits need their triangle only on meshes with smooth normals or textures
        prim = any(s.has_barycentrics and (s.has_shading_normals or s.bsdf.textures or
                                                   (s.emitter is not None and s.emitter.texture is not None))
                   for s in scene.shapes)
        self.geometry = SceneGeometry(scene, track_prim=prim, kernels=kernels)
        emits = np.array([s.emitter is not None for s in scene.shapes], bool)
        # rays leaving a surface only need the first emitter they meet and whether a
        # non-emitter blocks it: two smaller geometries (see ``trace``; the emitters' below)
        # (the whole scene's geometry where no shape emits: the same primitives, built once)
        self.blocker_geometry = self.geometry if not emits.any() else \
            SceneGeometry(scene, np.flatnonzero(~emits), track_prim=prim, kernels=kernels)
        self.camera = scene.sensor
        self.hide_emitters = bool(scene.integrator.hide_emitters)
        self.shading = bool(scene.integrator.shading)
        shapes = scene.shapes
        # shapes with equal BSDFs are shaded together (one batch per distinct BSDF)
        keys = [s.bsdf.key() for s in shapes]
        distinct = {k: g for g, k in enumerate(dict.fromkeys(keys))}
        self.group_of_shape = np.array([distinct[k] for k in keys], dtype=np.int64)
        first = [keys.index(k) for k in distinct]
        self.bsdfs = [shapes[i].bsdf for i in first]      # one model per group
        # the Lambertian albedo per group (None for a textured BSDF: per point, at shading time)
        self.kd = [None if b.textures else np.asarray(b.diffuse_albedo(), float) for b in self.bsdfs]
        self.twosided = np.array([b.twosided for b in self.bsdfs], dtype=bool)
        #: uniforms of one BSDF sample in this scene: 2, or 3 where some BSDF picks its lobe after
        #: its microfacet normal (roughdielectric); the others read the first two
        self.bsdf_dim_u = max([2] + [int(b.dim_u) for b in self.bsdfs])
        #: every lobe name of the scene's BSDFs (techniques "bsdf:<name>"; of density 0 where a
        #: BSDF has no such lobe)
        self.lobe_names = tuple(dict.fromkeys(n for b in self.bsdfs for n in b.LOBES))
        self.is_emitter = emits
        #: emitting shapes whose radiance is a texture (shape index -> texture)
        self.emitter_textures = {k: s.emitter.texture for k, s in enumerate(shapes)
                                 if s.emitter is not None and s.emitter.texture is not None}
        #: shapes whose shading normals differ from the geometric ones (meshes with vertex normals)
        self.smooth = [k for k, s in enumerate(shapes) if s.has_shading_normals]
        self.smooth_emitters = [k for k in self.smooth if shapes[k].emitter is not None]
        self.shapes = shapes
        # black BSDFs reflect nothing; with a path of depth 1 nothing is shaded
        self.shaded = np.array([self.shading and not s.bsdf.is_black() for s in shapes], dtype=bool)
        self.radiance = np.array([s.emitter.mean_radiance if s.emitter is not None else np.zeros(3)
                                  for s in shapes], F32)
        self.eps = 1e-5              # ray offset, relative to 1 + max|p| (float32 hit decisions)
        self.lights: LightSet | None = None
        self.light_error = "the scene has no emitters"
        free = list(scene.free_emitters)
        envs = [e for e in free if e.is_infinite and not e.is_delta]
        if len(envs) > 1:
            raise ValueError(f"emitters: a scene takes at most one environment emitter (as in Mitsuba), got "
                             f"{', '.join(e.plugin_name for e in envs)}")
        self.env_shape = len(shapes)            # the shape index of rays that leave the scene
        self.env_light = -1                     # the light index of the environment, if any
        if emits.any() or free:
            try:
                self.lights = LightSet(shapes, light_selection, free, radius=max(self.geometry.scale, 1e-6),
                                       kernels=kernels)
            except ValueError as exc:            # an emitting shape without light sampling
                self.light_error = str(exc)
        # split mesh lights ("bvh": a leaf per triangle) need the exact triangle of each hit
        split = [] if self.lights is None else self.lights.shape_of_light[self.lights.split].tolist()
        self.emitter_geometry = SceneGeometry(scene, np.flatnonzero(emits), track_prim=prim or bool(split),
                                              unmerged=split, kernels=kernels)
        #: whether some light's samples must not be hidden by their own light (split meshes)
        self.self_occluding = bool(split)
        if self.lights is not None:
            self.light_of_shape = np.append(self.lights.light_of_shape, -1)
            if envs:
                self.env_light = int(emits.sum()) + free.index(envs[0])
                self.light_of_shape[-1] = self.env_light
            self._radiance_of_light = np.concatenate([np.zeros((1, 3), F32), self.lights.radiance32])
        else:                                    # BSDF samples still see the emitting shapes
            n_lights = int(emits.sum())
            self._radiance_of_light = np.zeros((n_lights + 1, 3), F32)     # row 0: j = -1, none
            self._radiance_of_light[1:] = self.radiance[emits]
            self.light_of_shape = np.full(len(shapes) + 1, -1)
            self.light_of_shape[np.flatnonzero(emits)] = np.arange(n_lights)
        #: the environment emitter (constant, envmap) seen by rays that leave the scene, or None
        self.environment = envs[0] if envs else None
        self.radiance = np.concatenate([self.radiance, np.zeros((1, 3), F32)])      # + the environment's row

    def build(self) -> None:
        """Build the geometries' lazily built structures now (:meth:`SceneGeometry.build`)."""
        for geo in {id(g): g for g in (self.geometry, self.blocker_geometry, self.emitter_geometry)}.values():
            geo.build()

    def pixel_hits(self, sub: int = 4) -> np.ndarray:
        """(H*W, sub*sub): the shape hit by each of ``sub`` x ``sub`` camera rays through a pixel
        (stratum centres; pixels in raster order; negative where a ray leaves the scene). For
        masks of pixels that see one shape only, or see a light."""
        sub = checks.integer(sub, "sub", low=1)
        h, w = self.camera.height, self.camera.width
        rows, cols = np.divmod(np.arange(h * w), w)
        pix = np.broadcast_to(np.stack([rows, cols], -1)[:, None, :], (h * w, sub * sub, 2))
        g = (np.arange(sub) + 0.5) / sub
        off = np.broadcast_to(np.stack(np.meshgrid(g, g), -1).reshape(1, -1, 2), (h * w, sub * sub, 2))
        o, d = self.camera.pixel_rays(pix, off)
        return self.geometry.intersect(o.reshape(-1, 3), d.reshape(-1, 3)).shape.reshape(h * w, sub * sub)

    def facing(self, hits: Hits, d: np.ndarray) -> np.ndarray:
        """Whether each hit's surface faces the ray ``d`` (the side an area light emits to): by
        the shading normal on meshes with vertex normals, as Mitsuba's ``area`` emitter judges
        it (``cos_theta(si.wi) > 0`` in the shading frame), else by the geometric normal."""
        front = dot(hits.n, d) < 0
        if self.smooth_emitters:
            for k, rows in rows_by_key(hits.shape, self.smooth_emitters):
                ns = self.shapes[k].shading_normals(hits.p[rows], hits.n[rows], hits.prim[rows])
                front[rows] = dot(ns, np.take(d, rows, axis=0)) < 0
        return front

    def shading_normals(self, hits: Hits) -> np.ndarray | None:
        """Shading normals of camera hits (None where every shape shades with its geometric normal)."""
        if not self.smooth:
            return None
        ns = hits.n.copy()
        for k, rows in rows_by_key(hits.shape, self.smooth):
            ns[rows] = self.shapes[k].shading_normals(hits.p[rows], hits.n[rows], hits.prim[rows])
        return ns

    def tangents(self, group: int, hits: Hits, rows) -> tuple[np.ndarray, np.ndarray] | None:
        """World ``(dp_du, dp_dv)`` ``(N, 3)`` at the camera hits ``rows`` when BSDF group
        ``group`` needs a tangent frame (anisotropic roughness, normal and bump maps), else
        None.  Shapes without a surface parametrisation give the tangents of
        :func:`~vrlab.distributions.orthonormal_basis`."""
        if not self.bsdfs[group].needs_tangents:
            return None
        from ..distributions.frames import orthonormal_basis

        shape, p, prim, n = hits.shape[rows], hits.p[rows], hits.prim[rows], hits.n[rows]
        du, dv = (np.empty((len(shape), 3)) for _ in range(2))
        for k, sel in rows_by_key(shape, np.unique(shape)):
            try:
                du[sel], dv[sel] = self.shapes[k].uv_derivatives(p[sel], prim[sel], n[sel])
            except ValueError:                           # no uv: Mitsuba's coordinate system of n
                du[sel], dv[sel] = orthonormal_basis(np.asarray(n[sel], float))
        return du, dv

    def bsdf_values(self, group: int, hits: Hits, rows) -> dict | None:
        """The textured parameters of BSDF group ``group`` at the camera hits ``rows``
        (``{name: (N, 3)}``), or None for an untextured BSDF: each shape's textures are
        looked up at its surface points (Mitsuba's uv, triangle and barycentrics)."""
        bsdf = self.bsdfs[group]
        textures = bsdf.textures
        if not textures:
            return None
        scalar, grad = bsdf.SCALAR_TEXTURES, bsdf.GRADIENT_TEXTURES
        shape, p, prim = hits.shape[rows], hits.p[rows], hits.prim[rows]
        out = {a: np.empty((len(shape),) if a in scalar else (len(shape), 2 if a in grad else 3)) for a in textures}
        for k, sel in rows_by_key(shape, np.unique(shape)):
            si = self.surface_points(k, p[sel], prim[sel])
            for a, tex in textures.items():
                out[a][sel] = tex.eval_1(si) if a in scalar else tex.eval_1_grad(si) if a in grad else tex.eval(si)
        return out

    def surface_points(self, k: int, p: np.ndarray, prim: np.ndarray | None):
        """The :class:`~vrlab.render.textures.SurfacePoints` of points ``p`` on shape ``k``
        (triangles ``prim`` of a mesh): Mitsuba's uv, barycentrics, the shape and ``p``."""
        from .textures import SurfacePoints

        s = self.shapes[k]
        prim = np.zeros(len(p), np.int64) if prim is None else prim
        bary = s.barycentrics(p, prim)
        return SurfacePoints(s.uv(p, prim), prim, bary, s, p)

    def textured_radiance(self, shape: np.ndarray, p: np.ndarray, prim: np.ndarray | None,
                          le: np.ndarray) -> np.ndarray:
        """``le`` with the rows on emitters of textured radiance (``shape``: their shape index;
        points ``p``) replaced by the texture's value there."""
        for k, tex in self.emitter_textures.items():
            rows = np.flatnonzero(shape == k)
            if len(rows):
                si = self.surface_points(k, np.asarray(p[rows], float), None if prim is None else prim[rows])
                le[rows] = tex.eval(si)
        return le

    def light_radiance(self, j: np.ndarray) -> np.ndarray:
        """L_e of lights ``j`` ``(R, 3)`` float32 (0 for j = -1)."""
        return np.take(self._radiance_of_light, np.asarray(j) + 1, axis=0)

    def light_hit(self, hits: Hits) -> np.ndarray:
        """The light index of each hit (-1 on a miss or a non-emitter; the environment's for a
        ray that left the scene, shape ``env_shape``)."""
        return np.where(hits.shape >= 0, self.light_of_shape[np.maximum(hits.shape, 0)], -1)

    # ------------------------------------------------------------------ tracing
    def emitted(self, hits, d: np.ndarray) -> np.ndarray:
        """One-sided emitted radiance ``(N, 3)`` seen along ``d`` at ``hits``."""
        front = (hits.shape >= 0) & self.facing(hits, d)
        le = np.take(self.radiance, np.maximum(hits.shape, 0), axis=0)
        if self.emitter_textures:
            le = self.textured_radiance(hits.shape, hits.p, hits.prim, le)
        if self.environment is not None:
            env = np.flatnonzero(hits.shape == self.env_shape)
            if len(env):
                le[env] = self.environment.radiance(np.take(hits.p, env, axis=0), np.take(d, env, axis=0))
        return scale(le, front)

    def escaped(self, hits: Hits, o: np.ndarray, d: np.ndarray, rows: np.ndarray) -> None:
        """Mark the rays ``rows`` (which met nothing) as reaching the environment, in place:
        shape ``env_shape``, normal -d (facing the ray), t = inf."""
        if self.environment is None or not len(rows):
            return
        hits.shape[rows] = self.env_shape
        hits.n[rows] = -np.take(d, rows, axis=0)
        hits.p[rows] = np.take(o, rows, axis=0) + 1e30 * np.take(d, rows, axis=0)

    def trace(self, p: np.ndarray, n: np.ndarray, w: np.ndarray, cost=None) -> tuple[Hits, np.ndarray]:
        """The emitter seen by rays leaving surface points ``p`` (normal ``n``) along ``w``
        and its emission: ``(hits, L_e)`` with ``hits`` the first *emitter* hit of each ray
        (shape -1 where there is none or where a non-emitter blocks it, i.e. is closer by
        more than ``SHADOW_EPS`` relative).  Direct lighting needs nothing else from these
        rays, so only the emitters are intersected in full and the blockers only for rays
        that reach an emitter, without their hit data.  The origin is offset off the
        surface to ``w``'s side.  ``cost``: a :class:`~vrlab.render.cost.Cost` counting
        one closest-hit ray per row (the emitter query and the blocker test are one ray)."""
        if cost is not None:
            cost.closest_rays += len(p)
        o = self._origin(p, n, w)
        hits = self.emitter_geometry.intersect(o, w)
        if self.environment is not None:         # rays that meet no emitter may reach the environment
            self.escaped(hits, o, w, np.flatnonzero(hits.shape < 0))
        le = self.emitted(hits, w)
        seen = np.flatnonzero(hits.shape >= 0)
        if len(seen) and self.blocker_geometry.n_shapes:
            t_max = hits.t[seen] * (1.0 - SHADOW_EPS)
            if len(seen) < len(o):
                blocked = self.blocker_geometry.occluded(np.take(o, seen, axis=0), np.take(w, seen, axis=0), t_max)
            else:
                blocked = self.blocker_geometry.occluded(o, w, t_max)
            hidden = seen[blocked]
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

    def unblocked(self, p: np.ndarray, n: np.ndarray, w: np.ndarray, y: np.ndarray, j: np.ndarray,
                  cost=None) -> np.ndarray:
        """Whether light ``j`` is the first thing seen from ``p`` along ``w`` when ``y`` is its
        first point along w (``LightSet.sample`` with ``simple`` lights): no non-emitter is
        closer than y by more than ``SHADOW_EPS`` (relative; a distance query without hit
        data) and the first emitter met is light j itself (decided by index, not distance:
        near a sphere's silhouette its float32 t is too rough to compare).  For split mesh
        lights (a triangle per light-BVH leaf) y must be the first point of the mesh itself:
        no emitter, j included, is closer than y by more than ``SHADOW_EPS``.  ``cost``: a
        :class:`~vrlab.render.cost.Cost` counting one shadow (any-hit) ray per row."""
        if cost is not None:
            cost.shadow_rays += len(p)
        o = self._origin(p, n, w)
        t_max = dot(y - o, w)
        t_max *= 1.0 - SHADOW_EPS
        visible = np.ones(len(o), bool)
        if self.blocker_geometry.n_shapes:
            visible &= ~self.blocker_geometry.occluded(o, w, t_max)
        if self.emitter_geometry.n_shapes > 1 or self.self_occluding or \
                (self.emitter_geometry.n_shapes and self.lights.is_emitter.any()):
            # another emitter in front of light j (or, for split meshes, any part of j itself)
            te, se = self.emitter_geometry.distance(o, w, with_shape=True)
            own = se == self.lights.shape_of_light[j]
            if self.self_occluding:
                own &= ~self.lights.split[j]
            visible &= own | (te >= t_max)
        return visible


