"""Time ``vrlab demo --quick`` and the full ``vrlab demo`` as a user runs them, and print a table.

    python benchmarks/bench_demo.py [--quick-only] [--repeat K] [--csv out.csv]

Each run is a fresh ``python -m vrlab demo [--quick] --out TMP --json`` process, so the
wall time includes Python's start-up and the imports.  Reported per demo: the best and
the worst wall time of ``--repeat`` runs (default 3 quick, 1 full), the CPU seconds of the
process and its children (forked lab workers and figure painters), the 1-minute load
average before the runs (another job on the 2 cores inflates every time), the budget
(quick < 10 s, full < 2 min, issue 15) and the demo's own seconds per section (best run).
A timing benchmark, not a test: nothing here fails a build.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import pandas as pd

from vrlab.cli import DEMO_BUDGET_S as BUDGET      # the one place: `vrlab demo --help` states it too


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def time_demo(quick: bool) -> dict:
    """One demo run in a fresh process: wall and CPU seconds and the demo's JSON summary."""
    with tempfile.TemporaryDirectory() as out:
        cmd = [sys.executable, "-m", "vrlab", "demo", "--out", out, "--json"] + (["--quick"] if quick else [])
        cpu0, t0 = _children_cpu(), time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, check=True)
        wall, cpu = time.perf_counter() - t0, _children_cpu() - cpu0
    summary = json.loads(proc.stdout)          # --json: stdout is only the JSON
    return {"wall_s": wall, "cpu_s": cpu, "demo_s": summary["seconds"], "sections": summary["sections"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick-only", action="store_true", help="time only `vrlab demo --quick`")
    parser.add_argument("--repeat", type=int, default=None, help="runs per demo (default: 3 quick, 1 full)")
    parser.add_argument("--csv", help="also write the rows to this CSV file")
    args = parser.parse_args()
    rows, sections = [], {}
    for mode in ("quick",) if args.quick_only else ("quick", "full"):
        repeat = args.repeat or (3 if mode == "quick" else 1)
        load = os.getloadavg()[0]
        runs = [time_demo(mode == "quick") for _ in range(repeat)]
        best = min(runs, key=lambda r: r["wall_s"])
        sections[mode] = best["sections"]
        rows.append({"demo": mode, "runs": repeat, "best_wall_s": best["wall_s"],
                     "worst_wall_s": max(r["wall_s"] for r in runs), "cpu_s": best["cpu_s"],
                     "load_before": load, "budget_s": BUDGET[mode],
                     "within_budget": best["wall_s"] < BUDGET[mode]})
    df = pd.DataFrame(rows)
    with pd.option_context("display.width", 160, "display.max_columns", 20):
        print(df.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
        print("\nseconds per section (best run; figures are drawn in a forked process meanwhile):")
        print(pd.DataFrame(sections).to_string(float_format=lambda v: f"{v:.2f}"))
    print(f"\n{os.cpu_count()} cores; load average now {os.getloadavg()[0]:.2f}")
    if args.csv:
        df.to_csv(args.csv, index=False)


if __name__ == "__main__":
    main()
