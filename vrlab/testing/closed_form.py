"""The renderer's closed-form scene of :func:`vrlab.testing.check_estimator` (its ``render``
check): a Lambertian floor under a rectangular area light, whose radiance at the origin is
exact by Lambert's polygon formula."""
from __future__ import annotations

import numpy as np

__all__ = ["CLOSED_FORM_RADIANCE", "FOOTPRINT_TOL", "closed_form_scene"]

_RHO = np.array([0.2, 0.5, 0.8])
_L_E = 3.0
# rectangle light [-0.3, 0.5] x {1} x [-0.25, 0.35] facing down onto a diffuse floor y = 0
_LIGHT = np.array([[-0.3, 1.0, -0.25], [0.5, 1.0, -0.25], [0.5, 1.0, 0.35], [-0.3, 1.0, 0.35]])


def closed_form_scene(width: int = 8, height: int = 6) -> str:
    """Mitsuba 3 XML of the closed-form scene: a camera 0.5 above a diffuse floor (reflectance
    :data:`_RHO`) looking straight down with a 2 degree field of view, under a rectangular
    area light of radiance 3 at height 1.  Every pixel sees the floor within 0.009 of the
    origin, whose radiance is :data:`CLOSED_FORM_RADIANCE`."""
    rho = ", ".join(map(str, _RHO))
    return f"""<scene version="3.0.0">
  <integrator type="direct"/>
  <sensor type="perspective">
    <float name="fov" value="2"/>
    <transform name="to_world"><lookat origin="0, 0.5, 0" target="0, 0, 0" up="0, 0, -1"/></transform>
    <film type="hdrfilm"><integer name="width" value="{width}"/><integer name="height" value="{height}"/>
      <rfilter type="box"/></film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><scale value="10"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="{rho}"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><scale x="0.4" y="0.3"/><rotate x="1" angle="90"/>
      <translate x="0.1" y="1" z="0.05"/></transform>
    <emitter type="area"><rgb name="radiance" value="{_L_E}"/></emitter>
  </shape>
</scene>"""


def _polygon_irradiance(x: np.ndarray, normal: np.ndarray, verts: np.ndarray, radiance: float) -> float:
    """Lambert's formula for a uniformly emitting polygon: E = L/2 |sum_k theta_k N . unit(v_k x v_k+1)|,
    v_k the unit vectors from x to the vertices (Lambert 1760; Arvo 1995, "Applications of
    irradiance tensors", eq. 5)."""
    v = verts - x
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    w = np.roll(v, -1, axis=0)
    theta = np.arccos(np.clip(np.sum(v * w, -1), -1, 1))
    c = np.cross(v, w)
    c /= np.linalg.norm(c, axis=-1, keepdims=True)
    return float(radiance / 2 * abs(np.sum(theta * (c @ normal))))


#: radiance (RGB) of the floor at the origin: rho / pi x E (a Lambertian surface)
CLOSED_FORM_RADIANCE = _RHO / np.pi * _polygon_irradiance(np.zeros(3), np.array([0.0, 1.0, 0.0]), _LIGHT, _L_E)
#: the floor radiance varies by less than this (relative) over the 2 degree footprint
FOOTPRINT_TOL = 1e-3
