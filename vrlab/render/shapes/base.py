"""The base of every shape element, and the primitive parts shapes hand to the ray tracer.

A shape (Mitsuba's ``<shape type=...>``) owns its parameters, its ``to_world`` (object to
world, Mitsuba's conventions: :mod:`vrlab.render.transforms`), its BSDF and optional area
emitter, and its behaviour:

* ``parts()``: what the ray tracer (:class:`vrlab.render.accel.geometry.SceneGeometry`)
  intersects, as primitive parts: :class:`Parallelograms`, :class:`Triangles` (world
  triangles; ``box`` marks the six faces of a parallelepiped for the slab test),
  :class:`IndexedTriangles` (a mesh: world vertices and faces, pooled with the scene's other
  triangles without a copy per triangle), :class:`Quadric`
  (an ellipsoid ``|M^-1 (x - c)| = 1``), :class:`DiskPart`, :class:`TubePart` (an open
  tube, the cylinder), or :class:`CustomPart` (the shape's own batched ``intersect(o, d,
  t_min) -> (t, normal)``).  The kernels for all but the last are vectorised over rays and
  primitives; a new shape type that is not one of them brings its own intersection;
* ``area``, ``center``, ``bound_radius``;
* ``surface()``: its area-sampling distribution from :mod:`vrlab.distributions` (the
  ``"light"`` technique converts it to solid angle), or None;
* ``sphere_light``: ``(center, radius)`` for spheres (sampled by the cone they subtend);
* ``cos_integral(ref, n)``: the closed-form unoccluded integral of cos over the
  directions that reach the shape, where one exists (control variates).

Geometric normals follow Mitsuba: ``M^-T`` of the object normal for analytic shapes,
the winding ``e1 x e2`` for meshes, outward for closed shapes, reversed by
``flip_normals``.
"""
from __future__ import annotations

from typing import Any, Callable, NamedTuple

import numpy as np

from ... import checks
from ..._vec import matvec3
from .. import transforms as tf
from ..registry import Element
from ..scene_checks import MAX_COORD, affine, matrix4

__all__ = ["CustomPart", "DiskPart", "IndexedTriangles", "Parallelograms", "Quadric", "Shape", "Triangles",
           "TubePart"]


class Parallelograms(NamedTuple):
    """``data (P, 4, 3)``: rows (corner, edge1, edge2, unit normal) of x = corner + s e1 + u e2."""
    data: np.ndarray


class Triangles(NamedTuple):
    """World triangles ``(T, 3, 3)`` (outward winding); with ``merge``, consecutive pairs that
    form a parallelogram are found and tested as one (then a hit's triangle index is that of
    the pair's first).  ``box``: the ``to_world`` of a cube whose six faces these are (tested
    by the slab test), else None."""
    tri: np.ndarray
    box: np.ndarray | None = None
    merge: bool = True


class IndexedTriangles(NamedTuple):
    """A triangle mesh in the world: ``vertices (V, 3)`` float64 world positions and ``faces
    (T, 3)`` integer indices in outward winding (triangle i is ``vertices[faces[i]]``);
    ``merge`` as for :class:`Triangles`."""
    vertices: np.ndarray
    faces: np.ndarray
    merge: bool = True


class Quadric(NamedTuple):
    """The ellipsoid ``x = center + M s``, ``|s| = 1``; ``sign`` -1 flips its normals."""
    center: np.ndarray
    matrix: np.ndarray
    sign: float


class DiskPart(NamedTuple):
    """The disk ``x = center + M (x, y, 0)``, ``x^2 + y^2 <= 1``, with unit ``normal``."""
    center: np.ndarray
    matrix: np.ndarray
    normal: np.ndarray


class TubePart(NamedTuple):
    """The open tube ``x = center + M (cos phi, sin phi, z)``, ``0 <= z <= 1`` (M's first two
    columns orthogonal and of equal length); ``sign`` -1 flips its normals."""
    center: np.ndarray
    matrix: np.ndarray
    sign: float


class CustomPart(NamedTuple):
    """A shape's own intersection: ``intersect(o (N, 3), d (N, 3), t_min) -> (t (N,), n (N, 3))``
    in float64, t = inf on a miss, n the unit geometric normal at the closest hit."""
    intersect: Callable


def shape_matrix(value: Any) -> np.ndarray:
    """``to_world`` checked: a finite affine 4x4 matrix within the float32 range."""
    m = matrix4(np.eye(4) if value is None else value, "to_world")
    affine(m, "to_world")
    return m


class Shape(Element):
    """Base of the shape elements (see the module docstring).

    Keyword arguments common to every shape: ``to_world`` (4x4, default identity),
    ``bsdf`` (a :class:`vrlab.render.bsdfs.BSDFModel`; default ``diffuse`` 0.5 as in
    Mitsuba, black for an emitter, which in Mitsuba reflects only through an explicit
    BSDF), ``emitter`` (an area emitter, or None) and ``flip_normals``.
    """

    kind = "shape"

    def __init__(self, *, to_world: Any = None, bsdf: Any = None, emitter: Any = None,
                 flip_normals: bool = False, id: str | None = None):
        from ..bsdfs import BSDFModel, Diffuse
        from ..emitters import Emitter

        self.to_world = shape_matrix(to_world)
        if bsdf is None:
            bsdf = Diffuse(0.0 if emitter is not None else 0.5)
        if not isinstance(bsdf, BSDFModel):
            raise TypeError(f"bsdf must be a vrlab.render BSDF element, got {checks.describe(bsdf)}")
        if emitter is not None and not isinstance(emitter, Emitter):
            raise TypeError(f"emitter must be a vrlab.render emitter element, got {checks.describe(emitter)}")
        if emitter is not None and not getattr(emitter, "is_area", False):
            raise ValueError(f"emitter: a shape carries only an area emitter, got {emitter.plugin_name!r}")
        self.bsdf, self.emitter = bsdf, emitter
        self.flip_normals = checks.flag(flip_normals, "flip_normals")
        self.id = id

    @staticmethod
    def common(p) -> dict:
        """The parameters every shape reads from a scene file (``to_world``, ``flip_normals``,
        one nested ``<bsdf>`` and one ``<emitter>``)."""
        return dict(to_world=p.transform("to_world"), flip_normals=p.bool("flip_normals", False),
                    bsdf=p.child("bsdf"), emitter=p.child("emitter"))

    @classmethod
    def from_props(cls, p) -> Shape:
        return cls(**cls.common(p))

    @property
    def type(self) -> str:
        """The Mitsuba plugin name (``"sphere"``, ...)."""
        return self.plugin_name

    #: whether a top-level element of this type is a shape of the scene itself
    top_level_shape = True

    def scene_shapes(self) -> list:
        """The shapes this element puts in a scene: itself (an ``instance`` its group's copies)."""
        return [self]

    def validate(self) -> None:
        """Check ``to_world``, the BSDF and the emitter again (after changes in place)."""
        self.to_world = shape_matrix(self.to_world)
        for name in ("bsdf", "emitter"):
            obj = getattr(self, name)
            if obj is not None:
                try:
                    obj.validate()
                except (TypeError, ValueError) as exc:
                    raise type(exc)(f"{name}: {exc}") from None

    # ------------------------------------------------------------------ geometry
    def parts(self) -> list:  # pragma: no cover - every shape overrides it
        raise NotImplementedError

    @property
    def center(self) -> np.ndarray:
        """World position of the object-space origin."""
        return self.to_world[:3, 3].copy()

    @property
    def bound_radius(self) -> float:
        """A radius about ``center`` that holds the whole shape."""
        return float(np.linalg.norm(self.to_world[:3, :3], 2) * np.sqrt(3.0))

    @property
    def area(self) -> float:  # pragma: no cover - every shape overrides it
        raise NotImplementedError

    def surface(self):
        """The area-sampling distribution of the shape (:mod:`vrlab.distributions`), or None."""
        return None

    def surface32(self):
        """A float32 copy of :meth:`surface` for float32 reference points, or None."""
        return None

    @property
    def sphere_light(self) -> tuple[np.ndarray, float] | None:
        """``(center, radius)`` of a sphere, sampled as a light by the cone it subtends; else None."""
        return None

    def cos_integral(self, ref: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(I, valid)``: int cos dw over the directions from ``ref`` (normal ``n``) that reach
        the shape, unoccluded, where a closed form applies (default: none)."""
        return np.zeros(len(ref)), np.zeros(len(ref), bool)

    def corners(self) -> np.ndarray | None:
        """World corners ``(k, 3)`` of a planar polygon (the light BVH bounds a planar light by
        them), or None (the default: no corners; the bounding sphere is used)."""
        return None

    #: whether :meth:`barycentrics` answers (triangle meshes): hits then keep their triangle
    has_barycentrics = False

    def barycentrics(self, p: np.ndarray, prim: np.ndarray) -> np.ndarray | None:
        """``(b1, b2)`` of world points ``p`` on triangles ``prim`` (meshes), or None (the default:
        a shape without triangles)."""
        return None

    has_shading_normals = False

    def uv(self, p: np.ndarray, prim: np.ndarray) -> np.ndarray:
        """Surface coordinates ``(N, 2)`` of world points ``p`` on the shape (primitives
        ``prim``), with Mitsuba's parametrisation of the shape (for textures)."""
        raise ValueError(f"uv: a {self.plugin_name!r} shape has no surface parametrisation for textures")

    def uv_derivatives(self, p: np.ndarray, prim: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(dp_du, dp_dv)`` ``(N, 3)``: the world tangents of the shape's ``uv`` at hits ``p``
        (unit geometric normals ``n``), what Mitsuba's ``SurfaceInteraction`` holds and its
        shading frame, normal maps and bump maps start from.

        Generic: central differences of :meth:`uv` along the tangent plane (steps of 1e-6 of
        ``bound_radius``, u and v differences taken modulo 1 across a seam), J = d(u, v) /
        d(t1, t2), and [dp_du dp_dv] = [t1 t2] J^-1; where J is singular (a pole, a disk's
        centre) the tangents of :func:`~vrlab.distributions.orthonormal_basis`.  Meshes
        override it with the exact per-triangle values."""
        from ...distributions.frames import orthonormal_basis

        p, n = np.asarray(p, np.float64), np.asarray(n, np.float64)
        t1, t2 = orthonormal_basis(n)
        h = 1e-6 * max(float(self.bound_radius), 1e-12)

        def diff(t):
            d = (self.uv(p + h * t, prim) - self.uv(p - h * t, prim))
            return (d - np.round(d)) / (2 * h)          # a seam of a periodic coordinate is a jump of 1

        a, b = diff(t1), diff(t2)                         # columns of J: d(u, v)/dt1, d(u, v)/dt2
        det = a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1]
        ok = np.abs(det) > 1e-12 * (np.abs(a).sum(-1) * np.abs(b).sum(-1) + 1e-300)
        det = np.where(ok, det, 1.0)
        # J^-1 = [[b_v, -b_u], [-a_v, a_u]] / det: dp_du = (b_v t1 - a_v t2) / det, dp_dv = (-b_u t1 + a_u t2) / det
        dp_du = (b[:, 1:2] * t1 - a[:, 1:2] * t2) / det[:, None]
        dp_dv = (-b[:, 0:1] * t1 + a[:, 0:1] * t2) / det[:, None]
        return np.where(ok[:, None], dp_du, t1), np.where(ok[:, None], dp_dv, t2)

    def local_points(self, p: np.ndarray) -> np.ndarray:
        """``to_world^-1`` of world points ``(N, 3)``."""
        m = self.to_world
        return matvec3(np.linalg.inv(m[:3, :3]), np.asarray(p, float) - m[:3, 3])

    def shading_normals(self, p: np.ndarray, n: np.ndarray, prim: np.ndarray) -> np.ndarray:
        """Unit shading normals at hits ``p`` (geometric normals ``n``, primitives ``prim``)
        where they differ from the geometric ones (``has_shading_normals``); default ``n``."""
        return n

    def triangles(self) -> np.ndarray:
        """World triangles ``(T, 3, 3)`` (meshes only)."""
        raise ValueError(f"triangles() is not available for a {self.plugin_name!r} shape")

    def normal_z(self) -> np.ndarray:
        """Unit world normal of the object's +z (planar shapes), flipped by ``flip_normals``."""
        n = tf.transform_normals(self.to_world, np.array([0.0, 0.0, 1.0]))
        n = n / np.linalg.norm(n)
        return -n if self.flip_normals else n

    def __repr__(self) -> str:
        em = "" if self.emitter is None else f", emitter={self.emitter!r}"
        return f"{type(self).__name__}(id={self.id!r}, bsdf={self.bsdf!r}{em})"


def check_world_points(points: np.ndarray, to_world: np.ndarray, name: str = "vertices") -> None:
    """World coordinates of ``points`` within +-MAX_COORD (float32 renderer)."""
    if len(points) == 0:
        return
    world = np.abs(points @ to_world[:3, :3].T + to_world[:3, 3]).max()
    if world > MAX_COORD:
        raise ValueError(f"{name}: world coordinates must lie within +-{MAX_COORD:g}, got {world:g}")
