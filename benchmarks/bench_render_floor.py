"""Where a render's time goes: ray queries against everything else, per sample, next to
Mitsuba 3's whole cost per sample, in CPU microseconds (one process each).

vrlab renders with ``workers=1``; every call of the scene's ray queries
(``SceneGeometry.intersect``, ``distance``, ``occluded``) is timed, the outermost call only.
The rest (camera, light and BSDF sampling, MIS weights, the estimator, the film) is what
no faster ray tracer can remove.  Mitsuba's ``direct`` integrator renders the same scene
(``scalar_rgb``; its threads' CPU time from ``getrusage``, a warm-up render first).
A tracer that brought vrlab level with Mitsuba would have to answer all of a sample's
queries in (Mitsuba - rest) microseconds: the last column.

    python benchmarks/bench_render_floor.py [--scene many_lights --width 256 --height 192 --spp 64]
"""
from __future__ import annotations

import argparse
import functools
import resource
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))


def cpu_seconds() -> float:
    """CPU time of this process, all threads (user + system)."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def vrlab_split(scene_name: str, w: int, h: int, spp: int, strategy: str, repeat: int):
    """(CPU µs per sample, of which in ray queries, rays queried per sample) of the fastest
    of ``repeat`` renders."""
    from vrlab.render import builtin_scene_path, load_scene, render
    from vrlab.render.accel import geometry

    spent = {"t": 0.0, "depth": 0, "rays": 0}

    def timed(f):
        @functools.wraps(f)
        def call(*a, **k):
            if not spent["depth"]:
                spent["rays"] += len(a[1]) if len(a) > 1 and hasattr(a[1], "__len__") else 0
            spent["depth"] += 1
            t = time.process_time()
            try:
                return f(*a, **k)
            finally:
                spent["depth"] -= 1
                if not spent["depth"]:
                    spent["t"] += time.process_time() - t
        return call

    for name in ("intersect", "distance", "occluded"):
        setattr(geometry.SceneGeometry, name, timed(getattr(geometry.SceneGeometry, name)))
    scene = load_scene(builtin_scene_path(scene_name))
    render(scene, 1, strategy, width=32, height=24, rng=1)
    best = None
    for rep in range(repeat):
        spent["t"], spent["rays"] = 0.0, 0
        t = cpu_seconds()
        render(scene, spp, strategy, width=w, height=h, rng=rep, workers=1)
        n = w * h * spp
        row = ((cpu_seconds() - t) / n * 1e6, spent["t"] / n * 1e6, spent["rays"] / n)
        best = row if best is None or row[0] < best[0] else best
    return best


def mitsuba_cost(scene_name: str, w: int, h: int, spp: int, repeat: int):
    """CPU µs per sample of Mitsuba ``scalar_rgb`` (all its threads), fastest of ``repeat``."""
    try:
        import mitsuba as mi
    except ImportError:
        return None
    from mitsuba_references import load
    mi.set_variant("scalar_rgb")
    scene = load(mi, scene_name, w, h)
    mi.render(scene, spp=1, seed=999)
    best = None
    for rep in range(repeat):
        t = cpu_seconds()
        mi.render(scene, spp=spp, seed=rep)
        c = (cpu_seconds() - t) / (w * h * spp) * 1e6
        best = c if best is None else min(best, c)
    return best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="many_lights")
    ap.add_argument("--width", type=int, default=256)
    ap.add_argument("--height", type=int, default=192)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--strategy", default="mis-power")
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args(argv)
    total, queries, rays = vrlab_split(a.scene, a.width, a.height, a.spp, a.strategy, a.repeat)
    mit = mitsuba_cost(a.scene, a.width, a.height, a.spp, a.repeat)
    print(f"{a.scene} {a.width}x{a.height}, {a.spp} spp, vrlab {a.strategy!r}; CPU microseconds per sample")
    print("| vrlab total | ray queries | rest | Mitsuba scalar_rgb (direct) | rest / Mitsuba | "
          "query budget for parity | rays / sample | rays/s per core needed |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    rest = total - queries
    cells = [f"{total:.3f}", f"{queries:.3f}", f"{rest:.3f}"]
    if mit is None:
        cells += ["(no mitsuba)", "", "", f"{rays:.2f}", ""]
    else:
        budget = mit - rest
        need = f"{rays / budget * 1e6:.3g}" if budget > 0 else "none: the rest alone is slower"
        cells += [f"{mit:.3f}", f"{rest / mit:.2f}", f"{budget:.3f}", f"{rays:.2f}", need]
    print("| " + " | ".join(cells) + " |")

if __name__ == "__main__":
    main()
