"""Checks of the scene objects (:mod:`vrlab.render.scene`): ranges the renderer supports.

Every ``Sensor``, ``Integrator``, ``BSDF``, ``AreaEmitter``, ``Shape`` and ``Scene`` runs
these in its constructor (and ``Scene.validate()`` runs them again, as ``render`` does
once per call, after fields were changed in place).  Errors are ``TypeError`` (wrong
kind) or ``ValueError`` (bad value) whose message starts with the field's name; the XML
loader turns them into a :class:`~vrlab.render.SceneError` naming the element.

Limits (the renderer intersects and shades in float32, see :mod:`vrlab.render.direct`):

* coordinates: every entry of a ``to_world`` matrix and every mesh vertex within
  +-:data:`MAX_COORD` (1e8); scale factors (singular values of the linear part) within
  :data:`SCALE_RANGE` = [1e-9, 1e8]; shapes are affine (last row ``0 0 0 1``), the
  sensor a rigid motion, a sphere a similarity (uniform scale);
* values: radiance and reflectances finite, >= 0 and <= :data:`MAX_VALUE` (1e15);
  ``alpha`` in (0, 1e4]; the Phong ``exponent`` in [0, 1e6];
* sensor: ``fov`` in (0, 180) degrees (and so is the horizontal fov it implies);
  ``width``, ``height`` in [1, 65536] with at most 2^26 pixels; ``spp`` >= 1;
* integrator: ``emitter_samples``, ``bsdf_samples`` in [0, 4096], not both 0.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .. import checks

MAX_COORD = 1e8
SCALE_RANGE = (1e-9, 1e8)
MAX_VALUE = 1e15
MAX_ALPHA = 1e4
MAX_EXPONENT = 1e6
MAX_SIDE = 65536
MAX_PIXELS = 1 << 26
MAX_SAMPLES = 4096            # emitter_samples, bsdf_samples (and render's ris_candidates)
SHAPE_TYPES = ("rectangle", "cube", "sphere", "disk", "obj", "ellipsoid")
BSDF_TYPES = ("diffuse", "roughconductor", "phong")
FOV_AXES = ("x", "y", "diagonal", "smaller", "larger")
DISTRIBUTIONS = ("beckmann", "ggx")
BSDF_PARAMS = {"diffuse": ("reflectance",),
               "phong": ("diffuse_reflectance", "specular_reflectance", "exponent"),
               "roughconductor": ("distribution", "alpha", "sample_visible")}


def rgb(value: Any, name: str) -> np.ndarray:
    """A colour as a float array ``(3,)`` from a number or 3 numbers: finite, in [0, MAX_VALUE]."""
    if isinstance(value, np.ndarray) and value.shape == (3,) and value.dtype == np.float64:
        a = value                                      # fast path: already checked before
        lo, hi = a.min(), a.max()
        if lo >= 0 and hi <= MAX_VALUE:
            return a
    if value is None:
        raise TypeError(f"{name} must be a number or 3 numbers (RGB), got None")
    a = checks.finite_array(value, name)
    if a.ndim > 1 or a.size not in (1, 3):
        raise ValueError(f"{name} must be one number or 3 (RGB), got shape {a.shape}")
    a = np.broadcast_to(a.reshape(-1), (3,)).astype(float)
    if np.any(a < 0) or np.any(a > MAX_VALUE):
        raise ValueError(f"{name} must lie in [0, {MAX_VALUE:g}], got {a.tolist()}")
    return a


def matrix4(value: Any, name: str) -> np.ndarray:
    """A finite float ``(4, 4)`` matrix whose entries lie within +-MAX_COORD."""
    m = checks.finite_array(value, name)
    if m.shape != (4, 4):
        raise ValueError(f"{name} must be a 4x4 matrix, got shape {m.shape}")
    if np.abs(m).max() > MAX_COORD:
        raise ValueError(f"{name}: entries must lie within +-{MAX_COORD:g} (the renderer works in "
                         f"float32), got {np.abs(m).max():g}")
    return m.copy()


def affine(m: np.ndarray, name: str) -> None:
    """``m`` maps points affinely (last row 0 0 0 1) with scale factors in SCALE_RANGE."""
    if np.any(m[3] != [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"{name} must be affine (last row 0 0 0 1), got last row {m[3].tolist()}")
    s = np.linalg.svd(m[:3, :3], compute_uv=False)
    low, high = SCALE_RANGE
    if not (s[-1] >= low and s[0] <= high):
        what = "singular" if s[-1] == 0 else "scaled too far"
        raise ValueError(f"{name} is {what}: its scale factors (singular values) must lie in "
                         f"[{low:g}, {high:g}], got {s[-1]:g} to {s[0]:g}")


def rigid(m: np.ndarray, name: str) -> None:
    """``m`` is a rigid motion (rotation or reflection, and translation)."""
    r = m[:3, :3]
    if not np.allclose(r.T @ r, np.eye(3), atol=1e-6) or np.any(m[3] != [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"{name}: the sensor to_world must be a rigid motion (no scale, shear or "
                         "projection), as in Mitsuba; supported: translate, rotate, lookat, "
                         "orthonormal matrix")


def _type(value: Any, cls: type, name: str) -> None:
    if not isinstance(value, cls):
        raise TypeError(f"{name} must be a {cls.__name__}, got {checks.describe(value)}")


def check_integrator(it) -> None:
    checks.choice(it.type, "type", ("direct",))
    it.emitter_samples = checks.integer(it.emitter_samples, "emitter_samples", low=0, high=MAX_SAMPLES)
    it.bsdf_samples = checks.integer(it.bsdf_samples, "bsdf_samples", low=0, high=MAX_SAMPLES)
    if it.emitter_samples + it.bsdf_samples == 0:
        raise ValueError("emitter_samples and bsdf_samples are both 0; at least one must be >= 1")


def check_sensor(s) -> None:
    s.fov = checks.real(s.fov, "fov", low=0, high=180, low_open=True, high_open=True)
    s.fov_axis = checks.choice(s.fov_axis, "fov_axis", FOV_AXES)
    s.to_world = matrix4(s.to_world, "to_world")
    rigid(s.to_world, "to_world")
    s.width = checks.integer(s.width, "width", low=1, high=MAX_SIDE)
    s.height = checks.integer(s.height, "height", low=1, high=MAX_SIDE)
    if s.width * s.height > MAX_PIXELS:
        raise ValueError(f"width x height = {s.width} x {s.height} exceeds {MAX_PIXELS} pixels "
                         "(e.g. 8192 x 8192)")
    s.spp = checks.integer(s.spp, "spp", low=1)
    s.rfilter = checks.choice(s.rfilter, "rfilter", ("box",))
    fx = s.fov_x
    if not 0 < fx < 180:                 # only by rounding, with a very wide image
        raise ValueError(f"fov: the horizontal field of view {fx:g} must be in (0, 180)")


def check_bsdf(b) -> None:
    checks.choice(b.type, "type", BSDF_TYPES)
    b.twosided = checks.flag(b.twosided, "twosided")
    if not isinstance(b.params, dict):
        raise TypeError(f"params must be a dict, got {checks.describe(b.params)}")
    allowed = BSDF_PARAMS[b.type]
    extra = sorted(set(b.params) - set(allowed))
    if extra:
        raise ValueError(f"params: unknown key(s) {', '.join(map(repr, extra))} for a {b.type!r} "
                         f"BSDF; allowed: {', '.join(allowed)}")
    p = dict(b.params)
    if b.type == "diffuse":
        p["reflectance"] = rgb(p.get("reflectance", 0.5), "reflectance")
    elif b.type == "phong":
        p["diffuse_reflectance"] = rgb(p.get("diffuse_reflectance", 0.5), "diffuse_reflectance")
        p["specular_reflectance"] = rgb(p.get("specular_reflectance", 0.2), "specular_reflectance")
        p["exponent"] = checks.real(p.get("exponent", 30.0), "exponent", low=0, high=MAX_EXPONENT)
    else:
        p["distribution"] = checks.choice(p.get("distribution", "beckmann"), "distribution", DISTRIBUTIONS)
        p["alpha"] = checks.real(p.get("alpha", 0.1), "alpha", low=0, high=MAX_ALPHA, low_open=True)
        if checks.flag(p.get("sample_visible", False), "sample_visible"):
            raise ValueError("sample_visible=True is not supported (vrlab samples the full NDF)")
        p["sample_visible"] = False
    b.params = p


def check_emitter(e) -> None:
    e.radiance = rgb(e.radiance, "radiance")


def check_shape(sh) -> None:
    from .scene import BSDF, AreaEmitter

    checks.choice(sh.type, "type", SHAPE_TYPES)
    sh.to_world = matrix4(sh.to_world, "to_world")
    affine(sh.to_world, "to_world")
    if sh.type == "sphere":
        g = sh.to_world[:3, :3].T @ sh.to_world[:3, :3]
        if np.abs(g - g[0, 0] * np.eye(3)).max() > 1e-6 * g[0, 0]:
            raise ValueError("to_world of a sphere must be a similarity (no non-uniform scale or "
                             "shear); use the vrlab 'ellipsoid' shape")
    _type(sh.bsdf, BSDF, "bsdf")
    if sh.emitter is not None:
        _type(sh.emitter, AreaEmitter, "emitter")
    sh.flip_normals = checks.flag(sh.flip_normals, "flip_normals")
    if not isinstance(sh.params, dict):
        raise TypeError(f"params must be a dict, got {checks.describe(sh.params)}")
    if sh.type == "obj":
        sh.params = dict(sh.params)
        sh.params["vertices"], sh.params["faces"] = mesh(sh.params.get("vertices"), sh.params.get("faces"))
        world = np.abs(sh.to_world[:3, :3] @ sh.params["vertices"].T + sh.to_world[:3, 3:]).max()
        if world > MAX_COORD:
            raise ValueError(f"vertices: world coordinates must lie within +-{MAX_COORD:g}, got {world:g}")


def mesh(vertices: Any, faces: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(vertices (V, 3) float, faces (T, 3) int)`` of a triangle mesh, checked."""
    if vertices is None or faces is None:
        raise ValueError("params: an 'obj' shape needs params 'vertices' (V, 3) and 'faces' (T, 3)")
    v = checks.finite_array(vertices, "vertices", ndim=2, last=3)
    if np.abs(v).max(initial=0.0) > MAX_COORD:
        raise ValueError(f"vertices must lie within +-{MAX_COORD:g}, got {np.abs(v).max():g}")
    f = np.asarray(faces)
    if f.dtype.kind not in "iu" or f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(f"faces must be an integer array (T, 3), got {f.dtype} {f.shape}")
    if len(f) == 0:
        raise ValueError("faces: the mesh has no faces")
    if f.min() < 0 or f.max() >= len(v):
        raise ValueError(f"faces: vertex indices must lie in [0, {len(v) - 1}], got {f.min()} to {f.max()}")
    tri = v[f]
    if not np.any(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])):
        raise ValueError("faces: every triangle of the mesh has zero area")
    return v, f.astype(np.int64)


def check_scene(sc, deep: bool = True) -> None:
    from .scene import Integrator, Sensor, Shape

    _type(sc.integrator, Integrator, "integrator")
    _type(sc.sensor, Sensor, "sensor")
    if isinstance(sc.shapes, (str, bytes)) or not hasattr(sc.shapes, "__iter__"):
        raise TypeError(f"shapes must be a list of Shape, got {checks.describe(sc.shapes)}")
    sc.shapes = list(sc.shapes)
    if not sc.shapes:
        raise ValueError("shapes: the scene has no shapes")
    for k, s in enumerate(sc.shapes):
        _type(s, Shape, f"shapes[{k}]")
    if not isinstance(sc.source, str):
        raise TypeError(f"source must be a string, got {checks.describe(sc.source)}")
    if deep:
        sc.integrator.validate()
        sc.sensor.validate()
        for k, s in enumerate(sc.shapes):
            try:
                s.validate()
            except (TypeError, ValueError) as exc:
                raise type(exc)(f"shapes[{k}] ({s.type!r}): {exc}") from None
