"""vrlab's direct-lighting renderer: Mitsuba 3 XML scenes, ``render``, images, and the
screened Poisson reconstruction of gradient-domain rendering (``screened_poisson``).

``load_scene(path_or_xml)`` reads Mitsuba 3 scene files into a :class:`Scene` of registered
element objects (one class per Mitsuba plugin: :mod:`vrlab.render.registry`, ``register``
and ``registered``), with NumPy 4x4 ``to_world`` matrices; see :mod:`vrlab.render.scene`
for the supported elements and :mod:`vrlab.render.transforms` for the conventions.
"""
from . import transforms
from .registry import Element, register, registered
from .builtin import (builtin_scene_path, describe_builtin_scene, export_builtin_scene, list_builtin_scenes,
                      list_mitsuba_references, mitsuba_reference)
from .loader import load_scene
from .scene import Scene, SceneError
from .._alloc import keep_freed_memory
from .._lazy import lazy_attributes

__all__ = ["BSDFModel", "Diffuse", "Element", "Emitter", "Phong", "RoughConductor", "TwoSided", "AreaEmitter",
           "Integrator", "Scene", "register", "registered",
           "SceneError", "Sensor", "Shape", "builtin_scene_path", "describe_builtin_scene", "export_builtin_scene",
           "keep_freed_memory", "list_builtin_scenes", "list_mitsuba_references", "mitsuba_reference", "load_scene", "read_obj", "render", "PixelIntegrand", "PRESETS", "preset",
           "RenderPlan", "plan",
           "GradientDomainImage", "render_gradient_domain",
           "ShadingIntegrand", "screened_poisson",
           "transforms"]

# imported on first use: the reconstruction needs scipy.fft and scipy.sparse, which a
# render does not, and a scene needs only its own elements, not the renderer's machinery
# (``vrlab render``'s start-up time is benchmarked; so is every worker process's)
__getattr__, __dir__ = lazy_attributes(__name__, {
    "render": "film", "RenderPlan": "planning", "plan": "planning", "GradientDomainImage": "gradient",
    "render_gradient_domain": "gradient", "PixelIntegrand": "pixels", "PRESETS": "presets",
    "preset": "presets", "ShadingIntegrand": "shading",
    "screened_poisson": "poisson", "read_obj": "meshes", "Shape": "shapes", "AreaEmitter": "emitters",
    "Emitter": "emitters", "Integrator": "integrators", "Sensor": "sensors", "BSDFModel": "bsdfs",
    "Diffuse": "bsdfs", "Phong": "bsdfs", "RoughConductor": "bsdfs", "TwoSided": "bsdfs"}, __all__)
