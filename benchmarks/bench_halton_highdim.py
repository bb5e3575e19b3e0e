"""Halton in high dimension: time and peak memory of vrlab vs scipy.stats.qmc.Halton.

    python benchmarks/bench_halton_highdim.py [--repeat 3] [--scipy-scrambled]

Each measurement is one fresh subprocess that builds the engine and draws ``n`` points
(``Halton(d, scramble=..., rng=1).random(n)``): wall time with ``time.perf_counter``
(construction + draw, imports excluded) and peak RSS with ``resource.getrusage``
(whole process, imports included).  Runs alternate between the libraries; the table
shows the best time and the largest peak over ``--repeat`` runs.  SciPy's scrambled
Halton at d = 10^4 needs ~12 GB and over a minute, so it runs only with
``--scipy-scrambled``.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys

_CHILD = r"""
import json, resource, sys, time
lib, d, n, scramble = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), json.loads(sys.argv[4])
if lib == "scipy":
    from scipy.stats import qmc
    make = lambda: qmc.Halton(d, scramble=scramble, rng=1)
else:
    from vrlab.points import Halton
    make = lambda: Halton(d, scramble=scramble, rng=1)
t0 = time.perf_counter()
x = make().random(n)
t = time.perf_counter() - t0
assert x.shape == (n, d)
print(json.dumps({"s": t, "rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""

CASES = [  # (d, n, scramble)
    (10_000, 2, False), (10_000, 1000, False), (2000, 10_000, False), (100, 100_000, False),
    (10_000, 2, True), (10_000, 1000, True), (1000, 10_000, True), (100, 100_000, True),
    (10_000, 2, "owen"), (10_000, 1000, "owen"),
]


def run(lib: str, d: int, n: int, scramble) -> dict:
    out = subprocess.run([sys.executable, "-c", _CHILD, lib, str(d), str(n), json.dumps(scramble)],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per library and case (default 3)")
    parser.add_argument("--scipy-scrambled", action="store_true",
                        help="also run SciPy's scrambled Halton at d = 10^4 (~12 GB, > 1 min)")
    args = parser.parse_args()
    print(f"{'d':>6} {'n':>7} {'scramble':>8} | {'vrlab s':>8} {'MiB':>6} | {'scipy s':>8} {'MiB':>6}")
    for d, n, scramble in CASES:
        scipy_ok = scramble is not True or d < 5000 or args.scipy_scrambled
        res: dict[str, list[dict]] = {"vrlab": [], "scipy": []}
        for _ in range(args.repeat):
            res["vrlab"].append(run("vrlab", d, n, scramble))
            if scipy_ok and scramble != "owen":
                res["scipy"].append(run("scipy", d, n, scramble))
        cols = []
        for lib in ("vrlab", "scipy"):
            r = res[lib]
            cols.append(f"{min(x['s'] for x in r):8.3f} {max(x['rss_mib'] for x in r):6.0f}" if r
                        else f"{'-':>8} {'-':>6}")
        print(f"{d:>6} {n:>7} {str(scramble):>8} | {cols[0]} | {cols[1]}", flush=True)


if __name__ == "__main__":
    main()
