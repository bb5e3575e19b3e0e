"""Render scaling: the same image with 1 and 2 local worker processes and on a Dask
``LocalCluster`` of 2 workers (issue 14), whole render call, best of ``--repeat`` runs.

    python benchmarks/bench_render_scaling.py [--scene cornell_box --size 512 --spp 32 --repeat 3]

Prints the seconds, the speed-up over one process and whether the images are identical
(they must be: units are seeded by (tile, spp batch), not by worker).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="cornell_box")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--spp", type=int, default=32)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    from vrlab.render import keep_freed_memory, render

    keep_freed_memory()        # this benchmark's process is like vrlab render's: allocator tuned
    kw = dict(rng=1, width=args.size, height=args.size)

    def best(**extra):
        times, img = [], None
        for _ in range(args.repeat):
            t = time.perf_counter()
            img = render(args.scene, args.spp, **kw, **extra).value
            times.append(time.perf_counter() - t)
        return min(times), img

    rows = [("1 process", *best(workers=1)), ("2 local processes", *best(workers=2))]
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        print("dask.distributed is not installed: no Dask row")
    else:
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address=None) as cluster, Client(cluster) as client:
            client.run(keep_freed_memory)
            rows.append(("Dask LocalCluster, 2 workers", *best(workers=2, executor=client)))
    load = os.getloadavg()[0]
    print(f"{args.scene} {args.size}x{args.size}, {args.spp} spp, mis-power, best of {args.repeat}; "
          f"load average at the end {load:.1f} on {os.cpu_count()} CPUs\n")
    print("| run | seconds | speed-up | image identical to 1 process |")
    print("|---|---|---|---|")
    for name, t, img in rows:
        print(f"| {name} | {t:.2f} | {rows[0][1] / t:.2f} | {np.array_equal(img, rows[0][2])} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
