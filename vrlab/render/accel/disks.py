"""Disks as a primitive group of :class:`~vrlab.render.accel.geometry.SceneGeometry`: every ray
against every disk in float64 while they are few, and the pair interface (``boxes``, ``exact``,
``normals``, ``prims``; see :class:`~vrlab.render.accel.groups.Planar`) for the scene's BVH."""
from __future__ import annotations

import numpy as np

from .flat import DISK
from .groups import affine_boxes

__all__ = ["Disks"]


class Disks:
    """Disks ``c + M (s, 0)``, |s| <= 1 (``(shape, center, M^-1, normal)`` tuples), with their
    shape index and unit normal; hit where the ray meets z = 0 of the disk frame M^-1 (x - c)
    inside the unit circle."""

    def __init__(self, disks: list):
        self.shape = np.array([k for k, _, _, _ in disks], np.int64)
        self.c = np.array([c for _, c, _, _ in disks], float).reshape(-1, 3)
        self.minv = np.array([m for _, _, m, _ in disks], float).reshape(-1, 3, 3)
        self.n = np.array([n for _, _, _, n in disks], float).reshape(-1, 3)

    def __len__(self) -> int:
        return len(self.shape)

    @staticmethod
    def _hit(ol: np.ndarray, dl: np.ndarray, t_min: float) -> np.ndarray:
        """t of rays in disk frames (inf on a miss)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -ol[:, 2] / dl[:, 2]
            x, y = ol[:, 0] + t * dl[:, 0], ol[:, 1] + t * dl[:, 1]
            ok = np.isfinite(t) & (t > t_min) & (x * x + y * y <= 1.0)
        return np.where(ok, t, np.inf)

    def closest(self, o, d, t_min, t, shape, normal, prim=None) -> None:
        """Fold every ray's hits with every disk into the closest hits (all pairs, in place)."""
        for k in range(len(self)):
            tt = self._hit((o - self.c[k]) @ self.minv[k].T, d @ self.minv[k].T, t_min)
            better = tt < t
            t[better] = tt[better]
            shape[better] = self.shape[k]
            normal[better] = self.n[k]
            if prim is not None:
                prim[better] = 0

    # -- the pair interface (see ``Planar``) -------------------------------------------------
    def boxes(self) -> tuple[np.ndarray, np.ndarray]:
        """Exact boxes of the disks: c_i +- sqrt(M_i0^2 + M_i1^2)."""
        return affine_boxes(self.c, np.linalg.inv(self.minv)[:, :, :2])

    def exact(self, o, d, t_min, i, j):
        """Exact t (inf on a miss) of the pairs ``(ray i, disk j)``: the ray in the disk frame,
        ``(M^-1 x)_a = sum_b M^-1_ab x_b`` summed over b in order (as the compiled walk does)."""
        minv = self.minv[j]
        oc, dd = o[i] - self.c[j], d[i]
        ol = minv[:, :, 0] * oc[:, 0:1] + minv[:, :, 1] * oc[:, 1:2] + minv[:, :, 2] * oc[:, 2:3]
        dl = minv[:, :, 0] * dd[:, 0:1] + minv[:, :, 1] * dd[:, 1:2] + minv[:, :, 2] * dd[:, 2:3]
        return self._hit(ol, dl, t_min)

    def normals(self, o, d, rows, j, t) -> np.ndarray:
        return self.n[j]

    def prims(self, j) -> np.ndarray:
        return np.zeros(len(j), np.int64)

    def kernel_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """``(kind codes, rows (P, 16))`` of the compiled traversal (:mod:`.flat`): ``c, M^-1``, the
        normal."""
        rows = np.concatenate([self.c, self.minv.reshape(-1, 9), self.n, np.zeros((len(self), 1))], axis=1)
        return np.full(len(self), DISK, np.int64), rows
