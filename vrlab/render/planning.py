"""The render plan: every setting of a render resolved and checked once, in one frozen object.

``plan(scene, spp, estimator, **settings) -> RenderPlan`` does what every renderer entry
point needs before the first sample, in one place:

- the scene (a :class:`Scene`, a file, an XML string or a built-in name) loaded and sized
  (``width``, ``height``);
- the estimator: an object, or a preset name looked up once in the registry
  (:func:`vrlab.render.presets.preset`), with its units per shading point;
- the pixel integrand built once (:class:`~vrlab.render.pixels.PixelIntegrand`: the
  lighting, the light selection and one probe of the estimator for its unit dimensions and
  output columns);
- the sample counts (``emitter_samples``, ``bsdf_samples`` default to the scene's
  integrator's; ``ris_candidates``), the points (the scene's sampler by default), ``spp``
  (the scene's by default) and the execution settings (``spp_batch``, ``chunk_pixels``,
  ``workers``, ``kernels``), each checked against :mod:`vrlab.limits` with errors naming it.

:func:`vrlab.render.render`, :func:`~vrlab.render.render_gradient_domain` and
:func:`~vrlab.render.compare` take a plan or build one; ``render(plan, rng=...)`` gives the
same bytes as ``render(scene, spp, estimator, ..., rng=...)`` with the same settings.  The
seed is not part of the plan (one plan, many seeds), nor is a caller's executor (a live
object); everything else is.  The plan pickles (worker processes receive it once), and
``repr(plan)`` is what ``vrlab render --json`` reports under ``"plan"``.
"""
from __future__ import annotations

import dataclasses
import os
from typing import Any

from .. import checks, limits
from .pixels import PixelIntegrand
from .scene import Scene

__all__ = ["RenderPlan", "plan", "KERNELS", "default_workers", "resolve_kernels"]

#: the kernel choices of ``plan(kernels=...)``: ``"auto"`` is the compiled kernels where numba
#: imports and they gain, else NumPy (:func:`resolve_kernels`)
KERNELS = ("auto", "numba", "numpy")
TILE_PIXELS = 1024           # pixels per work unit (fixed: it defines the random streams)
SPP_BATCH = 64               # samples per pixel of one work unit (a batch); more spp: more batches
_RAYS_PER_CHUNK = 5 << 14    # block size budget (1024 pixels x 64 spp of mis-power: one block per tile)
#: one pixel's block (spp x (rays + uniforms/4) per sample) may be at most 32 default blocks (~1 GB)
MAX_PIXEL_WORK = 32 * 4 * _RAYS_PER_CHUNK


def default_workers() -> int:
    """Worker processes to use by default: the CPUs this process may run on."""

    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        return os.cpu_count() or 1


#: the compiled kernels of the per-sample path: the ray queries' (every render); by the light
#: selection that uses it, the light BVH walk's and (its leaves are mesh triangles) the sampling
#: towards given triangles; by the estimator, RIS's and ReSTIR's reservoirs
#: and reuse (an estimator object names its own in ``kernel_module``)
COMPILED = {"rays": "vrlab.render.accel.traverse_kernel",
            "light_selection": {"bvh": ("vrlab.distributions.light_bvh_kernel",
                                        "vrlab.distributions.mesh_light_kernel")},
            "estimator": {"ris": "vrlab.estimators.restir_kernel", "restir": "vrlab.estimators.restir_kernel"}}


def resolve_kernels(kernels: Any, light_selection: str, estimator: Any = None, scene: Scene | None = None) -> str:
    """The kernels that run for ``kernels`` in :data:`KERNELS`: ``"numba"`` (:data:`COMPILED`: the
    ray queries; the light BVH's walk where the render selects lights by it; RIS's and ReSTIR's
    reservoirs and reuse) where ``kernels`` is ``"numba"``, or ``"auto"`` with numba importable
    and something to gain: a compiled kernel of the light selection or the estimator, or ray
    queries that the compiled walk speeds up (:func:`~vrlab.render.accel.choice.compiled_walk_pays`
    for ``scene``; not the small scenes that the NumPy path tests all pairs, where importing
    numba would cost more than it saves); else ``"numpy"``, which imports nothing.  ``"numba"`` where numba cannot be imported:
    ``ValueError`` naming ``kernels``.  The kernels are compiled or loaded from numba's cache
    here, before any worker process starts (:func:`vrlab.kernels.load_kernels`): forked workers
    inherit them."""
    from ..kernels import load_kernels
    from ..kernels import resolve_kernels as resolve

    checks.choice(kernels, "kernels", KERNELS)
    if kernels == "numpy":
        return "numpy"
    by_estimator = COMPILED["estimator"].get(estimator) if isinstance(estimator, str) else \
        getattr(estimator, "kernel_module", None)
    modules = [*COMPILED["light_selection"].get(light_selection, ()), *([by_estimator] if by_estimator else [])]
    if kernels == "auto" and not modules and scene is not None:
        from .accel.choice import compiled_walk_pays

        if not compiled_walk_pays(scene):
            return "numpy"
    if resolve(kernels) == "numpy":
        return "numpy"
    load_kernels(COMPILED["rays"], *modules)
    return "numba"


@dataclasses.dataclass(frozen=True, repr=False, eq=False)
class RenderPlan:
    """A render's settings, resolved and checked once (module docstring).  Build it with
    :func:`plan`; its fields are read-only."""

    scene: Scene
    spp: int
    integrand: PixelIntegrand
    light_selection: str
    emitter_samples: int
    bsdf_samples: int
    ris_candidates: int
    points: Any
    spp_batch: int
    chunk_pixels: int | None
    workers: int
    kernels: str
    #: the preset name the estimator was built from (None for an estimator object)
    strategy: str | None = None

    @property
    def estimator(self):
        """The estimator object (a preset name resolved once)."""
        return self.integrand.estimator

    @property
    def units(self) -> int:
        """Units of the estimator per shading point."""
        return self.integrand.units

    @property
    def unit_dim(self) -> int | None:
        """Uniforms of one unit (None for a spatial estimator: per pixel sample, ``dim``)."""
        return getattr(self.integrand, "unit_dim", None)

    @property
    def columns(self) -> int:
        """Columns of the estimator's unit outputs."""
        return self.integrand.columns

    @property
    def dim(self) -> int:
        """Uniforms per pixel sample (camera, then the units')."""
        return self.integrand.dim

    @property
    def size(self) -> tuple[int, int]:
        """``(width, height)`` of the film."""
        return self.scene.sensor.width, self.scene.sensor.height

    def sampling(self) -> dict:
        """The light selection and sample counts (what a checkpoint's hash keeps besides the scene,
        the estimator, the points and the seed)."""
        return {"light_selection": self.light_selection, "emitter_samples": self.emitter_samples,
                "bsdf_samples": self.bsdf_samples, "ris_candidates": self.ris_candidates}

    def settings(self) -> dict:
        """The settings as plain values (checkpoints hash them; ``--json`` prints :meth:`__repr__`)."""
        return {"spp": self.spp, "strategy": self.strategy, "estimator": repr(self.estimator), "units": self.units,
                "light_selection": self.light_selection, "emitter_samples": self.emitter_samples,
                "bsdf_samples": self.bsdf_samples, "ris_candidates": self.ris_candidates,
                "points": _points_label(self.points), "spp_batch": self.spp_batch,
                "chunk_pixels": self.chunk_pixels, "workers": self.workers, "kernels": self.kernels}

    def __repr__(self) -> str:
        w, h = self.size
        fields = ", ".join(f"{k}={v!r}" for k, v in self.settings().items() if k != "estimator")
        return f"RenderPlan(film={w}x{h}, estimator={self.estimator!r}, unit_dim={self.unit_dim}, " \
               f"columns={self.columns}, {fields})"


def _as_scene(scene: Any) -> Scene:
    """A :class:`Scene`, or one loaded from an XML path, an XML string or a built-in name."""
    if isinstance(scene, Scene):
        return scene.validate()
    if not isinstance(scene, (str, os.PathLike)) or isinstance(scene, bytes):
        raise TypeError("scene must be a vrlab.render.Scene, a path to a scene XML file or a built-in "
                        f"scene name, got {type(scene).__name__}")
    from .builtin import builtin_scene_path, list_builtin_scenes
    from .loader import load_scene
    if isinstance(scene, str) and not scene.lstrip().startswith("<") and not os.path.exists(scene):
        stem = scene[:-4] if scene.endswith(".xml") else scene
        if stem in list_builtin_scenes():
            return load_scene(builtin_scene_path(stem))
        raise ValueError(f"scene: {scene!r} is neither a scene file nor a built-in scene; built-in: "
                         f"{', '.join(list_builtin_scenes())}")
    return load_scene(scene)


def _points_label(points: Any) -> str:
    if points is None or isinstance(points, str):
        return "independent" if points is None else points
    return getattr(points, "__name__", None) or type(points).__name__


def plan(scene: Any, spp: int | None = None, estimator: Any = "mis-power", *, points: Any = None,
         units: int | None = None, light_selection: str = "uniform", emitter_samples: int | None = None,
         bsdf_samples: int | None = None, ris_candidates: int = 8, chunk_pixels: int | None = None,
         width: int | None = None, height: int | None = None, spp_batch: int | None = None,
         workers: int | None = 1, kernels: str = "auto") -> RenderPlan:
    """Resolve and check a render's settings once: a :class:`RenderPlan` (module docstring).
    The arguments are :func:`vrlab.render.render`'s; errors name the argument."""
    scene = _as_scene(scene)
    spp = checks.integer(scene.sensor.spp if spp is None else spp, "spp", low=1, high=limits.MAX_SPP)
    batch = min(spp, SPP_BATCH if spp_batch is None else checks.integer(spp_batch, "spp_batch", low=1))
    chunk = None if chunk_pixels is None else checks.integer(chunk_pixels, "chunk_pixels", low=1)
    workers = default_workers() if workers is None else checks.integer(workers, "workers", low=1,
                                                                      high=limits.max_workers())
    ran = resolve_kernels(kernels, light_selection, estimator, scene)
    if width is not None or height is not None:
        scene = scene.with_size(width, height)
    # the sample counts (the scene's integrator's by default) and the estimator are checked and
    # resolved here, once, by the pixel integrand (a preset name looked up once)
    integrand = PixelIntegrand(scene, estimator, units=units, light_selection=light_selection,
                               emitter_samples=emitter_samples, bsdf_samples=bsdf_samples,
                               ris_candidates=ris_candidates, kernels=ran)
    check_work(integrand, spp, batch, chunk, 1)
    if points is None:                   # the scene's sampler plays its part (sensors.samplers)
        points = scene.sensor.sampler.points
    return RenderPlan(scene, spp, integrand, integrand.light_selection, integrand.emitter_samples,
                      integrand.bsdf_samples, integrand.ris_candidates, points, batch, chunk, workers, ran,
                      estimator if isinstance(estimator, str) else None)


def check_work(integrand: PixelIntegrand, spp: int, batch: int, chunk: int | None, cost: int) -> int:
    """The block size in pixels: ``chunk`` checked, or the automatic one, for ``cost`` pixel
    integrand evaluations per sample (3 for gradient-domain renders); ``ValueError`` naming
    ``spp``, ``spp_batch`` or ``chunk_pixels`` for work that does not fit a block."""
    est = integrand.estimator
    need = int(est.min_units)
    if spp < need:
        raise ValueError(f"spp: {est.label} fits its coefficients per pixel and needs spp >= {need}, got {spp}")
    work = integrand.work_per_sample * cost
    if batch * work > MAX_PIXEL_WORK:
        raise ValueError(f"spp_batch: {batch} samples per pixel and batch x {work} (rays + uniforms/4 per sample, "
                         f"for {est.label} with {integrand.units} unit(s) per shading point) exceeds the per-pixel "
                         f"block limit {MAX_PIXEL_WORK}; use spp_batch <= {MAX_PIXEL_WORK // work}")
    if chunk is None:
        # spatial estimators (ReSTIR) reuse among the pixels of a block: a whole tile, whatever
        # the work (they bound their memory by steps of sample indices, vrlab.render.reuse)
        return TILE_PIXELS if est.spatial else min(TILE_PIXELS, max(1, (4 * _RAYS_PER_CHUNK) // (batch * work)))
    if min(chunk, TILE_PIXELS) * batch * work > MAX_PIXEL_WORK:
        raise ValueError(f"chunk_pixels: a block of {chunk} pixels x {batch} spp x {work} (rays + "
                         f"uniforms/4 per sample) exceeds the block limit {MAX_PIXEL_WORK}; use "
                         f"chunk_pixels <= {MAX_PIXEL_WORK // (batch * work)} or None (automatic)")
    return min(chunk, TILE_PIXELS)
