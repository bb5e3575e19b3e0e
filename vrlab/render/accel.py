"""One acceleration structure over every primitive of a scene: a :class:`~vrlab.render.bvh.BVH`
whose leaves hold planar primitives (parallelograms, triangles), quadrics (spheres,
ellipsoids) and disks alike.

Each primitive has an index in one global list, kind after kind (the planar groups, then
the quadrics, then the disks); the BVH is built over their boxes:

* planar ``v0 + s e1 + u e2``: the box of its corners;
* quadric ``c + M s`` (|s| = 1) and disk ``c + M (s, 0)`` (|s| <= 1): the exact box of the
  image of the unit sphere / disk, c_i +- sqrt(sum_j M_ij^2) (over j = 0, 1 for the disk).

At a leaf the (ray, primitive) pairs are split by kind and tested exactly in float64 (the
planar group's dual-basis test, the stable quadratic roots in the unit-sphere frame, the
disk's plane hit inside the unit circle).  ``closest`` then finishes each ray's hit with its
kind's shape index, normal and primitive index; ``occluded`` answers shadow queries (any hit
before ``t_max``) without finishing anything.
"""
from __future__ import annotations

import numpy as np

from .bvh import BVH
from .groups import Planar, Quadrics, unit_sphere_hit

__all__ = ["Accel", "BACKENDS"]


class _Disks:
    """Disks ``c + M (s, 0)``, |s| <= 1, with their shape index and unit normal."""

    def __init__(self, disks: list):
        self.shape = np.array([k for k, _, _, _ in disks], np.int64)
        self.c = np.array([c for _, c, _, _ in disks], float).reshape(-1, 3)
        self.minv = np.array([m for _, _, m, _ in disks], float).reshape(-1, 3, 3)
        self.n = np.array([n for _, _, _, n in disks], float).reshape(-1, 3)

    def __len__(self) -> int:
        return len(self.shape)

    def exact(self, o, d, t_min, i, j):
        minv = self.minv[j]
        ol = np.einsum("kab,kb->ka", minv, o[i] - self.c[j])
        dl = np.einsum("kab,kb->ka", minv, d[i])
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -ol[:, 2] / dl[:, 2]
            x, y = ol[:, 0] + t * dl[:, 0], ol[:, 1] + t * dl[:, 1]
            ok = np.isfinite(t) & (t > t_min) & (x * x + y * y <= 1.0)
        return np.where(ok, t, np.inf)


BACKENDS = ("auto", "numpy", "embree")


class Accel:
    """A BVH over the primitives of ``planar`` (a list of :class:`Planar` groups),
    ``quadrics`` (a :class:`Quadrics` or None) and ``disks`` (``(shape, center, M^-1,
    normal)`` tuples); see the module docstring.  ``backend``: ``"numpy"`` (every kind in the
    NumPy BVH), ``"embree"`` (planar primitives through Embree, :mod:`vrlab.render.embree`;
    the others in the NumPy BVH) or ``"auto"`` (Embree where ``embreex`` imports)."""

    def __init__(self, planar: list[Planar], quadrics: Quadrics | None, disks: list, backend: str = "auto"):
        from .embree import EmbreeTriangles, embree_available

        if backend not in BACKENDS:
            raise ValueError(f"backend: expected one of {', '.join(BACKENDS)}, got {backend!r}")
        if backend == "embree" and not embree_available():
            raise ValueError("backend: 'embree' needs the embreex package (pip install embreex)")
        use_embree = bool(planar) and (backend == "embree" or (backend == "auto" and embree_available()))
        #: the planar groups traced by Embree (None: in the NumPy BVH)
        self.embree = EmbreeTriangles(planar) if use_embree else None
        self.kinds: list = [] if use_embree else list(planar)
        if quadrics is not None:
            self.kinds.append(quadrics)
        if disks:
            self.kinds.append(_Disks(disks))
        sizes = [len(k) for k in self.kinds]
        self.first = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        lo, hi = zip(*(self._boxes(k) for k in self.kinds)) if self.kinds else ([np.zeros((0, 3))],) * 2
        self.bvh = BVH.from_boxes(np.concatenate(lo), np.concatenate(hi)) if self.kinds else None

    def __len__(self) -> int:
        return int(self.first[-1]) + (0 if self.embree is None else sum(len(g) for g in self.embree.planar))

    @staticmethod
    def _boxes(kind) -> tuple[np.ndarray, np.ndarray]:
        if isinstance(kind, Planar):
            corners = [kind.v0, kind.v0 + kind.e1, kind.v0 + kind.e2]
            if kind.para:
                corners.append(kind.v0 + kind.e1 + kind.e2)
            c = np.stack(corners, 1)
            return c.min(1), c.max(1)
        m = np.linalg.inv(kind.minv)                         # (P, 3, 3): x = c + M s
        if isinstance(kind, _Disks):
            m = m[:, :, :2]
        half = np.sqrt(np.sum(m * m, -1))
        return kind.c - half, kind.c + half

    def _split(self, j: np.ndarray):
        """``(kind index, mask or None, local j)`` per kind with pairs among ``j``."""
        if len(self.kinds) == 1:
            yield 0, None, j
            return
        which = np.searchsorted(self.first, j, side="right") - 1
        for k in np.unique(which):
            m = which == k
            yield int(k), m, j[m] - self.first[k]

    def _exact(self, kind, rays, o, d, t_min, i, j):
        if isinstance(kind, Planar):
            return kind.exact(rays, t_min, i, j)
        if isinstance(kind, Quadrics):
            return unit_sphere_hit(*kind._local(o, d, i, j)[:2], t_min)
        return kind.exact(o, d, t_min, i, j)

    def _test(self, o, d, t_min):
        rays = np.concatenate([o, d], axis=1)

        def test(i, j):
            t = np.empty(len(i))
            for k, m, jl in self._split(j):
                if m is None:
                    return self._exact(self.kinds[k], rays, o, d, t_min, i, jl)
                t[m] = self._exact(self.kinds[k], rays, o, d, t_min, i[m], jl)
            return t
        return test

    def closest(self, o, d, t_min, t, shape, normal, prim=None) -> None:
        """Update the closest hits ``t, shape, normal`` (and ``prim``) of rays in place (the NumPy
        BVH needs float64 rays; Embree's planar hits come first and keep ties)."""
        if self.embree is not None:
            self.embree.closest(o, d, t_min, t, shape, normal, prim)
        if self.bvh is None:
            return
        o, d = o.astype(np.float64, copy=False), d.astype(np.float64, copy=False)
        i, j, tt = self.bvh.closest(o, d, t_min, t, self._test(o, d, t_min))
        if self.embree is not None and len(i):            # strictly closer than a planar hit
            keep = tt < t[i]
            i, j, tt = i[keep], j[keep], tt[keep]
        if not len(i):
            return
        t[i] = tt
        for k, m, jl in self._split(j):
            kind = self.kinds[k]
            rows, th = (i, tt) if m is None else (i[m], tt[m])
            shape[rows] = kind.shape[jl]
            if isinstance(kind, Planar):
                normal[rows] = kind.normal[jl]
                local = kind.local[jl]
            elif isinstance(kind, Quadrics):
                ol, dl, minv = kind._local(o, d, rows, jl)
                normal[rows] = kind._normal(ol, dl, minv, jl, th)
                local = 0
            else:
                normal[rows] = kind.n[jl]
                local = 0
            if prim is not None:
                prim[rows] = local

    def occluded(self, o, d, t_min: float, t_max: np.ndarray) -> np.ndarray:
        """Whether each ray hits a primitive with ``t_min < t < t_max``."""
        hit = np.zeros(len(o), bool) if self.embree is None else self.embree.occluded(o, d, t_min, t_max)
        if self.bvh is not None:
            rest = np.flatnonzero(~hit)
            if len(rest):
                o64, d64 = o[rest].astype(np.float64), d[rest].astype(np.float64)
                hit[rest] = self.bvh.occluded(o64, d64, t_min, np.broadcast_to(t_max, (len(o),))[rest],
                                              self._test(o64, d64, t_min))
        return hit
