"""All lights of a scene and how one is picked per shading point.

* :class:`LightSet`: the lights (:mod:`vrlab.render.lights`) plus the light-selection table
  (uniform, or by power = the flux, pi x mean radiance x area for emitting shapes, through an
  ``AliasTable``), or, with ``"bvh"``, pbrt-v4's light BVH: P_j depends on the shading point
  and its normal (:mod:`vrlab.render.light_tree`); there an emissive triangle mesh is *split*:
  each triangle is a leaf, (j, t) ~ P(j, t | p, n), w is sampled towards triangle t and the
  density is P(j, t | p, n) p_t(w) for the mesh's first triangle t along w (see
  :meth:`LightSet.sample` for why that convention, not the sum over the ray's hits of
  :meth:`~vrlab.render.lights.Light.pdf`, keeps closed or layered meshes unbiased).  When every
  emitter is black, power selection has nothing to weigh: it falls back to uniform selection and
  the lights contribute zero, as they do under any selection (a black image, as in Mitsuba).
  ``sample`` draws (light j, direction) pairs with density P_j p_j(w); all sphere lights are
  sampled in one batched call, so scenes with hundreds of spheres cost no Python loop per light.
* ``LightSet.cos_integrals``: the closed-form unoccluded integral of cos(theta) over
  the directions that reach each light, for control variates (each shape's
  ``cos_integral``: Lambert's polygon formula for rectangles, the cone of a sphere).
  Where no closed form applies ``valid`` is False.
"""
from __future__ import annotations

import numpy as np

from .. import checks
from .._vec import dot, norm
from ..distributions import AliasTable, SphereCone
from .lights import EmitterLight, Light
from .shapes import Shape
from .shapes.sphere import sphere_cos_integral

__all__ = ["LIGHT_SELECTIONS", "LightSet"]

from ..limits import LIGHT_SELECTIONS  # noqa: E402  (the one list of names, shared with the CLI)


def _rows_by_light(j: np.ndarray, which: np.ndarray):
    """``(i, rows)`` for each light i with ``which[i]`` that occurs in ``j`` (-1: none);
    rows is ``slice(None)`` when every row is light i (no gathers)."""
    counts = np.bincount(j + 1, minlength=len(which) + 1)[1:]
    for i in np.flatnonzero(counts * which):
        yield i, (slice(None) if counts[i] == len(j) else np.flatnonzero(j == i))


class LightSet:
    """All lights of a scene and the selection probabilities P_j (see the module docstring):
    the emitting shapes (indices 0.. in shape order) then the other ``emitters`` (point, spot,
    directional, constant, envmap, ...); ``radius``: of a sphere around the scene (power of
    lights at infinity).  Selection weights are multiplied by each emitter's
    ``sampling_weight``.  ``kernels``: the light BVH walk's and the mesh lights' sampling towards
    given triangles (``"numpy"`` or ``"numba"``)."""

    def __init__(self, shapes: list[Shape], selection: str = "uniform", emitters=(), radius: float = 1.0, *,
                 kernels: str = "numpy"):
        checks.choice(selection, "light_selection", LIGHT_SELECTIONS)
        if isinstance(shapes, (str, bytes)) or not all(isinstance(s, Shape) for s in shapes):
            raise TypeError(f"shapes must be a list of vrlab.render.Shape, got {shapes!r:.60}")
        self.light_of_shape = np.full(len(shapes), -1)
        self.lights: list = []
        weights = []
        for k, s in enumerate(shapes):
            if s.emitter is not None:
                self.light_of_shape[k] = len(self.lights)
                self.lights.append(Light(s, kernels=kernels))
                weights.append(s.emitter.sampling_weight)
        self.shape_of_light = np.flatnonzero(self.light_of_shape >= 0)
        for e in emitters:
            self.lights.append(EmitterLight(e, radius))
            weights.append(e.sampling_weight)
        self.shape_of_light = np.concatenate([self.shape_of_light, np.full(len(emitters), -1)]).astype(np.int64)
        if not self.lights:
            raise ValueError("the scene has no emitters to sample")
        self.radiance = np.array([l.radiance for l in self.lights])
        self.radiance32 = self.radiance.astype(np.float32)
        self.is_sphere = np.array([l.sphere is not None for l in self.lights])
        self.is_delta = np.array([l.is_delta for l in self.lights], bool)
        self.is_emitter = np.array([isinstance(l, EmitterLight) for l in self.lights])
        self.is_infinite = np.array([l.is_infinite for l in self.lights], bool)
        self.centers = np.array([l.sphere[0] if l.sphere is not None else np.zeros(3) for l in self.lights])
        self.radii = np.array([l.sphere[1] if l.sphere is not None else 1.0 for l in self.lights])
        self.signs = np.array([l.sign for l in self.lights])
        self.centers32, self.radii32 = self.centers.astype(np.float32), self.radii.astype(np.float32)
        #: lights whose triangles are leaves of the light BVH (``"bvh"``: every mesh light)
        self.split = np.array([selection == "bvh" and "method" in l.directions for l in self.lights], bool)
        #: every light gives its first point y along a sampled w (spheres, planar and non-shape
        #: lights, and split meshes: a point on one triangle)
        self.simple = all(l.sphere is not None or l.planar or s for l, s in zip(self.lights, self.split))
        weights = np.array(weights, float)
        power = np.array([l.power for l in self.lights])
        if selection == "power" and power.sum() > 0:     # every emitter black: nothing to weigh, uniform
            weights = weights * power
        if not weights.sum() > 0:
            raise ValueError("sampling_weight: every emitter has sampling_weight 0 (or no power): none can be "
                             "sampled")
        self.selection = AliasTable(weights)
        #: pbrt-v4's light BVH (``"bvh"``): P_j per shading point; else None (``selection``'s P_j)
        self.tree = None
        if selection == "bvh":
            from .light_tree import BVHSelection

            self.tree = BVHSelection(self.lights, weights, power, self.split, kernels=kernels)

    def __len__(self) -> int:
        return len(self.lights)

    def __iter__(self):
        return iter(self.lights)

    def __getitem__(self, j: int):
        return self.lights[j]

    def _select(self, ref: np.ndarray, n, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(j, P, t)``: the light chosen by ``u (m,)``, its selection probability (j = -1,
        P = 0 where the light BVH finds no light that can reach the point) and, for a split
        mesh light, the triangle chosen with it (P = P(j, t | p, n)); t = -1 otherwise."""
        if self.tree is not None:
            return self.tree.sample(ref, n, u)
        j = self.selection.sample(u)
        return j, self.selection.pmf(j), np.full(len(j), -1)

    def selection_pmf(self, ref: np.ndarray, j: np.ndarray, n=None, t=None) -> np.ndarray:
        """P_j at points ``ref`` (normals ``n``; None: none) for light indices ``j`` (-1: 0); for
        split mesh lights P(j, t | p, n) of triangles ``t`` (None: the marginal over t)."""
        if self.tree is not None:
            return self.tree.pmf(ref, n, j, t)
        return np.where(j >= 0, self.selection.pmf(np.maximum(j, 0)), 0.0)

    def sample(self, ref: np.ndarray, u3: np.ndarray, n: np.ndarray | None = None,
               triangles: bool = False) -> tuple[np.ndarray, ...]:
        """``(j, w, pdf, front, y, le)`` for uniforms ``u3 (m, 3)``: light j ~ P (``u3[:, 0]``),
        a direction towards it (``u3[:, 1:3]``), pdf = P_j p_j(w) (solid angle; P_j for a
        delta light), whether light j emits towards ``ref`` there, its first point y along w
        (see :meth:`Light.sample`; NaN where unknown) and ``le``, the radiance arriving along
        w (None when every light is a shape with a constant radiance: the caller's table).
        ``n``: the points' normals, for ``"bvh"`` selection (None: no normal); with it, j may be
        -1 (no light can reach the point: pdf 0, not in front).

        Split mesh lights (``"bvh"``: one leaf per triangle, :mod:`vrlab.render.light_tree`):
        (j, t) ~ P(j, t | p, n), then w towards triangle t; pdf = P(j, t | p, n) p_t(w) and y
        the sampled point on t.  That pdf is the density of the light technique *restricted
        to samples whose triangle t is the first thing seen along w* (the renderer's shadow
        test of these rows also rejects the mesh itself in front of y): a sample on a far or
        hidden triangle of a closed mesh contributes 0, and every direction that reaches the
        mesh's first triangle t* has density P(j, t* | p, n) p_t*(w), the value :meth:`pdf`
        gives a BSDF sample that hit t*.  So the estimator is unbiased and MIS weights sum to
        1 (both techniques on the space of (light, first triangle, w)), with no sum over the
        ray's hits as in :meth:`Light.pdf`.  ``triangles``: also return t, the triangle of each
        split light's sample (-1 for the other rows), as a seventh array."""
        j, pj, t = self._select(ref, n, u3[:, 0])
        none = j < 0
        if none.any():                    # light 0 stands in for the direction; its pdf is zeroed
            out = (j,) + self._directions(ref, u3, np.maximum(j, 0), np.where(none, 0.0, pj), none, t)
        else:
            out = (j,) + self._directions(ref, u3, j, pj, None, t)
        return out + (np.where(none, -1, t),) if triangles else out

    def _directions(self, ref, u3, j, pj, none=None, t=None) -> tuple[np.ndarray, ...]:
        """``(w, pdf, front, y, le)`` of :meth:`sample` for chosen lights ``j`` with selection
        probabilities ``pj`` (rows ``none``: no light, pdf 0 and not in front; ``t``: the
        triangles of split lights)."""
        n = len(ref)
        if len(self.lights) == 1 and not self.is_sphere[0] and not self.is_emitter[0] \
                and not self.split[0]:                                          # no gathers
            w, pdf, front, y = self.lights[0].sample(ref, u3[:, 1:3])
            if none is not None:
                front = front & ~none
            return w.astype(ref.dtype, copy=False), pdf * pj, front, y, None
        w = np.zeros_like(ref)
        pdf = np.zeros(n)
        front = np.ones(n, bool)
        y = np.full((n, 3), np.nan, ref.dtype)
        le = None
        sph = self.is_sphere[j]
        if sph.any():                            # all sphere lights in one batched cone
            m = slice(None) if sph.all() else np.flatnonzero(sph)
            jm = j[m]
            cone = self._cones(jm, ref[m])
            s = cone.sample_point(u3[m, 1:3].astype(ref.dtype))
            w[m], pdf[m], y[m] = s.w, s.pdf, s.y
            front[m] = self.signs[jm] * dot(s.y - cone.center, s.w) < 0
        for i, m in _rows_by_light(j, ~self.is_sphere):
            if self.is_emitter[i]:
                if le is None:
                    le = np.take(self.radiance32, j, axis=0)
                w[m], pdf[m], front[m], y[m], le[m] = self.lights[i].sample(ref[m], u3[m, 1:3])
            elif self.split[i]:
                tm = t[m]
                if none is not None:                 # rows without a light stand in with triangle 0
                    tm = np.maximum(tm, 0)
                w[m], pdf[m], front[m], y[m] = self.lights[i].sample_triangle(ref[m], u3[m, 1:3], tm)
            else:
                w[m], pdf[m], front[m], y[m] = self.lights[i].sample(ref[m], u3[m, 1:3])
        if none is not None:
            front &= ~none
        return w, pdf * pj, front, y, le

    def pdf(self, ref: np.ndarray, w: np.ndarray, j: np.ndarray, hit_p: np.ndarray | None = None,
            n: np.ndarray | None = None, prim: np.ndarray | None = None) -> np.ndarray:
        """P_j p_j(w) for light indices ``j`` (-1: no light, density 0; a delta light: P_j);
        ``hit_p``: where each ray met light j, if known (see :meth:`Light.pdf`; for a sphere
        it means w is in its cone, so only the cone's solid angle is needed); ``n``: the
        points' normals (``"bvh"`` selection; None: no normal).  Split mesh lights: P(j, t* | p,
        n) p_t*(w) with t* the first triangle of mesh j along w (see :meth:`sample`): ``prim``
        (with ``hit_p``), the triangle each ray met, else found by intersecting the mesh."""
        out = np.zeros(len(ref))
        tri = None
        has = j >= 0
        sph = has & self.is_sphere[np.maximum(j, 0)]
        if sph.any():
            m = slice(None) if sph.all() else np.flatnonzero(sph)
            if hit_p is None:
                out[m] = self._cones(j[m], ref[m]).pdf(w[m])
            else:               # the ray met sphere j, so w is in its cone: 1 / solid angle
                c, r = self._spheres(j[m], ref)
                out[m] = 1.0 / (2.0 * np.pi * SphereCone.cone_size(norm(c - ref[m]), r))
        for i, m in _rows_by_light(j, ~self.is_sphere):
            if self.split[i]:
                if tri is None:
                    tri = np.full(len(ref), -1)
                known = None if hit_p is None or prim is None else prim[m]
                out[m], tri[m] = self.lights[i].pdf_triangle(ref[m], w[m], known)
            else:
                out[m] = self.lights[i].pdf(ref[m], w[m], None if hit_p is None else hit_p[m])
        return out * self.selection_pmf(ref, j, n, tri)

    def first_points(self, ref: np.ndarray, w: np.ndarray, j: np.ndarray) -> np.ndarray:
        """The first point along ``w`` of the non-shape lights ``j`` (NaN for other rows): a
        delta light is reached only along its direction, which no traced ray can hit."""
        y = np.full_like(ref, np.nan)
        for i, m in _rows_by_light(j, self.is_emitter):
            y[m] = self.lights[i].first_point(ref[m], w[m])
        return y

    def point_normals(self, y: np.ndarray, j: np.ndarray, t: np.ndarray | None = None,
                      shading: bool = False) -> np.ndarray:
        """Unit normals ``(m, 3)`` of shape lights ``j`` at their points ``y``, on the side
        they emit to (as ``Light.sample`` judges it: a sphere's outward normal times its sign,
        a planar light's surface normal; a split mesh light's triangle ``t``: its winding
        normal, or with ``shading`` and vertex normals the shading normal at y, which decides
        where it faces); zeros for the other rows (non-shape lights, j = -1)."""
        out = np.zeros(np.shape(y), np.float64)
        y = np.asarray(y, np.float64)
        j = np.asarray(j)
        sphere = (j >= 0) & self.is_sphere[np.maximum(j, 0)]
        if sphere.any():                  # every sphere light at once: sign (y - centre) / radius
            m = slice(None) if sphere.all() else np.flatnonzero(sphere)
            js = j[m]
            sign, centre, radius, ym = self.signs[js], self.centers[js], self.radii[js], y[m]
            n = np.empty_like(ym)
            for k in range(3):            # column by column (vrlab._vec): (y - c) sign / r
                np.subtract(ym[:, k], centre[:, k], out=n[:, k])
                n[:, k] *= sign
                n[:, k] /= radius
            out[m] = n
        for i, m in _rows_by_light(j, ~self.is_emitter & ~self.is_sphere):
            light = self.lights[i]
            if self.split[i] and t is not None:           # the triangle is known: O(1)
                out[m] = light.triangle_normals(y[m], np.maximum(np.asarray(t)[m], 0), shading)
            else:
                out[m] = light.surface.normal(y[m])
        return out

    def emitter_radiance(self, ref: np.ndarray, w: np.ndarray, j: np.ndarray, le: np.ndarray) -> np.ndarray:
        """``le`` (area lights' constant radiance by ``j``) with the rows of non-shape lights
        replaced by their radiance arriving at ``ref`` along ``w``."""
        for i, m in _rows_by_light(j, self.is_emitter):
            le[m] = self.lights[i].emitter.radiance(ref[m], w[m])
        return le

    def _spheres(self, j: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Centres and radii of sphere lights ``j`` in ``ref``'s precision (float32 for the
        renderer: the cone formulas are stable, see ``SphereCone``)."""
        f32 = ref.dtype == np.float32
        return (self.centers32 if f32 else self.centers)[j], (self.radii32 if f32 else self.radii)[j]

    def _cones(self, j: np.ndarray, ref: np.ndarray) -> SphereCone:
        """The cones of sphere lights ``j`` from ``ref``."""
        return SphereCone(*self._spheres(j, ref), ref)

    def cos_integrals(self, ref: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(I, valid)``, both ``(m, lights)``: every light's closed-form unoccluded
        int cos dw from ``ref`` with normal ``n`` (:meth:`Light.cos_integral`); sphere
        lights are done together on ``(m, lights)`` arrays."""
        m, L = len(ref), len(self.lights)
        out, valid = np.zeros((m, L)), np.zeros((m, L), bool)      # textured lights: no closed form
        s = np.flatnonzero(self.is_sphere)
        if len(s):                                       # (m, S) at once
            out[:, s], valid[:, s] = sphere_cos_integral(self.centers[s], self.radii[s], ref[:, None], n[:, None])
        for i in np.flatnonzero(~self.is_sphere):
            out[:, i], valid[:, i] = self.lights[i].cos_integral(ref, n)
        valid[:, self.is_emitter] = False
        valid[:, [l.textured for l in self.lights]] = False
        return out, valid
