"""pbrt-v4's light bounds as arrays: union, importance at reference points, split cost.

A *light bounds* record (pbrt-v4: Pharr, Jakob & Humphreys, "Physically Based Rendering",
4th ed., section 12.6.3, ``LightBounds``) bounds one light or a set of lights:

* a box ``[lo, hi]`` holding every emitting point;
* a cone of emission normals: unit axis ``w``, half-angle theta_o (``cos_o``);
* theta_e (``cos_e``): how far beyond a normal the light emits (pi/2 for a Lambertian
  area light; a sphere or point light has theta_o = pi, theta_e = pi/2);
* ``phi``: the emitted power (a sum over the set), ``two``: emits on both sides.

Every function here works on :class:`Bounds` whose fields are arrays with one row per
record (no Python loop over records).

**Union** (pbrt's ``Union(LightBounds, LightBounds)``): a record with phi = 0 is empty and
gives the other; else boxes are joined, phi summed, ``two`` OR-ed, cos_e = min, and the
cones are joined (pbrt's ``DirectionCone`` ``Union``): with theta_a, theta_b the half-angles
and theta_d the angle between the axes, a cone inside the other (theta_d + theta_b <=
theta_a, capped at pi) is the union; else theta_o = (theta_a + theta_d + theta_b) / 2
(the whole sphere if >= pi or if the axes are (anti)parallel) and the axis is w_a turned
by theta_o - theta_a towards w_b.

**Importance** at a point p with normal n (n = 0: none), pbrt's ``Importance``: with pc the
box centre, d = max(|p - pc|, |hi - lo| / 2) (the distance, clamped at half the box
diagonal), wi = (p - pc)/|p - pc|, theta_w the angle between w and wi (|cos| for two-sided
lights), theta_b the half-angle of the cone from p around the box's bounding sphere (pi if
p is inside it), and x (-) y = max(x - y, 0)::

    cos theta' = cos(theta_w (-) theta_o (-) theta_b),     0 if cos theta' <= cos theta_e
    importance = phi cos theta' / d^2  [x cos(theta_i (-) theta_b), theta_i = angle(wi, +-n)]

(pbrt-v4's code clamps d^2 at half the diagonal *length*, not its square; we clamp the
distance, as the text describes.  Any clamp gives a valid distribution, as sample and pmf
use the same importance.)  The importance bounds the light from above: it is 0 only where
no light of the set can reach p (behind a one-sided emitter), so selecting by it is unbiased.

**Split cost** (pbrt's ``EvaluateCost``, the surface area orientation heuristic):
``phi M_omega K_r area(box)`` with theta_w = min(theta_o + theta_e, pi),
M_omega = 2 pi (1 - cos theta_o) + pi/2 (2 theta_w sin theta_o - cos(theta_o - 2 theta_w)
- 2 theta_o sin theta_o + cos theta_o) and K_r = (longest side of the node's box) / (its side
along the split axis); an empty record costs 0.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .._vec import dot, norm, scale

__all__ = ["Bounds", "Prepared", "cone_union", "union", "importance", "importance_prepared", "prepare",
           "split_cost", "empty_bounds"]


class Bounds(NamedTuple):
    """Light bounds, one row per record: ``lo, hi, w (m, 3)``, ``cos_o, cos_e, phi (m,)``,
    ``two (m,)`` bool."""
    lo: np.ndarray
    hi: np.ndarray
    w: np.ndarray
    cos_o: np.ndarray
    cos_e: np.ndarray
    phi: np.ndarray
    two: np.ndarray

    def take(self, idx) -> "Bounds":
        """The records ``idx`` (an index array or a boolean mask)."""
        return Bounds(*(f[idx] for f in self))

    def put(self, idx, other: "Bounds") -> None:
        """Overwrite the records ``idx`` with ``other`` (in place)."""
        for f, g in zip(self, other):
            f[idx] = g


def empty_bounds(shape) -> Bounds:
    """``shape`` empty records (phi = 0, an inverted box): the identity of :func:`union`."""
    shape = tuple(np.atleast_1d(shape))
    return Bounds(np.full(shape + (3,), np.inf), np.full(shape + (3,), -np.inf),
                  np.tile([0.0, 0.0, 1.0], shape + (1,)), np.ones(shape), np.ones(shape), np.zeros(shape),
                  np.zeros(shape, bool))


def _angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The angle between unit vectors, accurate near 0 and pi (asin of half a chord)."""
    near = 2 * np.arcsin(np.minimum(norm(b - a) / 2, 1.0))
    far = np.pi - 2 * np.arcsin(np.minimum(norm(a + b) / 2, 1.0))
    return np.where(dot(a, b) < 0, far, near)


def cone_union(wa, ca, wb, cb) -> tuple[np.ndarray, np.ndarray]:
    """``(w, cos)`` of the smallest-axis-turn cone holding the cones (wa, ca) and (wb, cb)
    (rows of unit axes and cosines of half-angles; see the module docstring)."""
    ta, tb = np.arccos(np.clip(ca, -1, 1)), np.arccos(np.clip(cb, -1, 1))
    td = _angle_between(wa, wb)
    a_holds = np.minimum(td + tb, np.pi) <= ta
    b_holds = ~a_holds & (np.minimum(td + ta, np.pi) <= tb)
    to = (ta + td + tb) / 2
    axis = np.cross(wa, wb)
    length = norm(axis)
    whole = ~a_holds & ~b_holds & ((to >= np.pi) | (length == 0))
    k = scale(axis, 1.0 / np.where(length > 0, length, 1.0))
    tr = to - ta
    w = scale(wa, np.cos(tr)) + scale(np.cross(k, wa), np.sin(tr))      # Rodrigues, k . wa = 0
    w = scale(w, 1.0 / np.maximum(norm(w), 1e-300))
    w = np.where(a_holds[:, None], wa, np.where(b_holds[:, None], wb, w))
    cos = np.where(a_holds, ca, np.where(b_holds, cb, np.where(whole, -1.0, np.cos(to))))
    w = np.where(whole[:, None], wa, w)
    return w, cos


def union(a: Bounds, b: Bounds) -> Bounds:
    """Row-wise union of two sets of records (an empty record, phi = 0, gives the other)."""
    w, cos_o = cone_union(a.w, a.cos_o, b.w, b.cos_o)
    out = Bounds(np.minimum(a.lo, b.lo), np.maximum(a.hi, b.hi), w, cos_o, np.minimum(a.cos_e, b.cos_e),
                 a.phi + b.phi, a.two | b.two)
    a_empty, b_empty = a.phi == 0, b.phi == 0
    return Bounds(*(np.where(_rows(b_empty, f), fa, np.where(_rows(a_empty, f), fb, f))
                    for fa, fb, f in zip(a, b, out)))


def _rows(mask, like):
    return mask[:, None] if like.ndim == 2 else mask


def _cos_sub(sin_a, cos_a, sin_b, cos_b):
    """cos(max(theta_a - theta_b, 0))."""
    return np.where(cos_a > cos_b, 1.0, cos_a * cos_b + sin_a * sin_b)


def _sin_sub(sin_a, cos_a, sin_b, cos_b):
    """sin(max(theta_a - theta_b, 0))."""
    return np.where(cos_a > cos_b, 0.0, sin_a * cos_b - cos_a * sin_b)


def _sin(cos):
    s = cos * cos
    np.subtract(1.0, s, out=s)
    np.maximum(s, 0.0, out=s)
    return np.sqrt(s, out=s)


class Prepared(NamedTuple):
    """Light bounds in the form :func:`importance_prepared` reads, fields component-first so
    that every array is contiguous: ``pc (3, *S)`` the box centre, ``w (3, *S)`` the cone axis,
    ``r2 (*S)`` the squared radius of the box's bounding sphere, ``cos_o, sin_o, cos_e, phi
    (*S)``, ``two (*S)`` bool or None (no record is two-sided)."""
    pc: np.ndarray
    w: np.ndarray
    r2: np.ndarray
    cos_o: np.ndarray
    sin_o: np.ndarray
    cos_e: np.ndarray
    phi: np.ndarray
    two: np.ndarray | None


def prepare(b: Bounds) -> Prepared:
    """The per-record constants of :func:`importance` (``two`` None if no record is two-sided)."""
    e = b.hi - b.lo
    return Prepared(np.ascontiguousarray(((b.lo + b.hi) / 2).T), np.ascontiguousarray(b.w.T), dot(e, e) / 4,
                    b.cos_o, _sin(b.cos_o), b.cos_e, b.phi, b.two if b.two.any() else None)


def importance(b: Bounds, p: np.ndarray, n: np.ndarray, floor2: float = 1e-300) -> np.ndarray:
    """pbrt-v4's importance of records ``b`` (m rows) at points ``p (m, 3)`` with normals
    ``n (m, 3)`` (unit, or 0 for none); ``floor2``: a lower bound on d^2 (a point light at
    p itself).  Empty records (phi = 0) have importance 0."""
    has_n = dot(n, n) > 0
    return importance_prepared(prepare(b), p.T, n.T if has_n.any() else None, floor2,
                               None if has_n.all() else has_n)


def importance_prepared(t: Prepared, p, n=None, floor2: float = 1e-300, has_n=None,
                        positive: bool = False) -> np.ndarray:
    """:func:`importance` of prepared records ``t`` (fields of shape S) at points ``p (3, ...)``
    (component-first, broadcasting against S) with unit normals ``n (3, ...)`` (None: no point
    has one; ``has_n``: which points have one, None: all).  ``positive``: every record has
    phi > 0 (skips that test).  The same operations in the same order for every element, so
    a record's importance at a point does not depend on what else is in the batch."""
    rx, ry, rz = p[0] - t.pc[0], p[1] - t.pc[1], p[2] - t.pc[2]
    dist2 = rx * rx
    dist2 += ry * ry
    dist2 += rz * rz
    d2 = np.maximum(dist2, t.r2)
    np.maximum(d2, floor2, out=d2)
    pos = dist2 > 0
    centre = not pos.all()                           # p at a box centre: wi is any unit vector
    inv = np.sqrt(np.where(pos, dist2, 1.0) if centre else dist2)
    np.divide(1.0, inv, out=inv)
    rx *= inv
    ry *= inv
    rz *= inv
    if centre:
        rx, ry, rz = (np.where(pos, r, wk) for r, wk in zip((rx, ry, rz), t.w))
    cos_w = t.w[0] * rx
    cos_w += t.w[1] * ry
    cos_w += t.w[2] * rz
    if t.two is not None:
        cos_w = np.where(t.two, np.abs(cos_w), cos_w)
    sin_w = _sin(cos_w)
    inside = dist2 < t.r2
    cos_b = np.divide(t.r2, d2, out=dist2)            # dist2 is not needed below
    np.subtract(1.0, cos_b, out=cos_b)
    np.maximum(cos_b, 0.0, out=cos_b)
    np.sqrt(cos_b, out=cos_b)
    cos_b = np.where(inside, -1.0, cos_b)             # (np.where: masked stores are slower)
    sin_b = _sin(cos_b)
    gt = cos_w > t.cos_o
    cos_x = cos_w * t.cos_o
    cos_x += sin_w * t.sin_o
    cos_x = np.where(gt, 1.0, cos_x)
    sin_x = sin_w * t.cos_o
    sin_x -= cos_w * t.sin_o
    sin_x = np.where(gt, 0.0, sin_x)
    cos_p = cos_x * cos_b
    cos_p += sin_x * sin_b
    cos_p = np.where(cos_x > cos_b, 1.0, cos_p)
    imp = t.phi * cos_p
    imp /= d2
    if n is not None:
        cos_i = rx * n[0]
        cos_i += ry * n[1]
        cos_i += rz * n[2]
        np.abs(cos_i, out=cos_i)
        f = _cos_sub(_sin(cos_i), cos_i, sin_b, cos_b)
        if has_n is None:
            imp *= f
        else:
            imp = np.where(has_n, imp * f, imp)
    ok = cos_p > t.cos_e
    if not positive:
        ok &= t.phi > 0
    np.maximum(imp, 0.0, out=imp)
    return np.where(ok, imp, 0.0)


def orientation_measure(cos_o: np.ndarray, cos_e: np.ndarray) -> np.ndarray:
    """pbrt's M_omega: the solid-angle measure of the directions a record can emit into."""
    to, te = np.arccos(np.clip(cos_o, -1, 1)), np.arccos(np.clip(cos_e, -1, 1))
    tw = np.minimum(to + te, np.pi)
    so = _sin(cos_o)
    return 2 * np.pi * (1 - cos_o) + np.pi / 2 * (2 * tw * so - np.cos(to - 2 * tw) - 2 * to * so + cos_o)


def split_cost(b: Bounds, kr: np.ndarray) -> np.ndarray:
    """pbrt's EvaluateCost: phi M_omega K_r area(box) (0 for an empty record)."""
    e = np.where((b.phi > 0)[..., None], b.hi - b.lo, 0.0)
    area = 2 * (e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0])
    return np.where(b.phi > 0, b.phi * orientation_measure(b.cos_o, b.cos_e) * kr * area, 0.0)
