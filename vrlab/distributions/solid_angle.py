"""Directions towards light surfaces, with solid-angle densities.

* ``SolidAngleFromArea(surface, ref)``: w = normalize(y - ref) for y ~ surface; in solid
  angle p(w) = sum over *all* hits y_k of the ray (ref, w) of p_A(y_k) |y_k - ref|^2 /
  |cos theta_k|.  A closed (two-sided) light is met twice by one direction, and both
  points could have produced w, so both terms count (Russian lecture 4, "two-sided lights").
* ``SphereCone(center, r, ref)``: directions uniform in the cone subtended by a sphere,
  cos_max = sqrt(1 - r^2/d^2), p = 1 / (2 pi (1 - cos_max)) (PBRT 3rd ed. 14.2.2).
"""
from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from .._vec import dot, norm, scale
from .base import (ArgumentTypeError, Distribution, as_float, as_points, as_uniforms, check_broadcast, finite_points,
                   positive_float)
from .frames import Frame
from ._sphere_chart import TWO_PI, _sphere_to_u, _unit   # not .surfaces, which imports this module


class LightSample(NamedTuple):
    """A direction sample towards a light: unit ``w``, the point ``y`` that produced it,
    ``dist = |y - ref|`` and the solid-angle ``pdf`` of ``w`` (all hits counted)."""

    w: np.ndarray
    y: np.ndarray
    dist: np.ndarray
    pdf: np.ndarray


class SolidAngleFromArea(Distribution):
    """Directions from reference points ``ref`` to area samples of ``surface``.

    sample(u) = normalize(y - ref), y = surface.sample(u).  Measure: solid angle,

        p(w) = sum_k p_A(y_k) |y_k - ref|^2 / |cos theta_k|,  cos theta_k = -w . n(y_k),

    over *every* hit y_k of the ray (ref, w) with the surface (``surface.intersect``).
    A closed light seen from outside is crossed twice, and a sample on either point
    produces the same w, so both terms belong to p (Russian lecture 4; Shirley et al.
    1996).  Dropping the far hit leaves a pdf that integrates to the visible fraction
    of the light's sampling mass (1/2 - r/(2d) for a sphere at distance d), not to 1.

    ``ref`` (shape (..., 3)) broadcasts against the leading shape of the samples: for
    per-pixel points ``(*batch, 3)`` and u ``(*batch, n, 2)`` pass ``ref[..., None, :]``.

    For rendering: the estimator of int f(w) dw over the directions that hit the light
    is f(w) / p(w); radiance along w comes from the *first* hit (the sampled y may be
    the far point, hidden by the light itself), so visibility should be tested to the
    first hit, ``surface.intersect(ref, w)[..., 0]``.

    Checked: ``surface`` has ``sample``, ``pdf``, ``normal`` and ``intersect``
    (``ArgumentTypeError``, a ``TypeError`` and ``ValueError``); ``ref`` finite (..., 3).
    """

    dim_x = 3
    measure = "solid angle"

    def __init__(self, surface: "Surface", ref: np.ndarray):  # noqa: F821 (a vrlab.distributions.surfaces.Surface)
        for attr in ("sample", "pdf", "normal", "intersect"):
            if not callable(getattr(surface, attr, None)):
                raise ArgumentTypeError(f"surface: needs a {attr}() method, got {type(surface).__name__}")
        self.surface = surface
        self.ref = finite_points(ref, 3, "ref")
        self.dim_u = getattr(surface, "dim_u", 2)

    def _directions(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        y = self.surface.sample(check_broadcast(as_uniforms(u, self.dim_u), "u", self.ref.shape[:-1], "ref"))
        v = y - self.ref
        dist = norm(v)
        return scale(v, 1.0 / np.where(dist > 0, dist, 1.0)), y, dist

    def _term(self, y: np.ndarray, w: np.ndarray, dist2: np.ndarray) -> np.ndarray:
        """p_A(y) |y - ref|^2 / |cos theta| of points ``y`` met along unit ``w`` (0 at grazing)."""
        cos = np.abs(dot(self.surface.normal(y), w))
        return np.where(cos > 0, self.surface.pdf(y) * dist2 / np.where(cos > 0, cos, 1.0), 0.0)

    def sample(self, u: np.ndarray) -> np.ndarray:
        return self._directions(u)[0]

    def pdf(self, w: np.ndarray) -> np.ndarray:
        w = _unit(check_broadcast(as_points(w, 3, "w"), "w", self.ref.shape[:-1], "ref"))
        t = self.surface.intersect(self.ref, w)            # (..., K)
        hit = np.isfinite(t)
        tt = np.where(hit, t, 0.0)
        y = self.ref[..., None, :] + tt[..., None] * w[..., None, :]
        return np.sum(np.where(hit, self._term(y, w[..., None, :], tt * tt), 0.0), -1)

    def pdf_at(self, y: np.ndarray, w: np.ndarray) -> np.ndarray:
        """``pdf(w)`` for a surface met once per direction (``max_hits == 1``), given the
        point ``y`` where the ray (ref, w) meets it: no intersection needed."""
        y, w = as_points(y, 3, "y"), as_points(w, 3, "w")
        v = y - self.ref
        return self._term(y, scale(w, 1.0 / norm(w)), dot(v, v))

    def sample_pdf(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s = self.sample_point(u)
        return s.w, s.pdf

    def sample_point(self, u: np.ndarray) -> LightSample:
        """``LightSample(w, y, dist, pdf)``: direction, sampled light point, its distance
        from ``ref`` and the solid-angle pdf of ``w`` (sum over all hits; for surfaces met
        once per direction, the sampled point's own term)."""
        w, y, dist = self._directions(u)
        if getattr(self.surface, "max_hits", 2) == 1:
            return LightSample(w, y, dist, self._term(y, w, dist * dist))
        return LightSample(w, y, dist, self.pdf(w))

    def _repr_fields(self):
        return {"surface": self.surface, "ref_shape": self.ref.shape}


class SphereCone(Distribution):
    """Directions uniform in the cone a sphere (center, radius) subtends from ``ref``.

    d = |center - ref|, axis = (center - ref)/d, cos_max = sqrt(1 - r^2/d^2), computed as
    1 - cos_max = (r^2/d^2) / (1 + cos_max) to keep small cones accurate; z = 1 -
    u1 (1 - cos_max), phi = 2 pi u2 about the axis; p = 1 / (2 pi (1 - cos_max)) for
    w . axis >= cos_max, else 0 (measure: solid angle; Pharr et al., PBRT 3rd ed.
    14.2.2).  Every direction in the cone hits the sphere, and only those do.
    ``ref`` inside (or on) the sphere: the cone is the whole sphere of directions
    (cos_max = -1, p = 1/(4 pi)).  ``ref`` (..., 3) broadcasts like ``Oriented.axis``:
    pass ``ref[..., None, :]`` for u of shape (*batch, n, 2).  ``center`` and ``radius``
    may also be arrays broadcasting with ``ref`` (one sphere per reference point: the
    renderer samples all sphere lights of a scene in one call).
    Checked: ``center`` and ``ref`` finite (..., 3), ``radius`` finite > 0, and their
    leading shapes broadcast.
    """

    dim_u = 2
    dim_x = 3
    measure = "solid angle"

    def __init__(self, center: Any, radius: Any, ref: np.ndarray):
        self.center = finite_points(center, 3, "center")
        r = as_float(radius, "radius")
        if r.ndim == 0:
            self.radius = positive_float(r, "radius")
            r_shape = ()
        else:
            if not (np.all(np.isfinite(r)) and np.all(r > 0)):
                raise ValueError("radius must be finite and > 0 (a number or an array broadcasting with ref)")
            self.radius, r_shape = r, r.shape
        self.ref = finite_points(ref, 3, "ref")
        try:
            np.broadcast_shapes(self.center.shape[:-1], r_shape, self.ref.shape[:-1])
        except ValueError:
            raise ValueError(f"center, radius, ref: shapes {self.center.shape}, {r_shape}, {self.ref.shape} "
                             "do not broadcast (one center and radius per reference point, or one for all)") from None
        v = self.center - self.ref
        d = norm(v)
        self.inside = d <= self.radius
        safe = np.where(d > 0, d, 1.0)
        self.axis = scale(v, 1.0 / safe)
        if not np.all(d > 0):
            self.axis = np.where((d > 0)[..., None], self.axis, np.array([0.0, 0.0, 1.0], d.dtype))
        self.one_minus_cos = self.cone_size(d, self.radius)
        self.cos_max = 1.0 - self.one_minus_cos
        self.solid_angle = TWO_PI * self.one_minus_cos

    @staticmethod
    def cone_size(d: np.ndarray, radius: Any) -> np.ndarray:
        """1 - cos_max of the cone of a sphere of ``radius`` seen from distance ``d``:
        (r/d)^2 / (1 + sqrt(1 - (r/d)^2)) (no cancellation for small cones), 2 from inside
        (d <= r: the whole sphere of directions).  The solid angle is 2 pi times it."""
        inside = d <= radius
        ratio2 = np.where(inside, 1.0, (radius / np.where(d > 0, d, 1.0)) ** 2)
        return np.where(inside, 2.0, ratio2 / (1.0 + np.sqrt(1.0 - ratio2)))

    def sample(self, u: np.ndarray) -> np.ndarray:
        u = check_broadcast(as_uniforms(u, 2), "u", np.shape(self.one_minus_cos), "ref")
        omz = u[..., 0] * self.one_minus_cos                # 1 - z, exact for small cones
        sin = np.sqrt(np.clip(omz * (2.0 - omz), 0.0, None))
        phi = TWO_PI * u[..., 1]
        local = np.stack([sin * np.cos(phi), sin * np.sin(phi), 1.0 - omz], -1)
        return Frame._trusted(self.axis).to_world(local)

    def _one_minus_cos(self, w: np.ndarray) -> np.ndarray:
        diff = w - self.axis                                # |w - a|^2 / 2 = 1 - w.a
        return 0.5 * dot(diff, diff)

    def pdf(self, w: np.ndarray) -> np.ndarray:
        w = check_broadcast(as_points(w, 3, "w"), "w", np.shape(self.one_minus_cos), "ref")
        inside = self._one_minus_cos(w) <= self.one_minus_cos
        return np.where(inside, 1.0 / self.solid_angle, 0.0)

    def invert(self, w: np.ndarray) -> np.ndarray:
        w = check_broadcast(as_points(w, 3, "w"), "w", np.shape(self.one_minus_cos), "ref")
        u1 = self._one_minus_cos(w) / self.one_minus_cos
        u2 = _sphere_to_u(Frame._trusted(self.axis).to_local(w))[..., 1]
        return np.stack(np.broadcast_arrays(u1, u2), -1)

    def sample_point(self, u: np.ndarray) -> LightSample:
        """``LightSample(w, y, dist, pdf)`` with y the first (visible) point of the sphere
        along w (from inside: the exit point); grazing rays are clamped onto the sphere.
        ``pdf`` is 1 / solid angle: a sample lies in the cone by construction (recomputing
        ``pdf(w)`` could round a sample at the cone's edge out of it)."""
        w = self.sample(u)
        o = self.ref - self.center
        b = dot(o, w)
        perp = o - scale(w, b)                              # r^2 - |perp|^2: no cancellation
        sq = np.sqrt(np.clip(self.radius**2 - dot(perp, perp), 0.0, None))
        t = np.where(self.inside, -b + sq, -b - sq)
        y = self.ref + scale(w, t)
        return LightSample(w, y, t, np.broadcast_to(1.0 / self.solid_angle, t.shape))

    def _repr_fields(self):
        return {"radius": self.radius, "ref_shape": self.ref.shape}
