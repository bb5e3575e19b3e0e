"""``render``: the image as per-pixel Monte Carlo estimates, in tiles, optionally in parallel.

Work units are tiles of ``TILE_PIXELS`` consecutive pixels (row-major).  Tile t draws
its uniforms from its own stream, child t + 1 of the root ``SeedSequence`` (child 0
scrambles the shared QMC set of the ``sobol``/``halton`` pixel samplers), pixel after
pixel; inside a tile pixels are processed in blocks of ``chunk_pixels``.  So the image
depends on the seed only: not on the block size, the number of worker processes or
the order in which tiles finish (seeds per work unit, never per worker).  Memory is
bounded by the block size (rays x uniforms) plus the image accumulators.

``render`` has no process-wide side effects on the calling process: the glibc allocator
tuning of :mod:`vrlab._alloc` is applied only in the worker processes it starts (and by
the ``vrlab render`` command, whose process is vrlab's own).  With ``workers=1`` the
render runs in the caller's process with its allocator as it is: about 1.3x slower on
veach_mis than with the tuning (2.9-3.3 s against 2.1-2.6 s at 128x96, 16 spp, on a busy
2-core machine).  A program that wants the speed calls
``vrlab.render.keep_freed_memory()`` once, itself.

``render`` checks its arguments once per call (see its docstring); the per-ray work
(:mod:`vrlab.render.direct`) is not checked again.
"""
from __future__ import annotations

import dataclasses
import os
from concurrent.futures import ProcessPoolExecutor
from typing import Any, Callable

import numpy as np

from .. import checks
from .._alloc import keep_freed_memory
from .._rng import RNGLike, as_seed_sequence, unit_seed
from ..estimate import Moments
from .direct import STRATEGIES, DirectLighting
from .lights import LIGHT_SELECTIONS
from .pixel_samplers import PIXEL_SAMPLERS, PixelSampler
from .scene import Scene
from .scene_checks import MAX_SAMPLES

__all__ = ["TILE_PIXELS", "default_workers", "render"]

TILE_PIXELS = 1024           # pixels per work unit (fixed: it defines the random streams)
_RAYS_PER_CHUNK = 5 << 14    # block size budget (1024 pixels x 64 spp of mis-power: one block per tile)
#: one pixel's block (spp x (rays + uniforms/4) per sample) may be at most 32 default blocks (~1 GB)
MAX_PIXEL_WORK = 32 * 4 * _RAYS_PER_CHUNK
MAX_QMC_DIMS = 1024          # uniforms per sample of the sobol/halton pixel samplers (their set's memory)


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
    """Everything a worker needs to render tiles (built once per process)."""

    def __init__(self, scene, spp, strategy, pixel_sampler, light_selection, chunk_pixels, root, options,
                 integrator: DirectLighting | None = None):
        self.integrator = integrator or DirectLighting(scene, strategy, light_selection, **options)
        self.spp, self.root, self.chunk = spp, root, chunk_pixels
        self.width, self.n_pixels = scene.sensor.width, scene.sensor.width * scene.sensor.height
        lay = self.integrator.layout
        base = np.random.default_rng(unit_seed(root, 0))          # the shared QMC set's scramble
        self.sampler = PixelSampler(pixel_sampler, spp, lay.dims, base, groups=lay.groups)

    def tile(self, t: int) -> tuple[int, np.ndarray, np.ndarray]:
        """(first pixel, mean (n, 3), standard error (n, 3)) of tile ``t``."""
        a, b = t * TILE_PIXELS, min((t + 1) * TILE_PIXELS, self.n_pixels)
        gen = np.random.default_rng(unit_seed(self.root, t + 1))
        mean, err = np.zeros((b - a, 3)), np.zeros((b - a, 3))
        integ, spp = self.integrator, self.spp
        for c in range(a, b, self.chunk):
            idx = np.arange(c, min(c + self.chunk, b))
            pix = np.stack(np.divmod(idx, self.width), -1)
            u = self.sampler.draw(len(pix), gen)
            o, d = integ.camera.pixel_rays(pix[:, None, :], u[..., :2], np.float32)
            values = integ.radiance_of(o.reshape(-1, 3), d.reshape(-1, 3), u.reshape(-1, integ.dims))
            mom = Moments().add(values.reshape(len(pix), spp, 3), axis=1)
            mean[idx - a] = mom.mean
            with np.errstate(invalid="ignore"):
                err[idx - a] = np.sqrt(mom.variance / spp)
        return a, mean, err


_WORKER_JOB: _Job | None = None


def _init_worker(args) -> None:
    global _WORKER_JOB
    _WORKER_JOB = _Job(*args)


def _run_tiles(tiles: list[int]) -> list[tuple[int, np.ndarray, np.ndarray]]:
    keep_freed_memory()     # worker processes are vrlab's own: reuse freed ray temporaries (vrlab._alloc)
    return [_WORKER_JOB.tile(t) for t in tiles]


def render(scene: Scene | str | os.PathLike, spp: int | None = None, strategy: str = "mis-power", *,
           rng: RNGLike = None, pixel_sampler: str = "independent", chunk_pixels: int | None = None,
           light_selection: str = "uniform", emitter_samples: int | None = None,
           bsdf_samples: int | None = None, ris_candidates: int = 8, workers: int | None = 1,
           progress: Callable[[int, int], None] | None = None, width: int | None = None,
           height: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Render ``scene`` with direct lighting: ``(image, stderr)``, both ``(H, W, 3)`` float32.

    ``spp`` samples per pixel (default: the scene's sampler ``sample_count``); ``strategy``
    one of :data:`vrlab.render.direct.STRATEGIES`; ``emitter_samples``/``bsdf_samples``
    default to the scene's integrator settings; ``ris_candidates`` = M for ``"ris"``;
    ``rng`` seeds everything (see the module docstring); ``workers`` processes render
    tiles in parallel with the same result; ``progress(done_pixels, total)`` is called
    after each tile.  ``stderr`` is the per-pixel standard error sqrt(s^2 / spp) (NaN
    when spp = 1), valid for the ``independent`` pixel sampler only (the others
    correlate a pixel's samples; the i.i.d. formula then overestimates).

    ``scene`` may also be a path to a scene XML file, an XML string or a built-in scene
    name (loaded with :func:`~vrlab.render.load_scene`); ``width``/``height`` override the
    sensor's resolution; ``workers=None`` uses :func:`default_workers`.

    Checked once per call: the scene (``Scene.validate()``); ``strategy``,
    ``pixel_sampler`` and ``light_selection`` among their names; ``spp``,
    ``chunk_pixels`` and ``workers`` (at most max(256, 4 x CPUs)) integers >= 1;
    ``emitter_samples``, ``bsdf_samples`` and ``ris_candidates`` integers in [0, 4096]
    (``"ris"`` needs ``ris_candidates`` >= 1); ``rng`` as in :mod:`vrlab._rng`; ``progress``
    callable.  One pixel's block must fit :data:`MAX_PIXEL_WORK` (spp x (rays +
    uniforms/4) per sample, about 1 GB) and the ``sobol``/``halton`` samplers at most
    :data:`MAX_QMC_DIMS` uniforms per sample: else a ``ValueError`` naming ``spp`` /
    ``pixel_sampler`` and the sample counts.  Errors are ``TypeError``/``ValueError``
    naming the argument (:class:`~vrlab.render.SceneError` for a scene file).
    """
    scene = _as_scene(scene)
    strategy = checks.choice(strategy, "strategy", STRATEGIES)
    pixel_sampler = checks.choice(pixel_sampler, "pixel_sampler", PIXEL_SAMPLERS)
    light_selection = checks.choice(light_selection, "light_selection", LIGHT_SELECTIONS)
    spp = checks.integer(scene.sensor.spp if spp is None else spp, "spp", low=1)
    emitter_samples = _optional_int(emitter_samples, "emitter_samples", 0, MAX_SAMPLES)
    bsdf_samples = _optional_int(bsdf_samples, "bsdf_samples", 0, MAX_SAMPLES)
    ris_candidates = checks.integer(ris_candidates, "ris_candidates", low=0, high=MAX_SAMPLES)
    chunk_pixels = _optional_int(chunk_pixels, "chunk_pixels", 1)
    limit = max(256, 4 * (os.cpu_count() or 1))
    workers = default_workers() if workers is None else checks.integer(workers, "workers", low=1, high=limit)
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be a callable progress(done, total) or None, got {type(progress).__name__}")
    if width is not None or height is not None:
        sensor = dataclasses.replace(scene.sensor, width=scene.sensor.width if width is None else width,
                                     height=scene.sensor.height if height is None else height)
        scene = dataclasses.replace(scene, sensor=sensor)
    options = dict(emitter_samples=emitter_samples, bsdf_samples=bsdf_samples, ris_candidates=ris_candidates)
    root = as_seed_sequence(rng)
    probe = DirectLighting(scene, strategy, light_selection, **options)   # validates the settings
    rays_cost = 1 + probe.n_l + probe.n_b + (probe.n_l * probe.ris_candidates if strategy == "ris" else 0)
    work = rays_cost + probe.dims // 4
    if spp * work > MAX_PIXEL_WORK:
        raise ValueError(f"spp: {spp} samples per pixel x {work} (rays + uniforms/4 per sample, from "
                         f"emitter_samples={probe.n_l}, bsdf_samples={probe.n_b}, ris_candidates="
                         f"{probe.ris_candidates}) exceeds the per-pixel block limit {MAX_PIXEL_WORK}; "
                         f"use spp <= {MAX_PIXEL_WORK // work}, or fewer samples per shading point")
    if pixel_sampler in ("sobol", "halton") and probe.dims > MAX_QMC_DIMS:
        raise ValueError(f"pixel_sampler {pixel_sampler!r} supports at most {MAX_QMC_DIMS} uniforms per "
                         f"sample, these settings need {probe.dims} (emitter_samples={probe.n_l}, "
                         f"bsdf_samples={probe.n_b}, ris_candidates={probe.ris_candidates}); use "
                         "'independent' or 'stratified'")
    if chunk_pixels is None:
        chunk_pixels = max(1, (4 * _RAYS_PER_CHUNK) // (spp * work))
    elif min(chunk_pixels, TILE_PIXELS) * spp * work > MAX_PIXEL_WORK:
        raise ValueError(f"chunk_pixels: a block of {chunk_pixels} pixels x {spp} spp x {work} (rays + "
                         f"uniforms/4 per sample) exceeds the block limit {MAX_PIXEL_WORK}; use "
                         f"chunk_pixels <= {MAX_PIXEL_WORK // (spp * work)} or None (automatic)")
    args = (scene, spp, strategy, pixel_sampler, light_selection, min(chunk_pixels, TILE_PIXELS), root,
            options)
    height, width = scene.sensor.height, scene.sensor.width
    n_pixels = height * width
    tiles = list(range(-(-n_pixels // TILE_PIXELS)))
    mean, err = np.zeros((n_pixels, 3), np.float32), np.zeros((n_pixels, 3), np.float32)
    done = 0

    def collect(results):
        nonlocal done
        for a, m, e in results:
            mean[a:a + len(m)], err[a:a + len(m)] = m, e
            done += len(m)
            if progress is not None:
                progress(done, n_pixels)

    workers = min(workers, len(tiles))
    if workers == 1:
        job = _Job(*args, integrator=probe)
        for t in tiles:
            collect([job.tile(t)])
    else:
        import multiprocessing as mp
        global _WORKER_JOB
        fork = "fork" in mp.get_all_start_methods()
        ctx = mp.get_context("fork" if fork else "spawn")
        batches = [tiles[i::4 * workers] for i in range(4 * workers)]
        init = {} if fork else dict(initializer=_init_worker, initargs=(args,))
        if fork:                                  # forked workers inherit the job built here
            _WORKER_JOB = _Job(*args, integrator=probe)
        try:
            with ProcessPoolExecutor(workers, mp_context=ctx, **init) as pool:
                for res in pool.map(_run_tiles, [b for b in batches if b]):
                    collect(res)
        finally:
            _WORKER_JOB = None
    shape = (height, width, 3)
    return mean.reshape(shape), err.reshape(shape)


def default_workers() -> int:
    """Worker processes to use by default: the CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        return os.cpu_count() or 1
