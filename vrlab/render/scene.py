"""A scene: the integrator, the sensor and the shapes (with their BSDFs and area emitters) of a
Mitsuba 3 scene file, as registered element objects (:mod:`vrlab.render.registry`).

``load_scene(path_or_xml)`` (:mod:`vrlab.render.loader`) reads Mitsuba 3 scene files as
they are: scene versions 2.x and 3.x, ``<default>`` and ``$name`` everywhere (the
``type`` of an element included), ``<path value>`` search folders, ``<include
filename>``, ``id`` on any object with ``<ref id>`` anywhere (also as a named parameter,
``<ref name="reflectance" id="tex"/>``); ``load_scene(path, params={...})`` and ``vrlab render
-D name=value`` set ``$name`` as Mitsuba's ``-D`` does.  Unknown elements, types or parameters are
refused with a :class:`SceneError` naming the file, the element and its line, and what
is supported.

Supported elements (Mitsuba 3's plugin names and defaults unless marked *vrlab*;
``registered(kind)`` lists them, and each class's docstring gives its parameters):

* integrators: ``direct`` (``shading_samples``, ``emitter_samples``, ``bsdf_samples``,
  ``hide_emitters``), ``path``/``volpath`` with ``max_depth`` 1 or 2 (direct lighting;
  larger depths refused), ``moment`` around any of them;
* sensors: ``perspective`` (``fov``/``focal_length`` (default 50 mm), ``fov_axis``,
  ``principal_point_offset_x/y``, ``near_clip``, ``far_clip``, ``to_world``; ``focus_distance``
  accepted and ignored, as in Mitsuba), ``thinlens`` (the same with ``aperture_radius``,
  ``focus_distance`` used), ``orthographic``; film ``hdrfilm`` (``width``, ``height``, ``crop_*``,
  ``pixel_format`` rgb/rgba, ``file_format``, ``component_format``); rfilters ``box``,
  ``tent``, ``gaussian`` (the default); samplers ``independent``, ``stratified``,
  ``multijitter``, ``orthogonal``, ``ldsampler`` (``sample_count``, ``seed``; mapped to
  vrlab point sets, :mod:`vrlab.render.sensors.samplers`);
* shapes: ``rectangle``, ``disk``, ``sphere`` (``center``, ``radius``), ``cube``,
  ``cylinder`` (``p0``, ``p1``, ``radius``), the meshes ``obj``, ``ply`` (``filename``,
  ``face_normals``, ``flip_tex_coords``) and ``serialized`` (``filename``, ``shape_index``,
  ``face_normals``), smooth-shaded from their vertex normals (Mitsuba's angle-weighted ones
  where the file has none), ``shapegroup`` and ``instance`` (a ``<ref>`` to a group,
  ``to_world``), and the *vrlab* ``ellipsoid`` (``center``, ``radii``), each with
  ``to_world``, ``flip_normals``, one
  nested ``<bsdf>`` (default ``diffuse`` 0.5; black for an emitter) and an optional
  ``<emitter type="area">``;
* BSDFs: ``diffuse`` (``reflectance``), ``conductor`` (a smooth metal, a delta lobe:
  ``material`` or ``eta``/``k``, ``specular_reflectance``), ``roughconductor`` (``distribution``
  beckmann/ggx, ``alpha``, ``material`` none, ``specular_reflectance``,
  ``sample_visible``), ``plastic`` (a delta coating over a diffuse base: ``int_ior``,
  ``ext_ior``, ``diffuse_reflectance``, ``specular_reflectance``, ``nonlinear``),
  ``roughplastic`` (a microfacet coating over a diffuse base: ``distribution``, ``alpha``,
  ``sample_visible`` and the parameters of ``plastic``), ``roughdielectric`` (microfacet
  reflection and transmission, both sides: ``distribution``, ``alpha`` or ``alpha_u``/``alpha_v``,
  ``sample_visible``, ``int_ior``, ``ext_ior``, ``specular_reflectance``,
  ``specular_transmittance``),
  ``dielectric`` and ``thindielectric`` (delta reflection and transmission, both sides:
  ``int_ior``, ``ext_ior`` as numbers or names, ``specular_reflectance``,
  ``specular_transmittance``), ``blendbsdf`` (``weight``, two nested BSDFs), ``normalmap``
  (``normalmap`` texture, one nested BSDF), ``mask`` (``opacity``, one nested BSDF; light passes
  straight through the rest), ``bumpmap`` (a height texture, ``scale``, one nested BSDF),
  ``twosided`` (one nested BSDF), ``principled`` and ``principledthin`` (Burley's Disney BSDF
  and its thin sheet: ``base_color``, ``roughness``, ``metallic``, ``spec_trans``,
  ``clearcoat``, ``sheen``... all textures allowed; :mod:`vrlab.render.bsdfs.principled`) and
  the *vrlab*
  ``phong``; ``reflectance``, ``diffuse_reflectance``, ``specular_reflectance``,
  ``specular_transmittance``, ``eta``, ``k``, ``alpha`` and ``weight`` may be textures;
  a BSDF's lobes are techniques ``"bsdf:<lobe>"`` (:mod:`vrlab.render.bsdfs.base`);
* emitters: ``area`` (``radiance``, a colour or a texture) inside a shape; the delta
  lights ``point`` (``position`` or ``to_world``, ``intensity``), ``spot`` (``to_world``,
  ``intensity``, ``cutoff_angle``, ``beam_width``) and ``directional`` (``direction`` or
  ``to_world``, ``irradiance``) and ``projector`` (``irradiance`` a colour or texture,
  ``scale``, ``fov``/``focal_length``, ``fov_axis``, ``to_world``); the environments ``constant`` (``radiance``) and ``envmap`` (``filename``, ``scale``,
  ``to_world``, ``mis_compensation``); every
  emitter takes ``sampling_weight`` (:mod:`vrlab.render.emitters`);
* textures: ``bitmap`` (``filename``, ``filter_type``, ``wrap_mode``, ``raw``, ``to_uv``,
  ``format``), ``checkerboard`` (``color0``, ``color1``, ``to_uv``), ``mesh_attribute``
  (``name``, ``scale``), ``rawconstant`` (``value``: a ``<float>`` or ``<vector>`` kept as it
  is, e.g. a constant normal map), ``volume`` (``volume``: a nested volume, read at the surface
  point's world position) (:mod:`vrlab.render.textures`); image files PNG, JPEG, BMP, TGA, EXR,
  Radiance ``.hdr`` and ``.pfm`` (:func:`vrlab.render.image.read_bitmap`);
* volumes: ``gridvolume`` (``filename`` of a ``.vol`` file, ``filter_type``, ``wrap_mode``,
  ``to_world``, ``use_grid_bbox``) and ``constvolume`` (``value``)
  (:mod:`vrlab.render.volumes`);
* colours: ``<rgb>``, ``<float>``, ``<spectrum value="v">`` and ``<spectrum
  value="400:0.1, 500:0.5, ...">`` (converted to linear sRGB as Mitsuba's RGB variants
  do, :mod:`vrlab.render.spectra`), ``<spectrum type="regular">``/``"irregular"`` (the
  same conversion) and ``<spectrum type="blackbody">`` for emission (what Mitsuba's spectral
  variants render: its RGB variants cannot).

Elements are checked when built (their constructors, from Python or from XML: ranges in
:mod:`vrlab.render.scene_checks`); ``Scene.validate()`` checks every element again
after changes in place (``render`` calls it once per call).
"""
from __future__ import annotations

import copy
from typing import Any

from .. import checks
from .xml_props import SceneError

__all__ = ["Scene", "SceneError"]


def _is(value: Any, kind: str) -> bool:
    from .registry import Element

    return isinstance(value, Element) and value.kind == kind


class Scene:
    """A parsed scene: ``integrator``, ``sensor``, ``shapes`` (list), ``emitters`` (the
    emitters not attached to a shape) and ``source`` (the file path, or ``"<string>"``)."""

    def __init__(self, integrator: Any, sensor: Any, shapes: list, emitters: list | None = None,
                 source: str = "<python>"):
        self.integrator, self.sensor = integrator, sensor
        self.shapes = shapes
        self.free_emitters = [] if emitters is None else list(emitters)
        self.source = source
        #: the files the scene file reads (included scenes, meshes, images), set by the loader
        self.files: list = []
        self._check(deep=False)

    def _check(self, deep: bool) -> None:
        if not _is(self.integrator, "integrator"):
            raise TypeError(f"integrator must be a vrlab.render integrator element, got {checks.describe(self.integrator)}")
        if not _is(self.sensor, "sensor"):
            raise TypeError(f"sensor must be a vrlab.render sensor element, got {checks.describe(self.sensor)}")
        if isinstance(self.shapes, (str, bytes)) or not hasattr(self.shapes, "__iter__"):
            raise TypeError(f"shapes must be a list of shape elements, got {checks.describe(self.shapes)}")
        self.shapes = list(self.shapes)
        if not self.shapes:
            raise ValueError("shapes: the scene has no shapes")
        for k, s in enumerate(self.shapes):
            if not _is(s, "shape"):
                raise TypeError(f"shapes[{k}] must be a vrlab.render shape element, got {checks.describe(s)}")
        if not isinstance(self.source, str):
            raise TypeError(f"source must be a string, got {checks.describe(self.source)}")
        if deep:
            self.integrator.validate()
            self.sensor.validate()
            for k, s in enumerate(self.shapes):
                try:
                    s.validate()
                except (TypeError, ValueError) as exc:
                    raise type(exc)(f"shapes[{k}] ({s.plugin_name!r}): {exc}") from None

    def validate(self) -> Scene:
        """Check every element of the scene again (after changes in place); returns it."""
        self._check(deep=True)
        return self

    @property
    def emitters(self) -> list:
        """Shapes carrying an area emitter."""
        return [s for s in self.shapes if s.emitter is not None]

    def with_size(self, width: int | None = None, height: int | None = None) -> Scene:
        """A copy rendered at ``width`` x ``height`` (the sensor's film resized)."""
        out = copy.copy(self)
        out.sensor = self.sensor.with_size(width, height)
        return out

    def __repr__(self) -> str:
        return (f"Scene(source={self.source!r}, integrator={self.integrator!r}, sensor={type(self.sensor).__name__}"
                f"({self.sensor.width}x{self.sensor.height}), shapes={len(self.shapes)})")
