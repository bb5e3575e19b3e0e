"""Peak memory of ``vrlab render`` as a user runs it: the whole command in a child process,
its peak resident set size (``ru_maxrss`` of the child; with ``--workers 2`` the largest of
the command and its workers, measured one command at a time).

    python benchmarks/bench_render_memory.py [--scene cornell_box --size 1024 --spp 4]

Prints one row per (workers, output): peak RSS in MB and seconds.  The README's memory
numbers come from this script (and say so).
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time


def peak_mb(argv: list[str]) -> tuple[float, float]:
    """(peak RSS of the largest process of the command in MB, seconds), the command run alone."""
    code = ("import resource, subprocess, sys; r = subprocess.run(sys.argv[1:]); "
            "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); sys.exit(r.returncode)")
    t = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, check=True)
    seconds = time.perf_counter() - t
    return int(out.stdout.split()[-1]) / 1024, seconds       # Linux: ru_maxrss in KiB


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="cornell_box")
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--workers", default="1,2")
    args = ap.parse_args(argv)
    base = [sys.executable, "-m", "vrlab", "render", args.scene, "--spp", str(args.spp), "--width", str(args.size),
            "--height", str(args.size), "--no-progress"]
    print(f"vrlab render {args.scene} --spp {args.spp} --width {args.size} --height {args.size} "
          f"(ru_maxrss of the largest process; {os.cpu_count()} CPUs)")
    with tempfile.TemporaryDirectory() as tmp:
        for workers in args.workers.split(","):
            for out in (None, "img.npy", "img.png"):
                argv_ = base + ["--workers", workers] + ([] if out is None else ["-o", os.path.join(tmp, out)])
                mb, seconds = peak_mb(argv_)
                print(f"  --workers {workers:>2}  {'-o ' + out if out else 'no -o':>12}:  peak {mb:6.0f} MB  "
                      f"{seconds:5.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
