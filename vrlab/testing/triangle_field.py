"""A many-triangle-lights scene with occluders, written to a folder (Mitsuba 3 XML + OBJ).

:func:`write_triangle_field` writes ``triangle_field.xml`` and ``triangle_field_<i>.obj``
(``meshes`` emissive meshes of ``per_mesh`` separate triangles each; 4 x 300 = 1200 by
default) for the many-lights tests and ``benchmarks/bench_many_lights.py``: a diffuse
floor, three boxes (``cube``) and two spheres standing on it, and above them a field of
small emissive triangles at heights 0.7-2.0, most facing down (tilted up to 60 degrees),
15 % turned up to 110 degrees from down (some face up: they light nothing below and are
seen by the camera).  Edge lengths are log-uniform in [0.05, 0.3] (areas over a factor
~40) and each mesh has its own colour and radiance (a factor 100 between the meshes), so
powers span about four orders of magnitude.  The scene loads in vrlab and in Mitsuba 3
(``mi.load_file``); emitters are one-sided with black BSDFs, as vrlab's and Mitsuba's
``area`` emitters are.  Deterministic in ``seed``.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .. import checks

__all__ = ["write_triangle_field", "RADIANCES"]

#: the emitted radiance of each mesh (RGB), cycled when there are more meshes
RADIANCES = ((40.0, 12.0, 3.0), (2.0, 6.0, 24.0), (0.6, 0.9, 0.5), (150.0, 140.0, 120.0))

_OCCLUDERS = """
    <shape type="cube"><transform name="to_world"><scale x="0.35" y="0.6" z="0.35"/><rotate y="1" angle="20"/>
        <translate x="-1.2" y="0.6" z="-0.4"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.35, 0.3"/></bsdf></shape>
    <shape type="cube"><transform name="to_world"><scale x="0.8" y="0.25" z="0.3"/><rotate y="1" angle="-35"/>
        <translate x="1.1" y="0.25" z="0.6"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.3, 0.6, 0.35"/></bsdf></shape>
    <shape type="cube"><transform name="to_world"><scale x="0.3" y="0.9" z="0.3"/>
        <translate x="0.4" y="0.9" z="-1.6"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
    <shape type="sphere"><point name="center" value="-0.2, 0.45, 1.1"/><float name="radius" value="0.45"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.3, 0.4, 0.7"/></bsdf></shape>
    <shape type="sphere"><point name="center" value="2.0, 0.3, -0.9"/><float name="radius" value="0.3"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.7, 0.3"/></bsdf></shape>"""


def _triangles(g: np.random.Generator, n: int) -> np.ndarray:
    """``(n, 3, 3)`` separate triangles: centre, size, tilted frame (see the module docstring)."""
    c = np.column_stack([g.uniform(-3.2, 3.2, n), g.uniform(0.7, 2.0, n), g.uniform(-3.2, 2.2, n)])
    size = np.exp(g.uniform(np.log(0.05), np.log(0.3), n))
    tilt = np.where(g.random(n) < 0.15, g.uniform(0, np.radians(110), n), g.uniform(0, np.radians(60), n))
    az = g.uniform(0, 2 * np.pi, n)
    normal = np.column_stack([np.sin(tilt) * np.cos(az), -np.cos(tilt), np.sin(tilt) * np.sin(az)])
    a = np.cross(normal, np.where(np.abs(normal[:, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]]))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = np.cross(normal, a)                                   # (a, b, normal) right-handed
    ang = g.uniform(0, 2 * np.pi, n)[:, None] + np.array([0.0, 2.1, 4.2]) + g.uniform(-0.4, 0.4, (n, 3))
    r = size[:, None] * g.uniform(0.6, 1.0, (n, 3))
    v = c[:, None, :] + r[..., None] * (np.cos(ang)[..., None] * a[:, None] + np.sin(ang)[..., None] * b[:, None])
    return v            # counter-clockwise about ``normal``: the winding normal is ``normal``


def write_triangle_field(folder: str | os.PathLike, *, meshes: int = 4, per_mesh: int = 300, width: int = 64,
                         height: int = 48, seed: int = 20240701) -> Path:
    """Write the scene (see the module docstring) into ``folder`` (created if missing) and
    return the XML's path.  ``meshes`` >= 1 emissive OBJ meshes of ``per_mesh`` >= 1
    triangles, a ``width`` x ``height`` film (``$spp`` samples per pixel, default 16)."""
    meshes, per_mesh = checks.integer(meshes, "meshes", low=1), checks.integer(per_mesh, "per_mesh", low=1)
    width, height = checks.integer(width, "width", low=1), checks.integer(height, "height", low=1)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    g = np.random.default_rng(checks.integer(seed, "seed", low=0))
    shapes = []
    for i in range(meshes):
        tri = _triangles(g, per_mesh)
        name = f"triangle_field_{i}.obj"
        lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in tri.reshape(-1, 3)]
        lines += [f"f {3 * k + 1} {3 * k + 2} {3 * k + 3}" for k in range(per_mesh)]
        (folder / name).write_text("\n".join(lines) + "\n", encoding="utf-8")
        rgb = ", ".join(f"{v:g}" for v in RADIANCES[i % len(RADIANCES)])
        shapes.append(f'    <shape type="obj"><string name="filename" value="{name}"/>\n'
                      f'        <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>\n'
                      f'        <emitter type="area"><rgb name="radiance" value="{rgb}"/></emitter></shape>')
    xml = f"""<?xml version="1.0" encoding="utf-8"?>
<!-- vrlab: {meshes * per_mesh} small emissive triangles ({meshes} OBJ meshes) above a floor with three boxes
     and two spheres.  Written by vrlab.testing.triangle_field.write_triangle_field (seed {seed}). -->
<scene version="3.0.0">
    <default name="spp" value="16"/>
    <integrator type="direct"/>
    <sensor type="perspective">
        <float name="fov" value="55"/>
        <transform name="to_world"><lookat origin="0, 4.2, 6.5" target="0, 0.3, -0.3" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm"><integer name="width" value="{width}"/><integer name="height" value="{height}"/>
            <rfilter type="box"/></film>
    </sensor>
    <shape type="rectangle"><transform name="to_world"><scale value="5"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.6"/></bsdf></shape>{_OCCLUDERS}
{chr(10).join(shapes)}
</scene>
"""
    path = folder / "triangle_field.xml"
    path.write_text(xml, encoding="utf-8")
    return path
