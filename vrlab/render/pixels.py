"""The pixel integrand: a pixel's value as an integral over primary sample space.

One pixel sample takes uniforms ``u = (u_x, u_y, v_1, ..., v_k)``: the position in the
pixel, then ``k`` = ``units`` blocks of the estimator's unit uniforms (``unit_dim`` each).
Its value is

    L_e(camera hit, towards the camera) + (1/k) sum_i F_i,

where F_i is the estimator's unit value (:meth:`vrlab.estimators.Estimator.unit_values`)
on the :class:`~vrlab.render.shading.ShadingIntegrand` at the camera hit, uniforms v_i.
The pixel's estimate folds its spp samples with the estimator's ``fold`` (the mean and
sqrt(s^2 / spp) for averaging estimators, the regression for fitted control variates).
So point sets act on ``u`` (the pixel level) and estimators at each shading point,
batched over all camera hits of a block that share a BSDF.

``estimator``: an estimator object (any :class:`~vrlab.estimators.Estimator` with per-unit
values: its own ``dim_u``/``unit_values`` are enough), or a preset name
(:mod:`vrlab.render.presets`).  Estimators that only work on whole sample sets
(stratified, RQMC, Metropolis chains, CRN differences) are refused: stratify and
randomise with ``points=`` instead, at the pixel level.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .. import checks
from ..integrands.base import Integrand
from .cost import Cost
from .direct import DirectLighting
from .presets import preset
from .scene import Scene
from ..limits import MAX_CANDIDATES, MAX_SAMPLES
from .shading import ShadingIntegrand, checked_outputs

__all__ = ["PixelFunction", "PixelIntegrand", "as_estimator"]


def as_estimator(estimator: Any, *, emitter_samples: int = 1, bsdf_samples: int = 1,
                 ris_candidates: int = 8) -> tuple[Any, int]:
    """``(estimator, units per shading point)`` for an estimator object or a preset name."""
    from ..estimators.base import Estimator

    if isinstance(estimator, str):
        return preset(estimator, emitter_samples=emitter_samples, bsdf_samples=bsdf_samples,
                      ris_candidates=ris_candidates)
    if not isinstance(estimator, Estimator):
        raise TypeError("estimator: expected a preset name or a vrlab.estimators.Estimator object (subclass "
                        f"Estimator and define dim_u and unit_values), got {type(estimator).__name__}")
    cls = type(estimator)
    if not estimator.per_unit or (cls.unit_values is Estimator.unit_values and
                                  cls.unit_outputs is Estimator.unit_outputs):
        raise TypeError(f"estimator: {cls.__name__} works on whole sample sets and has no per-sample unit values, "
                        "which the renderer needs at each shading point; stratify or randomise the pixel's "
                        "uniforms with points= instead")
    return estimator, 1


class PixelIntegrand:
    """Pixel samples of ``scene`` under ``estimator`` (see the module docstring).

    ``units``: the estimator's units per shading point (default: 1, or the preset's, from
    ``emitter_samples`` / ``bsdf_samples``, which default to the scene's integrator
    settings); ``light_selection``: ``"uniform"``, ``"power"`` or ``"bvh"`` for the ``"light"``
    technique.  ``dim`` is the number of uniforms per pixel sample.
    """

    atoms: tuple = ()       #: no point masses in u-space (delta lights are in the shading integrand's measure)

    def __init__(self, scene: Scene, estimator: Any = "mis-power", *, units: int | None = None,
                 light_selection: str = "uniform", emitter_samples: int | None = None,
                 bsdf_samples: int | None = None, ris_candidates: int = 8, kernels: str = "numpy"):
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a vrlab.render.Scene, got {type(scene).__name__}")
        integ = scene.integrator
        n_l = checks.integer(integ.emitter_samples if emitter_samples is None else emitter_samples,
                             "emitter_samples", low=0, high=MAX_SAMPLES)
        n_b = checks.integer(integ.bsdf_samples if bsdf_samples is None else bsdf_samples,
                             "bsdf_samples", low=0, high=MAX_SAMPLES)
        m = checks.integer(ris_candidates, "ris_candidates", low=1, high=MAX_CANDIDATES)
        #: the sample counts the estimator was built with (the scene's integrator's by default)
        self.emitter_samples, self.bsdf_samples, self.ris_candidates = n_l, n_b, m
        self.light_selection = light_selection
        self.estimator, k = as_estimator(estimator, emitter_samples=n_l, bsdf_samples=n_b, ris_candidates=m)
        self.units = k if units is None else checks.integer(units, "units", low=1, high=MAX_SAMPLES)
        self.lighting = DirectLighting(scene, light_selection, kernels)
        probe = self.shading(0, *(np.zeros((0, 3), np.float32) for _ in range(3)))
        if self.estimator.spatial:                  # reuse across pixels (ReSTIR): vrlab.render.reuse
            from .reuse import check_spatial

            check_spatial(self, probe)
            self.columns = 1
        else:
            self.estimator.check(probe)
            self.unit_dim = int(self.estimator.unit_dim(probe))
            #: columns of the estimator's unit outputs (what a block with nothing to shade is made of)
            self.columns = self._output_columns()
        self._check_reach(probe.used)
        #: uniforms of the camera sample (sub-pixel offset, then a lens's), before the units'
        self.camera_dims = int(self.lighting.camera.camera_dims)
        self.dim = self.camera_dims + self.units * self.unit_dim
        evals = int(self.estimator.evals_per_unit)
        #: rays (and RIS candidates) per pixel sample: the memory of a block is about this x 4 x 12 bytes
        self.work_per_sample = 1 + self.units * (evals + int(self.estimator.candidates_per_unit)) + self.dim // 4

    def _output_columns(self) -> int:
        """The estimator's unit outputs' width, from an empty batch of shading points of group
        0 (its textured parameters and tangent frame as empty arrays)."""
        lit = self.lighting
        bsdf = lit.bsdfs[0]
        values = {a: np.zeros((0,) if a in bsdf.SCALAR_TEXTURES else (0, 2 if a in bsdf.GRADIENT_TEXTURES else 3))
                  for a in bsdf.textures} or None
        empty = np.zeros((0, 3), np.float32)
        tangents = (empty, empty) if bsdf.needs_tangents else None
        probe = self.shading(0, empty, empty, empty, None, values, tangents)
        return int(np.shape(self.estimator.unit_outputs(probe, np.zeros((0, 1, self.unit_dim))))[-1])

    def _check_reach(self, used: set) -> None:
        """Refuse an estimator whose techniques cannot reach some emitter: delta lights (point,
        spot, directional) only through ``"light"``; an emitter the light technique cannot
        sample (``lighting.light_error``) must not be left to it."""
        lit = self.lighting
        if not used:                       # an estimator that does not name its techniques: unknown
            return
        if "light" in used and lit.lights is None and lit.light_error != "the scene has no emitters":
            raise ValueError(f"estimator: {self.estimator.label} samples lights, but {lit.light_error}")
        if "light" not in used and lit.lights is not None and lit.lights.is_delta.any():
            names = sorted({lit.lights[i].emitter.plugin_name for i in np.flatnonzero(lit.lights.is_delta)})
            raise ValueError(f"estimator: {self.estimator.label} samples only {', '.join(sorted(used))}, which never "
                             f"reach the scene's delta emitters ({', '.join(names)}): its image would miss their "
                             "light; use an estimator with the 'light' technique (e.g. 'light', 'mis-power')")
        if "bsdf" not in used:             # delta lobes (smooth mirrors, refraction): only BSDF sampling finds them
            missed = sorted({f"{b.type} ({lobe})" for b in lit.bsdfs for lobe in b.DELTA if f"bsdf:{lobe}" not in used})
            if missed:
                raise ValueError(f"estimator: {self.estimator.label} samples only {', '.join(sorted(used))}, which never "
                                 f"reach the delta lobes of the scene's BSDFs ({', '.join(missed)}): its image would "
                                 "miss what they reflect; use an estimator with the 'bsdf' technique (e.g. 'bsdf', "
                                 "'mis-power')")

    @property
    def label(self) -> str:
        return self.estimator.label

    def shading(self, group: int, p: np.ndarray, n: np.ndarray, wo: np.ndarray,
                ns: np.ndarray | None = None, values: dict | None = None,
                tangents: tuple | None = None, cost: Cost | None = None) -> ShadingIntegrand:
        """The shading integrand at points ``p`` (geometric normals ``n``, shading normals ``ns``,
        towards ``wo``) of BSDF group ``group`` (``values``: its textured parameters there;
        ``tangents``: world ``(dp_du, dp_dv)`` for a BSDF that needs a tangent frame; ``cost``:
        the :class:`~vrlab.render.cost.Cost` its work is counted in)."""
        if not self.lighting.bsdfs:
            raise ValueError("scene: it has no shapes to shade")
        return ShadingIntegrand(self.lighting, group, p, n, wo, ns, values, tangents, cost)

    def outputs(self, pixels: np.ndarray, u: np.ndarray, cost: Cost | None = None) -> np.ndarray:
        """Unit outputs ``(3, P, S, c)`` of S samples in each of P pixels ``(P, 2)`` = (row,
        column), uniforms ``u (P, S, dim)``; column 0 is the sample's value (see
        :meth:`vrlab.estimators.Estimator.unit_outputs`).  ``cost``: a
        :class:`~vrlab.render.cost.Cost` the rays, samples and evaluations are added to."""
        pixels, u = np.asarray(pixels), np.asarray(u)
        if u.ndim != 3 or u.shape[-1] != self.dim or pixels.shape != (u.shape[0], 2):
            raise ValueError(f"u: expected uniforms (P, S, {self.dim}) for pixels (P, 2), got {u.shape} "
                             f"and {pixels.shape}")
        if self.estimator.spatial:                  # every pixel of the block at once: vrlab.render.reuse
            from .reuse import spatial_outputs

            return spatial_outputs(self, pixels, u, cost)
        P, S = u.shape[:2]
        lit = self.lighting
        hits, d, le, group = self.camera(pixels, u, cost)
        R = len(d)                                     # camera rays: P x S
        counts = np.bincount(group + 1, minlength=len(lit.bsdfs) + 1)[1:]
        u2 = u.reshape(P * S, self.dim)
        ue = u2[:, self.camera_dims:]                    # a view (whole rows are gathered below: 5x faster)
        out = None
        n_shading = lit.shading_normals(hits)                           # None: the geometric ones
        for g in np.flatnonzero(counts):
            ns = None
            if counts[g] == R:                                       # one group everywhere: no gathers
                rows, p, n, wo, ug = slice(None), hits.p, hits.n, -d, ue
                if n_shading is not None:
                    ns = n_shading
            else:
                rows = np.flatnonzero(group == g)
                p, n, wo, ug = (np.take(a, rows, axis=0) for a in (hits.p, hits.n, d, u2))
                ug = ug[:, self.camera_dims:]
                wo = np.negative(wo, out=wo)
                if n_shading is not None:
                    ns = np.take(n_shading, rows, axis=0)
            sh = self.shading(g, p, n, wo, ns, lit.bsdf_values(g, hits, rows), lit.tangents(g, hits, rows), cost)
            ug = ug.reshape(len(ug), self.units, self.unit_dim)
            vals = checked_outputs(self.estimator.unit_outputs(sh, ug), self.estimator, len(ug))
            vals = np.broadcast_to(vals, (3,) + vals.shape[-3:])
            vals = vals[..., 0, :] if self.units == 1 else vals.mean(-2)                # (3, rows, c)
            if out is None:
                if isinstance(rows, slice) and vals.flags.writeable and vals.base is None:
                    out = vals                                 # every ray in this group: no copy
                    continue
                out = np.zeros((3, R, vals.shape[-1]), np.result_type(vals, np.float32))
            out[:, rows] = vals
        if out is None:
            out = np.zeros((3, R, self.columns), np.float32)
        out = self.estimator.add_emitted(out, le.T)
        return out.reshape(3, P, S, -1)

    def camera(self, pixels: np.ndarray, u: np.ndarray, cost: Cost | None = None) -> tuple:
        """``(hits, d, le, group)`` of the camera rays of pixels ``(P, 2)`` with uniforms
        ``u (P, S, dim)``, rows in (pixel, sample) order: the first hits, ray directions
        ``(P S, 3)``, the emitted radiance seen ``(P S, 3)`` and each hit's BSDF group (-1:
        nothing to shade); ``cost`` counts the camera rays."""
        lit = self.lighting
        o, d = lit.camera.pixel_rays(pixels[:, None, :], u[..., :self.camera_dims], np.float32)
        o, d = o.reshape(-1, 3), d.reshape(-1, 3)
        if cost is not None:
            cost.camera_rays += len(o)
        # hide_emitters: camera rays pass through emitting shapes (Mitsuba 3.9 draws what lies
        # behind them), so they meet the other shapes only
        hits = (lit.blocker_geometry if lit.hide_emitters else lit.geometry).intersect(o, d)
        if lit.environment is not None and not lit.hide_emitters:       # the environment behind it all
            lit.escaped(hits, o, d, np.flatnonzero(hits.shape < 0))
        le = lit.emitted(hits, d)
        if lit.environment is not None:                                # nothing to shade out there
            hits.shape[hits.shape == lit.env_shape] = -1
        shape = np.maximum(hits.shape, 0)
        group = np.where((hits.shape >= 0) & lit.shaded[shape], lit.group_of_shape[shape], -1)
        return hits, d, le, group

    def values(self, pixels: np.ndarray, u: np.ndarray, cost: Cost | None = None) -> np.ndarray:
        """The values ``(P, S, 3)`` of the pixel samples (for averaging estimators: each an
        unbiased estimate of its pixel, RGB last); ``cost``: as for :meth:`outputs`."""
        return np.moveaxis(self.outputs(pixels, u, cost)[..., 0], 0, -1)

    def integrand(self, pixels: np.ndarray, shift: tuple[int, int] = (0, 0),
                  cost: Cost | None = None) -> "PixelFunction":
        """The pixels ``(P, 2)`` (moved by ``shift`` = (rows, columns)) as one batched
        :class:`vrlab.Integrand` on the unit cube of primary sample space: points ``u (P, n,
        dim)``, values ``(3, P, n)``, integral the pixel values.  Any estimator of
        :mod:`vrlab.estimators` runs on it (``MonteCarlo()`` is the plain pixel estimate,
        ``CRNDifference`` on two of them an image gradient).  ``cost``: the
        :class:`~vrlab.render.cost.Cost` its evaluations are counted in (None: not counted)."""
        return PixelFunction(self, pixels, shift, cost)

    def image_values(self, spp: int, rng: Any = None, *, block_pixels: int = 4096) -> np.ndarray:
        """The values ``(H, W, spp, 3)`` of ``spp`` samples in every pixel of the sensor, from
        i.i.d. uniforms drawn from ``numpy.random.default_rng(rng)`` block after block of
        ``block_pixels`` pixels (for experiments that study the samples themselves; memory
        H W spp 3 float32)."""
        spp = checks.integer(spp, "spp", low=1)
        block = checks.integer(block_pixels, "block_pixels", low=1)
        gen = np.random.default_rng(rng)
        sensor = self.lighting.camera
        h, w = sensor.height, sensor.width
        out = np.empty((h * w, spp, 3), np.float32)
        for a in range(0, h * w, block):
            idx = np.arange(a, min(a + block, h * w))
            out[idx] = self.values(np.stack(np.divmod(idx, w), -1), gen.random((len(idx), spp, self.dim)))
        return out.reshape(h, w, spp, 3)

    def estimate(self, pixels: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(value, stderr)``, both ``(P, 3)``: the estimator's fold of each pixel's S samples."""
        value, stderr = self.estimator.fold(self.outputs(pixels, u))
        return np.moveaxis(np.asarray(value), 0, -1), np.moveaxis(np.asarray(stderr), 0, -1)


class PixelFunction(Integrand):
    """Pixels of a :class:`PixelIntegrand` as a batched integrand over ``[0, 1)^dim`` (see
    :meth:`PixelIntegrand.integrand`).  The last evaluation is kept: the same points again
    (two estimators sharing a pixel's uniforms, as in gradient-domain rendering) are not
    rendered twice."""

    def __init__(self, pixel_integrand: PixelIntegrand, pixels: np.ndarray, shift: tuple[int, int] = (0, 0),
                 cost: Cost | None = None):
        pixels = np.asarray(pixels)
        if pixels.ndim != 2 or pixels.shape[1] != 2 or not np.issubdtype(pixels.dtype, np.integer):
            raise ValueError(f"pixels: expected integer (row, column) pairs of shape (P, 2), got {pixels.shape}")
        shift = tuple(checks.integer(k, "shift") for k in shift) if isinstance(shift, (tuple, list)) else None
        if shift is None or len(shift) != 2:
            raise TypeError("shift: expected (rows, columns), two integers")
        super().__init__(self._values, [(0.0, 1.0)] * pixel_integrand.dim, name=f"pixels{list(shift)}")
        self.pixel_integrand, self.pixels, self.shift = pixel_integrand, pixels + np.asarray(shift), shift
        self._last: tuple | None = None
        self.cost = cost

    def _values(self, u: np.ndarray) -> np.ndarray:
        if self._last is not None and self._last[0].shape == u.shape and np.array_equal(self._last[0], u):
            return self._last[1]
        if u.ndim != 3 or u.shape[0] != len(self.pixels):
            raise ValueError(f"u: expected points (P={len(self.pixels)}, n, {self.dim}), got shape {u.shape}")
        values = np.moveaxis(self.pixel_integrand.values(self.pixels, u, self.cost), -1, 0)
        self._last = (u.copy(), values)
        return values
