"""Parse a documented subset of Mitsuba 3 scene XML into plain Python/NumPy objects.

Supported (Mitsuba 3 conventions and defaults unless marked *vrlab*):

* ``<scene version="3.x.y">`` (version required); ``<default name value/>`` and ``$name``
  substitution in attribute values (``load_scene(src, params)`` overrides defaults).
* ``<integrator type="direct">``: integers ``shading_samples`` (default 1),
  ``emitter_samples`` and ``bsdf_samples`` (default ``shading_samples``);
  ``hide_emitters`` only ``false``.  The integrator is required (Mitsuba's default is
  ``path``, which vrlab does not render).
* ``<sensor type="perspective">``: ``fov`` (degrees, required), ``fov_axis`` (``x``
  default, ``y``, ``diagonal``, ``smaller``, ``larger``), ``near_clip``/``far_clip``
  (accepted, no effect), ``to_world``.  Camera looks along local +z, +y up, local +x is
  image-left (see :mod:`vrlab.render.transforms`).  Nested ``<sampler
  type="independent">`` (``sample_count``, default 4; ``seed`` accepted) and a required
  ``<film type="hdrfilm">`` (``width``/``height`` default 768x576, ``pixel_format`` only
  ``rgb``, ``file_format`` accepted) with a required explicit ``<rfilter type="box"/>``:
  Mitsuba's default filter is ``gaussian``, which vrlab does not implement.
* Shapes ``rectangle`` ([-1,1]^2 in z=0, normal +z), ``cube`` ([-1,1]^3), ``disk`` (unit
  disk in z=0, normal +z), ``sphere`` (``center``, ``radius``; composed into
  ``to_world`` as ``to_world @ T(center) @ S(radius)``, uniform scale only), ``obj``
  (``filename``; ``v``/``f`` lines, fan-triangulated, face normals only) and the *vrlab*
  ``ellipsoid`` (``center``, ``radii`` vector; ``to_world @ T(center) @ S(radii)``).
  All take ``to_world``, ``flip_normals``, a nested ``<bsdf>`` or ``<ref id/>`` (default:
  ``diffuse`` 0.5, as in Mitsuba; black for an emitter, which in Mitsuba reflects only
  through an explicit ``<bsdf>``) and an optional nested ``<emitter type="area">``.
* BSDFs ``diffuse`` (``reflectance``, default 0.5; one-sided), ``twosided`` (one nested
  bsdf; gives ``BSDF.twosided=True``), ``roughconductor`` (``distribution`` ``beckmann``
  default or ``ggx``, ``alpha`` default 0.1, ``material`` only ``none`` i.e. Fresnel = 1,
  ``sample_visible`` must be given explicitly as ``false``: Mitsuba defaults to ``true``,
  vrlab samples the full NDF) and the *vrlab* ``phong``: ``diffuse_reflectance`` k_d
  (0.5), ``specular_reflectance`` k_s (0.2), ``exponent`` n (30); f = k_d/pi + k_s (n+2)/
  (2 pi) cos^n(alpha), alpha the angle between the mirror direction and w_i.
* ``<emitter type="area">`` with ``radiance`` (rgb, single-value spectrum or float) only
  inside a shape.

Checked at load time (:mod:`vrlab.render.scene_checks` has the limits): the XML is
well formed, every element, attribute and parameter is known and of the right kind,
numbers are finite and in range (``fov`` in (0, 180), ``width``/``height`` >= 1,
``sample_count`` >= 1, ``near_clip`` > 0 and < ``far_clip``, ``radius``/``radii``/
``alpha`` > 0, colours >= 0, coordinates within +-1e8), transforms are non-singular
(shapes affine, the sensor rigid, spheres uniformly scaled), ``$name`` parameters are
defined and every ``params`` key is used, and ``obj`` files hold finite vertices and
faces whose indices exist (errors name the file and line).  Anything else raises
:class:`SceneError` naming the file, the element (tag, type, id) and its line, and what
is supported.  The dataclasses check the same ranges when built from Python (a
``ValueError``/``TypeError`` naming the field); ``Scene.validate()`` checks again after
fields were changed in place (``render`` calls it once per call).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import scene_checks as _checks
from . import transforms as tf

__all__ = ["SceneError", "Scene", "Integrator", "Sensor", "Shape", "BSDF", "AreaEmitter"]


class SceneError(ValueError):
    """A scene file uses something outside the supported subset, or is malformed."""


# ----------------------------------------------------------------------------- objects
@dataclass
class Integrator:
    """``direct`` integrator settings (samples per shading point)."""
    type: str
    emitter_samples: int
    bsdf_samples: int

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Check the fields: ``type`` 'direct', sample counts integers in [0, 4096], not both 0."""
        _checks.check_integrator(self)


@dataclass
class Sensor:
    """Perspective camera.  ``fov`` in degrees along ``fov_axis``; ``spp`` from the sampler."""
    fov: float
    fov_axis: str
    to_world: np.ndarray
    width: int
    height: int
    spp: int
    rfilter: str = "box"

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Check the fields (ranges in :mod:`vrlab.render.scene_checks`)."""
        _checks.check_sensor(self)

    @property
    def aspect(self) -> float:
        return self.width / self.height

    @property
    def fov_x(self) -> float:
        """Horizontal field of view in degrees (Mitsuba's ``parse_fov`` rules)."""
        a, f = self.aspect, self.fov
        axis = self.fov_axis
        if axis == "smaller":
            axis = "y" if a > 1 else "x"
        elif axis == "larger":
            axis = "x" if a > 1 else "y"
        if axis == "x":
            return f
        if axis == "y":
            return float(np.rad2deg(2 * np.arctan(np.tan(np.deg2rad(f) / 2) * a)))
        diag = 2 * np.tan(np.deg2rad(f) / 2)          # diagonal
        width = diag / np.sqrt(1 + 1 / a**2)
        return float(np.rad2deg(2 * np.arctan(width / 2)))

    @property
    def fov_y(self) -> float:
        """Vertical field of view in degrees."""
        return float(np.rad2deg(2 * np.arctan(np.tan(np.deg2rad(self.fov_x) / 2) / self.aspect)))

    @property
    def origin(self) -> np.ndarray:
        return self.to_world[:3, 3].copy()


@dataclass
class BSDF:
    """A BSDF: ``type`` in {diffuse, roughconductor, phong}; rgb values are (3,) arrays."""
    type: str
    params: dict[str, Any]
    twosided: bool = False

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Check ``type``, the parameter names and values (missing ones get Mitsuba's
        defaults; colours become ``(3,)`` arrays)."""
        _checks.check_bsdf(self)


@dataclass
class AreaEmitter:
    """Diffuse area light with constant ``radiance`` (rgb, shape (3,))."""
    radiance: np.ndarray

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """``radiance``: one number or RGB, finite, >= 0 (stored as ``(3,)``)."""
        _checks.check_emitter(self)


@dataclass
class Shape:
    """A shape in world space: ``to_world`` maps the canonical object to the world."""
    type: str
    to_world: np.ndarray
    bsdf: BSDF
    emitter: AreaEmitter | None = None
    flip_normals: bool = False
    params: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Check the type, ``to_world`` (finite, affine, non-singular), the BSDF and emitter,
        and an ``obj`` mesh's ``params['vertices']``/``params['faces']``."""
        _checks.check_shape(self)
        for name in ("bsdf", "emitter"):
            obj = getattr(self, name)
            if obj is not None:
                try:
                    obj.validate()
                except (TypeError, ValueError) as exc:
                    raise type(exc)(f"{name}: {exc}") from None

    @property
    def center(self) -> np.ndarray:
        """World position of the object-space origin."""
        return self.to_world[:3, 3].copy()

    def sphere(self) -> tuple[np.ndarray, float]:
        """(center, radius) of a sphere."""
        self._need("sphere")
        return self.center, float(np.linalg.norm(self.to_world[:3, 0]))

    def ellipsoid(self) -> tuple[np.ndarray, np.ndarray]:
        """(center, 3x3 linear map) with world points = center + A @ unit-sphere points."""
        self._need("ellipsoid", "sphere")
        return self.center, self.to_world[:3, :3].copy()

    def rectangle(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(corner, edge1, edge2, unit normal); points = corner + s*edge1 + t*edge2, s,t in [0,1]."""
        self._need("rectangle")
        m = self.to_world
        corner = tf.transform_points(m, np.array([-1.0, -1.0, 0.0]))
        e1 = tf.transform_vectors(m, np.array([2.0, 0.0, 0.0]))
        e2 = tf.transform_vectors(m, np.array([0.0, 2.0, 0.0]))
        return corner, e1, e2, self._normal_z()

    def disk(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(center, axis1, axis2, unit normal); points = center + r cos t axis1 + r sin t axis2."""
        self._need("disk")
        m = self.to_world
        return (self.center, m[:3, 0].copy(), m[:3, 1].copy(), self._normal_z())

    def triangles(self) -> np.ndarray:
        """World-space triangles ``(T, 3, 3)`` of rectangle, cube or obj shapes (outward winding)."""
        if self.type == "rectangle":
            v = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float)
            f = np.array([[0, 1, 2], [0, 2, 3]])
        elif self.type == "cube":
            v, f = _cube_mesh()
        elif self.type == "obj":
            v, f = self.params["vertices"], self.params["faces"]
        else:
            raise ValueError(f"triangles() is not available for shape type {self.type!r}; "
                             "supported: rectangle, cube, obj")
        tri = tf.transform_points(self.to_world, v[f])
        if self.flip_normals:
            tri = tri[:, ::-1]
        return tri

    def _normal_z(self) -> np.ndarray:
        n = tf.transform_normals(self.to_world, np.array([0.0, 0.0, 1.0]))
        n = n / np.linalg.norm(n)
        return -n if self.flip_normals else n

    def _need(self, *types: str) -> None:
        if self.type not in types:
            raise ValueError(f"shape is {self.type!r}; this helper needs {' or '.join(types)}")


@dataclass
class Scene:
    """Parsed scene; ``source`` is the file path (or ``"<string>"``)."""
    integrator: Integrator
    sensor: Sensor
    shapes: list[Shape]
    source: str = "<python>"

    def __post_init__(self) -> None:
        _checks.check_scene(self, deep=False)

    def validate(self) -> Scene:
        """Check every object of the scene again (after changes in place); returns it."""
        _checks.check_scene(self)
        return self

    @property
    def emitters(self) -> list[Shape]:
        """Shapes carrying an area emitter."""
        return [s for s in self.shapes if s.emitter is not None]


def _cube_mesh() -> tuple[np.ndarray, np.ndarray]:
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    idx = {tuple(p): i for i, p in enumerate(v.astype(int))}
    faces = []
    for axis in range(3):
        for sign in (-1, 1):
            a, b = (axis + 1) % 3, (axis + 2) % 3
            quad = []
            for s, t in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0, 0, 0]
                p[axis], p[a], p[b] = sign, s, t
                quad.append(idx[tuple(p)])
            if sign < 0:                   # (a, b, axis) is right-handed: CCW seen from +axis
                quad = quad[::-1]
            faces += [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
    return v, np.array(faces)
