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
uniforms) plus the image accumulators.  Worker processes receive the job (scene, its
BVH, estimator, point sampler) once each, as the shared input of
:func:`vrlab.execution.run_units` (inherited by forked local workers, pickled once per
spawned one, scattered once to each Dask worker); a task carries its (tile, batch)
indices only, and each worker builds Embree's scene once.

``render`` has no process-wide side effects on the calling process: the glibc allocator
tuning of :mod:`vrlab._alloc` is applied only in the worker processes it starts (and by
the ``vrlab render`` command, whose process is vrlab's own).  With ``workers=1`` the
render runs in the caller's process with its allocator as it is: about 1.3x slower on
veach_mis than with the tuning (2.9-3.3 s against 2.1-2.6 s at 128x96, 16 spp, on a busy
2-core machine).  A program that wants the speed calls
``vrlab.render.keep_freed_memory()`` once, itself.
"""
from __future__ import annotations

import inspect
import os
import time
from typing import Any, Callable

import numpy as np

from .. import checks, limits
from .._rng import RNGLike, as_seed_sequence, unit_seed
from ..estimate import Estimate
from ..execution import check_executor, check_picklable, forks_workers, run_units
from .cost import Cost
from .pixels import PixelIntegrand
from .planning import (MAX_PIXEL_WORK, SPP_BATCH, TILE_PIXELS, RenderPlan, _as_scene, check_work,  # noqa: F401
                   default_workers, plan)
from .scene import Scene

__all__ = ["TILE_PIXELS", "default_workers", "render"]

TASKS_PER_WORKER = 4         # tasks (groups of tiles) per worker process and batch: balances the load
MAX_SPP = limits.MAX_SPP       # samples per pixel of one render (vrlab.limits, shared with the CLI)


def _concat(stats: list):
    """Per-block statistics (pixel axis 1 of their arrays) joined into one for the tile, by the
    statistics' own ``concat`` (:class:`vrlab.estimate.Moments`)."""
    if len(stats) == 1:                     # one block per tile (the default block size)
        return stats[0]
    return type(stats[0]).concat(stats, axis=1)


class _Job:
    """Everything a process needs to render units, sent to each worker process once with the
    built integrand (13-110 KB pickled for the built-in scenes, ~740 MB for a 1 M-triangle
    mesh: cheaper to receive than to rebuild; :func:`vrlab.execution.run_units`' ``shared``).

    A unit is (tile t, spp batch k): the tile's pixels with samples [k B, (k + 1) B) of each
    (B = ``batch``), uniforms from the unit's own stream, child (t + 1, k) of the root seed.
    It returns mergeable per-pixel statistics (``Estimator.accumulate``), merged over the
    batches in batch order: so a render in one batch or in many, resumed or extended from a
    checkpoint, on any number of workers, gives the same bytes for the same batch size."""

    #: the estimates a render returns (one statistics object each per unit)
    estimates = ("image",)

    def __init__(self, plan: RenderPlan, samplers: dict, root, chunk: int):
        self.plan, self.samplers, self.root, self.chunk = plan, samplers, root, chunk
        self.scene, self.integrand = plan.scene, plan.integrand
        self.spp, self.batch = plan.spp, plan.spp_batch
        self.width, self.n_pixels = self.scene.sensor.width, self.scene.sensor.width * self.scene.sensor.height

    @property
    def n_batches(self) -> int:
        return -(-self.spp // self.batch)

    @property
    def n_tiles(self) -> int:
        return -(-self.n_pixels // TILE_PIXELS)

    def unit(self, t: int, k: int) -> tuple[int, int, tuple, Cost]:
        """``(t, k, statistics, cost)`` of tile ``t``, spp batch ``k``: its pixels block after
        block, and what they cost (:class:`~vrlab.render.cost.Cost`, the unit's own counter)."""
        a, b = t * TILE_PIXELS, min((t + 1) * TILE_PIXELS, self.n_pixels)
        size = min(self.batch, self.spp - k * self.batch)
        gen = np.random.default_rng(unit_seed(self.root, t + 1, k))
        stats = []
        cost = Cost()
        for c in range(a, b, self.chunk):
            idx = np.arange(c, min(c + self.chunk, b))
            pix = np.stack(np.divmod(idx, self.width), -1)
            u = self.samplers[size].draw(len(pix), gen)
            cost.samples += len(pix) * size
            with np.errstate(invalid="ignore", divide="ignore"):
                stats.append(self.block(pix, u, gen, cost))
        return t, k, tuple(_concat(list(s)) for s in zip(*stats)), cost

    def build(self) -> None:
        """Build the scene's lazily built structures here (:meth:`DirectLighting.build`):
        before forking workers, so that they inherit them instead of each building its own."""
        self.integrand.lighting.build()

    def block(self, pixels: np.ndarray, u: np.ndarray, gen: np.random.Generator, cost: Cost) -> tuple:
        """Statistics of a block of pixels ``(P, 2)`` with uniforms ``(P, S, dim)``; its work
        is counted in ``cost``."""
        integ = self.integrand
        return (integ.estimator.accumulate(integ.outputs(pixels, u, cost)),)

    def summarize(self, i: int, stats) -> tuple[np.ndarray, np.ndarray]:
        """``(value, stderr)``, both ``(P, 3)``, of estimate ``i`` from its merged statistics."""
        value, stderr = self.integrand.estimator.summarize(stats)
        return np.moveaxis(np.asarray(value), 0, -1), np.moveaxis(np.asarray(stderr), 0, -1)


def _units(job: _Job, units: list[tuple[int, int]]) -> list:
    """The units ``(tile, batch)`` of a task, on the job its worker received once."""
    return [job.unit(t, k) for t, k in units]


_PLAN_SETTINGS = ("spp", "estimator", "points", "units", "light_selection", "emitter_samples", "bsdf_samples",
                  "ris_candidates", "chunk_pixels", "width", "height", "spp_batch", "workers", "kernels")


def as_plan(scene: Any, given: dict) -> RenderPlan:
    """``scene`` if it is a :class:`RenderPlan` (then every setting in ``given`` must keep
    :func:`plan`'s default: a ``ValueError`` names the first that does not), else :func:`plan`
    of the scene with the ``given`` settings."""
    if not isinstance(scene, RenderPlan):
        return plan(scene, **given)
    defaults = {k: v.default for k, v in inspect.signature(plan).parameters.items()}
    for key, value in given.items():
        default = defaults[key]
        same = value is default or (type(value) is type(default) and isinstance(value, (str, int))
                                    and value == default)
        if not same:
            raise ValueError(f"{key}: the plan fixes it; build another plan with vrlab.render.plan(..., {key}=...) "
                             "instead")
    return scene


def render(scene: Any, spp: int | None = None, estimator: Any = "mis-power", *,
           points: Any = None, rng: RNGLike = None, workers: int | None = 1, executor: Any = None,
           units: int | None = None, light_selection: str = "uniform", emitter_samples: int | None = None,
           bsdf_samples: int | None = None, ris_candidates: int = 8, chunk_pixels: int | None = None,
           progress: Callable[[int, int], None] | None = None, width: int | None = None,
           height: int | None = None, spp_batch: int | None = None, checkpoint: Any = None,
           kernels: str = "auto") -> Estimate:
    """Render ``scene`` with direct lighting: an :class:`~vrlab.Estimate` whose ``value``
    (the image) and ``stderr`` (the per-pixel standard error) are ``(H, W, 3)`` float32,
    with ``n`` = spp.

    ``scene``: a :class:`~vrlab.render.RenderPlan` (:func:`vrlab.render.plan`: every setting
    resolved and checked once; then only ``rng``, ``executor``, ``progress`` and
    ``checkpoint`` may be given here, the other settings keep their defaults), or a
    :class:`Scene`, a path to a scene XML file, an XML string or a built-in scene name, with
    the settings below (``plan``'s):

    ``estimator``: an estimator object of :mod:`vrlab.estimators` (``MIS(["light",
    "bsdf"], heuristic=...)``, ``MonteCarlo("cosine")``, ``OneSampleMIS``, ``Antithetic``,
    ``RIS``, ``ControlVariate``, ``DefensiveMixture``...), a user's subclass of
    :class:`~vrlab.estimators.Estimator`, or a preset name (:mod:`vrlab.render.presets`;
    default ``"mis-power"``, Mitsuba's ``direct`` integrator).  It runs at every shading
    point on the :class:`~vrlab.render.shading.ShadingIntegrand`, whose techniques are
    ``"bsdf"``, ``"light"``, ``"cosine"`` and ``"uniform"``; ``units`` of it per camera ray
    (default 1; a preset's from ``emitter_samples``/``bsdf_samples``, which default to
    the scene's integrator settings; ``ris_candidates`` = M of ``"ris"``, default 8).

    ``points``: the pixels' primary-sample-space uniforms: None (the scene's sampler:
    i.i.d. for Mitsuba's ``independent``, see :mod:`vrlab.render.sensors.samplers`), any vrlab
    point set or SciPy engine, as a class, a name or an instance (see
    :class:`vrlab.points.SetSampler`: ``"stratified"`` / ``PaddedStratified`` are padded
    jittered strata, others a shared set with a Cranley-Patterson shift per pixel).
    ``stderr`` is only a valid error bar for i.i.d. points (``extra["stderr_note"]`` says so
    otherwise).  ``rng`` seeds everything (see the module docstring); ``workers``
    processes render tiles in parallel with the same result (None: :func:`default_workers`); ``executor``: a ``concurrent.futures.Executor`` of the caller's
    (e.g. a process pool with the spawn start method, a Dask client) to run the tiles on
    instead, in max(64, 4 x ``workers``) tasks per batch, also with the same result;
    ``progress(done, total)`` is called after each unit (tile x spp batch) with the pixel
    samples done and their total, H x W x spp; ``light_selection``:
    ``"uniform"`` (default), ``"power"`` or ``"bvh"``.  ``spp_batch``: samples per pixel of one
    work unit (default 64; the image depends on it, not on how units are run).
    ``checkpoint``: a ``.npz`` path where the per-pixel statistics are saved after each batch;
    an existing checkpoint of the same render resumes it, or extends it to a larger ``spp``
    (:mod:`vrlab.render.checkpoint`).  ``width``/``height`` override the scene's sensor.
    ``kernels``: ``"auto"`` (default), ``"numba"`` or ``"numpy"``: the kernels of the
    per-sample path (``extra["kernels"]`` says which ran).

    Checked once, by :func:`~vrlab.render.plan`, with errors naming the argument: the scene,
    the estimator (and its technique names against the shading integrand), ``points``,
    ``spp``, ``chunk_pixels``, ``workers`` (at most :func:`vrlab.limits.max_workers`), ``units``
    and the sample counts; one pixel's block must fit :data:`MAX_PIXEL_WORK` (about 1 GB); with
    ``workers > 1`` the estimator must be picklable (a heuristic defined at module level,
    not a lambda).
    """
    t0 = time.perf_counter()
    p = as_plan(scene, dict(spp=spp, estimator=estimator, points=points, units=units, light_selection=light_selection,
                            emitter_samples=emitter_samples, bsdf_samples=bsdf_samples, ris_candidates=ris_candidates,
                            chunk_pixels=chunk_pixels, width=width, height=height, spp_batch=spp_batch,
                            workers=workers, kernels=kernels))
    job, sampler = build_job(p, rng)
    loaded: list[int] = []
    cost = Cost()
    ((value, stderr),) = execute(job, p.workers, executor, progress, checkpoint, resumed=loaded.append, cost=cost)
    integrand, spp = job.integrand, job.spp
    est = integrand.estimator
    extra = {"units": integrand.units, "points": sampler.label, "spp_batch": job.batch, "kernels": p.kernels,
             "cost": cost.report()}
    if checkpoint is not None:            # samples per pixel read from the checkpoint, not rendered now
        extra["spp_resumed"] = loaded[0]
    if not sampler.iid:
        extra["stderr_note"] = ("stderr uses the i.i.d. formula but the pixel's points are not independent "
                                f"({sampler.label}): it is not a valid error bar")
    evals = integrand.units * int(est.evals_per_unit)
    return Estimate(value, stderr, spp, spp * evals, time.perf_counter() - t0, stderr.astype(np.float64) ** 2 * spp,
                    est.label, extra)


def build_job(p: RenderPlan, rng: RNGLike, job_class: type = _Job, cost: int = 1) -> tuple[_Job, Any]:
    """The work of plan ``p`` seeded by ``rng``: ``(job, point sampler)``.  ``cost``: pixel
    integrand evaluations per sample (3 for the gradient-domain renders: it sizes the blocks)."""
    from ..points import SetSampler

    chunk = check_work(p.integrand, p.spp, p.spp_batch, p.chunk_pixels, cost)
    root = as_seed_sequence(rng)
    batch, dim = p.spp_batch, p.integrand.dim
    samplers = {batch: SetSampler(p.points, dim, batch, rng=unit_seed(root, 0))}
    if p.spp % batch:                                  # the last, partial batch has its own set
        samplers[p.spp % batch] = SetSampler(p.points, dim, p.spp % batch, rng=unit_seed(root, 0, p.spp % batch))
    return job_class(p, samplers, root, chunk), samplers[batch]


def execute(job: _Job, workers: int, executor: Any = None, progress: Callable[[int, int], None] | None = None,
            checkpoint: Any = None, resumed: Callable[[int], None] | None = None, cost: Cost | None = None
            ) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """Run a job's units, batch after batch (in this process, a process pool of ``workers``
    or the caller's ``executor``), merging each tile's statistics in batch order and saving
    them to ``checkpoint`` after each batch: ``(value, stderr)`` images ``(H, W, 3)`` float32
    per estimate of the job.  ``resumed(spp)``, with a checkpoint: called once before any unit
    runs with the samples per pixel the checkpoint already holds (0 for a new one).  ``cost``:
    a :class:`~vrlab.render.cost.Cost` the units' counts are added to, batch after batch,
    tile after tile (the units rendered now: not those a checkpoint holds)."""
    from .checkpoint import check_path, load_checkpoint, render_hash, save_checkpoint

    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be a callable progress(done, total) or None, got {type(progress).__name__}")
    executor = check_executor(executor)
    path = None if checkpoint is None else check_path(checkpoint)
    workers = min(workers, job.n_tiles)
    if workers > 1 or executor is not None:     # the job goes to each worker once (run_units' shared)
        check_picklable(job, executor, f"estimator: {job.integrand.estimator!r} cannot be sent to worker "
                        "processes", "define functions it uses (e.g. a heuristic) at module level, or use "
                        "workers=1", keep=False)
    digest = None
    stats: dict = {}
    start = 0
    if path is not None:
        digest = render_hash(type(job).__name__, job.scene, repr(job.integrand.estimator), job.plan.units,
                             job.plan.sampling(), job.samplers[job.batch].label,
                             (job.root.entropy, tuple(job.root.spawn_key)), job.batch)
        start, stats = load_checkpoint(path, digest, job.batch, job.spp,
                                       job.integrand.estimator.statistics_from_state)
    if path is not None and resumed is not None:
        resumed(min(start * job.batch, job.spp))
    if workers > 1 and executor is None and forks_workers():
        job.build()                         # Embree's scene once, inherited by the forked workers
    tiles = list(range(job.n_tiles))
    # progress counts pixel samples: a unit (tile t, batch k) is its pixels x batch k's spp
    total, done = job.n_pixels * job.spp, min(start * job.batch, job.spp) * job.n_pixels
    # the local pool's processes (vrlab's own) tune their allocator in vrlab.execution.worker_init
    fn = _units
    # tasks per batch (one pool serves all batches): a tile each in this process; else about 4 per
    # worker, at least 64 on a caller's executor (a Dask cluster may have more workers than ``workers``)
    if workers == 1 and executor is None:
        groups = len(tiles)
    else:
        groups = min(len(tiles), TASKS_PER_WORKER * workers if executor is None else max(TASKS_PER_WORKER * workers, 64))
    tasks = [([(t, k) for t in tiles[i::groups]],) for k in range(start, job.n_batches) for i in range(groups)]
    new: dict = {}                          # batch -> {tile: statistics}, until the batch is merged
    k = start
    for _, res in run_units(fn, tasks, workers=workers, executor=executor, shared=job):
        for t, batch, st, counted in res:
            new.setdefault(batch, {})[t] = (st, counted)
            done += (min((t + 1) * TILE_PIXELS, job.n_pixels) - t * TILE_PIXELS) * min(job.batch,
                                                                                   job.spp - batch * job.batch)
            if progress is not None:
                progress(done, total)
        while len(new.get(k, ())) == len(tiles):   # merge whole batches in batch order: the same bytes
            for t, (st, counted) in sorted(new.pop(k).items()):        # however units ran
                stats[t] = st if t not in stats else tuple(a.merge(b) for a, b in zip(stats[t], st))
                if cost is not None:
                    cost.add(counted)
            k += 1
            if path is not None:
                save_checkpoint(path, digest, job.spp, job.batch, k, stats)
    height, width = job.scene.sensor.height, job.scene.sensor.width
    out = []
    for i in range(len(job.estimates)):
        value, stderr = np.zeros((job.n_pixels, 3), np.float32), np.zeros((job.n_pixels, 3), np.float32)
        for t in tiles:
            a = t * TILE_PIXELS
            v, e = job.summarize(i, stats[t][i])
            value[a:a + len(v)], stderr[a:a + len(e)] = v, e
        out.append((value.reshape(height, width, 3), stderr.reshape(height, width, 3)))
    return tuple(out)
