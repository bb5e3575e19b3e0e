"""Closest-hit ray intersection: rays/s of the old brute-force code vs SceneGeometry.

    python benchmarks/bench_intersect.py [--rays N] [--render]

Rays per scene: camera rays through random film points, plus rays leaving their hit
points in uniformly random directions to the normal's side (like shadow/BSDF rays).
The old implementation (Moller-Trumbore over all triangles with (N, T, 3) cross
products, one full pass per quadric) is kept below as ``OldGeometry``.  ``--render``
also times ``render(scene, 16, "mis-power")`` at 128x96 with the new code.
"""
import argparse
import sys
import time
from pathlib import Path

import numpy as np

try:
    from vrlab.render import builtin_scene_path, load_scene, render
except ImportError:  # run from a checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from vrlab.render import builtin_scene_path, load_scene, render
from vrlab.render.accel.geometry import SceneGeometry
from vrlab.render.accel.groups import unit_sphere_hit

SCENES = ("furnace", "veach_mis", "cornell_box", "many_lights", "box_ellipsoid")


def _unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


class OldGeometry:
    """The previous brute-force intersector (closest t, shape; normals omitted)."""

    def __init__(self, scene):
        tris, ids, self.quadrics, self.disks = [], [], [], []
        for k, s in enumerate(scene.shapes):
            if s.type in ("rectangle", "cube", "obj"):
                t = s.triangles()
                tris.append(t)
                ids.append(np.full(len(t), k))
            elif s.type in ("sphere", "ellipsoid"):
                c, m = s.ellipsoid()
                self.quadrics.append((k, c, np.linalg.inv(m)))
            else:
                self.disks.append((k, s.center, np.linalg.inv(s.to_world[:3, :3])))
        t = np.concatenate(tris) if tris else np.zeros((0, 3, 3))
        self.v0, self.e1, self.e2 = t[:, 0], t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
        self.ids = np.concatenate(ids) if ids else np.zeros(0, int)

    def intersect(self, o, d, chunk=1 << 15):
        t = np.full(len(o), np.inf)
        shape = np.full(len(o), -1)
        for a in range(0, len(o), chunk):
            sl = slice(a, a + chunk)
            self._closest(o[sl], d[sl], t[sl], shape[sl])
        return t, shape

    def _closest(self, o, d, t, shape):
        block = max(1, (1 << 19) // len(o))
        for a in range(0, len(self.v0), block):
            v0, e1, e2 = self.v0[a:a + block], self.e1[a:a + block], self.e2[a:a + block]
            p = np.cross(d[:, None, :], e2[None])
            det = np.einsum("tk,ntk->nt", e1, p)
            ok = det != 0.0
            inv = 1.0 / np.where(ok, det, 1.0)
            tv = o[:, None, :] - v0[None]
            u = np.einsum("ntk,ntk->nt", tv, p) * inv
            q = np.cross(tv, e1[None])
            v = np.einsum("nk,ntk->nt", d, q) * inv
            tt = np.einsum("tk,ntk->nt", e2, q) * inv
            ok &= (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (tt > 0.0)
            tt = np.where(ok, tt, np.inf)
            j = np.argmin(tt, axis=1)
            tt = tt[np.arange(len(tt)), j]
            better = tt < t
            t[better], shape[better] = tt[better], self.ids[j[better] + a]
        for k, c, minv in self.quadrics:
            tt = unit_sphere_hit((o - c) @ minv.T, d @ minv.T, 0.0)
            better = tt < t
            t[better], shape[better] = tt[better], k
        for k, c, minv in self.disks:
            ol, dl = (o - c) @ minv.T, d @ minv.T
            with np.errstate(divide="ignore", invalid="ignore"):
                tt = -ol[:, 2] / dl[:, 2]
            x = ol[:, :2] + np.where(np.isfinite(tt), tt, 0.0)[:, None] * dl[:, :2]
            tt = np.where(np.isfinite(tt) & (tt > 0) & (np.sum(x * x, -1) <= 1), tt, np.inf)
            better = tt < t
            t[better], shape[better] = tt[better], k


def _scene(name, width=128, height=96):
    """A built-in scene at ``width`` x ``height`` (the film is edited: not every scene has
    a resolution parameter)."""
        sc = load_scene(builtin_scene_path(name))
    sc = sc.with_size(width, height)
    return sc


def make_rays(scene, n, rng):
    """n camera rays and up to n rays leaving their hits."""
    cam = scene.sensor
    film = rng.uniform(size=(n, 2)) * [scene.sensor.width, scene.sensor.height]
    o, d = cam.rays(film)
    h = SceneGeometry(scene).intersect(o, d)
    m = h.shape >= 0
    w = rng.normal(size=(m.sum(), 3))
    w *= np.where(np.sum(w * h.n[m], -1) < 0, -1.0, 1.0)[:, None]
    p = h.p[m] + 1e-5 * (1 + np.abs(h.p[m]).max(-1, keepdims=True)) * h.n[m]
    return np.concatenate([o, p]), np.concatenate([d, w])


def timed(f, reps=3):
    best = np.inf
    for _ in range(reps):
        t0 = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rays", type=int, default=50_000, help="camera rays per scene")
    parser.add_argument("--render", action="store_true", help="also time 128x96x16 spp renders")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    print(f"{'scene':14s} {'rays':>8s} {'old rays/s':>11s} {'new rays/s':>11s} {'ratio':>6s} {'agree':>6s}")
    for name in SCENES:
        sc = _scene(name)
        o, d = make_rays(sc, args.rays, rng)
        old, new = OldGeometry(sc), SceneGeometry(sc)
        t_old, (t1, s1) = timed(lambda old=old, o=o, d=d: old.intersect(o, d),
                                reps=1 if name == "many_lights" else 3)
        t_new, h = timed(lambda new=new, o=o, d=d: new.intersect(o, d))
        agree = np.mean((s1 == h.shape) & ((t1 == h.t) | np.isclose(t1, h.t, rtol=1e-9)))
        print(f"{name:14s} {len(o):8d} {len(o) / t_old:11.3g} {len(o) / t_new:11.3g} "
              f"{t_old / t_new:6.1f} {agree:6.4f}", flush=True)
    if args.render:
        for name in ("veach_mis", "cornell_box", "many_lights"):
            sc = _scene(name)
            dt, _ = timed(lambda sc=sc: render(sc, 16, "mis-power", rng=1), reps=1)
            print(f"render {name:12s} 128x96x16: {128 * 96 * 16 / dt:.3g} samples/s ({dt:.1f} s)", flush=True)


if __name__ == "__main__":
    main()
