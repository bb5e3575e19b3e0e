"""Spatial reuse in the renderer: the pixels of a block as one view for spatial estimators
(``Estimator.spatial``; :class:`vrlab.estimators.ReSTIR`, Bitterli et al. 2020, weighted as
generalized RIS, Lin et al. 2022).

Units.  A spatial unit is one sample index over every pixel of a block (the pixels
:meth:`PixelIntegrand.outputs` gets together: by default a whole tile of
:data:`~vrlab.render.film.TILE_PIXELS` consecutive pixels, see ``film.plan``).  Its uniforms
are the pixels' own uniforms for that sample index, so a unit is a deterministic function of
its uniforms and the image is the same for any worker count or executor.  Pixels of
different blocks are never combined; the sample indices of a block are independent units,
so a pixel's mean and standard error over its spp stay honest.  Pixels of the same block and
the same sample index are *correlated* (a pixel's reservoir is reused by its neighbours): an
error bar of an image region is not its pixels' errors combined as if independent.  The
image depends on the block size (``chunk_pixels``), not on how blocks are run.

Samples are light points.  A candidate of pixel b is a ``"light"`` technique sample at its
shading point p_b (any ``light_selection``), kept as x = (y, j, t): the point y on light j
(the light's position for delta lights, a direction for lights at infinity) and, for a mesh
light split into triangles by the light BVH, the triangle t (its normal without a search).  A sample of pixel s
moves to pixel c by *reconnection*, w_c = normalize(y - p_c), whose Jacobian between the
solid-angle measures of the two pixels is

    J_{s->c}(y) = G_c(y) / G_s(y),   G_b(y) = |cos theta_y,b| / |y - p_b|^2

(theta_y,b the angle at the light between its normal at y and p_b - y; the solid angle at p_b
is G_b dA_y).  J = 1 for delta lights and lights at infinity (the shift is the identity in
their counting / direction measure).  At the receiving pixel c both the target (the
unshadowed contribution, luminance of f_r |cos| times that of L_e, where the light faces p_c:
RIS's ``"unshadowed"``) and f_c itself (with a shadow ray from p_c to y:
:meth:`~vrlab.render.direct.DirectLighting.unblocked`) are re-evaluated.

Neighbours: the integer offsets o with 0 < |o| <= radius in image coordinates, one picked
uniformly per neighbour slot; a neighbour outside the block (or the image) is *missing*: it
counts M = 0, so that pixel reuses fewer than k samples, which the pairwise and balance
weights handle (sum to 1 over the present contributors).  Not wrapped around.

Scenes: the lights must give their sampled point (spheres, planar shapes, point, spot,
directional, environment, and with ``light_selection="bvh"`` triangle meshes, sampled one
triangle at a time: ``LightSet.simple``); BSDFs with delta lobes are refused (light
points never reach a delta lobe), as for every estimator without the ``"bsdf"`` technique.
"""
from __future__ import annotations

import numpy as np

from .._vec import dot
from .lights import EmitterLight
from .shading import ShadingIntegrand, checked_outputs
from .techniques import F32

__all__ = ["BlockPixels", "check_spatial", "spatial_outputs"]

#: light-point evaluations (candidates or reuse) per step of sample indices: bounds memory
ROWS_PER_STEP = 1 << 17


def check_spatial(integrand, probe: ShadingIntegrand) -> None:
    """The renderer's checks of a spatial estimator on ``integrand`` (a ``PixelIntegrand``)
    and its probe shading integrand; sets ``integrand.unit_dim``."""
    est = integrand.estimator
    if integrand.units != 1:
        raise ValueError(f"units: {est.label} reuses one sample per pixel and sample index; use units=1 "
                         f"and more spp, got {integrand.units}")
    est.spatial_check(probe)
    integrand.unit_dim = int(est.spatial_dim(probe))
    lights = integrand.lighting.lights
    if lights is not None and not lights.simple:
        names = sorted({lights[i].type for i in range(len(lights))
                        if not isinstance(lights[i], EmitterLight) and lights[i].sphere is None
                        and not lights[i].planar})
        raise ValueError(f"estimator: {est.label} reconnects pixels to the sampled light points, which the scene's "
                         f"{', '.join(names)} emitters do not give (closed shapes other than spheres); use "
                         "light_selection='bvh' for triangle meshes (sampled triangle by triangle), another "
                         "estimator, or sphere / planar emitters")


def spatial_outputs(integrand, pixels: np.ndarray, u: np.ndarray, cost=None) -> np.ndarray:
    """Unit outputs ``(3, P, S, c)`` of a spatial estimator over the block ``pixels (P, 2)``
    with uniforms ``u (P, S, dim)``: one unit per sample index (in steps of sample indices
    that bound memory; each unit sees only its own uniforms), the emitted light seen
    directly added as for every estimator.  ``cost``: the :class:`~vrlab.render.cost.Cost`
    the camera rays, candidates and reconnections (shadow rays, targets) are counted in."""
    est = integrand.estimator
    P, S = u.shape[:2]
    work = max(int(est.candidates_per_unit), int(est.traced_per_unit()), 1)
    step = max(1, ROWS_PER_STEP // max(1, P * work))
    parts = []
    for a in range(0, S, step):
        ua = u[:, a: a + step]
        hits, d, le, group = integrand.camera(pixels, ua, cost)
        view = BlockPixels(integrand, pixels, hits, d, group, ua.shape[1], cost)
        vals = checked_outputs(est.spatial_outputs(view, np.moveaxis(ua[..., integrand.camera_dims:], 1, 0)), est,
                               None)                                                               # (3, s, P, c)
        vals = np.array(np.moveaxis(vals, 1, 2), dtype=np.result_type(vals, np.float32))  # (3, P, s, c)
        parts.append(est.add_emitted(vals, le.T.reshape(3, P, -1)))
    return parts[0] if len(parts) == 1 else np.concatenate(parts, 2)


class BlockPixels:
    """The camera samples of a block as the pixels of N independent spatial units: pixel b of
    unit n is the camera ray of pixel b with sample index n (row b N + n of ``hits``).  Points
    are light points x = (y_x, y_y, y_z, j, t) ``(N, ..., 5)`` (first axis: the unit; t the
    triangle of a split mesh light, -1 otherwise), pixel
    indices broadcast to ``x.shape[:-1]`` (the interface of ``vrlab.estimators.restir.PixelView``).
    ``cost``: the :class:`~vrlab.render.cost.Cost` the shading integrands count their work in.
    """

    def __init__(self, integrand, pixels: np.ndarray, hits, d: np.ndarray, group: np.ndarray, N: int,
                 cost=None):
        lit = integrand.lighting
        self.cost = cost
        self.lighting, self.lights, self.N, self.B = lit, lit.lights, int(N), len(pixels)
        self.shape = (self.B,)
        self.coords = np.asarray(pixels, np.int64)
        self.group, self.p = group, hits.p
        self._shading = integrand.shading
        self.pos = np.zeros(len(group), np.int64)          # row -> its index among its group's rows
        n_shading = lit.shading_normals(hits)
        self.groups = {}
        for g in np.unique(group[group >= 0]):
            rows = np.flatnonzero(group == g)
            self.pos[rows] = np.arange(len(rows))
            ns = None if n_shading is None else n_shading[rows]
            self.groups[int(g)] = (rows, hits.p[rows], hits.n[rows], -d[rows], ns, lit.bsdf_values(g, hits, rows),
                                   lit.tangents(g, hits, rows))
        self._last: tuple | None = None

    # -- geometry -------------------------------------------------------------------------
    def _rows(self, lead: tuple, pix) -> np.ndarray:
        """Flat camera rows ``pix N + n`` of points with leading shape ``lead`` (n: axis 0)."""
        n = np.arange(self.N).reshape((self.N,) + (1,) * (len(lead) - 1))
        return (np.broadcast_to(pix, lead) * self.N + n).reshape(-1)

    def _shade(self, g: int, rows: np.ndarray) -> ShadingIntegrand:
        """The shading integrand of group g at camera rows ``rows`` (in any order, repeated)."""
        _, p, n, wo, ns, values, tangents = self.groups[g]
        k = self.pos[rows]
        return self._shading(g, p[k], n[k], wo[k], None if ns is None else ns[k],
                             None if values is None else {a: v[k] for a, v in values.items()},
                             None if tangents is None else (tangents[0][k], tangents[1][k]), self.cost)

    def _G(self, y: np.ndarray, j: np.ndarray, tri: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """G_b(y) = |cos theta_y| / |y - p_b|^2 at camera rows ``rows`` (1 for delta lights and
        lights at infinity; 0 where there is no light or no shading point)."""
        out = np.zeros(len(rows))
        ok = (j >= 0) & (self.group[rows] >= 0)
        if self.lights is None or not ok.any():
            return out
        jj = np.maximum(j, 0)
        area = ok & ~self.lights.is_emitter[jj]
        out[ok & self.lights.is_emitter[jj]] = 1.0
        if area.any():
            m = np.flatnonzero(area)
            v = y[m] - np.asarray(self.p[rows[m]], np.float64)
            d2 = dot(v, v)
            cos = np.abs(dot(self.lights.point_normals(y[m], jj[m], tri[m]), v))
            out[m] = np.divide(cos, d2 * np.sqrt(d2), out=np.zeros(len(m)), where=d2 > 0)
        return out

    # -- the view's interface (vrlab.estimators.restir) ------------------------------------
    def candidates(self, uc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(x, p, t)`` ``(N, B, c, ...)``: light-technique samples at every pixel from
        ``uc (N, B, c, 3)`` as light points, their densities (solid angle x lights, P_j for a
        delta light) and the pixels' unshadowed targets there (no ray)."""
        N, B, c, dd = uc.shape
        x, p, t = np.zeros((N * B, c, 5)), np.zeros((N * B, c)), np.zeros((N * B, c))
        ue = uc.reshape(N * B, c, dd)
        for g, (rows, *_) in (self.groups.items() if self.lights is not None else ()):
            entries = (rows % N) * B + rows // N            # unit-major (n, b) of camera row b N + n
            sh = self._shade(g, rows)
            tech = sh.technique("light")
            xs = tech.sample(ue[entries])
            p[entries] = tech.pdf(xs)
            t[entries] = sh.targets["unshadowed"](xs)
            r = sh.rows(xs)
            y = np.where(self.lights.is_infinite[np.maximum(r.j, 0)][:, None], r.w, r.y)
            tri = np.full(len(r.j), -1) if r.tri is None else r.tri
            x[entries] = np.concatenate([y, r.j[:, None], tri[:, None]], -1).reshape(len(rows), c, 5)
        return x.reshape(N, B, c, 5), p.reshape(N, B, c), t.reshape(N, B, c)

    def _evaluate(self, x: np.ndarray, pix) -> tuple[np.ndarray, np.ndarray]:
        """``(f (3, ...), p̂ (...))`` of light points x at pixels ``pix`` (the last call cached:
        f and the target at the same points are asked for one after the other)."""
        last = self._last
        if last is not None and last[0] is x and np.array_equal(last[1], pix):
            return last[2], last[3]
        lead = x.shape[:-1]
        rows = self._rows(lead, pix)
        xf = x.reshape(-1, 5)
        f, t = np.zeros((3, len(rows)), F32), np.zeros(len(rows))
        grp = self.group[rows]
        for g in self.groups:
            sel = np.flatnonzero(grp == g)
            if len(sel) and self.lights is not None:
                sh = self._shade(g, rows[sel])
                x5 = self._points(sh, xf[sel])
                f[:, sel] = sh.f(x5)[..., 0]
                t[sel] = sh.targets["unshadowed"](x5)[:, 0]
        out = (f.reshape((3,) + lead), t.reshape(lead))
        self._last = (x, np.array(pix), *out)
        return out

    def _points(self, sh: ShadingIntegrand, xl: np.ndarray) -> np.ndarray:
        """Shading points ``(R, 1, 5)`` reconnecting each shading point of ``sh`` to its light
        point, with the rows' light point, facing and (no ray yet) cached."""
        lights = self.lights
        y, j, tri = xl[:, :3], np.rint(xl[:, 3]).astype(np.int64), np.rint(xl[:, 4]).astype(np.int64)
        jj = np.maximum(j, 0)
        p = np.asarray(sh.p, np.float64)
        inf = lights.is_infinite[jj]
        v = np.where(inf[:, None], y, y - p)
        dist = np.sqrt(dot(v, v))
        valid = (j >= 0) & (dist > 0)
        w = np.divide(v, dist[:, None], out=np.tile([0.0, 0.0, 1.0], (len(v), 1)), where=valid[:, None])
        front = valid & (lights.is_emitter[jj] | (dot(p - y, lights.point_normals(y, jj, tri, shading=True)) > 0))
        x5, r = sh.new_points(w.astype(F32), np.where(valid, j, -1), (len(w), 1))
        r.y = np.where(inf[:, None], p + EmitterLight.FAR * w, y).astype(F32)
        r.front = front
        return x5

    def f(self, x: np.ndarray, pix) -> np.ndarray:
        """RGB f_b(x) ``(3, ...)``: f_r |cos| L_e V at pixel b reconnected to light point x."""
        return self._evaluate(x, pix)[0]

    def phat(self, x: np.ndarray, pix) -> np.ndarray:
        """The unshadowed target p̂_b(x) (luminances; 0 where light j does not face p_b)."""
        return self._evaluate(x, pix)[1]

    @staticmethod
    def nonzero(f: np.ndarray) -> np.ndarray:
        return np.any(np.asarray(f) != 0, axis=0)

    def shift(self, x: np.ndarray, src, dst) -> tuple[np.ndarray, np.ndarray]:
        """Reconnection from pixel src to pixel dst: the same light point, Jacobian
        J = G_dst(y) / G_src(y) (module docstring)."""
        lead = x.shape[:-1]
        xf = x.reshape(-1, 5)
        y, j, tri = xf[:, :3], np.rint(xf[:, 3]).astype(np.int64), np.rint(xf[:, 4]).astype(np.int64)
        gs, gd = self._G(y, j, tri, self._rows(lead, src)), self._G(y, j, tri, self._rows(lead, dst))
        return x, np.divide(gd, gs, out=np.zeros(len(gs)), where=gs > 0).reshape(lead)

    def neighbours(self, un: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
        """``(nbr, present)`` (N, B, k): per slot a uniform offset o, 0 < |o| <= radius, of the
        pixel's image coordinates; present where that pixel is in the block (no wrapping)."""
        r = int(np.floor(radius))
        o = np.stack(np.meshgrid(np.arange(-r, r + 1), np.arange(-r, r + 1), indexing="ij"), -1).reshape(-1, 2)
        o = o[(np.sum(o * o, -1) <= radius * radius) & np.any(o != 0, -1)]
        own = np.broadcast_to(np.arange(self.B)[None, :, None], un.shape)
        if un.shape[-1] == 0 or not len(o):
            return own.copy(), np.zeros(un.shape, bool)
        coords = self.coords - self.coords.min(0) + r                 # >= r: every target >= 0
        width = int(coords[:, 1].max()) + r + 1
        keys = coords[:, 0] * width + coords[:, 1]
        order = np.argsort(keys, kind="stable")
        tgt = coords[None, :, None, :] + o[np.minimum((un * len(o)).astype(np.int64), len(o) - 1)]
        inside = (tgt[..., 1] >= 0) & (tgt[..., 1] < width)
        key = tgt[..., 0] * width + tgt[..., 1]
        at = np.minimum(np.searchsorted(keys[order], key), len(keys) - 1)
        present = inside & (keys[order][at] == key)
        return np.where(present, order[at], own), present
