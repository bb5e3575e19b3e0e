"""Estimator overhead against bare NumPy, and a 10^8-sample run in bounded memory.

Overhead: ``MonteCarlo(p).estimate(integrand, N)`` against the bare expression
``u = rng.random((N, d)); x = p.sample(u); np.mean(f(x) / p.pdf(x))`` with the *same*
integrand and distribution callables, so the ratio measures what the estimator adds
(point-set plumbing, chunking, the mergeable moments with the variance, the support
check).  Both times include drawing the uniforms.  For multi-sample MIS with the balance
heuristic (two techniques, N/2 samples each) the bare expression is
``sum_i sum_j f(x_ij) / (n_1 p_1(x_ij) + n_2 p_2(x_ij))`` (Veach 1997, eq. 9.4 with the
balance weights).  A third peer, the bare expression in chunks of the estimator's chunk
size, shows how much of the difference is cache effects rather than overhead.

Memory: a 10^8-sample estimate runs in a fresh Python process (so earlier runs do not
pollute its peak); we report its resident set size before the run, the peak during the
run (Linux: ``VmHWM`` after resetting it through ``/proc/self/clear_refs``; elsewhere
``resource.getrusage`` ``ru_maxrss``, the peak since start), and the peak of traced
allocations (``tracemalloc``, which NumPy reports its buffers to).  The bare expression
would need about 5 float64 arrays of N values (~4 GB at 10^8).

Each time is the best of ``repeat`` runs, methods taking turns, garbage collector paused.
"""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

from .. import checks
from .timing import race as _race

TARGET = 1.3


def _rows(task: str, n: int, times: dict[str, float], ours: str, bare: str, note: str = "") -> list[dict]:
    ref = times[bare]
    out = []
    for m, s in times.items():
        row = {"task": task, "n": n, "method": m, "seconds": s, "ratio_vs_bare": s / ref}
        if m == ours:
            row.update(target=TARGET, ok=bool(s / ref <= TARGET))
        row["note"] = note if m == ours else ""
        out.append(row)
    return out


def _bare_is(integrand, dist, n: int, seed: int, chunk: int | None = None) -> float:
    rng = np.random.default_rng(seed)
    if chunk is None:
        x = dist.sample(rng.random((n, dist.dim_u)))
        return float(np.mean(integrand.f(x) / dist.pdf(x)))
    total, done = 0.0, 0
    while done < n:
        k = min(chunk, n - done)
        x = dist.sample(rng.random((k, dist.dim_u)))
        total += float(np.sum(integrand.f(x) / dist.pdf(x)))
        done += k
    return total / n


def _bare_mis(integrand, dists, n: int, seed: int, chunk: int | None = None) -> float:
    rng = np.random.default_rng(seed)
    counts = [n // len(dists)] * len(dists)
    total = 0.0
    for dist, ni in zip(dists, counts):
        done, step = 0, ni if chunk is None else chunk
        while done < ni:
            k = min(step, ni - done)
            x = dist.sample(rng.random((k, dist.dim_u)))
            denom = sum(nj * q.pdf(x) for nj, q in zip(counts, dists))
            total += float(np.sum(integrand.f(x) / denom))
            done += k
    return total


def overhead_rows(n: int, repeat: int = 3, seed: int = 2026) -> list[dict]:
    """Overhead of ``MonteCarlo`` (exp with the linear density; glossy-light with light
    sampling) and of balance-heuristic ``MIS`` with two techniques, against bare NumPy.
    Checked: ``n`` in [2, 10^8], ``repeat`` in [1, 1000], ``seed`` an integer >= 0."""
    n = checks.integer(n, "n", low=2, high=10**8)
    repeat = checks.integer(repeat, "repeat", low=1, high=1000)
    seed = checks.integer(seed, "seed", low=0, high=2**62)
    from ..estimators import MonteCarlo
    from ..estimators.base import DEFAULT_CHUNK
    from ..integrands import get

    rows: list[dict] = []
    for name, tech in (("exp", "linear"), ("glossy-light", "light")):
        ig = get(name)
        dist = ig.techniques[tech]
        est = MonteCarlo(dist)
        ours = f"vrlab MonteCarlo({type(dist).__name__})"
        times = _race({
            "numpy bare": lambda ig=ig, dist=dist: _bare_is(ig, dist, n, seed),
            "numpy bare, chunked": lambda ig=ig, dist=dist: _bare_is(ig, dist, n, seed, DEFAULT_CHUNK),
            ours: lambda ig=ig, est=est: est.estimate(ig, n, rng=seed),
        }, repeat)
        rows += _rows(f"importance sampling: {name}, is:{tech}", n, times, ours, "numpy bare",
                      "value + standard error (bare: value only)")
    try:
        from ..estimators.mis import MIS
    except ImportError:
        rows.append({"task": "MIS balance, 2 techniques", "n": n, "method": "vrlab MIS", "seconds": np.nan,
                     "ratio_vs_bare": np.nan, "note": "vrlab.estimators.mis not available"})
        return rows
    for name, techs in (("exp", ("uniform", "linear")), ("glossy-light", ("brdf", "light"))):
        ig = get(name)
        dists = [ig.techniques[t] for t in techs]
        est = MIS(dists, heuristic="balance")
        ours = "vrlab MIS(balance)"
        times = _race({
            "numpy bare": lambda ig=ig, dists=dists: _bare_mis(ig, dists, n, seed),
            "numpy bare, chunked": lambda ig=ig, dists=dists: _bare_mis(ig, dists, n, seed, DEFAULT_CHUNK),
            ours: lambda ig=ig, est=est: est.estimate(ig, n, rng=seed),
        }, repeat)
        rows += _rows(f"MIS balance: {name}, {'+'.join(techs)}", n, times, ours, "numpy bare",
                      "2 techniques, n/2 samples each")
    return rows


_CHILD = r"""
import json, resource, sys, time, tracemalloc
import numpy as np
from vrlab.estimators import MonteCarlo
from vrlab.integrands import get

def status(key):   # Linux: VmRSS / VmHWM in kB; None elsewhere
    try:
        for line in open("/proc/self/status"):
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    except OSError:
        return None

def reset_peak():  # Linux >= 4.0: writing 5 to clear_refs resets VmHWM to the current RSS
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        return True
    except OSError:
        return False

n = int(sys.argv[1])
ig = get("exp")
est = MonteCarlo(ig.techniques["linear"])
est.estimate(ig, 1000, rng=0)                      # imports and first-call costs
scale = 1 if sys.platform == "darwin" else 1024     # ru_maxrss: bytes on macOS, KiB on Linux
idle = status("VmRSS") or resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * scale
hwm = reset_peak()
tracemalloc.start()
t0 = time.perf_counter()
e = est.estimate(ig, n, rng=1)
seconds = time.perf_counter() - t0
traced = tracemalloc.get_traced_memory()[1]
tracemalloc.stop()
peak = status("VmHWM") if hwm else None
maxrss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * scale
print(json.dumps({"idle": idle, "peak": peak if peak is not None else maxrss, "maxrss": maxrss,
                  "source": "VmHWM after clear_refs" if peak is not None else "ru_maxrss",
                  "traced": traced, "seconds": seconds, "value": e.value, "stderr": e.stderr}))
"""


def memory_rows(n: int) -> list[dict]:
    """Peak memory of a chunked ``n``-sample estimate in a fresh process (see module docstring);
    ``n`` an integer in [1, 10^9]."""
    n = checks.integer(n, "n", low=1, high=10**9)
    import importlib.util

    if importlib.util.find_spec("resource") is None:  # pragma: no cover - Windows
        return [{"task": "bounded memory", "n": n, "method": "vrlab MonteCarlo", "note": "needs resource (POSIX)"}]
    import os
    from pathlib import Path

    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    out = subprocess.run([sys.executable, "-c", _CHILD, str(n)], capture_output=True, text=True, env=env,
                         check=True)
    r = json.loads(out.stdout.strip().splitlines()[-1])
    mb = 1 / 2**20
    return [{"task": "bounded memory (chunked)", "n": n, "method": "vrlab MonteCarlo(LinearInterval) on exp",
             "seconds": r["seconds"], "peak_rss_mb": r["peak"] * mb, "idle_rss_mb": r["idle"] * mb,
             "rss_increase_mb": (r["peak"] - r["idle"]) * mb, "traced_peak_mb": r["traced"] * mb,
             "bare_numpy_mb": 5 * 8 * n * mb,
             "note": f"value {r['value']:.6f} +- {r['stderr']:.1e}; peak from {r['source']}; "
                     "bare_numpy_mb = 5 arrays of n float64"}]


def bench_estimators(quick: bool = False, *, repeat: int = 3, seed: int = 2026) -> list[dict]:
    """Overhead ratios (target <= 1.3x) at 10^7 samples and peak memory at 10^8 samples.

    ``quick``: 10^6 and 10^7 samples.  Rows: ``task, n, method, seconds, ratio_vs_bare,
    target, ok, note`` and for the memory run ``peak_rss_mb, idle_rss_mb, traced_peak_mb``.
    Checked: ``quick`` a bool, ``repeat`` in [1, 1000], ``seed`` an integer >= 0.
    """
    from . import _quick

    quick = _quick(quick)
    n = 10**6 if quick else 10**7
    rows = overhead_rows(n, repeat, seed)
    rows += memory_rows(10**7 if quick else 10**8)
    return rows
