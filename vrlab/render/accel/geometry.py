"""Scene geometry as arrays, and vectorised closest-hit ray intersection.

``SceneGeometry(scene)`` collects every shape of a :class:`~vrlab.render.Scene` into
primitive groups:

* planar primitives ``x = v0 + s e1 + u e2``: parallelograms (``s, u`` in [0, 1]; a
  rectangle, each cube face and every pair of mesh triangles that forms one) and the
  remaining mesh triangles (``s, u >= 0``, ``s + u <= 1``; ``obj``).  The hit is the
  plane hit ``t = (v0 - o).n / d.n`` and ``s = (x - v0).a1``, ``u = (x - v0).a2`` with
  the dual basis ``a1 = (e2 x m)/|m|^2``, ``a2 = (m x e1)/|m|^2``, ``m = e1 x e2``
  (the same hits as Moller & Trumbore 1997, "Fast, minimum storage ray/triangle
  intersection");
* quadrics (``sphere``, ``ellipsoid``): the unit sphere under an affine map
  x = c + M s, intersected in the unit-sphere frame;
* disks: the unit disk in z = 0 under an affine map;
* tubes (``cylinder``): the open unit tube under an affine map (:mod:`vrlab.render.accel.tubes`).

``intersect(origin, direction)`` (rays ``(N, 3)``, directions need not be unit; t is in
units of their length) returns :class:`Hits` with the closest ``t > t_min`` per ray,
the index of the shape hit (into ``scene.shapes``; -1 for a miss), the hit point and
the unit geometric normal, which follows Mitsuba: ``M^-T`` of the object normal for
analytic shapes (rectangle, disk, sphere, ellipsoid), the winding ``e1 x e2`` for
meshes (cube, obj), outward for closed shapes, and reversed by ``flip_normals``.

Scenes whose all-pairs cost is small (planar primitives + disks + quadrics / 4 at most
``DENSE_COST`` = 256: every built-in scene) are tested *all pairs*: planar primitives and up
to 16 quadrics in float32 (:mod:`vrlab.render.accel.dense`: one contiguous row of rays per
primitive, about 2.5x NumPy's float64 rate), which picks the closest primitive of each ray;
the six faces of a cube are tested together, by the slab test in the cube's frame (Kay &
Kajiya 1986: a third of the work), and the face is found for the winners only.  Then t, the
point and the normal of the closest primitive are recomputed in float64, except for float32
rays (the renderer's), which keep the float32 t and get float32 points and normals.  Hit/miss
decisions are therefore float32-accurate, as in Mitsuba's scalar variants: rays should start
at least about 1e-5 (1 + |o|) off a surface (the renderer offsets them by that much), and
rays within float32 rounding of an edge or of a second surface may pick either.  More than
16 quadrics (many_lights' 128 spheres) take a conservative cull of all (ray, quadric) pairs
with thin matrix products ``[d, d.o] @ W`` (the discriminant of each bounding sphere, with a
tolerance that only admits extra pairs) followed by the stable quadratic roots of the
candidate pairs, in float64.  Larger scenes put every primitive (planar, quadric, disk) into
one BVH (:mod:`vrlab.render.accel.scene_bvh`, :mod:`vrlab.render.accel.bvh`: binned SAH, depth-first
traversal per ray, any-hit shadow queries through :meth:`SceneGeometry.occluded`), with
exact float64 decisions; cost per ray grows with the logarithm of the primitive count
(measured in ``benchmarks/bench_accel.py``: the crossover with all pairs is near 300
triangles or 2 000 spheres).  Among equal ``t`` (coincident surfaces; in the float32 pass,
t equal to about 1e-5 relative) the first group (parallelograms, triangles, quadrics,
disks) and then the lowest primitive wins (a parallelogram before a cube face).  Loops run
over primitive groups, blocks and tree steps, never over single rays.  The primitive groups
live in :mod:`vrlab.render.accel.groups`.

With ``kernels="numba"`` every scene, small or large, goes into the BVH, walked by the
compiled kernel (:mod:`vrlab.render.accel.traverse_kernel`: one serial loop per ray, the
same float64 tests and tie rule as the NumPy walk, its oracle); planar primitives go to
Embree only from ``EMBREE_FROM`` of them on (with ``backend="auto"``).  Decisions are then
float64 everywhere: a render differs from the NumPy path's float32 all-pairs decisions only
at rays within float32 rounding of a silhouette or an edge.

Building: the loop over shapes only collects their parts; every triangle of every mesh and
cube is pooled into one indexed set (:mod:`vrlab.render.accel.pool`: one vertex array, one
face array, parallelograms found by array operations over all triangles at once), so the
set-up costs a few passes over the triangles whatever the number of meshes.  When Embree
traces the triangles of a large scene they keep no per-triangle tables at all (a hit's
normal, plane, shape and triangle are computed for the hit rows, with the same bits).

Checked: ``scene`` is a ``Scene`` and ``only`` distinct shape indices in range;
``intersect``/``distance`` check the ray arrays' shapes (``(N, 3)`` or broadcastable
``(..., 3)``), ``t_min`` (finite, >= 0) and ``chunk`` (integer >= 1), not the ray values
(the renderer calls them per block): rays with NaN components miss.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from ... import checks
from ...kernels import resolve_kernels
from ..._vec import scale
from ..scene import Scene
from ..shapes.base import CustomPart, DiskPart, IndexedTriangles, Parallelograms, Quadric, Triangles, TubePart
from .disks import Disks
from .groups import Planar, Quadrics
from .pool import IndexedPlanar, TrianglePool, pool_triangles
from .scene_bvh import BACKENDS, Accel, embree_used
from .tubes import Tubes

__all__ = ["DEFAULT_RAY_CHUNK", "DENSE_COST", "EMBREE_FROM", "Hits", "SceneGeometry", "all_pairs"]

DEFAULT_RAY_CHUNK = 1 << 15   # rays per block
DENSE_COST = 256              # scenes up to this all-pairs cost (planar primitives + quadrics / 4) skip the BVH
#: with the compiled walk (``kernels="numba"``) and ``backend="auto"``, Embree takes the planar
#: primitives from this many on (below, the compiled walk is as fast or faster:
#: benchmarks/bench_rays.py, 0.8-1.6x Embree's closest-hit rays/s at 10^3 triangles, 0.4x at 10^5)
EMBREE_FROM = 1000


def all_pairs(planar: int, quadrics: int, others: int) -> bool:
    """Whether the NumPy path tests these all pairs: planar + others + quadrics / 4 <= DENSE_COST."""
    return planar + others + quadrics / 4 <= DENSE_COST


class Hits(NamedTuple):
    """Closest hits: ``t (N,)`` (inf on a miss), ``shape (N,)`` int (-1 on a miss),
    ``p (N, 3)`` hit points, ``n (N, 3)`` unit geometric normals (0 on a miss) and ``prim
    (N,)``, the primitive's index within its shape (a mesh's triangle; 0 for other shapes)."""

    t: np.ndarray
    shape: np.ndarray
    p: np.ndarray
    n: np.ndarray
    prim: np.ndarray | None = None




def _rays(origin, direction, t_min, chunk) -> tuple[np.ndarray, np.ndarray]:
    """O(1) checks of ``intersect``'s arguments (not the values: a hot path)."""
    o, d = np.asarray(origin), np.asarray(direction)
    for name, a in (("origin", o), ("direction", d)):
        if a.dtype.kind not in "fiu" or a.ndim == 0 or a.shape[-1] != 3:
            raise ValueError(f"{name} must be real numbers of shape (N, 3), got {a.dtype} {a.shape}")
    if o.size // 3 not in (1, d.size // 3) and d.size // 3 != 1:
        raise ValueError(f"origin and direction hold {o.size // 3} and {d.size // 3} rays; they must match "
                         "(or one of them be a single ray)")
    if type(t_min) is not float or not t_min >= 0:      # fast path for the renderer's 0.0
        checks.real(t_min, "t_min", low=0)
    if type(chunk) is not int or chunk < 1:
        checks.integer(chunk, "chunk", low=1)
    return o, d


def _para_group(parts: list, order: list, pool: TrianglePool | None):
    """``(data (P, 4, 3), shape, index in the shape)`` of every parallelogram: the parts'
    (rectangles, cube faces) and the pool's pairs of mesh triangles, in the order of their parts."""
    counts = np.array([len(d) for _, d in parts], np.int64)
    data = np.concatenate([d for _, d in parts]) if parts else np.zeros((0, 4, 3))
    shape = np.repeat(np.array([k for k, _ in parts], np.int64), counts)
    local = np.arange(len(data)) - np.repeat(np.cumsum(counts) - counts, counts)
    if pool is None or not len(pool.para):
        return data, shape, local
    key = np.concatenate([np.repeat(np.asarray(order, np.int64), counts), pool.para_part])
    s = np.argsort(key, kind="stable")
    return (np.concatenate([data, pool.para])[s], np.concatenate([shape, pool.para_shape])[s],
            np.concatenate([local, pool.para_local])[s])


def _para_extent(parts: list) -> float:
    """The largest coordinate of the parallelogram parts' corners."""
    if not parts:
        return 0.0
    d = np.concatenate([d for _, d in parts])
    c, e1, e2 = d[:, 0], d[:, 1], d[:, 2]
    return float(max(np.max(np.abs(x)) for x in (c, c + e1, c + e2, c + e1 + e2)))


def _pool_extent(pool: TrianglePool | None) -> float:
    """The largest coordinate of the vertices the pool's faces use."""
    if pool is None:
        return 0.0
    used = np.zeros(len(pool.vertices), bool)
    used[pool.faces.ravel()] = True
    return float(np.max(np.abs(pool.vertices).max(axis=1), where=used, initial=0.0))


class SceneGeometry:
    """All shapes of ``scene`` as arrays of primitives (see the module docstring), or only
    the shapes ``only`` (indices into ``scene.shapes``, which the hits report);
    ``track_prim=False``: hits report primitive 0 (no mesh needs its triangle index);
    ``unmerged``: shapes whose triangles are never paired into parallelograms (their hits
    report the exact triangle: the light BVH's per-triangle mesh lights); ``backend``: how a
    large scene's BVH traces planar primitives (:data:`~vrlab.render.accel.scene_bvh.BACKENDS`:
    ``"auto"`` Embree where ``embreex`` is installed, else NumPy); ``kernels``: ``"numpy"``
    (default), ``"numba"`` or ``"auto"`` (:mod:`vrlab.kernels`): with numba every scene goes
    into the BVH, walked by the compiled kernel (see the module docstring)."""

    def __init__(self, scene: Scene, only: Sequence[int] | None = None, track_prim: bool = True,
                 unmerged: Sequence[int] = (), backend: str = "auto", kernels: str = "numpy"):
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a vrlab.render.Scene, got {type(scene).__name__}")
        checks.choice(backend, "backend", BACKENDS)
        #: the kernels of the ray queries ("numpy" or "numba", resolved)
        self.kernels = resolve_kernels(kernels)
        if only is not None:
            idx = np.asarray(only)
            if idx.ndim != 1 or (idx.size and idx.dtype.kind not in "iu"):
                raise TypeError(f"only must be a list of shape indices (integers), got {only!r}")
            if idx.size and (idx.min() < 0 or idx.max() >= len(scene.shapes) or len(set(idx.tolist())) < idx.size):
                raise ValueError(f"only: shape indices must be distinct and in [0, {len(scene.shapes) - 1}], "
                                 f"got {idx.tolist()}")
        #: whether ``intersect`` reports each hit's primitive (meshes' triangles: smooth normals, textures)
        self.track_prim = bool(track_prim)
        # collect the parts (references only: the arrays are pooled below, for every shape at once)
        para_parts, tri_parts, quad, disk, tube, custom, centers, boxes = [], [], [], [], [], [], [np.zeros(3)], {}
        para_order, tri_order = [], []
        self.n_shapes = len(scene.shapes) if only is None else len(only)
        radii = []
        unmerged = {int(k) for k in unmerged}
        for k in range(len(scene.shapes)) if only is None else [int(i) for i in only]:
            s = scene.shapes[k]
            centers.append(s.center)
            for part in s.parts():
                if isinstance(part, Parallelograms):
                    para_parts.append((k, part.data))
                    para_order.append(len(para_order) + len(tri_order))
                elif isinstance(part, (Triangles, IndexedTriangles)):
                    if isinstance(part, Triangles):
                        v, f = part.tri.reshape(-1, 3), np.arange(3 * len(part.tri)).reshape(-1, 3)
                        if part.box is not None:
                            boxes[k] = part.box
                    else:
                        v, f = part.vertices, part.faces
                    tri_parts.append((k, v, f, part.merge and k not in unmerged))
                    tri_order.append(len(para_order) + len(tri_order))
                elif isinstance(part, Quadric):
                    quad.append((k, part.center, np.linalg.inv(part.matrix), part.sign))
                    radii.append(np.linalg.norm(part.matrix, 2))
                elif isinstance(part, DiskPart):
                    disk.append((k, part.center, np.linalg.inv(part.matrix), part.normal))
                    radii.append(np.linalg.norm(part.matrix, 2))
                elif isinstance(part, TubePart):
                    tube.append((k, part.center, np.linalg.inv(part.matrix), part.sign))
                    radii.append(s.bound_radius)
                elif isinstance(part, CustomPart):
                    custom.append((k, part.intersect))
                    radii.append(s.bound_radius)
                else:
                    raise TypeError(f"shapes[{k}].parts(): unknown primitive part {type(part).__name__}; "
                                    "use the parts of vrlab.render.shapes.base")
        pool = pool_triangles(tri_parts, tri_order) if tri_parts else None
        para = _para_group(para_parts, para_order, pool)
        self._n_tri = 2 * sum(len(d) for _, d in para_parts) + (int(pool.start[-1]) if pool else 0)
        dense = all_pairs(len(para[0]) + (pool.n_group if pool else 0), len(quad), len(disk) + len(tube)) \
            and self.kernels == "numpy"
        n_planar = len(para[0]) + (pool.n_group if pool else 0)
        if self.kernels == "numba" and backend == "auto" and n_planar < EMBREE_FROM:
            backend = "numpy"            # the compiled walk is faster than Embree's calls here
        embree = not dense and embree_used(backend, n_planar > 0)
        self.planar = []
        if len(para[0]):
            data, ids, local = para
            self.planar.append(Planar(data[:, 0], data[:, 1], data[:, 2], data[:, 3], ids, True, boxes, local,
                                      dense=dense))
        if embree and pool is not None:   # Embree traces them: no per-triangle tables
            pool.drop_degenerate()
        if pool is not None and pool.n_group:
            if embree:
                self.planar.append(IndexedPlanar(pool))
            else:
                self.planar.append(IndexedPlanar(pool).planar(dense))
        self.quadrics = Quadrics(quad) if quad else None
        self.disks = Disks(disk) if disk else None
        self.tubes = Tubes(tube) if tube else None
        self.custom = custom
        #: the BVH over every primitive (:mod:`vrlab.render.accel.scene_bvh`) of scenes whose all-pairs
        #: cost exceeds ``DENSE_COST``; None: the all-pairs kernels
        self.accel = None if dense else Accel(self.planar, self.quadrics, self.disks, backend, self.kernels,
                                                   tubes=self.tubes)
        #: a length scale of the scene (for ray offsets): the largest coordinate of a shape's
        #: centre, a parallelogram's corner or a triangle's vertex, plus the largest radius
        extent = max(float(np.max(np.abs(np.vstack(centers)))), _para_extent(para_parts), _pool_extent(pool))
        self.scale = extent + max(radii, default=0.0)

    def build(self) -> None:
        """Build now what is otherwise built on first use in each process (Embree's scene,
        :meth:`~vrlab.render.accel.embree.EmbreeTriangles.build`), so that processes forked
        later inherit it."""
        if self.accel is not None and self.accel.embree is not None:
            self.accel.embree.build()

    @property
    def n_triangles(self) -> int:
        """Number of triangles of the mesh shapes (rectangle 2, cube 12, obj)."""
        return self._n_tri

    # ------------------------------------------------------------------ intersection
    def intersect(self, origin: np.ndarray, direction: np.ndarray, t_min: float = 0.0,
                  chunk: int = DEFAULT_RAY_CHUNK) -> Hits:
        """Closest hits with ``t > t_min`` of the rays ``origin + t direction`` (``(N, 3)``).

        float32 rays give float32 points and normals (t is float64 either way; it and the
        normal are computed in float64 from the float32 ray), anything else float64."""
        o, d = _rays(origin, direction, t_min, chunk)
        dt = np.float32 if o.dtype == d.dtype == np.float32 else np.float64
        o, d = np.broadcast_arrays(o.astype(dt, copy=False).reshape(-1, 3), d.astype(dt, copy=False).reshape(-1, 3))
        n_rays = len(d)
        t = np.full(n_rays, np.inf)
        shape = np.full(n_rays, -1, dtype=np.int64)
        normal = np.zeros((n_rays, 3), dt)
        prim = np.zeros(n_rays, np.int64)
        for a in range(0, n_rays, chunk):
            sl = slice(a, min(a + chunk, n_rays))
            self._closest(np.ascontiguousarray(o[sl]), np.ascontiguousarray(d[sl]), t_min,
                          t[sl], shape[sl], normal[sl], prim=prim[sl] if self.track_prim else None)
        hit = shape >= 0
        p = scale(d, np.where(hit, t, 0.0).astype(dt, copy=False))
        p += o
        return Hits(t, shape, p if hit.all() else scale(p, hit), normal, prim)

    def distance(self, origin: np.ndarray, direction: np.ndarray, t_min: float = 0.0,
                 chunk: int = DEFAULT_RAY_CHUNK, with_shape: bool = False):
        """t of the closest hit of each ray (inf on a miss), and with ``with_shape`` the
        shape hit (-1 on a miss), without the point or normal: for float32 rays the
        float32 pass's t (no finish), else ``intersect()``'s."""
        o, d = _rays(origin, direction, t_min, chunk)
        if not o.dtype == d.dtype == np.float32:
            h = self.intersect(o, d, t_min, chunk)
            return (h.t, h.shape) if with_shape else h.t
        o, d = np.broadcast_arrays(o.reshape(-1, 3), d.reshape(-1, 3))
        n_rays = len(d)
        t = np.full(n_rays, np.inf)
        shape, normal = np.full(n_rays, -1, dtype=np.int64), np.zeros((n_rays, 3), np.float32)
        for a in range(0, n_rays, chunk):
            sl = slice(a, min(a + chunk, n_rays))
            self._closest(np.ascontiguousarray(o[sl]), np.ascontiguousarray(d[sl]), t_min,
                          t[sl], shape[sl], normal[sl], finish=False, shapes=with_shape)
        return (t, shape) if with_shape else t

    def occluded(self, origin: np.ndarray, direction: np.ndarray, t_max: np.ndarray, t_min: float = 0.0,
                 chunk: int = DEFAULT_RAY_CHUNK) -> np.ndarray:
        """Whether each ray hits something with ``t_min < t < t_max`` (shadow rays).  Through
        the BVH a ray stops at its first hit (any hit); otherwise ``distance() < t_max``."""
        o, d = _rays(origin, direction, t_min, chunk)
        if self.accel is None:
            return self.distance(o, d, t_min, chunk) < t_max
        o, d = np.broadcast_arrays(o.reshape(-1, 3), d.reshape(-1, 3))
        t_max = np.broadcast_to(np.asarray(t_max, float), (len(d),))
        out = np.zeros(len(d), bool)
        for a in range(0, len(d), chunk):
            sl = slice(a, min(a + chunk, len(d)))
            hit = self.accel.occluded(o[sl], d[sl], t_min, t_max[sl])
            if self.custom:
                o64, d64 = o[sl].astype(np.float64), d[sl].astype(np.float64)
                t = np.full(len(o64), np.inf)
                self._custom(o64, d64, t_min, t, np.zeros(len(t), np.int64), np.zeros((len(t), 3)), None)
                hit |= t < t_max[sl]
            out[sl] = hit
        return out

    def _closest(self, o, d, t_min, t, shape, normal, finish: bool = True, shapes: bool = True, prim=None):
        """Update ``t``, ``shape``, ``normal`` (views of one chunk) in place; with
        ``finish=False`` (float32 rays) the dense groups only set t and, with ``shapes``,
        the shape."""
        if self.accel is not None:
            self.accel.closest(o, d, t_min, t, shape, normal if finish else None, prim)
            if self.custom:
                self._custom(o.astype(np.float64, copy=False), d.astype(np.float64, copy=False), t_min, t, shape,
                             normal, prim)
            return
        index = finish or shapes
        dense = list(self.planar)
        if self.quadrics is not None and self.quadrics.use_dense:
            dense.append(self.quadrics)
        if dense:                      # float32 all pairs: the winner, then its float64 hit
            o4 = np.ones((4, len(o)), np.float32)             # [o; 1] and d as float32 rows
            o4[:3] = o.T
            rows32 = (o4, np.ascontiguousarray(d.T, dtype=np.float32))
            best = None
            for k, g in enumerate(dense):
                tg, jg = g.dense(*rows32, t_min, index)
                if not index:
                    best = tg if best is None else np.minimum(best, tg)
                elif k == 0:
                    best, j_best, group = tg, jg, np.where(tg < np.inf, 0, -1)
                else:                                 # strict: the earlier group keeps ties
                    closer = tg < best
                    best, j_best, group = np.where(closer, tg, best), np.where(closer, jg, j_best), np.where(closer, k, group)
            if not finish:
                t[...] = best
                if shapes:
                    for k, g in enumerate(dense):
                        r = np.flatnonzero(group == k) if len(dense) > 1 else slice(None)
                        shape[r] = g.shape_of(j_best[r])
                    shape[best == np.inf] = -1
            for k, g in enumerate(dense if finish else []):
                r = np.flatnonzero(group == k)
                if len(r) and o.dtype == np.float32:       # float32 rays: float32 hits
                    g.finish32(o, d, t_min, r, j_best[r], best[r], t, shape, normal, prim)
                elif len(r):
                    g.finish(o, d, t_min, r, j_best[r], best[r], t, shape, normal, prim)
        cull = self.quadrics is not None and not self.quadrics.use_dense
        if cull or self.disks is not None or self.tubes is not None or self.custom:   # float64 decisions
            o, d = o.astype(np.float64, copy=False), d.astype(np.float64, copy=False)
        if cull:
            self.quadrics.closest(o, d, t_min, t, shape, normal, prim)
        if self.disks is not None:
            self.disks.closest(o, d, t_min, t, shape, normal, prim)
        if self.tubes is not None:
            self.tubes.closest(o, d, t_min, t, shape, normal, prim)
        self._custom(o, d, t_min, t, shape, normal, prim)

    def _custom(self, o, d, t_min, t, shape, normal, prim) -> None:
        """Fold the custom parts' hits (their own ``intersect``) into the closest hits."""
        for k, intersect in self.custom:
            tt, nn = intersect(o, d, t_min)
            better = tt < t
            t[better] = tt[better]
            shape[better] = k
            normal[better] = nn[better]
            if prim is not None:
                prim[better] = 0
