"""``area`` (Mitsuba 3): a diffuse emitter on the surface of the shape that carries it,
radiance L_e(x, w) = ``radiance`` towards the side its normal faces (one-sided); ``radiance``
may be a texture, looked up at the shape's uv as Mitsuba does (light selection by power then
uses its mean).  On a triangle mesh, the ``"light"`` technique picks a triangle by area and
then either a point uniformly on it, converted to solid angle (``triangle_sampling="area"``,
the default, as Mitsuba) or a direction uniformly in the spherical triangle it subtends
(``"spherical"``, Arvo 1995): a vrlab parameter, settable in Python or in the scene file
(which Mitsuba then refuses).

:class:`AreaLight` is the area emitter's light sampling, what the light set
(:mod:`vrlab.render.light_set`, which imports it as ``vrlab.render.lights.Light``) calls for
every emitting shape: spheres by the cone they subtend (``SphereCone``), other shapes by area
(their ``surface()`` distribution from :mod:`vrlab.distributions`) converted to solid angle over
every hit (``SolidAngleFromArea``: p_w = sum_k p_A d_k^2 / |cos theta_k|); split mesh lights
also triangle by triangle (``sample_triangle``)."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..._vec import dot
from ...distributions import SphereCone
from ...distributions.base import uniforms32
from ...distributions.surfaces import Surface
from ..registry import register
from ..scene_checks import rgb
from .base import Emitter, weight_param

if TYPE_CHECKING:
    from ..shapes import Shape

__all__ = ["AreaEmitter", "AreaLight", "lambertian_flux"]


@register("emitter", "area")
class AreaEmitter(Emitter):
    """``AreaEmitter(radiance)``: one number or RGB, finite, >= 0 (stored as ``(3,)``)."""

    is_area = True

    TRIANGLE_SAMPLING = ("area", "spherical")

    def __init__(self, radiance: Any, sampling_weight: float = 1.0, triangle_sampling: str = "area"):
        from ... import checks

        self.radiance = _radiance(radiance)
        self.sampling_weight = weight_param(sampling_weight)
        self.triangle_sampling = checks.choice(triangle_sampling, "triangle_sampling", self.TRIANGLE_SAMPLING)

    @classmethod
    def from_props(cls, p) -> "AreaEmitter":
        return cls(p.texture("radiance", kind="emission"), p.float("sampling_weight", 1.0),
                   p.string("triangle_sampling", "area", cls.TRIANGLE_SAMPLING))

    def validate(self) -> None:
        self.radiance = _radiance(self.radiance)

    @property
    def texture(self):
        """The radiance texture, or None for a constant radiance."""
        from ..textures import Texture

        return self.radiance if isinstance(self.radiance, Texture) else None

    @property
    def mean_radiance(self) -> np.ndarray:
        """The radiance (3,), or its texture's mean over uv."""
        tex = self.texture
        return self.radiance if tex is None else np.asarray(tex.mean(), float)

    def __repr__(self) -> str:
        r = self.radiance if self.texture is not None else np.asarray(self.radiance).tolist()
        return f"AreaEmitter(radiance={r})"


def _radiance(value: Any):
    from ..textures import Texture

    return value if isinstance(value, Texture) else rgb(value, "radiance")


def lambertian_flux(radiance: np.ndarray, area):
    """The power (flux) of a one-sided Lambertian emitter, pi x mean radiance x area (pbrt-v4's
    ``DiffuseAreaLight::Phi``; ``area`` a number or an array of triangle areas): on the scale
    of a point light's 4 pi I, so that power selection weighs area and non-area lights alike."""
    return np.pi * max(float(np.mean(radiance)), 0.0) * area


class AreaLight:
    """An emitting shape (its ``emitter`` an :class:`AreaEmitter`) as a direction sampler from
    reference points, the area-light sampling of the light set (:mod:`vrlab.render.lights`):
    spheres by their cone, other shapes by their area-sampling surface (``shape.surface()``)
    converted to solid angle.  A shape without a surface distribution cannot be sampled
    (ValueError).  It answers what the light set asks of every light (``emitter``, ``shape``,
    ``is_delta``, ``is_infinite``, ``textured``, ``directions``, ``planar``, ``sphere``...).
    ``kernels`` ("numpy" or "numba", resolved by the caller): a mesh's sampling towards given
    triangles (``TriangleMeshSolidAngle(kernels=...)``)."""

    def __init__(self, shape: Shape, *, kernels: str = "numpy"):
        self.emitter = shape.emitter
        self.radiance = np.asarray(shape.emitter.mean_radiance, float)      # a texture's mean
        self.textured = shape.emitter.texture is not None
        self.is_delta, self.is_infinite = shape.emitter.is_delta, shape.emitter.is_infinite
        self.shape = shape
        self.directions: dict = {}      # keyword arguments of solid_angle_from (a mesh: its triangle_sampling)
        self.type = shape.plugin_name
        self.sphere = shape.sphere_light
        self.sign = -1.0 if shape.flip_normals else 1.0
        self.surface32 = None           # a float32 copy for float32 reference points (rectangles)
        self.planar = False
        if self.sphere is not None:
            self.area = 4 * np.pi * self.sphere[1] ** 2
            self.power = float(lambertian_flux(self.radiance, self.area))
            return
        self.surface = shape.surface()
        if self.surface is None:
            raise ValueError(f"light sampling of {shape.plugin_name!r} emitters is not supported; use "
                             "strategy 'cosine' or 'bsdf', or rectangle/cube/disk/sphere/ellipsoid lights")
        self.surface32 = shape.surface32()
        # meshes: by area or by spherical triangles (the emitter's ``triangle_sampling``)
        from ...distributions import TriangleMeshSurface

        self.directions = {"method": shape.emitter.triangle_sampling, "kernels": kernels} \
            if isinstance(self.surface, TriangleMeshSurface) else {}
        # one hit per direction: whether the light faces the point is a function of w
        self.planar = self.surface.max_hits == 1
        self.area = self.surface.area
        self.power = float(lambertian_flux(self.radiance, self.area))

    def sample(self, ref: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, ...]:
        """``(w, pdf, front, y)``: directions ``(m, 3)`` from ``ref (m, 3)``, their solid-angle
        pdf ``(m,)``, whether the light emits towards ``ref`` there and ``y``, the light's
        first point along w (for spheres and planar lights; NaN for closed shapes, where
        the sampled point may lie behind the first one)."""
        if self.sphere is not None:
            cone = SphereCone(self.sphere[0], self.sphere[1], ref)
            s = cone.sample_point(u)
            front = self.sign * dot(s.y - self.sphere[0], s.w) < 0
            return s.w, s.pdf, front, s.y
        surface = self._surface(ref)
        if surface is self.surface32:
            u = uniforms32(u)
        s = surface.solid_angle_from(ref, **self.directions).sample_point(u)
        if self.planar:
            return s.w, s.pdf, dot(ref - s.y, surface.normal(s.y)) > 0, s.y
        return s.w, s.pdf, np.ones(len(s.w), bool), np.full_like(s.y, np.nan)

    def sample_triangle(self, ref: np.ndarray, u: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, ...]:
        """``(w, p_t(w), front, y)`` of a mesh light's given triangles ``t (m,)`` (a split light of
        the light BVH): w towards triangle t by area or by its spherical triangle (the
        emitter's ``triangle_sampling``, ``TriangleMeshSolidAngle.sample_given``), p_t the
        density given t, front: t's winding normal (flip_normals is in the winding) or, with
        vertex normals, the shading normal at y faces ``ref``; y the sampled point on t."""
        s = self.surface.solid_angle_from(ref, **self.directions).sample_given(t, u)
        return s.w, s.pdf, dot(ref - s.y, self.triangle_normals(s.y, t)) > 0, s.y

    def triangle_normals(self, y: np.ndarray, t: np.ndarray, shading: bool = True) -> np.ndarray:
        """Normals of a mesh light at its points ``y`` on triangles ``t``: the winding normal or,
        with ``shading`` and vertex normals, the shading normal at y (which decides where it
        faces, as ``DirectLighting.facing`` judges hits)."""
        normal = self.surface.face_normals[t]
        if shading and self.shape.has_shading_normals:
            normal = self.shape.shading_normals(y, normal, t)
        return normal

    def pdf_triangle(self, ref: np.ndarray, w: np.ndarray, t: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
        """``(p_t(w), t)``: the density of ``w`` given the triangle t of this mesh that the ray
        (ref, w) meets *first* (``t``: known from the renderer's trace; None: found here by
        ``surface.hits``, O(F) per ray); t = -1 and density 0 where the ray misses the mesh."""
        if t is None:
            t = self.surface.hits(np.asarray(ref, float), np.asarray(w, float))[1][:, 0]
        t = np.asarray(t, np.int64)
        out = np.zeros(len(t))
        hit = np.flatnonzero(t >= 0)
        if len(hit):
            out[hit] = self.surface.solid_angle_from(ref[hit], **self.directions).pdf_given(w[hit], t[hit])
        return out, t

    def pdf(self, ref: np.ndarray, w: np.ndarray, hit_p: np.ndarray | None = None) -> np.ndarray:
        """Solid-angle pdf of directions ``w`` from ``ref``.  For planar lights, ``hit_p``
        (where the rays ``(ref, w)`` met this light, from the renderer's trace) replaces a
        second intersection."""
        if self.sphere is not None:
            return SphereCone(self.sphere[0], self.sphere[1], ref).pdf(w)
        if self.planar and hit_p is not None:
            return self._surface(ref).solid_angle_from(ref).pdf_at(hit_p, w)
        return self.surface.solid_angle_from(ref, **self.directions).pdf(w)

    def _surface(self, ref: np.ndarray) -> Surface:
        """The surface in ``ref``'s precision (float32 for the renderer's rectangles)."""
        return self.surface32 if ref.dtype == np.float32 and self.surface32 is not None else self.surface

    def cos_integral(self, ref: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(I, valid)``: I = int cos(theta) dw over the directions from ``ref`` (normal
        ``n``) that reach this light, without occlusion, where a closed form applies."""
        return self.shape.cos_integral(ref, n)
