"""Whole-process render time of two vrlab revisions, side by side (issue 12's speed check).

Exports each git revision (``git archive``) into a temporary folder, compiles its
bytecode (as an installed package has), then renders veach_mis, cornell_box and
many_lights at their own resolution and at twice the width and height, ``--spp``
samples per pixel with ``--estimator`` and ``--workers`` processes, each render in a
fresh ``python -c`` process (start-up, imports, scene loading and the render: what a user
waits for).  Rounds are interleaved (old, new, old, new, ... for every configuration in
every round) because this machine's speed drifts over minutes; the fastest run of each
configuration is reported, with the median, and the ratio new/old of both.

    python benchmarks/bench_render_versions.py --old 64b32d5 --new HEAD [--rounds 3 --spp 16]

(``--new WORKTREE`` measures the files of this checkout as they are.)

``--instructions`` counts instead of timing: each configuration runs once per revision under
``valgrind --tool=callgrind --trace-children=yes`` and the instructions executed by the
process and its forked workers are summed.  Unlike times, the counts do not depend on what
else the machine runs (the 2-core test machine is shared); about 50x slower than a render.
"""
from __future__ import annotations

import argparse
import compileall
import re
import io
import resource
import shutil
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENES = ("veach_mis", "cornell_box", "many_lights")
# the NumPy path on revisions that have the kernels switch (issue 31), the only path on older ones
CODE = ("import sys, inspect; sys.path.insert(0, {src!r}); import vrlab.render as R; "
        "kw = {{'kernels': 'numpy'}} if 'kernels' in inspect.signature(R.render).parameters else {{}}; "
        "r = R.render({scene!r}, {spp}, {est!r}, rng=1, workers={workers}, width={w}, height={h}, **kw); "
        "img = r.value if hasattr(r, 'value') else r[0]; assert img.shape == ({h}, {w}, 3)")


def export(rev: str, where: Path) -> Path:
    """The tree of git revision ``rev`` (``WORKTREE``: this checkout's files) in ``where``,
    bytecode compiled."""
    if rev == "WORKTREE":
        shutil.copytree(ROOT / "vrlab", where / "vrlab", ignore=shutil.ignore_patterns("__pycache__"))
    else:
        data = subprocess.run(["git", "archive", rev, "vrlab"], cwd=ROOT, capture_output=True, check=True).stdout
        with tarfile.open(fileobj=io.BytesIO(data)) as tar:
            tar.extractall(where, filter="data")
    compileall.compile_dir(str(where / "vrlab"), quiet=1)
    return where


def sizes(scene: str) -> tuple[int, int]:
    sys.path.insert(0, str(ROOT))
    from vrlab.render import builtin_scene_path, load_scene

    s = load_scene(builtin_scene_path(scene)).sensor
    return s.width, s.height


def run(src: Path, scene: str, w: int, h: int, spp: int, est: str, workers: int) -> tuple[float, float]:
    """(wall seconds, CPU seconds of the process and its worker processes) of one render."""
    code = CODE.format(src=str(src), scene=scene, spp=spp, est=est, workers=workers, w=w, h=h)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tempfile.gettempdir())
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode:
        raise RuntimeError(p.stderr[-2000:])
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def instructions(src: Path, scene: str, w: int, h: int, spp: int, est: str, workers: int) -> int:
    """Instructions executed by one render: the process and its worker processes, summed."""
    code = CODE.format(src=str(src), scene=scene, spp=spp, est=est, workers=workers, w=w, h=h)
    with tempfile.TemporaryDirectory() as tmp:
        p = subprocess.run(["valgrind", "--tool=callgrind", "--trace-children=yes",
                            f"--callgrind-out-file={tmp}/cg.%p", sys.executable, "-c", code],
                           capture_output=True, text=True, cwd=tmp)
    if p.returncode:
        raise RuntimeError(p.stderr[-2000:])
    return sum(int(n.replace(",", "")) for n in re.findall(r"I\s+refs:\s+([\d,]+)", p.stderr))


def count_main(args, srcs) -> None:
    print(f"vrlab {args.new} against {args.old}: {args.estimator}, {args.spp} spp, {args.workers} workers; "
          "instructions of the process and its workers (callgrind)\n")
    print("| scene | size | old (10^9) | new (10^9) | new/old |")
    print("|---|---|---|---|---|")
    for sc in args.scenes:
        for k in args.scales:
            w, h = sizes(sc)
            o, n = (instructions(srcs[v], sc, k * w, k * h, args.spp, args.estimator, args.workers)
                    for v in ("old", "new"))
            print(f"| {sc} | {k * w}x{k * h} | {o / 1e9:.3f} | {n / 1e9:.3f} | {n / o:.3f} |", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", default="64b32d5")
    ap.add_argument("--new", default="HEAD")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--estimator", default="mis-power")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--scenes", nargs="*", default=list(SCENES))
    ap.add_argument("--scales", nargs="*", type=int, default=[1, 2])
    ap.add_argument("--instructions", action="store_true", help="count instructions with callgrind instead")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        srcs = {"old": export(args.old, Path(tmp) / "old"), "new": export(args.new, Path(tmp) / "new")}
        if args.instructions:
            count_main(args, srcs)
            return 0
        configs = [(sc, k) for sc in args.scenes for k in args.scales]
        times: dict = {}
        for r in range(args.rounds):
            for sc, k in configs:
                w, h = sizes(sc)
                for which in ("old", "new") if r % 2 == 0 else ("new", "old"):
                    times.setdefault((sc, k, which), []).append(
                        run(srcs[which], sc, k * w, k * h, args.spp, args.estimator, args.workers))
        print(f"vrlab {args.new} against {args.old}: {args.estimator}, {args.spp} spp, {args.workers} workers, "
              f"{args.rounds} interleaved rounds.  Wall: whole-process seconds (fastest / median); CPU: user + "
              "system seconds of the process and its workers (fastest); paired: the median over rounds of "
              "new/old within the round\n")
        print("| scene | size | wall old | wall new | new/old wall (fastest) | new/old wall (paired median) "
              "| new/old CPU (fastest) |")
        print("|---|---|---|---|---|---|---|")
        for sc, k in configs:
            w, h = sizes(sc)
            o, n = times[(sc, k, "old")], times[(sc, k, "new")]
            ow, nw = [x[0] for x in o], [x[0] for x in n]
            oc, nc = [x[1] for x in o], [x[1] for x in n]
            paired = statistics.median(b / a for a, b in zip(ow, nw))
            print(f"| {sc} | {k * w}x{k * h} | {min(ow):.2f} / {statistics.median(ow):.2f} | "
                  f"{min(nw):.2f} / {statistics.median(nw):.2f} | {min(nw) / min(ow):.3f} | {paired:.3f} | "
                  f"{min(nc) / min(oc):.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
