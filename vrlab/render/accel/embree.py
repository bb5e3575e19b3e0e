"""Planar primitives traced by Intel Embree (through the ``embreex`` package), where installed.

The scene's BVH (:mod:`vrlab.render.accel.scene_bvh`) hands its planar groups (parallelograms,
triangles) to Embree when ``embreex`` imports (it has wheels for x86-64 Linux, Windows and
macOS; elsewhere the NumPy BVH traces them).  The pooled mesh triangles
(:class:`~vrlab.render.accel.pool.IndexedPlanar`) go in as an indexed mesh (their float32
vertices and int32 faces); each parallelogram ``v0 + s e1 + u e2`` is
two triangles (v0, v0 + e1, v0 + e1 + e2) and (v0, v0 + e1 + e2, v0 + e2); Embree builds
its own BVH over the triangles and intersects float32 rays (watertight, both faces), so
hit/miss decisions are float32-accurate, as the all-pairs kernels' and Mitsuba's scalar
variants'.  Then, as for those kernels, t of the winner is recomputed in float64 from its
plane for float64 rays (float32 rays keep Embree's float32 t), and the shape, the normal and
the primitive's index within its shape come from the planar group.  ``t_min`` moves the
origins forward (Embree's rays start at t = 0).  Shadow queries use Embree's occlusion test
(any hit before ``t_max``).

The Embree scene is not pickled: a process that receives the geometry by pickle builds it on
first use (milliseconds for thousands of triangles; about 1.5 s for 2 million on this machine,
most of it embreex copying the index buffer, 0.45 us per triangle), under a lock (threads of
one process build it once).  :meth:`EmbreeTriangles.build` builds and commits it at once (one
query: embreex commits on the first); a process forked after that inherits the committed scene
and only queries it (queries run in the calling thread; Embree's build threads are not needed),
so a render's parent builds it once before forking its workers (:meth:`vrlab.render.film.execute`)
instead of each worker building its own copy.
"""
from __future__ import annotations

import threading

import numpy as np

from ..._vec import dot as _dot

__all__ = ["EmbreeTriangles", "embree_available"]


def embree_available() -> bool:
    """Whether ``embreex`` imports (Embree's Python bindings)."""
    try:
        import embreex.mesh_construction  # noqa: F401
        import embreex.rtcore_scene  # noqa: F401
    except ImportError:
        return False
    return True


class EmbreeTriangles:
    """The planar groups ``planar`` (:class:`~vrlab.render.accel.groups.Planar` or
    :class:`~vrlab.render.accel.pool.IndexedPlanar`) as one Embree triangle mesh: group g's
    primitives are Embree's triangles ``first[g] ..`` (a parallelogram two of them, its j-th
    half at j and at j + its group's size).  Nothing is stored per triangle: the Embree
    scene is built from the groups on first use (in the process that traces rays)."""

    def __init__(self, planar: list):
        self.planar = list(planar)
        sizes = [(2 if pl.para else 1) * len(pl) for pl in self.planar]
        self.first = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        self._scene = None
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return int(self.first[-1])

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_scene"] = state["_lock"] = None   # Embree's scene does not pickle: built on use
        return state

    @staticmethod
    def _arrays(pl) -> tuple[np.ndarray, np.ndarray]:
        """``(vertices float32, indices int32)`` of a group's Embree triangles."""
        if not pl.para:
            if hasattr(pl, "embree_arrays"):
                return pl.embree_arrays()
            tri = np.stack([pl.v0, pl.v0 + pl.e1, pl.v0 + pl.e2], 1)
        else:
            v0, e1, e2 = pl.v0, pl.e1, pl.e2
            far = v0 + e1 + e2
            tri = np.concatenate([np.stack([v0, v0 + e1, far], 1), np.stack([v0, far, v0 + e2], 1)])
        return tri.reshape(-1, 3).astype(np.float32), np.arange(3 * len(tri), dtype=np.int32).reshape(-1, 3)

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()

    @property
    def scene(self):
        """Embree's scene of the triangles, built once per process, or inherited from the
        parent of a forked process (see the module docstring)."""
        if self._scene is None:
            with self._lock:
                if self._scene is None:
                    from embreex import rtcore_scene
                    from embreex.mesh_construction import TriangleMesh

                    verts, index = zip(*(self._arrays(pl) for pl in self.planar))
                    if len(verts) > 1:
                        off = np.cumsum([0] + [len(v) for v in verts[:-1]])
                        index = [i + np.int32(o) for i, o in zip(index, off)]
                    scene = rtcore_scene.EmbreeScene()
                    TriangleMesh(scene, np.concatenate(verts), np.concatenate(index))
                    self._scene = scene
        return self._scene

    def build(self) -> None:
        """Build and commit Embree's scene in this process now (embreex commits at the first
        query: one ray, answered or not), so that processes forked later inherit it."""
        one = np.zeros((1, 3), np.float32)
        self.scene.run(one, one + np.float32(1.0), output=1)

    @staticmethod
    def _start(o: np.ndarray, d: np.ndarray, t_min: float) -> tuple[np.ndarray, np.ndarray]:
        o32 = np.ascontiguousarray(o + t_min * d if t_min else o, dtype=np.float32)
        return o32, np.ascontiguousarray(d, dtype=np.float32)

    def closest(self, o, d, t_min: float, t, shape, normal, prim=None) -> np.ndarray:
        """Set the closest planar hits of rays ``(o, d)`` in ``t, shape, normal`` (and
        ``prim``) where they are closer than ``t`` (in place; ``normal=None``: no normals);
        returns the rows set."""
        o32, d32 = self._start(o, d, t_min)
        res = self.scene.run(o32, d32, output=1)
        k = np.asarray(res["primID"], np.int64)
        tt = np.asarray(res["tfar"], np.float64) + t_min
        rows = np.flatnonzero((k >= 0) & (tt < t))
        if not len(rows):
            return rows
        k = k[rows]
        one = len(self.planar) == 1
        gs = np.zeros(len(k), np.int64) if one else np.searchsorted(self.first, k, side="right") - 1
        for g in np.unique(gs):
            m = rows if one else rows[gs == g]
            pl = self.planar[int(g)]
            jm = (k if one else k[gs == g]) - self.first[g]
            if pl.para:
                jm %= len(pl)
            q, nrm, sh, loc = pl.hit_info(jm, plane=o.dtype == np.float64)
            if q is not None:                           # float64 rays: t from the plane
                with np.errstate(divide="ignore", invalid="ignore"):
                    t64 = -_dot(o[m] - q[:, :3], q[:, 3:6]) / _dot(d[m], q[:, 3:6])
                tt[m] = np.where(np.isfinite(t64) & (t64 > t_min), t64, tt[m])
            t[m] = tt[m]
            shape[m] = sh
            if normal is not None:
                normal[m] = nrm
            if prim is not None:
                prim[m] = loc
        return rows

    def occluded(self, o, d, t_min: float, t_max: np.ndarray) -> np.ndarray:
        """Whether each ray hits a planar primitive with ``t_min < t < t_max`` (any hit)."""
        o32, d32 = self._start(o, d, t_min)
        far = np.broadcast_to(np.asarray(t_max, np.float64) - t_min, (len(o32),))
        ok = far > 0
        out = np.zeros(len(o32), bool)
        if ok.any():
            rows = np.flatnonzero(ok)
            dist = np.ascontiguousarray(np.minimum(far[rows], 3e38), dtype=np.float32)
            hit = np.asarray(self.scene.run(o32[rows], d32[rows], dists=dist, query="OCCLUDED"))
            out[rows] = hit >= 0
        return out
