"""Lab sweeps on the execution layer (issue 14): per-unit overhead, scaling, peak memory.

Three measurements, each sweep in a fresh ``python -c`` process so that peak memory
(``resource.getrusage``) is the sweep's own; that process calls ``keep_freed_memory()``, as
the ``vrlab`` command does, and so do vrlab's own local worker processes:

1. overhead per work unit: 200 units of n = 1000 (``mc`` on ``exp``, one repetition per
   unit: ``UNIT_SAMPLES`` set to 1000), in this process (workers=1), 2 local processes and a
   Dask ``LocalCluster`` of 2 single-threaded worker processes (started before the clock);
   the compute is ~0.2 ms per unit, so the wall time per unit is about the overhead;
2. scaling from 1 to 2 workers: a compute-bound sweep (3 estimators x 2 integrands x
   n = 2^16, 2^18, 2^20 x 16 repetitions, 1.3e8 evaluations) with workers = 1, 2 and Dask (2);
   Dask also with ``client.run(vrlab.render.keep_freed_memory)`` on its workers (the nanny sets
   ``MALLOC_TRIM_THRESHOLD_``, which turns off glibc's adaptive mmap threshold);
3. peak memory of a 10^9-sample sweep (``mc`` on ``exp``, ns = [10^8], reps = 10, workers = 2,
   also with ``--store``): maxrss of the parent and of the largest worker.

Rounds are interleaved and the fastest of each mode is reported (this 2-core machine is shared).

    python benchmarks/bench_execution.py [--rounds 3] [--quick]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, resource, sys, time, warnings
sys.path.insert(0, {root!r})
from vrlab.lab import runner, run
from vrlab.render import keep_freed_memory
keep_freed_memory()                       # this process is vrlab's own, as in the vrlab CLI
spec = json.loads({spec!r})
if spec.get("unit_samples"):
    runner.UNIT_SAMPLES = spec["unit_samples"]
executor = cluster = None
if spec["mode"] == "dask":
    from distributed import Client, LocalCluster
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address=None)
    executor = Client(cluster, set_as_default=False)
    executor.run(lambda: __import__("vrlab.lab.runner"))        # imports done before the clock
    if spec.get("keep"):                  # undo the nanny's MALLOC_TRIM_THRESHOLD_ (see BENCHMARKS.md)
        executor.run(keep_freed_memory)
t = time.perf_counter()
df = run(spec["estimators"], spec["integrands"], spec["ns"], spec["reps"], rng=1,
         workers=spec["workers"], executor=executor, store=spec.get("store"))
wall = time.perf_counter() - t
out = {{"wall": wall, "rows": len(df), "units_seconds": float(df["seconds"].sum()),
        "parent_maxrss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}}
if executor is not None:
    rss = executor.run(lambda: __import__("resource").getrusage(__import__("resource").RUSAGE_SELF).ru_maxrss)
    out["worker_maxrss_mb"] = max(rss.values()) / 1024
    executor.close(); cluster.close()
else:
    out["worker_maxrss_mb"] = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
print(json.dumps(out))
"""


def sweep(mode: str, workers: int, **spec) -> dict:
    spec = {"mode": mode, "workers": workers, **spec}
    code = CHILD.format(root=str(ROOT), spec=json.dumps(spec))
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    if res.returncode:
        raise RuntimeError(res.stderr[-2000:])
    return json.loads(res.stdout.strip().splitlines()[-1])


MODES = [("workers=1", "local", 1, False), ("workers=2", "local", 2, False),
         ("dask LocalCluster (2)", "dask", 1, False), ("  + keep_freed_memory", "dask", 1, True)]


def best(rounds: int, **spec) -> list[dict]:
    """The fastest of ``rounds`` runs of every mode, rounds interleaved (A B C D A B C D ...)
    so that the machine's drift falls on every mode alike."""
    runs: dict[str, list] = {label: [] for label, *_ in MODES}
    for _ in range(rounds):
        for label, mode, workers, keep in MODES:
            runs[label].append(sweep(mode, workers, keep=keep, **spec))
    return [(label, min(runs[label], key=lambda r: r["wall"])) for label, *_ in MODES]


def overhead(rounds: int, quick: bool) -> None:
    units = 40 if quick else 200
    print(f"\n1. overhead per unit: {units} units of n = 1000 (mc on exp, one repetition each)")
    print(f"{'':24s} {'wall s':>8s} {'ms / unit':>10s} {'compute ms / unit':>18s}")
    for label, r in best(rounds, estimators=["mc"], integrands=["exp"], ns=[1000], reps=units, unit_samples=1000):
        print(f"{label:24s} {r['wall']:8.3f} {1e3 * r['wall'] / units:10.3f} {1e3 * r['units_seconds'] / units:18.3f}")


def scaling(rounds: int, quick: bool) -> None:
    ns = [2**12, 2**14] if quick else [2**16, 2**18, 2**20]
    evals = 3 * 2 * 16 * sum(ns)
    print(f"\n2. scaling: mc, antithetic, jittered x exp, sin x n = {ns} x 16 reps ({evals:.3g} evaluations)")
    print(f"{'':24s} {'wall s':>8s} {'speed-up':>9s}")
    base = None
    for label, r in best(rounds, estimators=["mc", "antithetic", "jittered"], integrands=["exp", "sin"], ns=ns,
                         reps=16):
        base = base or r["wall"]
        print(f"{label:24s} {r['wall']:8.3f} {base / r['wall']:9.2f}")


def memory(rounds: int, quick: bool) -> None:
    n = 10**6 if quick else 10**8
    print(f"\n3. peak memory: mc on exp, ns = [{n:.0e}], reps = 10 ({10 * n:.0e} samples), one round")
    print(f"{'':34s} {'wall s':>8s} {'parent MB':>10s} {'worker MB':>10s}")
    with tempfile.TemporaryDirectory() as d:
        for label, mode, w, store, keep in [("workers=2", "local", 2, None, False),
                                            ("workers=2, --store", "local", 2, os.path.join(d, "big.sqlite"), False),
                                            ("dask LocalCluster (2)", "dask", 1, None, False),
                                            ("  + keep_freed_memory", "dask", 1, None, True)]:
            t = time.perf_counter()
            r = sweep(mode, w, estimators=["mc"], integrands=["exp"], ns=[n], reps=10, store=store, keep=keep)
            print(f"{label:34s} {r['wall']:8.2f} {r['parent_maxrss_mb']:10.0f} {r['worker_maxrss_mb']:10.0f}"
                  f"   (process {time.perf_counter() - t:.1f} s)")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="smaller sweeps (a smoke test)")
    ap.add_argument("--only", default="1,2,3", help="which measurements, e.g. 2 or 1,3 (default: all)")
    a = ap.parse_args(argv)
    print(f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f} at the start")
    for k in sorted({int(k) for k in a.only.split(",")}):
        {1: overhead, 2: scaling, 3: memory}[k](a.rounds, a.quick)
    print(f"\nload average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
