"""Scene geometry as arrays, and vectorised closest-hit ray intersection.

``SceneGeometry(scene)`` collects every shape of a :class:`~vrlab.render.Scene` into
primitive groups:

* triangles (``rectangle``, ``cube``, ``obj``; Moller & Trumbore 1997, "Fast,
  minimum storage ray/triangle intersection"), one array of all triangles;
* quadrics (``sphere``, ``ellipsoid``): the unit sphere under an affine map
  x = c + M s, intersected in the unit-sphere frame;
* disks: the unit disk in z = 0 under an affine map.

``intersect(origin, direction)`` (rays ``(N, 3)``, directions need not be unit; t is in
units of their length) returns :class:`Hits` with the closest ``t > t_min`` per ray,
the index of the shape hit (into ``scene.shapes``; -1 for a miss), the hit point and
the unit geometric normal, which follows Mitsuba: ``M^-T`` of the object normal for
analytic shapes (rectangle, disk, sphere, ellipsoid), the winding ``e1 x e2`` for
meshes (cube, obj), outward for closed shapes, and reversed by ``flip_normals``.
Loops run over primitive groups and blocks of rays, never over single rays.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .scene import Scene

__all__ = ["DEFAULT_RAY_CHUNK", "Hits", "SceneGeometry"]

DEFAULT_RAY_CHUNK = 1 << 15   # rays per block
_BLOCK_ELEMS = 1 << 19        # rays x triangles per Moller-Trumbore block


class Hits(NamedTuple):
    """Closest hits: ``t (N,)`` (inf on a miss), ``shape (N,)`` int (-1 on a miss),
    ``p (N, 3)`` hit points and ``n (N, 3)`` unit geometric normals (0 on a miss)."""

    t: np.ndarray
    shape: np.ndarray
    p: np.ndarray
    n: np.ndarray


def _unit(v: np.ndarray) -> np.ndarray:
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(norm > 0, norm, 1.0)


class SceneGeometry:
    """All shapes of ``scene`` as arrays of primitives (see the module docstring)."""

    def __init__(self, scene: Scene):
        tris, tri_shape, tri_normal = [], [], []
        quad, disk = [], []
        for k, s in enumerate(scene.shapes):
            if s.type in ("rectangle", "cube", "obj"):
                t = s.triangles()
                n = _unit(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]))
                if s.type == "rectangle":      # analytic in Mitsuba: normal M^-T z (mirrors too)
                    n = np.broadcast_to(s.rectangle()[3], n.shape)
                tris.append(t)
                tri_normal.append(n)
                tri_shape.append(np.full(len(t), k))
            elif s.type in ("sphere", "ellipsoid"):
                c, m = s.ellipsoid()
                quad.append((k, c, np.linalg.inv(m), -1.0 if s.flip_normals else 1.0))
            elif s.type == "disk":
                c, m = s.center, s.to_world[:3, :3]
                disk.append((k, c, np.linalg.inv(m), s.disk()[3]))
            else:  # pragma: no cover - the loader rejects other types
                raise ValueError(f"shape type {s.type!r} is not supported by the renderer")
        if tris:
            t = np.concatenate(tris)
            self.v0 = t[:, 0]
            self.e1 = t[:, 1] - t[:, 0]
            self.e2 = t[:, 2] - t[:, 0]
            self.tri_shape = np.concatenate(tri_shape)
            self.tri_normal = np.concatenate(tri_normal)
        else:
            self.v0 = self.e1 = self.e2 = self.tri_normal = np.zeros((0, 3))
            self.tri_shape = np.zeros(0, int)
        self.quadrics = quad
        self.disks = disk
        pts = [np.zeros(3)] + [s.center for s in scene.shapes]
        if tris:
            pts.append(t.reshape(-1, 3))
        pts = np.vstack(pts)
        radii = [np.linalg.norm(np.linalg.inv(q[2]), 2) for q in quad + disk]
        #: a length scale of the scene (for ray offsets)
        self.scale = float(np.max(np.abs(pts)) + max(radii, default=0.0))

    @property
    def n_triangles(self) -> int:
        return len(self.v0)

    # ------------------------------------------------------------------ intersection
    def intersect(self, origin: np.ndarray, direction: np.ndarray, t_min: float = 0.0,
                  chunk: int = DEFAULT_RAY_CHUNK) -> Hits:
        """Closest hits with ``t > t_min`` of the rays ``origin + t direction`` (``(N, 3)``)."""
        o = np.asarray(origin, float).reshape(-1, 3)
        d = np.asarray(direction, float).reshape(-1, 3)
        o, d = np.broadcast_arrays(o, d)
        n_rays = len(d)
        t = np.full(n_rays, np.inf)
        shape = np.full(n_rays, -1, dtype=np.int64)
        normal = np.zeros((n_rays, 3))
        for a in range(0, n_rays, chunk):
            sl = slice(a, min(a + chunk, n_rays))
            self._closest(o[sl], d[sl], t_min, t[sl], shape[sl], normal[sl])
        hit = shape >= 0
        p = np.where(hit[:, None], o + np.where(hit, t, 0.0)[:, None] * d, 0.0)
        return Hits(t, shape, p, normal)

    def _closest(self, o, d, t_min, t, shape, normal):
        """Update ``t``, ``shape``, ``normal`` (views of one chunk) in place."""
        block = max(1, _BLOCK_ELEMS // max(len(o), 1))
        for a in range(0, self.n_triangles, block):
            tt, idx = self._triangles(o, d, t_min, slice(a, a + block))
            better = tt < t
            t[better] = tt[better]
            shape[better] = self.tri_shape[idx[better]]
            normal[better] = self.tri_normal[idx[better]]
        for k, c, minv, sign in self.quadrics:
            ol, dl = (o - c) @ minv.T, d @ minv.T
            tt = _unit_sphere_hit(ol, dl, t_min)
            better = tt < t
            t[better] = tt[better]
            shape[better] = k
            s = ol[better] + tt[better, None] * dl[better]           # unit-sphere point
            normal[better] = sign * _unit(s @ minv)                  # M^-T s
        for k, c, minv, n in self.disks:
            ol, dl = (o - c) @ minv.T, d @ minv.T
            with np.errstate(divide="ignore", invalid="ignore"):
                tt = -ol[:, 2] / dl[:, 2]
            ok = np.isfinite(tt) & (tt > t_min)
            x = ol[:, :2] + np.where(ok, tt, 0.0)[:, None] * dl[:, :2]
            ok &= np.sum(x * x, -1) <= 1.0
            better = ok & (tt < t)
            t[better] = tt[better]
            shape[better] = k
            normal[better] = n

    def _triangles(self, o, d, t_min, sl):
        """Closest triangle hit within the block ``sl``: ``(t (N,), triangle index (N,))``."""
        v0, e1, e2 = self.v0[sl], self.e1[sl], self.e2[sl]
        pvec = np.cross(d[:, None, :], e2[None])                     # (N, T, 3)
        det = np.einsum("tk,ntk->nt", e1, pvec)
        ok = det != 0.0
        inv = 1.0 / np.where(ok, det, 1.0)
        tvec = o[:, None, :] - v0[None]
        u = np.einsum("ntk,ntk->nt", tvec, pvec) * inv
        qvec = np.cross(tvec, e1[None])
        v = np.einsum("nk,ntk->nt", d, qvec) * inv
        tt = np.einsum("tk,ntk->nt", e2, qvec) * inv
        ok &= (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (tt > t_min)
        tt = np.where(ok, tt, np.inf)
        j = np.argmin(tt, axis=1)
        return tt[np.arange(len(tt)), j], j + (sl.start or 0)


def _unit_sphere_hit(o: np.ndarray, d: np.ndarray, t_min: float) -> np.ndarray:
    """Smallest t > t_min with |o + t d| = 1, inf if none (stable quadratic roots)."""
    a = np.sum(d * d, -1)
    b = np.sum(o * d, -1)
    c = np.sum(o * o, -1) - 1.0
    disc = b * b - a * c
    hit = disc >= 0.0
    sq = np.sqrt(np.where(hit, disc, 0.0))
    q = -(b + np.where(b >= 0.0, sq, -sq))
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = q / a
        t2 = np.where(q != 0.0, c / np.where(q != 0.0, q, 1.0), t1)
    lo, hi = np.minimum(t1, t2), np.maximum(t1, t2)
    t = np.where(lo > t_min, lo, np.where(hi > t_min, hi, np.inf))
    return np.where(hit & np.isfinite(t), t, np.inf)
