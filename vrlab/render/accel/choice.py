"""Whether a scene's ray queries gain from the compiled BVH walk (what ``kernels="auto"``
asks before it imports numba).

The NumPy path tests small scenes *all pairs* in float32 (all-pairs cost at most
:data:`~vrlab.render.accel.geometry.DENSE_COST`, at most
:data:`~vrlab.render.accel.groups.DENSE_QUADRICS` quadrics: cornell_box, veach_mis) and gives
large planar sets to Embree; there the compiled walk is no faster (0.97-1.07x measured,
``benchmarks/bench_rays.py``), while importing numba and loading the kernels costs a process
about 0.5-1 s.  It pays where the NumPy path walks its own BVH or culls many quadrics: more
quadrics than the all-pairs limit (many_lights' 128 spheres: 1.4-1.6x per sample), or a scene
past the all-pairs cost with primitives that Embree does not take (quadrics, disks,
cylinders; every primitive without ``embreex``).
"""
from __future__ import annotations

from ..scene import Scene
from ..shapes.base import DiskPart, IndexedTriangles, Parallelograms, Quadric, Triangles, TubePart

__all__ = ["compiled_walk_pays"]


def compiled_walk_pays(scene: Scene, backend: str = "auto") -> bool:
    """Whether the compiled walk would trace some of ``scene``'s primitives faster than the
    NumPy path does (see the module docstring); counts the shapes' parts, builds nothing."""
    from .embree import embree_available
    from .geometry import EMBREE_FROM, all_pairs
    from .groups import DENSE_QUADRICS

    planar = quadrics = others = 0
    for s in scene.shapes:
        for part in s.parts():
            if isinstance(part, Parallelograms):
                planar += len(part.data)
            elif isinstance(part, (Triangles, IndexedTriangles)):   # pairs merge into parallelograms
                n = len(part.tri) if isinstance(part, Triangles) else len(part.faces)
                planar += (n + 1) // 2 if part.merge else n
            elif isinstance(part, Quadric):
                quadrics += 1
            elif isinstance(part, (DiskPart, TubePart)):
                others += 1
    if quadrics > DENSE_QUADRICS:
        return True
    if all_pairs(planar, quadrics, others):
        return False
    embree = backend in ("auto", "embree") and embree_available() and planar >= EMBREE_FROM
    return bool(quadrics or others or not embree)
