"""``render``: the image as per-pixel Monte Carlo estimates, in tiles, optionally in parallel.

Work units are tiles of ``TILE_PIXELS`` consecutive pixels (row-major).  Tile t draws
its uniforms from its own stream, child t + 1 of the root ``SeedSequence`` (child 0
scrambles the shared QMC set of the ``sobol``/``halton`` pixel samplers), pixel after
pixel; inside a tile pixels are processed in blocks of ``chunk_pixels``.  So the image
depends on the seed only: not on the block size, the number of worker processes or
the order in which tiles finish (seeds per work unit, never per worker).  Memory is
bounded by the block size (rays x uniforms) plus the image accumulators.
"""
from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor
from typing import Callable

import numpy as np

from .._alloc import keep_freed_memory
from .._rng import RNGLike, as_seed_sequence, unit_seed
from ..estimate import Moments
from ..points.base import check_int
from .direct import DirectLighting
from .pixel_samplers import PixelSampler
from .scene import Scene

__all__ = ["TILE_PIXELS", "default_workers", "render"]

TILE_PIXELS = 1024           # pixels per work unit (fixed: it defines the random streams)
_RAYS_PER_CHUNK = 5 << 14    # block size budget (1024 pixels x 64 spp of mis-power: one block per tile)


class _Job:
    """Everything a worker needs to render tiles (built once per process)."""

    def __init__(self, scene, spp, strategy, pixel_sampler, light_selection, chunk_pixels, root, options,
                 integrator: DirectLighting | None = None):
        keep_freed_memory()             # reuse freed ray temporaries (see vrlab._alloc)
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
    return [_WORKER_JOB.tile(t) for t in tiles]


def render(scene: Scene, spp: int | None = None, strategy: str = "mis-power", *, rng: RNGLike = None,
           pixel_sampler: str = "independent", chunk_pixels: int | None = None,
           light_selection: str = "uniform", emitter_samples: int | None = None,
           bsdf_samples: int | None = None, ris_candidates: int = 8, workers: int = 1,
           progress: Callable[[int, int], None] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Render ``scene`` with direct lighting: ``(image, stderr)``, both ``(H, W, 3)`` float32.

    ``spp`` samples per pixel (default: the scene's sampler ``sample_count``); ``strategy``
    one of :data:`vrlab.render.direct.STRATEGIES`; ``emitter_samples``/``bsdf_samples``
    default to the scene's integrator settings; ``ris_candidates`` = M for ``"ris"``;
    ``rng`` seeds everything (see the module docstring); ``workers`` processes render
    tiles in parallel with the same result; ``progress(done_pixels, total)`` is called
    after each tile.  ``stderr`` is the per-pixel standard error sqrt(s^2 / spp) (NaN
    when spp = 1), valid for the ``independent`` pixel sampler only (the others
    correlate a pixel's samples; the i.i.d. formula then overestimates).
    """
    spp = check_int("spp", scene.sensor.spp if spp is None else spp, 1)
    workers = check_int("workers", workers, 1)
    options = dict(emitter_samples=emitter_samples, bsdf_samples=bsdf_samples, ris_candidates=ris_candidates)
    root = as_seed_sequence(rng)
    probe = DirectLighting(scene, strategy, light_selection, **options)   # validates the settings
    rays_cost = 1 + probe.n_l + probe.n_b + (probe.n_l * probe.ris_candidates if strategy == "ris" else 0)
    if chunk_pixels is None:
        chunk_pixels = max(1, (4 * _RAYS_PER_CHUNK) // (spp * (rays_cost + probe.dims // 4)))
    chunk_pixels = check_int("chunk_pixels", chunk_pixels, 1)
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

    workers = min(int(workers), len(tiles))
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
