"""Workers receive a render's job once (issue 35): a worker process unpickles the job at most
once however many tasks it runs (forked local workers: never, they inherit it), builds Embree's
scene once, and the image is the in-process one, byte for byte.

The job is a :class:`CountingJob`, whose ``__setstate__`` (each unpickling) and ``unit`` append
the process id to a log file: the counts per worker process are read back from it."""
from __future__ import annotations

import collections
import os
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import pytest

from vrlab import execution
from vrlab.render import plan
from vrlab.render.film import _Job, build_job, execute

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="counts per pid, forks")


class CountingJob(_Job):
    """A render job that logs "load pid" when unpickled and "unit pid id(job)" per unit."""

    log = os.devnull

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        with open(self.log, "a") as f:
            f.write(f"load {os.getpid()}\n")

    def unit(self, t: int, k: int):
        with open(self.log, "a") as f:
            f.write(f"unit {os.getpid()} {id(self)}\n")
        return super().unit(t, k)


@pytest.fixture(scope="module")
def mesh_scene(tmp_path_factory):
    """A height field of 1058 triangles (none coplanar with a neighbour: more than the all-pairs
    limit and than EMBREE_FROM, so the scene goes to the BVH and its triangles to Embree, with
    either kernels) under a rectangle light."""
    from vrlab.render import load_scene

    folder = tmp_path_factory.mktemp("mesh")
    grid = 24
    x, y = np.meshgrid(np.linspace(-1, 1, grid), np.linspace(-1, 1, grid), indexing="ij")
    z = 0.03 * np.random.default_rng(0).standard_normal(x.shape)
    v = np.stack([x, y, z], -1).reshape(-1, 3)
    i = np.arange(grid * grid).reshape(grid, grid)[:-1, :-1].ravel()
    tri = np.concatenate([np.stack([i, i + grid, i + grid + 1], 1), np.stack([i, i + grid + 1, i + 1], 1)])
    lines = ["ply", "format ascii 1.0", f"element vertex {len(v)}", "property float x", "property float y",
             "property float z", f"element face {len(tri)}", "property list uchar int vertex_indices", "end_header"]
    lines += [" ".join(f"{c:.6f}" for c in p) for p in v] + [f"3 {a} {b} {c}" for a, b, c in tri]
    (folder / "terrain.ply").write_text("\n".join(lines) + "\n")
    xml = folder / "scene.xml"
    xml.write_text("""<scene version="3.0.0"><integrator type="direct"/>
  <sensor type="perspective"><float name="fov" value="50"/>
    <transform name="to_world"><lookat origin="0, -2.2, 1.6" target="0, 0, 0" up="0, 0, 1"/></transform>
    <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="30"/></film></sensor>
  <shape type="ply"><string name="filename" value="terrain.ply"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.6, 0.5"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.3"/><rotate x="1" angle="180"/>
    <translate z="1.5"/></transform><emitter type="area"><rgb name="radiance" value="20"/></emitter></shape>
</scene>""")
    return load_scene(xml)


def _job(scene, log, ballast: int = 0) -> CountingJob:
    """8 units (2 tiles x 4 spp batches), so 8 tasks on 2 workers; ``ballast`` float64s make it large."""
    job, _ = build_job(plan(scene, 8, "mis-power", workers=2, spp_batch=2), 7, CountingJob)
    job.log = str(log)
    job.ballast = np.zeros(ballast)
    return job


def _counts(log) -> tuple[dict, dict, dict]:
    """``(loads, units, distinct job objects)`` per process id, from the log."""
    loads, units, jobs = collections.Counter(), collections.Counter(), collections.defaultdict(set)
    for line in log.read_text().splitlines():
        kind, pid, *rest = line.split()
        if kind == "load":
            loads[int(pid)] += 1
        else:
            units[int(pid)] += 1
            jobs[int(pid)].add(rest[0])
    return loads, units, jobs


@pytest.fixture(scope="module")
def reference(mesh_scene, tmp_path_factory):
    log = tmp_path_factory.mktemp("ref") / "log"
    return execute(_job(mesh_scene, log), 1)


def _same(a, b) -> None:
    for (va, ea), (vb, eb) in zip(a, b):
        np.testing.assert_array_equal(va, vb)
        np.testing.assert_array_equal(ea, eb)


def _check_once(log, loads_per_worker: int) -> dict:
    """Every process that ran units unpickled the job ``loads_per_worker`` times (0: forked) and
    used one job object for all of them; the units were spread so that a per-task unpickling
    would show (some worker ran several)."""
    loads, units, jobs = _counts(log)
    workers = set(units) - {os.getpid()}
    assert workers and sum(units.values()) == 8 and max(units.values()) >= 2, units
    assert {pid: loads[pid] for pid in workers} == dict.fromkeys(workers, loads_per_worker), (loads, units)
    assert all(len(jobs[pid]) == 1 for pid in workers), jobs
    assert set(loads) <= workers, loads              # nobody else unpickled it (this process neither)
    return units


@pytest.mark.parametrize("method", ["fork", "spawn"])
def test_local_workers_receive_the_job_once(mesh_scene, reference, tmp_path, monkeypatch, method):
    """vrlab's own pool: through its initialiser (forked: inherited, never unpickled)."""
    monkeypatch.setattr(execution, "_start_method", lambda: method)
    builds = tmp_path / "builds"
    if method == "fork":                           # Embree's scenes: counted per process
        rtcore = pytest.importorskip("embreex.rtcore_scene")
        real = rtcore.EmbreeScene

        def counting(*args):
            with open(builds, "a") as f:
                f.write(f"{os.getpid()}\n")
            return real(*args)
        monkeypatch.setattr(rtcore, "EmbreeScene", counting)
    log = tmp_path / "log"
    _same(reference, execute(_job(mesh_scene, log), 2))
    units = _check_once(log, 0 if method == "fork" else 1)
    if method == "fork":
        built = collections.Counter(int(p) for p in builds.read_text().split())
        # one per Embree mesh of the job (the scene's geometry, the shadow rays' blockers), built
        # in this process before the pool forks: the workers inherit them and build none
        assert built == {os.getpid(): 2}, (built, units)


def test_a_callers_process_pool_receives_the_job_once(mesh_scene, reference, tmp_path):
    """Any executor: units carry a token; a worker without the job asks for it once."""
    import multiprocessing as mp

    log = tmp_path / "log"
    with ProcessPoolExecutor(2, mp_context=mp.get_context("spawn")) as pool:
        _same(reference, execute(_job(mesh_scene, log), 2, pool))
    _check_once(log, 1)


def test_a_thread_executor_leaves_nothing_behind(mesh_scene, reference, tmp_path):
    """Threads share this process's store: the job is unpickled once, then dropped at the end."""
    log = tmp_path / "log"
    with ThreadPoolExecutor(2) as pool:
        _same(reference, execute(_job(mesh_scene, log), 2, pool))
    loads, units, jobs = _counts(log)
    assert dict(loads) == {os.getpid(): 1} and len(jobs[os.getpid()]) == 1, (loads, jobs)
    assert execution.RECEIVED.token is None


def test_dask_workers_receive_the_job_once(mesh_scene, reference, tmp_path):
    """Scattered to every worker once; the tasks refer to it (no large object in the task graph,
    though the job carries 16 MB of ballast)."""
    distributed = pytest.importorskip("distributed")
    log = tmp_path / "log"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)       # the dashboard's port
        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                           dashboard_address=None)
    try:
        with distributed.Client(cluster, set_as_default=False) as client:
            with warnings.catch_warnings(record=True) as seen:
                warnings.simplefilter("always")
                got = execute(_job(mesh_scene, log, ballast=2 * 10**6), 2, client)
            assert not [w for w in seen if "Large object" in str(w.message)], [str(w.message) for w in seen]
            _same(reference, got)
            deadline = time.monotonic() + 10           # the job is released (the scheduler hears it soon)
            while any(k.startswith("CountingJob") for k in client.who_has()) and time.monotonic() < deadline:
                time.sleep(0.05)
            assert not any(k.startswith("CountingJob") for k in client.who_has()), client.who_has()
    finally:
        cluster.close()
    _check_once(log, 1)


class CountingCubic:
    """The integrand 3 x^2 on [0, 1] (integral 1), logging "load pid" when unpickled."""

    def __init__(self, log: str):
        self.log = log

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        with open(self.log, "a") as f:
            f.write(f"load {os.getpid()}\n")

    def __call__(self, x):
        with open(self.log, "a") as f:
            f.write(f"unit {os.getpid()} {id(self)}\n")
        return 3 * x[..., 0] ** 2


def test_lab_workers_receive_the_specs_once(tmp_path):
    """A sweep sends its estimator and integrand specs once per worker process, too."""
    import multiprocessing as mp

    from vrlab import lab
    from vrlab.integrands import Integrand

    log = tmp_path / "log"
    cubic = Integrand(CountingCubic(str(log)), [(0, 1)], 1.0, "cubic")
    want = lab.run(["mc", "antithetic"], [cubic], [64], 8, rng=3)
    log.write_text("")
    with ProcessPoolExecutor(2, mp_context=mp.get_context("spawn")) as pool:
        got = lab.run(["mc", "antithetic"], [cubic], [64], 8, rng=3, executor=pool)
    assert got.drop(columns="seconds").equals(want.drop(columns="seconds"))
    loads, units, _ = _counts(log)
    workers = set(units)
    assert os.getpid() not in workers and max(units.values()) >= 4, units     # 16 blocks of one repetition
    assert {pid: loads[pid] for pid in workers} == dict.fromkeys(workers, 1), (loads, units)
