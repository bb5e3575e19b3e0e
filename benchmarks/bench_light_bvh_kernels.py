"""The light-BVH walk, NumPy vs the compiled kernel (vrlab.kernels): sample + pmf per shading point.

    python benchmarks/bench_light_bvh_kernels.py [--points N] [--repeat R]

Scene: L lights in a 10 x 10 x 4 room, half small one-sided quads facing down from the ceiling,
half spheres; N shading points on the floor and walls with their normals, one uniform each
(``unique``), or N / 8 points with 8 candidates each (``8 per point``, as RIS asks: the NumPy
walk shares the importances of candidates that go down together).  Best of R wall times
(``vrlab.bench.timing.race``); the kernel is compiled or loaded before.
"""
import argparse
import sys
from pathlib import Path

import numpy as np

try:
    from vrlab.bench.timing import race
except ImportError:  # run from a checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from vrlab.bench.timing import race
from vrlab.distributions import LightBVH


def scene(L, rng):
    quad = rng.random(L) < 0.5
    c = rng.uniform([0, 0, 0.5], [10, 10, 4], (L, 3))
    c[quad, 2] = 4.0
    e = np.where(quad[:, None], [0.1, 0.1, 0.0], 0.05)
    w = np.tile([0.0, 0.0, -1.0], (L, 1))
    return dict(lo=c - e, hi=c + e, w=w, cos_theta_o=np.where(quad, 1.0, -1.0), cos_theta_e=np.zeros(L),
                phi=rng.uniform(0.5, 2.0, L))


def points(N, rng, per_point=1):
    m = N // per_point
    p = rng.uniform([0, 0, 0], [10, 10, 4], (m, 3))
    wall = rng.random(m) < 0.4
    p[~wall, 2] = 0.0
    p[wall, 0] = np.where(rng.random(wall.sum()) < 0.5, 0.0, 10.0)
    n = np.zeros((m, 3))
    n[~wall, 2] = 1.0
    n[wall, 0] = np.where(p[wall, 0] == 0.0, 1.0, -1.0)
    return np.repeat(p, per_point, 0), np.repeat(n, per_point, 0), rng.random(m * per_point)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=100_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    rng = np.random.default_rng(31)
    print(f"{'lights':>7} {'points':>16} {'numpy s':>8} {'numba s':>8} {'speed-up':>8}  (sample + pmf)")
    for L in (1000, 10_000):
        sc = scene(L, rng)
        trees = {k: LightBVH(**sc, kernels=k) for k in ("numpy", "numba")}
        for per in (1, 8):
            p, n, u = points(args.points, rng, per)
            j, _ = trees["numba"].sample(p, n, u)   # compile or load
            t = race({k: (lambda b=b: (b.sample(p, n, u), b.pmf(p, n, j))) for k, b in trees.items()}, args.repeat)
            label = "unique" if per == 1 else f"{per} per point"
            print(f"{L:>7} {len(u):>7} {label:>8} {t['numpy']:8.3f} {t['numba']:8.3f} {t['numpy'] / t['numba']:8.1f}")
