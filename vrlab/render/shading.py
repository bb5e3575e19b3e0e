"""Direct lighting at shading points as an integrand, with its techniques as distributions.

At a surface point p with normal n, BSDF f_r and outgoing direction wo, direct lighting is

    L_d(p) = sum_j int L_e,j(w) V_j(p, w) f_r(wo, w) cos(theta_w) dw,

light j contributing where it is the first thing seen along w (V_j) and faces p.  The
points of this integrand are directions *with the light they reach*, ``x = (w_x, w_y,
w_z, j, k + 1)`` (world direction, light index as a float, j = -1 for none; k = -1, or the
index of the BSDF's delta lobe that produced w, stored as k + 1): the measure is solid angle times counting
over lights, so ``f(w, j) = f_r cos L_e,j V_j``, plus counting over the atoms of delta
lights (one direction each) and of delta BSDF lobes (a smooth mirror or refraction: one
direction per wo, k >= 0, where f is the lobe's integral of f_r |cos|, ``delta_value``).  This is what
lets every technique be an ordinary distribution with an exact density (Veach 1997, 9.2:
MIS needs every technique's pdf at every sample):

* ``"bsdf"``, ``"cosine"``, ``"uniform"``: w from the BSDF's lobes / cos/pi / 1/(2 pi) on the
  hemisphere of n, and j = the light first seen along w (a traced ray).  Density
  p(w) [j is first seen along w]: at a light sample hidden behind something it is 0.  At a
  delta lobe's atom the ``"bsdf"`` density is the lobe's probability P_k(wo), the others' 0.
* ``"bsdf:<lobe>"`` for each lobe of a BSDF with several (``LOBES``): that lobe alone
  (density 1 at its atom for a delta lobe), for MIS or one-sample MIS over lobes.
* ``"light"``: light j with probability P_j (``light_selection``), then w towards it
  (spheres by their cone, other shapes by area, converted to solid angle, counting every
  hit of the ray with light j).  Density P_j p_j(w), occluded or not; 0 at delta lobes' atoms.

Named extras for the estimators (:class:`vrlab.Integrand` ``controls`` / ``targets``):

* control ``"lambertian"``: h(w, j) = (k_d/pi) L_e,j cos(theta_w) where w meets light j,
  unoccluded, for lights with a closed form (``LightSet.cos_integrals``: rectangles above
  the horizon, spheres); its integral is (k_d/pi) sum_j L_e,j int_{Omega_j} cos dw.  Only
  the ``"light"`` technique covers h's support (a BSDF sample never lands on a hidden
  light), so use it with ``distribution="light"``;
* target ``"unshadowed"``: p̂(w, j) = Y(f_r cos) Y(L_e,j) where light j faces p
  (Y = luminance), the RIS target of Talbot et al. (2005) without the shadow ray.

Every evaluation at a point a technique has just sampled reuses that sample's ray
(a cache keyed on the sample array, cleared per batch): one ray per sample, as a
hand-written MIS loop would trace.  Points from elsewhere (a mixture's select, a
reservoir's pick) are traced again; the values are the same, only slower.
"""
from __future__ import annotations

import numpy as np

from .._vec import dot, scale, side
from ..distributions import Frame
from ..integrands.base import Integrand
from ..colour import luminance
from .cost import Cost
from .techniques import F32, NO_SAMPLE, _Directional, _LightTechnique, _Lobe


def checked_outputs(vals, estimator, rows: int | None) -> np.ndarray:
    """An estimator's unit outputs at ``rows`` shading points (``(..., rows, units, columns)``;
    None: a spatial estimator's own layout) as a real array, all finite (one reduction; a user's
    estimator is duck-typed): ``TypeError`` / ``ValueError`` naming the ``estimator`` instead of
    a complex value cast to real or a NaN in the image."""
    a = np.asarray(vals)
    label = getattr(estimator, "label", type(estimator).__name__)
    if a.dtype.kind not in "biuf":
        raise TypeError(f"estimator: {label} returned {a.dtype} unit outputs; they must be real numbers")
    if rows is not None and (a.ndim < 3 or a.shape[-3] != rows):
        raise ValueError(f"estimator: {label} returned unit outputs of shape {a.shape} for {rows} shading points; "
                         "expected (..., points, units, columns)")
    if a.size and not np.isfinite(np.add.reduce(a, axis=None)):
        bad = ~np.isfinite(a)
        if bad.any():
            raise ValueError(f"estimator: {label} returned {int(bad.sum())} non-finite unit output(s) "
                             f"(first: {a[tuple(np.argwhere(bad)[0])]}) of {a.size}")
    return a


class _Rows:
    """What is known about the rows (samples) of one point array: directions, lights, rays."""

    __slots__ = ("x", "w", "wl", "j", "lobe", "first", "front", "le", "le_raw", "y", "hit_p", "hit_prim", "tri",
                 "pdfs", "bsdf_done", "light_done")

    def __init__(self, x, w, wl, j, lobe=None):
        self.x, self.w, self.wl, self.j = x, w, wl, j
        self.lobe = lobe                  # None: every row a continuous point (k = -1)
        self.first = self.front = self.le = self.le_raw = self.y = self.hit_p = self.hit_prim = self.tri = None
        self.pdfs: dict = {}
        #: whether the rows' BSDF / light value and density are counted (vrlab.render.cost): by the
        #: technique that sampled them, or by their first evaluation
        self.bsdf_done = self.light_done = False


class ShadingIntegrand(Integrand):
    """Direct lighting at ``N`` shading points sharing one BSDF (see the module docstring).

    ``lighting``: the scene's :class:`~vrlab.render.direct.DirectLighting`; ``group``: the
    BSDF group; ``p``, ``n``, ``wo`` (N, 3): points, unit geometric normals and outgoing
    directions (world); ``ns``: unit shading normals (default ``n``; a mesh's interpolated
    vertex normals), whose frame the BSDF is evaluated in, as in Mitsuba.  Points ``x (N, m, 5)``
    (direction, light, delta lobe); values ``(3, N, m)`` (RGB first: a batch axis).  ``cost``:
    the :class:`~vrlab.render.cost.Cost` of the work unit, which the rays, samples and
    evaluations made here are added to (None: a counter of its own, ``self.cost``).
    """

    def __init__(self, lighting, group: int, p: np.ndarray, n: np.ndarray, wo: np.ndarray,
                 ns: np.ndarray | None = None, values: dict | None = None, tangents: tuple | None = None,
                 cost: Cost | None = None):
        self.lighting = lighting
        self.cost = Cost() if cost is None else cost
        p, n, wo = (np.asarray(a, F32) for a in (p, n, wo))
        ns = n if ns is None else np.asarray(ns, F32)
        flip = side(dot(wo, ns)) if lighting.twosided[group] else None
        if flip is not None:
            ns = scale(ns, flip)
        self.p, self.n, self.ns = p, n, ns      # geometric normals offset the rays, shading ones give the frame
        if tangents is None:
            self.frame = Frame._trusted(ns)     # hit normals are unit vectors (geometry normalises them)
        else:
            self.frame, local = self._tangent_frame(ns, flip, *tangents)
            local["n_geo"] = self.frame.to_local(n)                 # bump maps turn their normal to its side
            values = {**(values or {}), **local}
        self._values = values
        self._bsdf = lighting.bsdfs[group]
        # a textured BSDF at these points (one row each); untextured: the group's own
        self.bsdf = self._bsdf if values is None else self._bsdf.at(values)
        self._bsdf_rows: dict = {}
        self.wo_l = self.frame.to_local(wo)
        self.kd = lighting.kd[group] if values is None else np.asarray(self.bsdf.diffuse_albedo(), float)
        self.name, self.domain, self.dim, self.volume = "direct lighting", "directions x lights", 5, 4 * np.pi
        self.bounds, self.exact, self.f2, self.theory = None, None, None, {}
        self._valid = self._lambertian_value = None            # the control's integral: on first use
        self._cache: dict[int, _Rows] = {}
        self.used: set[str] = set()

    @staticmethod
    def _tangent_frame(ns, flip, dp_du, dp_dv) -> tuple[Frame, dict]:
        """Mitsuba's shading frame: s = dp_du made orthogonal to n (Gram-Schmidt), t = n x s
        (with the unflipped n for a twosided BSDF seen from the back: Mitsuba mirrors z only);
        and the local ``dp_du``, ``dp_dv`` for the BSDF's ``at``."""
        from ..distributions.frames import tangent_towards

        n64 = np.asarray(ns, np.float64)
        s = tangent_towards(n64, dp_du)
        n_up = n64 if flip is None else n64 * flip[:, None]
        t = np.cross(n_up, s)
        frame = Frame._trusted(ns, s.astype(F32), t.astype(F32))
        local = {"dp_du": frame.to_local(np.asarray(dp_du, F32)), "dp_dv": frame.to_local(np.asarray(dp_dv, F32))}
        return frame, local

    # Techniques, controls and targets are built on access.  Stored, they would close reference
    # cycles (integrand -> technique -> integrand) that keep every batch's rays alive until the
    # cyclic garbage collector runs: about 3.5 MB of page faults per tile in a fresh worker.
    @property
    def techniques(self) -> dict:
        out = {"bsdf": _Directional(self, None), "cosine": _Directional(self, "cosine"),
               "uniform": _Directional(self, "uniform"), "light": _LightTechnique(self)}
        out.update({f"bsdf:{name}": _Lobe(self, name) for name in self.lighting.lobe_names})
        return out

    @property
    def controls(self) -> dict:
        return {"lambertian": (self._lambertian, self._lambertian_value)}

    @property
    def targets(self) -> dict:
        return {"unshadowed": self._unshadowed}

    def technique(self, name: str, arg: str = "distribution"):
        """The technique ``name`` (see :attr:`techniques`), remembering that it was asked for
        (``used``: the renderer refuses an estimator whose techniques miss some emitter).
        Built alone (the hot path: estimators resolve their techniques at every batch)."""
        if name in ("bsdf", "cosine", "uniform"):
            tech = _Directional(self, None if name == "bsdf" else name)
        elif name == "light":
            tech = _LightTechnique(self)
        else:
            tech = super().technique(name, arg)
        self.used.add(name)
        return tech

    def f(self, x: np.ndarray) -> np.ndarray:
        r = self.rows(x)
        return self._rgb(self.bsdf_value(x, r) * self.emission(r), x)

    def bsdf_value(self, x: np.ndarray, r: "_Rows") -> np.ndarray:
        """f_r |cos theta_i| at the rows' directions ``(R, 3)``; at a delta lobe's atom (k >= 0)
        the lobe's ``delta_value`` instead."""
        bsdf, wo = self.bsdf_for(x.shape[-2]), self.rep(self.wo_l, x)
        self.count_bsdf(r)
        v = bsdf.eval(wo, r.wl)
        if r.lobe is not None:
            for k in np.unique(r.lobe[r.lobe >= 0]):
                d = np.broadcast_to(bsdf.delta_value(bsdf.LOBES[k], wo)[1], v.shape)
                v = np.where((r.lobe == k)[:, None], d, v).astype(v.dtype, copy=False)
            v = np.where((r.lobe == NO_SAMPLE)[:, None], v.dtype.type(0), v)
        return v

    def uniform(self):
        return _Directional(self, "uniform")

    def count_bsdf(self, r: "_Rows") -> None:
        """Count the rows' BSDF evaluation (value and density: once per row, none for rows the
        BSDF sampled)."""
        if not r.bsdf_done:
            self.cost.bsdf_evals += len(r.j)
            r.bsdf_done = True

    def count_light(self, r: "_Rows") -> None:
        """Count the rows' light evaluation (radiance and density: once per row that reaches a
        light, none for light samples)."""
        if not r.light_done:
            self.cost.emitter_evals += int(np.count_nonzero(r.j >= 0))
            r.light_done = True

    def control(self, name: str, arg: str = "control") -> tuple:
        h, integral = super().control(name, arg)
        if integral is None:
            integral = self._lambertian_value = self._lambertian_integral()
        return h, integral

    def bsdf_for(self, m: int):
        """The BSDF for the rows of point arrays with ``m`` samples per point (a textured
        BSDF's per-point parameters repeated ``m`` times)."""
        if self._values is None or m == 1:
            return self.bsdf
        if m not in self._bsdf_rows:
            self._bsdf_rows[m] = self._bsdf.at({k: np.repeat(v, m, axis=0) for k, v in self._values.items()})
        return self._bsdf_rows[m]

    # ---------------------------------------------------------------- rows of a point array
    @staticmethod
    def rep(a: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Per-point ``a (N, ...)`` repeated for the m samples of each point of ``x (N, m, .)``."""
        m = x.shape[-2]
        return a if m == 1 else np.repeat(a, m, axis=0)

    def rep_frame(self, m: int) -> Frame:
        fr = self.frame
        return fr if m == 1 else Frame._trusted(*(np.repeat(a, m, axis=0) for a in (fr.n, fr.t, fr.b)))

    @staticmethod
    def _rgb(values: np.ndarray, x: np.ndarray) -> np.ndarray:
        """RGB rows ``(R, 3)`` as values ``(3, *x.shape[:-1])``."""
        return values.T.reshape((3,) + x.shape[:-1])          # a view when each point has one sample

    def new_points(self, w: np.ndarray, j: np.ndarray, shape: tuple,
                   lobe: np.ndarray | None = None) -> tuple[np.ndarray, _Rows]:
        """Sample points ``x (*shape, 5)`` from rows ``w (R, 3)``, ``j (R,)`` and delta lobes
        ``lobe (R,)`` (None: all -1), with their cached rows."""
        x = np.empty((len(w), 5), F32)
        x[:, :3] = w
        x[:, 3] = j
        x[:, 4] = 0 if lobe is None else lobe + 1          # stored as k + 1: zeros are continuous points
        x = x.reshape(shape + (5,))
        r = _Rows(x, w, None, j, None if lobe is None or not np.any(lobe != -1) else lobe)
        self._cache[id(x)] = r
        return x, r

    def rows(self, x: np.ndarray) -> _Rows:
        """The cached rows of a technique's own sample array, or new rows for other points."""
        r = self._cache.get(id(x))
        if r is None or r.x is not x:
            x = np.asarray(x)
            if x.ndim != 3 or x.shape[0] != len(self.p) or x.shape[-1] != 5:
                raise ValueError(f"x: expected points (N={len(self.p)}, m, 5) (direction, light, delta lobe), "
                                 f"got {x.shape}")
            w = np.asarray(x[..., :3], F32).reshape(-1, 3)
            j = np.rint(np.asarray(x[..., 3], float)).astype(np.int64).reshape(-1)
            lobe = np.rint(np.asarray(x[..., 4], float)).astype(np.int64).reshape(-1) - 1
            r = _Rows(x, w, None, j, lobe if np.any(lobe != -1) else None)
            self._cache[id(x)] = r
        if r.wl is None:
            r.wl = self.rep_frame(x.shape[-2]).to_local(r.w)
        return r

    def first_seen(self, r: _Rows) -> np.ndarray:
        """[light j (-1: none) is the first thing seen along w] per row: one ray, cached.  Rows
        with a known first point y of their light (light samples; points on non-shape lights,
        which a traced ray cannot meet: a delta light) take a shadow ray to it; the others
        trace the ray."""
        if r.first is None:
            x, lit = r.x, self.lighting
            p, n = self.rep(self.p, x), self.rep(self.n, x)
            front_known = r.front is not None
            if r.y is None and lit.lights is not None and lit.lights.is_emitter.any():
                r.y = lit.lights.first_points(p, r.w, r.j)          # NaN for the other rows
            known = np.zeros(len(r.j), bool) if r.y is None else ~np.isnan(r.y[:, 0])
            if known.all():                                          # shadow rays only
                r.first = lit.unblocked(p, n, r.w, r.y, r.j, cost=self.cost)
                if not front_known:
                    r.front = np.ones(len(r.j), bool)
                return r.first
            whole = not known.any()
            rows = slice(None) if whole else np.flatnonzero(~known)
            hits, _ = lit.trace(p[rows], n[rows], r.w[rows], cost=self.cost)
            first = lit.light_hit(hits) == r.j[rows]
            if whole:
                r.hit_p, r.hit_prim = hits.p, hits.prim
            else:
                if r.hit_p is None:
                    r.hit_p = np.full((len(r.j), 3), np.nan, p.dtype)
                    r.hit_prim = np.full(len(r.j), -1)
                r.hit_p[rows] = hits.p
                if hits.prim is not None and r.hit_prim is not None:
                    r.hit_prim[rows] = hits.prim
            # the traced first hit decides the facing (a light sample on a closed or open mesh
            # may lie on a far or back face: its light is seen from the front only)
            front = lit.facing(hits, r.w[rows])
            if not front_known:
                if whole:
                    r.front = front
                else:
                    r.front = np.ones(len(r.j), bool)
                    r.front[rows] = front
            else:
                r.front = r.front.copy()
                r.front[rows] &= front | (r.j[rows] < 0)
            if not whole:
                k = np.flatnonzero(known)
                all_first = np.zeros(len(r.j), bool)
                all_first[rows] = first
                all_first[k] = lit.unblocked(p[k], n[k], r.w[k], r.y[k], r.j[k], cost=self.cost)
                first = all_first
            r.first = first
        return r.first

    def unshadowed_emission(self, r: _Rows) -> np.ndarray:
        """L_e,j arriving along each row's w, without visibility: a light sample's own value,
        else the light's radiance (non-shape lights: their radiance along w, e.g. I / d^2)."""
        if r.le_raw is not None:
            return r.le_raw
        self.count_light(r)
        lit = self.lighting
        le = lit.light_radiance(r.j)
        if lit.lights is not None and lit.lights.is_emitter.any():
            le = lit.lights.emitter_radiance(self.rep(self.p, r.x), r.w, r.j, le.copy())
        return le

    def emission(self, r: _Rows) -> np.ndarray:
        """L_e,j V_j reaching the points along each row ``(R, 3)``."""
        if r.le is None:
            lit = self.lighting
            seen = self.first_seen(r) & r.front & (r.j >= 0)
            le = self.unshadowed_emission(r)
            if lit.emitter_textures:                  # textured radiance at the light's point
                y = r.y if r.hit_p is None else r.hit_p if r.y is None else \
                    np.where(np.isnan(r.y[:, :1]), r.hit_p, r.y)            # the light's point along w
                shape = np.where(r.j >= 0, lit.lights.shape_of_light[np.maximum(r.j, 0)], -1) \
                    if lit.lights is not None else np.full(len(r.j), -1)
                le = lit.textured_radiance(np.where(seen, shape, -1), np.nan_to_num(y), None, le.copy())
            r.le = scale(le, seen)
        return r.le

    def light_pdf(self, r: _Rows) -> np.ndarray:
        """P_j p_j(w) per row (cached)."""
        if "light" not in r.pdfs:
            lit = self.lighting
            if lit.lights is None:
                r.pdfs["light"] = np.zeros(len(r.j), F32)
            else:
                self.count_light(r)
                if lit.lights.tree is not None:              # P_j of a reached light: a walk
                    self.cost.light_walks += int(np.count_nonzero(r.j >= 0))
                r.pdfs["light"] = lit.lights.pdf(self.rep(self.p, r.x), r.w, r.j, r.hit_p,
                                                 self.rep(self.n, r.x), r.hit_prim).astype(F32)
                if r.lobe is not None:                       # no light sample is a delta lobe's atom
                    r.pdfs["light"][r.lobe != -1] = 0
        return r.pdfs["light"]

    # ---------------------------------------------------------------- named extras
    def _lambertian(self, x: np.ndarray) -> np.ndarray:
        r = self.rows(x)
        lit = self.lighting
        if lit.lights is None or not np.any(self.kd > 0) or len(self.p) == 0:
            return np.zeros((3,) + x.shape[:-1])
        if self._valid is None:
            self.control("lambertian")
        jj = np.maximum(r.j, 0)
        valid = self.rep(self._valid, x)[np.arange(len(jj)), jj] & (r.j >= 0) & (self.light_pdf(r) > 0)
        if r.lobe is not None:                               # h lives on the continuous part
            valid &= r.lobe == -1
        kd = self.kd if self.kd.ndim == 1 else self.rep(self.kd, x)          # per point when textured
        g = (kd / np.pi) * lit.light_radiance(r.j) * np.clip(r.wl[:, 2:3], 0.0, None)
        return self._rgb(scale(g, valid), x)

    def _lambertian_integral(self) -> np.ndarray:
        lit = self.lighting
        if lit.lights is None or not np.any(self.kd > 0) or len(self.p) == 0:
            return np.zeros((3, len(self.p)))
        integral, self._valid = lit.lights.cos_integrals(self.p, self.ns)          # (N, L)
        return ((self.kd / np.pi) * ((integral * self._valid) @ lit.lights.radiance)).T

    def _unshadowed(self, x: np.ndarray) -> np.ndarray:
        r = self.rows(x)
        if r.front is None:          # not a sample of a technique: the traced ray decides the facing
            self.first_seen(r)
        t = luminance(self.bsdf_value(x, r)) * luminance(self.unshadowed_emission(r))
        return np.where(r.front & (r.j >= 0), np.maximum(t, 0.0), 0.0).reshape(x.shape[:-1])
