"""Scene layer of vrlab's direct-lighting renderer: a Mitsuba 3 XML subset and transforms.

``load_scene(path_or_xml)`` returns plain dataclasses (:class:`Scene`, :class:`Sensor`,
:class:`Shape`, ...) with NumPy 4x4 ``to_world`` matrices; see :mod:`vrlab.render.scene`
for the supported subset and :mod:`vrlab.render.transforms` for the conventions.
"""
from . import transforms
from .bsdfs import BSDFModel, Diffuse, Phong, RoughConductor
from .builtin import builtin_scene_path, describe_builtin_scene, export_builtin_scene, list_builtin_scenes
from .loader import load_scene, read_obj
from .scene import BSDF, AreaEmitter, Integrator, Scene, SceneError, Sensor, Shape
from .film import render

__all__ = ["BSDFModel", "Diffuse", "Phong", "RoughConductor", "AreaEmitter", "BSDF", "Integrator", "Scene", "SceneError", "Sensor", "Shape",
           "builtin_scene_path", "describe_builtin_scene", "export_builtin_scene", "list_builtin_scenes", "load_scene", "read_obj", "render", "transforms"]
