"""The scene BVH flattened for the compiled traversal (:mod:`.traverse_kernel`), built with NumPy.

The compiled closest-hit and any-hit walks read one :class:`FlatBVH`: the
:class:`~vrlab.render.accel.bvh.BVH`'s nodes with each inner node holding the boxes of its
two children (one row fetch gives both slab tests), and every primitive of every kind as
one row of 16 float64 numbers in leaf order (a leaf's primitives are contiguous), with a
kind code and its global index (the index :class:`~vrlab.render.accel.scene_bvh.Accel`
numbers primitives by: kind after kind).  Rows per kind (the data the NumPy pair tests use,
so that both paths compute the same numbers):

* ``PARA``, ``TRI`` (parallelograms, triangles): ``v0, n, a1, a2``, the plane point, unit
  normal and dual basis of :class:`~vrlab.render.accel.groups.Planar` (its ``packed``), then
  its normal (the group's ``normal`` table) in columns 12-14;
* ``SPHERE``: ``c, 1 / r`` (a group of spheres only: the NumPy test scales by 1 / r), the
  normals' sign in column 15;
* ``QUADRIC``: ``c, M^-1`` (row-major): the unit-sphere frame of an ellipsoid; sign in 15;
* ``DISK``: ``c, M^-1``: the disk frame (the unit disk in z = 0); the normal in 12-14;
* ``TUBE``: ``c, M^-1``: the frame of an open tube (a cylinder, :mod:`.tubes`); sign in 15.

Nothing here imports Numba: the arrays are built where the geometry is built and pickle with
it; the kernel module is loaded where rays are traced (:mod:`vrlab.kernels`).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["DISK", "FlatBVH", "PARA", "QUADRIC", "SPHERE", "TRI", "TUBE", "flatten"]

PARA, TRI, SPHERE, QUADRIC, DISK, TUBE = 0, 1, 2, 3, 4, 5       # kind codes of the primitive rows


class FlatBVH(NamedTuple):
    """The kernel's arrays (see the module docstring): ``root (1, 6)`` the root's box ``lo, hi``;
    per node ``kids (M, 12)`` the boxes ``lo, hi`` of its left and right child (inner nodes),
    ``child (M, 2)`` the left and right child (inner) or ``(first row, -)`` (leaf) and
    ``count (M,)`` the leaf's primitive count (0: inner); per primitive row in leaf order
    ``kind (P,)``, ``prim (P, 16)`` and ``gid (P,)`` the global index; ``depth``, the tree's
    levels (stack size)."""

    root: np.ndarray
    kids: np.ndarray
    child: np.ndarray
    count: np.ndarray
    kind: np.ndarray
    prim: np.ndarray
    gid: np.ndarray
    depth: int


def flatten(bvh, kind: np.ndarray, prim: np.ndarray) -> FlatBVH:
    """The :class:`FlatBVH` of ``bvh`` over primitives with codes ``kind (P,)`` and rows
    ``prim (P, 16)`` in global order."""
    lo, hi = bvh.lo, bvh.hi
    inner = bvh.count == 0
    left, right = np.where(inner, bvh.left, 0), np.where(inner, bvh.right, 0)
    kids = np.concatenate([lo[left], hi[left], lo[right], hi[right]], axis=1)
    kids[~inner] = 0.0
    child = np.stack([np.where(inner, bvh.left, bvh.start), np.where(inner, bvh.right, 0)], axis=1)
    order = np.asarray(bvh.order, np.int64)
    return FlatBVH(np.concatenate([lo[0], hi[0]])[None], np.ascontiguousarray(kids),
                   np.ascontiguousarray(child, np.int64), np.ascontiguousarray(bvh.count, np.int64),
                   np.ascontiguousarray(kind[order], np.int64), np.ascontiguousarray(prim[order], np.float64), order,
                   int(bvh.depth))
