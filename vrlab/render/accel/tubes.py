"""Open tubes (the ``cylinder`` shape) as a primitive group of
:class:`~vrlab.render.accel.geometry.SceneGeometry`: every ray against every tube in float64
while they are few, and the pair interface (``boxes``, ``exact``, ``normals``, ``prims``,
``kernel_rows``; see :class:`~vrlab.render.accel.groups.Planar`) for the scene's BVH.

A tube is ``x = c + M (cos phi, sin phi, z)``, ``0 <= z <= 1``: in its frame ``M^-1 (x - c)``
a ray meets it at the stable roots of (o_x + t d_x)^2 + (o_y + t d_y)^2 = 1 with 0 <= z <= 1
(:func:`vrlab.distributions.cylinder.tube_hits`; the caps are open, as in Mitsuba).  The
normal at the frame point s is ``sign M^-T (s_x, s_y, 0)``, normalised (outward for sign 1).
Box: along world axis a, ``c_a + [min(0, M_a2), max(0, M_a2)] +- sqrt(M_a0^2 + M_a1^2)``.
"""
from __future__ import annotations

import numpy as np

from ..._vec import matvec3
from ...distributions.cylinder import tube_hits
from .flat import TUBE
from .groups import unit

__all__ = ["Tubes"]


class Tubes:
    """Tubes from ``(shape, center, M^-1, sign)`` tuples (see the module docstring)."""

    def __init__(self, tubes: list):
        self.shape = np.array([k for k, _, _, _ in tubes], np.int64)
        self.c = np.array([c for _, c, _, _ in tubes], float).reshape(-1, 3)
        self.minv = np.array([m for _, _, m, _ in tubes], float).reshape(-1, 3, 3)
        self.sign = np.array([s for _, _, _, s in tubes], float)

    def __len__(self) -> int:
        return len(self.shape)

    def _local(self, o, d, i, j):
        """Pair rays in the tube frames: ``M^-1 (o - c)``, ``M^-1 d`` (rows summed in order)."""
        minv = self.minv[j]
        oc, dd = o[i] - self.c[j], d[i]
        ol = minv[:, :, 0] * oc[:, 0:1] + minv[:, :, 1] * oc[:, 1:2] + minv[:, :, 2] * oc[:, 2:3]
        dl = minv[:, :, 0] * dd[:, 0:1] + minv[:, :, 1] * dd[:, 1:2] + minv[:, :, 2] * dd[:, 2:3]
        return ol, dl, minv

    def _normal(self, ol, dl, minv, j, t) -> np.ndarray:
        x = ol + t[:, None] * dl
        n = x[:, 0:1] * minv[:, 0] + x[:, 1:2] * minv[:, 1]                  # M^-T (x, y, 0)
        return self.sign[j, None] * unit(n)

    def closest(self, o, d, t_min, t, shape, normal, prim=None) -> None:
        """Fold every ray's hits with every tube into the closest hits (all pairs, in place)."""
        i = np.arange(len(o))
        for k in range(len(self)):
            m = self.minv[k]
            ol, dl = matvec3(m, o - self.c[k]), matvec3(m, d)
            tt = tube_hits(ol, dl, t_min)[:, 0]
            better = np.flatnonzero(tt < t)
            if not len(better):
                continue
            t[better] = tt[better]
            shape[better] = self.shape[k]
            jj = np.full(len(better), k)
            normal[better] = self._normal(*self._local(o, d, i[better], jj), jj, tt[better])
            if prim is not None:
                prim[better] = 0

    # -- the pair interface (see ``Planar``) -------------------------------------------------
    def boxes(self) -> tuple[np.ndarray, np.ndarray]:
        """Exact boxes of the tubes (module docstring)."""
        m = np.linalg.inv(self.minv)
        half = np.sqrt(m[:, :, 0] ** 2 + m[:, :, 1] ** 2)
        axis = m[:, :, 2]
        return self.c + np.minimum(axis, 0.0) - half, self.c + np.maximum(axis, 0.0) + half

    def exact(self, o, d, t_min, i, j):
        """Exact t (inf on a miss) of the pairs ``(ray i, tube j)``: the first root of ``tube_hits``."""
        ol, dl, _ = self._local(o, d, i, j)
        return tube_hits(ol, dl, t_min)[:, 0]

    def normals(self, o, d, rows, j, t) -> np.ndarray:
        return self._normal(*self._local(o, d, rows, j), j, t)

    def prims(self, j) -> np.ndarray:
        return np.zeros(len(j), np.int64)

    def kernel_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """``(kind codes, rows (P, 16))`` of the compiled traversal (:mod:`.flat`): ``c, M^-1``, the
        normals' sign."""
        rows = np.zeros((len(self), 16))
        rows[:, :3], rows[:, 3:12], rows[:, 15] = self.c, self.minv.reshape(-1, 9), self.sign
        return np.full(len(self), TUBE, np.int64), rows
