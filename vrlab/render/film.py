"""``render``: the image as per-pixel Monte Carlo estimates, in tiles, optionally in parallel.

Each pixel is the integral of the :class:`~vrlab.render.pixels.PixelIntegrand` over its
primary sample space; its ``spp`` samples come from ``points`` (a
:class:`vrlab.points.SetSampler`: i.i.d., padded strata, or a shared QMC set with a
Cranley-Patterson shift per pixel) and the estimator object folds them.

Work units are tiles of ``TILE_PIXELS`` consecutive pixels (row-major).  Tile t draws
its uniforms from its own stream, child t + 1 of the root ``SeedSequence`` (child 0
seeds the shared point set, if any), pixel after pixel; inside a tile pixels are
processed in blocks of ``chunk_pixels``.  So the image depends on the seed only: not on
the block size, the number of worker processes or the order in which tiles finish
(seeds per work unit, never per worker).  Memory is bounded by the block size (rays x
uniforms) plus the image accumulators.  Worker processes receive the job (scene,
estimator, point sampler) by pickling, under any start method.

``render`` has no process-wide side effects on the calling process: the glibc allocator
tuning of :mod:`vrlab._alloc` is applied only in the worker processes it starts (and by
the ``vrlab render`` command, whose process is vrlab's own).  With ``workers=1`` the
render runs in the caller's process with its allocator as it is: about 1.3x slower on
veach_mis than with the tuning (2.9-3.3 s against 2.1-2.6 s at 128x96, 16 spp, on a busy
2-core machine).  A program that wants the speed calls
``vrlab.render.keep_freed_memory()`` once, itself.
"""
from __future__ import annotations

import dataclasses
import os
import pickle
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any, Callable

import numpy as np

from .. import checks
from .._alloc import keep_freed_memory
from .._rng import RNGLike, as_seed_sequence, unit_seed
from ..estimate import Estimate
from .pixels import PixelIntegrand
from .scene import Scene

__all__ = ["TILE_PIXELS", "default_workers", "render"]

TILE_PIXELS = 1024           # pixels per work unit (fixed: it defines the random streams)
_RAYS_PER_CHUNK = 5 << 14    # block size budget (1024 pixels x 64 spp of mis-power: one block per tile)
#: one pixel's block (spp x (rays + uniforms/4) per sample) may be at most 32 default blocks (~1 GB)
MAX_PIXEL_WORK = 32 * 4 * _RAYS_PER_CHUNK


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


def _optional_int(value: Any, name: str, low: int, high: int | None = None) -> int | None:
    return None if value is None else checks.integer(value, name, low=low, high=high)


class _Job:
    """Everything a process needs to render tiles; pickled to workers without the built
    integrand (each process builds it once per task from the scene)."""

    def __init__(self, scene: Scene, settings: dict, sampler, spp: int, root, chunk: int,
                 integrand: PixelIntegrand | None = None):
        self.scene, self.settings, self.sampler = scene, settings, sampler
        self.spp, self.root, self.chunk = spp, root, chunk
        self.width, self.n_pixels = scene.sensor.width, scene.sensor.width * scene.sensor.height
        self._integrand = integrand

    def __getstate__(self) -> dict:
        return {**self.__dict__, "_integrand": None}

    @property
    def integrand(self) -> PixelIntegrand:
        if self._integrand is None:
            self._integrand = PixelIntegrand(self.scene, **self.settings)
        return self._integrand

    #: the per-pixel (n, 3) arrays a tile returns
    outputs = ("value", "stderr")

    def tile(self, t: int) -> tuple[int, tuple[np.ndarray, ...]]:
        """(first pixel, (estimate (n, 3), standard error (n, 3))) of tile ``t``: its pixels
        block after block, uniforms from the tile's own stream."""
        a, b = t * TILE_PIXELS, min((t + 1) * TILE_PIXELS, self.n_pixels)
        gen = np.random.default_rng(unit_seed(self.root, t + 1))
        out = tuple(np.zeros((b - a, 3)) for _ in self.outputs)
        for c in range(a, b, self.chunk):
            idx = np.arange(c, min(c + self.chunk, b))
            pix = np.stack(np.divmod(idx, self.width), -1)
            u = self.sampler.draw(len(pix), gen)
            with np.errstate(invalid="ignore", divide="ignore"):
                for buf, value in zip(out, self.block(pix, u)):
                    buf[idx - a] = value
        return a, out

    def block(self, pixels: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, ...]:
        """The outputs of a block of pixels ``(P, 2)`` with uniforms ``(P, spp, dim)``."""
        return self.integrand.estimate(pixels, u)


def _run_tiles(job: _Job, tiles: list[int]) -> list[tuple[int, tuple[np.ndarray, ...]]]:
    keep_freed_memory()     # worker processes are vrlab's own: reuse freed ray temporaries (vrlab._alloc)
    return [job.tile(t) for t in tiles]


def render(scene: Scene | str | os.PathLike, spp: int | None = None, estimator: Any = "mis-power", *,
           points: Any = None, rng: RNGLike = None, workers: int | None = 1, executor: Any = None,
           units: int | None = None,
           light_selection: str = "uniform", emitter_samples: int | None = None,
           bsdf_samples: int | None = None, ris_candidates: int = 8, chunk_pixels: int | None = None,
           progress: Callable[[int, int], None] | None = None, width: int | None = None,
           height: int | None = None) -> Estimate:
    """Render ``scene`` with direct lighting: an :class:`~vrlab.Estimate` whose ``value``
    (the image) and ``stderr`` (the per-pixel standard error) are ``(H, W, 3)`` float32,
    with ``n`` = spp.

    ``estimator``: an estimator object of :mod:`vrlab.estimators` (``MIS(["light",
    "bsdf"], heuristic=...)``, ``MonteCarlo("cosine")``, ``OneSampleMIS``, ``Antithetic``,
    ``RIS``, ``ControlVariate``, ``DefensiveMixture``...), a user's subclass of
    :class:`~vrlab.estimators.Estimator`, or a preset name (:mod:`vrlab.render.presets`;
    default ``"mis-power"``, Mitsuba's ``direct`` integrator).  It runs at every shading
    point on the :class:`~vrlab.render.shading.ShadingIntegrand`, whose techniques are
    ``"bsdf"``, ``"light"``, ``"cosine"`` and ``"uniform"``; ``units`` of it per camera ray
    (default 1; a preset's from ``emitter_samples``/``bsdf_samples``, which default to
    the scene's integrator settings; ``ris_candidates`` = M of ``"ris"``).

    ``points``: the pixels' primary-sample-space uniforms: None (i.i.d.), any vrlab
    point set or SciPy engine, as a class, a name or an instance (see
    :class:`vrlab.points.SetSampler`: ``"stratified"`` / ``PaddedStratified`` are padded
    jittered strata, others a shared set with a Cranley-Patterson shift per pixel).
    ``stderr`` is only a valid error bar for i.i.d. points (``extra["stderr_note"]`` says so
    otherwise).  ``rng`` seeds everything (see the module docstring); ``workers``
    processes render tiles in parallel with the same result (None: :func:`default_workers`);
    ``executor``: a ``concurrent.futures.Executor`` of the caller's (e.g. a process pool
    with the spawn start method) to run the tiles on instead, in 2 x ``workers`` tasks,
    also with the same result;
    ``progress(done_pixels, total)`` is called after each tile; ``light_selection``:
    ``"uniform"`` or ``"power"``.  ``scene`` may be a :class:`Scene`, a path to a scene XML
    file, an XML string or a built-in scene name; ``width``/``height`` override its sensor.

    Checked once per call, with errors naming the argument: the scene, the estimator
    (and its technique names against the shading integrand), ``points``, ``spp``,
    ``chunk_pixels``, ``workers`` (at most max(256, 4 x CPUs)), ``units`` and the sample
    counts; one pixel's block must fit :data:`MAX_PIXEL_WORK` (about 1 GB); with
    ``workers > 1`` the estimator must be picklable (a heuristic defined at module level,
    not a lambda).
    """
    t0 = time.perf_counter()
    job, sampler, workers = plan(scene, spp, settings=dict(
        estimator=estimator, units=units, light_selection=light_selection, emitter_samples=emitter_samples,
        bsdf_samples=bsdf_samples, ris_candidates=ris_candidates), points=points, rng=rng, workers=workers,
        chunk_pixels=chunk_pixels, width=width, height=height)
    value, stderr = execute(job, workers, executor, progress)
    integrand, spp = job.integrand, job.spp
    est = integrand.estimator
    extra = {"units": integrand.units, "points": sampler.label}
    if not sampler.iid:
        extra["stderr_note"] = ("stderr uses the i.i.d. formula but the pixel's points are not independent "
                                f"({sampler.label}): it is not a valid error bar")
    evals = integrand.units * int(getattr(est, "evals_per_unit", 1))
    return Estimate(value, stderr, spp, spp * evals, time.perf_counter() - t0, stderr.astype(np.float64) ** 2 * spp,
                    est.label, extra)


def plan(scene: Any, spp: int | None, *, settings: dict, points: Any, rng: RNGLike, workers: int | None,
         chunk_pixels: int | None, width: int | None, height: int | None, job_class: type = _Job,
         cost: int = 1) -> tuple[_Job, Any, int]:
    """Check the arguments of a render and build its job: ``(job, point sampler, workers)``.
    ``cost``: pixel-integrand evaluations per sample (3 for the gradient-domain renders)."""
    scene = _as_scene(scene)
    spp = checks.integer(scene.sensor.spp if spp is None else spp, "spp", low=1)
    chunk_pixels = _optional_int(chunk_pixels, "chunk_pixels", 1)
    limit = max(256, 4 * (os.cpu_count() or 1))
    workers = default_workers() if workers is None else checks.integer(workers, "workers", low=1, high=limit)
    if width is not None or height is not None:
        sensor = dataclasses.replace(scene.sensor, width=scene.sensor.width if width is None else width,
                                     height=scene.sensor.height if height is None else height)
        scene = dataclasses.replace(scene, sensor=sensor)
    settings = dict(settings)
    integrand = PixelIntegrand(scene, **settings)
    est = integrand.estimator
    need = int(getattr(est, "min_units", 1))
    if spp < need:
        raise ValueError(f"spp: {est.label} fits its coefficients per pixel and needs spp >= {need}, got {spp}")
    work = integrand.work_per_sample * cost
    if spp * work > MAX_PIXEL_WORK:
        raise ValueError(f"spp: {spp} samples per pixel x {work} (rays + uniforms/4 per sample, for {est.label} "
                         f"with {integrand.units} unit(s) per shading point) exceeds the per-pixel block limit "
                         f"{MAX_PIXEL_WORK}; use spp <= {MAX_PIXEL_WORK // work}, or fewer samples per shading point")
    if chunk_pixels is None:
        chunk_pixels = max(1, (4 * _RAYS_PER_CHUNK) // (spp * work))
    elif min(chunk_pixels, TILE_PIXELS) * spp * work > MAX_PIXEL_WORK:
        raise ValueError(f"chunk_pixels: a block of {chunk_pixels} pixels x {spp} spp x {work} (rays + "
                         f"uniforms/4 per sample) exceeds the block limit {MAX_PIXEL_WORK}; use "
                         f"chunk_pixels <= {MAX_PIXEL_WORK // (spp * work)} or None (automatic)")
    from ..points import SetSampler

    root = as_seed_sequence(rng)
    sampler = SetSampler(points, integrand.dim, spp, rng=unit_seed(root, 0))
    settings["estimator"], settings["units"] = est, integrand.units
    job = job_class(scene, settings, sampler, spp, root, min(chunk_pixels, TILE_PIXELS), integrand)
    return job, sampler, workers


def execute(job: _Job, workers: int, executor: Any = None,
            progress: Callable[[int, int], None] | None = None) -> tuple[np.ndarray, ...]:
    """Run a job's tiles (in this process, a process pool of ``workers`` or the caller's
    ``executor``): its outputs as ``(H, W, 3)`` float32 images."""
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be a callable progress(done, total) or None, got {type(progress).__name__}")
    if executor is not None and not callable(getattr(executor, "submit", None)):
        raise TypeError(f"executor: expected a concurrent.futures.Executor or None, got {type(executor).__name__}")
    height, width = job.scene.sensor.height, job.scene.sensor.width
    n_pixels = height * width
    tiles = list(range(-(-n_pixels // TILE_PIXELS)))
    images = tuple(np.zeros((n_pixels, 3), np.float32) for _ in job.outputs)
    done = 0

    def collect(results):
        nonlocal done
        for a, arrays in results:
            for image, arr in zip(images, arrays):
                image[a:a + len(arr)] = arr
            done += len(arrays[0])
            if progress is not None:
                progress(done, n_pixels)

    workers = min(workers, len(tiles))
    if workers == 1 and executor is None:
        for t in tiles:
            collect([job.tile(t)])
    else:
        try:
            pickle.dumps(job)
        except (pickle.PicklingError, AttributeError, TypeError) as exc:
            raise TypeError(f"estimator: {job.integrand.estimator!r} cannot be sent to worker processes ({exc}); "
                            "define functions it uses (e.g. a heuristic) at module level, or use workers=1") from None
        n_batches = 2 * workers
        batches = [b for b in (tiles[i::n_batches] for i in range(n_batches)) if b]
        if executor is not None:
            for res in executor.map(_run_tiles, [job] * len(batches), batches):
                collect(res)
        else:
            import multiprocessing as mp
            ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
            with ProcessPoolExecutor(workers, mp_context=ctx) as pool:
                for res in pool.map(_run_tiles, [job] * len(batches), batches):
                    collect(res)
    return tuple(image.reshape(height, width, 3) for image in images)


def default_workers() -> int:
    """Worker processes to use by default: the CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        return os.cpu_count() or 1
