"""One acceleration structure over every primitive of a scene: a :class:`~vrlab.render.accel.bvh.BVH`
whose leaves hold planar primitives (parallelograms, triangles), quadrics (spheres,
ellipsoids), disks and tubes (cylinders) alike.

Each primitive has an index in one global list, kind after kind (the planar groups, then
the quadrics, the disks, the tubes); the BVH is built over their boxes:

* planar ``v0 + s e1 + u e2``: the box of its corners;
* quadric ``c + M s`` (|s| = 1) and disk ``c + M (s, 0)`` (|s| <= 1): the exact box of the
  image of the unit sphere / disk, c_i +- sqrt(sum_j M_ij^2) (over j = 0, 1 for the disk);
* tube ``c + M (cos phi, sin phi, z)``: its exact box (:mod:`.tubes`).

At a leaf the (ray, primitive) pairs are split by kind and tested exactly in float64 (the
planar group's dual-basis test, the stable quadratic roots in the unit-sphere frame, the
disk's plane hit inside the unit circle, the tube's roots: each group's
``boxes``/``exact``/``normals``/``prims``, :mod:`.groups`, :mod:`.disks`, :mod:`.tubes`).
``closest`` then finishes each ray's hit with its kind's shape index, normal and primitive
index; ``occluded`` answers shadow queries (any hit
before ``t_max``) without finishing anything.

``kernels="numba"``: the same walks compiled (:mod:`.traverse_kernel`, over the arrays of
:mod:`.flat`, built here), one serial loop per ray, with the hit's t and normal computed there
(the formulas of the kinds' ``normals``) and its shape and primitive from tables; up to
``KERNEL_SMALL`` primitives over a BVH with smaller leaves, split by the SAH at every node.
Only the choice (a string) and the arrays are stored: the compiled functions are looked up on use
(:func:`vrlab.kernels.load_kernel`, loaded once per process; load them before forking workers),
so an ``Accel`` pickles to worker processes.
"""
from __future__ import annotations

import numpy as np

from ...kernels import load_kernel, resolve_kernels
from .bvh import BVH
from .disks import Disks
from .flat import flatten
from .groups import Quadrics

__all__ = ["Accel", "BACKENDS", "KERNEL_MODULE", "embree_used"]

#: the compiled traversal (``kernels="numba"``)
KERNEL_MODULE = "vrlab.render.accel.traverse_kernel"
#: up to this many primitives the compiled walk gets a BVH with leaves of at most 2, split by the
#: SAH at every node (1.2-1.5x faster walks on the built-in scenes); larger scenes keep the
#: default tree (as fast there, and the full SAH would double a 10^6-primitive build)
KERNEL_SMALL = 4096


BACKENDS = ("auto", "numpy", "embree")


def embree_used(backend: str, planar: bool) -> bool:
    """Whether a BVH with ``backend`` traces its planar primitives (if ``planar``) by Embree;
    ``ValueError`` for an unknown backend or ``"embree"`` without ``embreex``."""
    from .embree import embree_available

    if backend not in BACKENDS:
        raise ValueError(f"backend: expected one of {', '.join(BACKENDS)}, got {backend!r}")
    if backend == "embree" and not embree_available():
        raise ValueError("backend: 'embree' needs the embreex package (pip install embreex)")
    return planar and (backend == "embree" or (backend == "auto" and embree_available()))


class Accel:
    """A BVH over the primitives of ``planar`` (a list of :class:`Planar` groups, or with Embree
    also :class:`~vrlab.render.accel.pool.IndexedPlanar`),
    ``quadrics`` (a :class:`Quadrics` or None), ``disks`` (a :class:`Disks` or None) and
    ``tubes`` (a :class:`~vrlab.render.accel.tubes.Tubes` or None); see the module docstring.
    ``backend``: ``"numpy"`` (every kind in the NumPy BVH), ``"embree"`` (planar primitives
    through Embree, :mod:`vrlab.render.accel.embree`; the others in the NumPy BVH) or ``"auto"``
    (Embree where ``embreex`` imports).
    ``kernels``: the walk of the BVH, ``"numpy"`` (default), ``"numba"`` or ``"auto"`` (see
    :mod:`vrlab.kernels`; attribute ``kernels`` is the resolved choice)."""

    def __init__(self, planar: list, quadrics: Quadrics | None, disks: Disks | None, backend: str = "auto",
                 kernels: str = "numpy", tubes=None):
        from .embree import EmbreeTriangles

        self.kernels = resolve_kernels(kernels)

        use_embree = embree_used(backend, bool(planar))
        #: the planar groups traced by Embree (None: in the NumPy BVH)
        self.embree = EmbreeTriangles(planar) if use_embree else None
        self.kinds: list = [] if use_embree else list(planar)
        if quadrics is not None:
            self.kinds.append(quadrics)
        if disks is not None:
            self.kinds.append(disks)
        if tubes is not None:
            self.kinds.append(tubes)
        sizes = [len(k) for k in self.kinds]
        self.first = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        self.bvh = None
        if self.kinds:
            lo, hi = zip(*(k.boxes() for k in self.kinds))
            small = self.kernels == "numba" and self.first[-1] <= KERNEL_SMALL
            self.bvh = BVH.from_boxes(np.concatenate(lo), np.concatenate(hi), *((2, 0) if small else ()))
        #: the compiled walk's arrays (:class:`~vrlab.render.accel.flat.FlatBVH`), None for NumPy
        self.flat = None
        if self.kernels == "numba" and self.bvh is not None and self.first[-1] > 0:
            codes, rows = zip(*(k.kernel_rows() for k in self.kinds))
            self.flat = flatten(self.bvh, np.concatenate(codes), np.concatenate(rows))
            #: each global primitive's shape and index within its shape (the compiled walk's hits)
            self._shape_of = np.concatenate([k.shape for k in self.kinds]).astype(np.int64)
            self._prim_of = np.concatenate([k.prims(np.arange(len(k))) for k in self.kinds]).astype(np.int64)

    def __len__(self) -> int:
        return int(self.first[-1]) + (0 if self.embree is None else sum(len(g) for g in self.embree.planar))

    def _split(self, j: np.ndarray):
        """``(kind index, mask or None, local j)`` per kind with pairs among ``j``."""
        if len(self.kinds) == 1:
            yield 0, None, j
            return
        which = np.searchsorted(self.first, j, side="right") - 1
        for k in np.unique(which):
            m = which == k
            yield int(k), m, j[m] - self.first[k]

    def _test(self, o, d, t_min):
        """``test(i, j)``: the exact t of (ray i, global primitive j) pairs, kind by kind."""
        def test(i, j):
            t = np.empty(len(i))
            for k, m, jl in self._split(j):
                if m is None:
                    return self.kinds[k].exact(o, d, t_min, i, jl)
                t[m] = self.kinds[k].exact(o, d, t_min, i[m], jl)
            return t
        return test

    def closest(self, o, d, t_min, t, shape, normal, prim=None) -> None:
        """Update the closest hits ``t, shape, normal`` (and ``prim``) of rays in place (the NumPy
        BVH needs float64 rays; Embree's planar hits come first and keep ties); ``normal=None``:
        no normals (distance queries)."""
        if self.embree is not None:
            self.embree.closest(o, d, t_min, t, shape, normal, prim)
        if self.bvh is None:
            return
        o, d = o.astype(np.float64, copy=False), d.astype(np.float64, copy=False)
        if self.flat is not None:
            self._closest_compiled(o, d, t_min, t, shape, normal, prim)
            return
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
            if normal is not None:
                normal[rows] = kind.normals(o, d, rows, jl, th)
            if prim is not None:
                prim[rows] = kind.prims(jl)

    def occluded(self, o, d, t_min: float, t_max: np.ndarray) -> np.ndarray:
        """Whether each ray hits a primitive with ``t_min < t < t_max``."""
        if self.flat is not None and self.embree is None:         # the compiled walk, every ray
            hit = np.empty(len(o), bool)
            tm = np.ascontiguousarray(np.broadcast_to(np.asarray(t_max, np.float64), (len(o),)))
            self._compiled("occluded")(*self.flat, np.ascontiguousarray(o, np.float64),
                                       np.ascontiguousarray(d, np.float64), float(t_min), tm, hit)
            return hit
        hit = np.zeros(len(o), bool) if self.embree is None else self.embree.occluded(o, d, t_min, t_max)
        if self.bvh is not None:
            rest = np.flatnonzero(~hit)
            if len(rest):
                o64, d64 = o[rest].astype(np.float64), d[rest].astype(np.float64)
                tm = np.broadcast_to(t_max, (len(o),))[rest]
                if self.flat is not None:
                    out = np.zeros(len(rest), bool)
                    self._compiled("occluded")(*self.flat, o64, d64, float(t_min), tm.astype(np.float64), out)
                    hit[rest] = out
                else:
                    hit[rest] = self.bvh.occluded(o64, d64, t_min, tm, self._test(o64, d64, t_min))
        return hit

    @staticmethod
    def _compiled(name: str):
        """The compiled walk ``name`` (loaded once per process)."""
        return load_kernel(KERNEL_MODULE, name)

    def _closest_compiled(self, o, d, t_min, t, shape, normal, prim) -> None:
        """``closest`` by the compiled walk: t and the normal from the kernel, the shape and the
        primitive in its shape from the tables (where a hit beats ``t``: Embree's keeps ties)."""
        tb = np.array(t, np.float64)
        j = np.empty(len(o), np.int64)
        nrm = np.empty((len(o) if normal is not None else 0, 3))
        self._compiled("closest")(*self.flat, np.ascontiguousarray(o), np.ascontiguousarray(d), float(t_min), tb, j,
                                  normal is not None, nrm)
        i = np.flatnonzero(j >= 0)
        if len(i) == len(o):
            i = slice(None)
        jj = j[i]
        t[i] = tb[i]
        shape[i] = np.take(self._shape_of, jj)
        if normal is not None:
            normal[i] = nrm[i]
        if prim is not None:
            prim[i] = np.take(self._prim_of, jj)
