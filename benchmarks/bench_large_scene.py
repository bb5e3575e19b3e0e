"""vrlab vs Mitsuba 3 on a scene of a real scene's size: load, build, render, peak memory.

The scene is :mod:`make_large_scene`'s (by default 440 binary PLY meshes, 2 M triangles, an
.exr environment map, 6 shared diffuse BSDFs, 128 x 128, 256 spp; written once into
``--cache``).  Each configuration runs alone in a child process, started through a small
wrapper that reports the child's ``ru_maxrss`` (``RUSAGE_CHILDREN``: the largest process of
the child's tree, workers included) and the whole-process wall time (interpreter start,
imports, loading, rendering, saving the image):

* vrlab (``--workers 1`` and the default, the CPUs available): ``load_scene`` (load), then
  the render's set-up up to its first sample (build: ``vrlab.render.plan``, the job, i.e. the
  scene's geometry, acceleration structures, lights, and Embree's own BVH, built in this
  process, which forked workers inherit), then the samples (render:
  ``vrlab.render.film.execute``), as ``vrlab render`` runs them;
* Mitsuba 3 ``scalar_rgb`` with 2 threads (``drjit.set_thread_count(2)``): ``mi.load_file``
  (load; Mitsuba builds its acceleration structure while loading) and ``mi.render`` at the
  same spp.

The two images are compared (the relative difference of their means, which must be within
the noise), as a check that both rendered the same scene.

    python benchmarks/bench_large_scene.py [--triangles 2e6 --meshes 440 --size 128 --spp 256]
    python benchmarks/bench_large_scene.py --scaling 1e4,1e5,1e6,4e6 [--spp 16]

prints a markdown table; ``--scaling`` one row per triangle count (vrlab ``--workers 1`` and
Mitsuba), with ``min(meshes, triangles / 50)`` meshes.
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
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

# a child's peak RSS: the wrapper runs it and reads RUSAGE_CHILDREN (Linux: KiB)
_WRAPPER = ("import resource, subprocess, sys; r = subprocess.run(sys.argv[1:]); "
            "print('MAXRSS', resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); sys.exit(r.returncode)")


def _child_vrlab(scene: str, spp: int, workers: int | None, out: str) -> dict:
    import numpy as np

    import vrlab

    from vrlab._alloc import keep_freed_memory
    from vrlab.render import load_scene
    from vrlab.render import film

    keep_freed_memory()                      # as vrlab render does
    t = time.perf_counter()
    sc = load_scene(scene)
    t_load = time.perf_counter() - t
    t = time.perf_counter()
    if hasattr(film, "build_job"):           # the render plan (vrlab.render.plan)
        p = film.plan(sc, spp, "mis-power", workers=workers)
        (job, _), workers = film.build_job(p, 0), p.workers
    else:                                    # an older checkout (--vrlab-root)
        job, _, workers = film.plan(sc, spp, settings=dict(estimator="mis-power", units=None,
                                                           light_selection="uniform", emitter_samples=None,
                                                           bsdf_samples=None, ris_candidates=8),
                                    points=None, rng=0, workers=workers, chunk_pixels=None, width=None, height=None)
    if hasattr(job, "build"):    # Embree's BVH, built here (forked workers inherit it), as execute does
        job.build()
    elif workers == 1:       # an older checkout: Embree builds its BVH on first use, in this process
        lit = job.integrand.lighting
        for geo in {id(g): g for g in (lit.geometry, lit.blocker_geometry, lit.emitter_geometry)}.values():
            if geo.accel is not None and geo.accel.embree is not None:
                geo.accel.embree.scene
    t_build = time.perf_counter() - t
    t = time.perf_counter()
    ((value, _),) = film.execute(job, workers)
    t_render = time.perf_counter() - t
    np.save(out, value)
    return {"load": t_load, "build": t_build, "render": t_render, "workers": workers, "vrlab": vrlab.__file__}


def _child_mitsuba(scene: str, spp: int, threads: int, out: str) -> dict:
    import drjit as dr
    import mitsuba as mi
    import numpy as np

    mi.set_variant("scalar_rgb")
    dr.set_thread_count(threads)
    t = time.perf_counter()
    sc = mi.load_file(scene)
    t_load = time.perf_counter() - t
    t = time.perf_counter()
    img = np.array(mi.render(sc, spp=spp), dtype=np.float32)[..., :3]
    t_render = time.perf_counter() - t
    np.save(out, img)
    return {"load": t_load, "build": None, "render": t_render, "workers": threads}


def run_child(kind: str, scene: Path, spp: int, workers: int | None, out: Path, root: Path = ROOT) -> dict:
    """One configuration in a fresh process (vrlab imported from the checkout ``root``): its phase
    times, whole-process seconds and peak MB."""
    argv = [sys.executable, __file__, "--child", kind, "--scene-file", str(scene), "--spp", str(spp),
            "--workers", "0" if workers is None else str(workers), "--out", str(out), "--vrlab-root", str(root)]
    t = time.perf_counter()
    res = subprocess.run([sys.executable, "-c", _WRAPPER, *argv], capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": str(root)})
    seconds = time.perf_counter() - t
    if res.returncode:
        raise RuntimeError(f"{kind} child failed:\n{res.stderr[-3000:]}")
    lines = res.stdout.splitlines()
    info = json.loads(next(ln for ln in lines if ln.startswith("{")))
    info["whole"] = seconds
    info["peak_mb"] = int(next(ln for ln in lines if ln.startswith("MAXRSS")).split()[1]) / 1024
    return info


def scene_for(cache: Path, triangles: int, meshes: int, size: int, spp: int) -> Path:
    """The generated scene of these parameters (written once into ``cache``)."""
    from make_large_scene import make_scene

    folder = cache / f"t{triangles}_m{meshes}_s{size}_p{spp}"
    if not (folder / "scene.xml").exists():
        make_scene(folder, triangles, meshes, width=size, height=size, spp=spp)
    return folder / "scene.xml"


def _fmt(x, digits=2) -> str:
    return "-" if x is None else f"{x:.{digits}f}"


def compare(scene: Path, spp: int, tmp: Path, workers: list, root: Path = ROOT) -> None:
    import numpy as np

    rows = []
    images = {}
    for label, kind, w in [(f"vrlab --workers {w if w else 'default'}", "vrlab", w or None) for w in workers] + \
                          [("Mitsuba scalar_rgb, 2 threads", "mitsuba", 2)]:
        out = tmp / f"{kind}_{w}.npy"
        r = run_child(kind, scene, spp, w, out, root)
        images[label] = np.load(out)
        rows.append((label, r))
    print(f"\n{scene.parent.name}: {(scene.parent / 'SIZE').read_text().strip()}, spp {spp}, vrlab from {root} "
          f"({os.cpu_count()} CPUs; load average {os.getloadavg()[0]:.2f})\n")
    print("| renderer | load s | build s | load to first sample s | render s | whole process s | peak RSS GB |")
    print("|---|---|---|---|---|---|---|")
    for label, r in rows:
        first = r["load"] + (r["build"] or 0.0)
        print(f"| {label} | {_fmt(r['load'])} | {_fmt(r['build']) if r['build'] is not None else '(in load)'} | "
              f"{_fmt(first)} | {_fmt(r['render'])} | {_fmt(r['whole'])} | {r['peak_mb'] / 1024:.2f} |")
    ref = images[rows[-1][0]].mean((0, 1))
    for label, img in images.items():
        mean = img.mean((0, 1))
        print(f"  {label}: image mean {', '.join(f'{x:.4f}' for x in mean)} "
              f"(relative to Mitsuba's: {', '.join(f'{x:+.2%}' for x in mean / ref - 1)})")


def scaling(counts: list[int], meshes: int, size: int, spp: int, cache: Path, tmp: Path) -> None:
    print(f"\nscaling: {size} x {size}, spp {spp}, vrlab --workers 1, Mitsuba scalar_rgb 2 threads "
          f"({os.cpu_count()} CPUs; load average {os.getloadavg()[0]:.2f})\n")
    print("| triangles | meshes | vrlab load s | vrlab build s | vrlab render s | vrlab whole s | vrlab peak GB "
          "| Mitsuba load s | Mitsuba render s | Mitsuba whole s | Mitsuba peak GB |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for n in counts:
        m = max(10, min(meshes, n // 50))
        scene = scene_for(cache, n, m, size, spp)
        v = run_child("vrlab", scene, spp, 1, tmp / "v.npy")
        mi = run_child("mitsuba", scene, spp, 2, tmp / "m.npy")
        print(f"| {n:.0e} | {m} | {_fmt(v['load'])} | {_fmt(v['build'])} | {_fmt(v['render'])} | {_fmt(v['whole'])} "
              f"| {v['peak_mb'] / 1024:.2f} | {_fmt(mi['load'])} | {_fmt(mi['render'])} | {_fmt(mi['whole'])} "
              f"| {mi['peak_mb'] / 1024:.2f} |", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--triangles", type=float, default=2e6)
    ap.add_argument("--meshes", type=int, default=440)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--workers", default="1,0", help="vrlab worker counts, 0 for the default (default: 1,0)")
    ap.add_argument("--scaling", help="comma-separated triangle counts, e.g. 1e4,1e5,1e6,4e6")
    ap.add_argument("--cache", default=os.path.join(tempfile.gettempdir(), "vrlab_large_scenes"))
    ap.add_argument("--vrlab-root", default=str(ROOT),
                    help="the vrlab checkout to time (default: this one; another, e.g. an older commit's worktree, "
                         "for before/after)")
    ap.add_argument("--child", choices=["vrlab", "mitsuba"], help=argparse.SUPPRESS)
    ap.add_argument("--scene-file", help=argparse.SUPPRESS)
    ap.add_argument("--out", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        sys.path.insert(0, args.vrlab_root)          # vrlab from the checkout timed
        w = int(args.workers)
        fn = _child_vrlab if args.child == "vrlab" else _child_mitsuba
        print(json.dumps(fn(args.scene_file, args.spp, w if w or args.child == "mitsuba" else None, args.out)))
        return 0
    cache = Path(args.cache)
    with tempfile.TemporaryDirectory() as tmp:
        if args.scaling:
            scaling([int(float(x)) for x in args.scaling.split(",")], args.meshes, args.size, args.spp, cache,
                    Path(tmp))
        else:
            scene = scene_for(cache, int(args.triangles), args.meshes, args.size, args.spp)
            compare(scene, args.spp, Path(tmp), [int(w) for w in args.workers.split(",")], Path(args.vrlab_root))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
