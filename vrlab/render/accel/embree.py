"""Planar primitives traced by Intel Embree (through the ``embreex`` package), where installed.

The scene's BVH (:mod:`vrlab.render.accel.scene_bvh`) hands its planar groups (parallelograms,
triangles) to Embree when ``embreex`` imports (it has wheels for x86-64 Linux, Windows and
macOS; elsewhere the NumPy BVH traces them).  Each parallelogram ``v0 + s e1 + u e2`` is
two triangles (v0, v0 + e1, v0 + e1 + e2) and (v0, v0 + e1 + e2, v0 + e2); Embree builds
its own BVH over the triangles and intersects float32 rays (watertight, both faces), so
hit/miss decisions are float32-accurate, as the all-pairs kernels' and Mitsuba's scalar
variants'.  Then, as for those kernels, t of the winner is recomputed in float64 from its
plane for float64 rays (float32 rays keep Embree's float32 t), and the shape, the normal and
the primitive's index within its shape come from the planar group.  ``t_min`` moves the
origins forward (Embree's rays start at t = 0).  Shadow queries use Embree's occlusion test
(any hit before ``t_max``).

The Embree scene is not pickled: a process that receives the geometry builds it on first use
(milliseconds for thousands of triangles, about a second for a million), under a lock (threads
of one process build it once) and again in a forked child (Embree's threads do not survive a
fork).  Worker processes receive a render's job once (:mod:`vrlab.execution`), so each builds
its Embree scene once.
"""
from __future__ import annotations

import os
import threading

import numpy as np

from ..._vec import dot as _dot
from .groups import Planar

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
    """The planar groups ``planar`` (a list of :class:`~vrlab.render.accel.groups.Planar`) as one
    Embree triangle mesh; triangle i is primitive ``prim[i]`` of group ``group[i]``."""

    def __init__(self, planar: list[Planar]):
        self.planar = list(planar)
        tris, group, prim = [], [], []
        for g, pl in enumerate(self.planar):
            v0, e1, e2 = pl.v0, pl.e1, pl.e2
            j = np.arange(len(v0))
            if pl.para:
                far = v0 + e1 + e2
                tris += [np.stack([v0, v0 + e1, far], 1), np.stack([v0, far, v0 + e2], 1)]
                group += [np.full(2 * len(v0), g)]
                prim += [j, j]
            else:
                tris.append(np.stack([v0, v0 + e1, v0 + e2], 1))
                group.append(np.full(len(v0), g))
                prim.append(j)
        self.tri = np.ascontiguousarray(np.concatenate(tris), dtype=np.float32)
        self.group = np.concatenate(group).astype(np.int64)
        self.prim = np.concatenate(prim).astype(np.int64)
        self._scene, self._pid, self._lock = None, None, threading.Lock()

    def __len__(self) -> int:
        return len(self.tri)

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_scene"] = state["_pid"] = state["_lock"] = None   # Embree's scene does not pickle: built on use
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()

    @property
    def scene(self):
        """Embree's scene of the triangles, built once per process (see the module docstring)."""
        if self._scene is None or self._pid != os.getpid():
            with self._lock:
                if self._scene is None or self._pid != os.getpid():
                    from embreex import rtcore_scene
                    from embreex.mesh_construction import TriangleMesh

                    scene = rtcore_scene.EmbreeScene()
                    TriangleMesh(scene, self.tri)
                    self._scene, self._pid = scene, os.getpid()
        return self._scene

    @staticmethod
    def _start(o: np.ndarray, d: np.ndarray, t_min: float) -> tuple[np.ndarray, np.ndarray]:
        o32 = np.ascontiguousarray(o + t_min * d if t_min else o, dtype=np.float32)
        return o32, np.ascontiguousarray(d, dtype=np.float32)

    def closest(self, o, d, t_min: float, t, shape, normal, prim=None) -> np.ndarray:
        """Set the closest planar hits of rays ``(o, d)`` in ``t, shape, normal`` (and
        ``prim``) where they are closer than ``t`` (in place); returns the rows set."""
        o32, d32 = self._start(o, d, t_min)
        res = self.scene.run(o32, d32, output=1)
        k = np.asarray(res["primID"], np.int64)
        tt = np.asarray(res["tfar"], np.float64) + t_min
        rows = np.flatnonzero((k >= 0) & (tt < t))
        if not len(rows):
            return rows
        k = k[rows]
        gs, js = self.group[k], self.prim[k]
        for g in np.unique(gs):
            m = rows if len(self.planar) == 1 else rows[gs == g]
            jm = js if len(self.planar) == 1 else js[gs == g]
            pl = self.planar[int(g)]
            if o.dtype == np.float64:                   # float64 rays: t from the plane
                q = pl.packed[jm]
                with np.errstate(divide="ignore", invalid="ignore"):
                    t64 = -_dot(o[m] - q[:, :3], q[:, 3:6]) / _dot(d[m], q[:, 3:6])
                tt[m] = np.where(np.isfinite(t64) & (t64 > t_min), t64, tt[m])
            t[m] = tt[m]
            shape[m] = pl.shape[jm]
            normal[m] = pl.normal[jm]
            if prim is not None:
                prim[m] = pl.local[jm]
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
