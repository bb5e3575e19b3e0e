"""Mitsuba 3 XML subset -> vrlab scene objects: plugins and the ``load_scene`` entry point."""
from __future__ import annotations

import numbers
import os
import re
from collections.abc import Mapping
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from .. import checks
from . import transforms as tf
from .obj import read_obj
from .scene import AreaEmitter, BSDF, Integrator, Scene, SceneError, Sensor, Shape
from .xml_props import _Ctx, _parse_xml, _Props

__all__ = ["load_scene", "read_obj"]


def _build(ctx: _Ctx, el: ET.Element, props: dict[str, ET.Element], make):
    """``make()``, with a constructor's ``ValueError``/``TypeError`` (its message starts with
    the field's name) turned into a :class:`SceneError` at that property's element."""
    try:
        return make()
    except SceneError:
        raise
    except (TypeError, ValueError) as exc:
        m = re.match(r"\w+", str(exc))
        target = props.get(m.group(0)) if m else None
        raise ctx.error(el if target is None else target, str(exc), scope=el) from None


# ----------------------------------------------------------------------------- plugins
def _check_type(ctx: _Ctx, el: ET.Element, supported: tuple[str, ...]) -> str:
    if el.get("type") is None:
        raise ctx.error(el, "missing required attribute 'type'", supported)
    t = ctx.attr(el, "type")
    if t not in supported:
        raise ctx.error(el, f"unsupported {el.tag} type '{t}'", supported)
    return t


def _parse_integrator(ctx: _Ctx, el: ET.Element) -> Integrator:
    ctx.check_attrs(el, ("type", "id", "name"))
    t = _check_type(ctx, el, ("direct",))
    p = _Props(ctx, el, {"shading_samples": ("integer",), "emitter_samples": ("integer",),
                         "bsdf_samples": ("integer",), "hide_emitters": ("boolean",)})
    shading = p.int("shading_samples", 1)
    es, bs = p.int("emitter_samples", shading), p.int("bsdf_samples", shading)
    if p.bool("hide_emitters", False):
        raise ctx.error(p.props["hide_emitters"], "hide_emitters=true is not supported", ["false"])
    for name, v in (("shading_samples", shading), ("emitter_samples", es), ("bsdf_samples", bs)):
        if v < 0:
            raise ctx.error(p.props.get(name, el), f"'{name}' must be >= 0, got {v}")
    if es + bs == 0:
        raise ctx.error(el, "emitter_samples and bsdf_samples are both 0")
    return _build(ctx, el, p.props, lambda: Integrator(t, es, bs))


def _parse_sensor(ctx: _Ctx, el: ET.Element) -> Sensor:
    ctx.check_attrs(el, ("type", "id", "name"))
    _check_type(ctx, el, ("perspective",))
    p = _Props(ctx, el, {"fov": ("float", "integer"), "fov_axis": ("string",),
                         "near_clip": ("float", "integer"), "far_clip": ("float", "integer"),
                         "to_world": ("transform",)}, objects=("sampler", "film"))
    fov = p.float("fov")
    if not 0 < fov < 180:
        raise ctx.error(p.props["fov"], f"fov={fov} must be in (0, 180) degrees")
    axis = p.string("fov_axis", "x", ("x", "y", "diagonal", "smaller", "larger"))
    near, far = p.float("near_clip", 1e-2), p.float("far_clip", 1e4)
    if not near > 0:
        raise ctx.error(p.props["near_clip"], f"near_clip must be > 0, got {near:g}")
    if not far > near:
        raise ctx.error(p.props.get("far_clip", p.props.get("near_clip")),
                        f"far_clip must be > near_clip, got near_clip={near:g}, far_clip={far:g}")
    spp, film = 4, None
    for c in p.objects:
        if any(o.tag == c.tag for o in p.objects if o is not c):
            raise ctx.error(c, f"more than one <{c.tag}> in the sensor")
        if c.tag == "sampler":
            ctx.check_attrs(c, ("type", "id", "name"))
            _check_type(ctx, c, ("independent",))
            sp = _Props(ctx, c, {"sample_count": ("integer",), "seed": ("integer",)})
            spp = sp.int("sample_count", 4)
            if spp < 1:
                raise ctx.error(sp.props["sample_count"], f"sample_count must be >= 1, got {spp}")
            if sp.int("seed", 0) < 0:
                raise ctx.error(sp.props["seed"], "seed must be >= 0")
        else:
            film = c
    if film is None:
        raise ctx.error(el, "a <film type=\"hdrfilm\"> with <rfilter type=\"box\"/> is required "
                            "(Mitsuba's default film uses a gaussian filter)")
    ctx.check_attrs(film, ("type", "id", "name"))
    _check_type(ctx, film, ("hdrfilm",))
    fp = _Props(ctx, film, {"width": ("integer",), "height": ("integer",),
                            "pixel_format": ("string",), "file_format": ("string",)},
                objects=("rfilter",))
    width, height = fp.int("width", 768), fp.int("height", 576)
    for name, v in (("width", width), ("height", height)):
        if v < 1:
            raise ctx.error(fp.props[name], f"{name} must be >= 1, got {v}")
    fp.string("pixel_format", "rgb", ("rgb",))
    fp.string("file_format", "openexr", ("openexr", "exr", "rgbe", "pfm"))
    if len(fp.objects) != 1:
        raise ctx.error(film, "exactly one <rfilter> is required (Mitsuba's default is gaussian)",
                        ["<rfilter type=\"box\"/>"])
    rf = fp.objects[0]
    ctx.check_attrs(rf, ("type", "id", "name"))
    _check_type(ctx, rf, ("box",))
    _Props(ctx, rf, {})
    m = p.transform("to_world")
    return _build(ctx, el, {**p.props, **fp.props}, lambda: Sensor(fov, axis, m, width, height, spp, "box"))


_BSDF_TYPES = ("diffuse", "roughconductor", "phong", "twosided")


def _parse_bsdf(ctx: _Ctx, el: ET.Element) -> BSDF:
    ctx.check_attrs(el, ("type", "id", "name"))
    t = _check_type(ctx, el, _BSDF_TYPES)
    col = ("rgb", "spectrum", "float")
    if t == "twosided":
        p = _Props(ctx, el, {}, objects=("bsdf", "ref"))
        if len(p.objects) != 1:
            raise ctx.error(el, "twosided needs exactly one nested <bsdf> or <ref>")
        inner = _bsdf_or_ref(ctx, p.objects[0])
        if inner.twosided:
            raise ctx.error(el, "nested twosided BSDFs are not supported")
        return BSDF(inner.type, dict(inner.params), twosided=True)
    if t == "diffuse":
        p = _Props(ctx, el, {"reflectance": col})
        refl = p.rgb("reflectance", 0.5)
        return _build(ctx, el, p.props, lambda: BSDF(t, {"reflectance": refl}))
    if t == "phong":
        p = _Props(ctx, el, {"diffuse_reflectance": col, "specular_reflectance": col,
                             "exponent": ("float", "integer")})
        n = p.float("exponent", 30.0)
        if n < 0:
            raise ctx.error(p.props["exponent"], f"exponent must be >= 0, got {n}")
        kd, ks = p.rgb("diffuse_reflectance", 0.5), p.rgb("specular_reflectance", 0.2)
        return _build(ctx, el, p.props, lambda: BSDF(t, {"diffuse_reflectance": kd,
                                                         "specular_reflectance": ks, "exponent": n}))
    p = _Props(ctx, el, {"distribution": ("string",), "alpha": ("float",), "material": ("string",),
                         "sample_visible": ("boolean",)})
    dist = p.string("distribution", "beckmann", ("beckmann", "ggx"))
    alpha = p.float("alpha", 0.1)
    if not alpha > 0:
        raise ctx.error(p.props["alpha"], f"alpha must be > 0, got {alpha}")
    p.string("material", "none", ("none",))
    if not p.has("sample_visible"):
        raise ctx.error(el, "set <boolean name=\"sample_visible\" value=\"false\"/> explicitly: "
                            "Mitsuba defaults to true (visible-normal sampling), vrlab samples the full "
                            "NDF", ["false"])
    if p.bool("sample_visible", False):
        raise ctx.error(p.props["sample_visible"], "sample_visible=true is not supported", ["false"])
    return _build(ctx, el, p.props, lambda: BSDF(t, {"distribution": dist, "alpha": alpha,
                                                     "sample_visible": False}))


def _bsdf_or_ref(ctx: _Ctx, el: ET.Element) -> BSDF:
    if el.tag == "bsdf":
        return _parse_bsdf(ctx, el)
    ctx.check_attrs(el, ("id", "name"))
    rid = ctx.attr(el, "id")
    if rid not in ctx.bsdfs:
        raise ctx.error(el, f"unknown reference id '{rid}'",
                        sorted(ctx.bsdfs) or "no top-level <bsdf id=...> defined before it")
    return ctx.bsdfs[rid]


def _parse_emitter(ctx: _Ctx, el: ET.Element) -> AreaEmitter:
    ctx.check_attrs(el, ("type", "id", "name"))
    _check_type(ctx, el, ("area",))
    p = _Props(ctx, el, {"radiance": ("rgb", "spectrum", "float")})
    radiance = p.rgb("radiance", None)
    return _build(ctx, el, p.props, lambda: AreaEmitter(radiance))


_SHAPE_TYPES = ("rectangle", "cube", "sphere", "disk", "obj", "ellipsoid")


def _parse_shape(ctx: _Ctx, el: ET.Element) -> Shape:
    ctx.check_attrs(el, ("type", "id", "name"))
    t = _check_type(ctx, el, _SHAPE_TYPES)
    allowed: dict[str, tuple[str, ...]] = {"to_world": ("transform",), "flip_normals": ("boolean",)}
    if t == "sphere":
        allowed.update(center=("point",), radius=("float", "integer"))
    elif t == "ellipsoid":
        allowed.update(center=("point",), radii=("vector",))
    elif t == "obj":
        allowed.update(filename=("string",), face_normals=("boolean",))
    p = _Props(ctx, el, allowed, objects=("bsdf", "ref", "emitter"))
    m = p.transform("to_world")
    params: dict[str, Any] = {}
    if t == "sphere":
        r = p.float("radius", 1.0)
        if not r > 0:
            raise ctx.error(p.props["radius"], f"radius must be > 0, got {r:g}")
        m = m @ tf.translate(p.vector("center", (0, 0, 0))) @ tf.scale(r)
    elif t == "ellipsoid":
        radii = p.vector("radii", (1, 1, 1))
        if np.any(radii <= 0):
            raise ctx.error(p.props["radii"], f"radii must be > 0, got {radii.tolist()}")
        m = m @ tf.translate(p.vector("center", (0, 0, 0))) @ tf.scale(radii)
    elif t == "obj":
        fname = p.string("filename", None)
        path = Path(fname) if os.path.isabs(fname) else ctx.base / fname
        try:
            v, f, has_vn = read_obj(path)
        except (OSError, ValueError) as exc:
            raise ctx.error(p.props.get("filename", el), f"cannot read OBJ file: {exc}") from None
        if has_vn and not p.bool("face_normals", False):
            raise ctx.error(el, "the OBJ file has vertex normals but vrlab shades with face "
                                "normals; set <boolean name=\"face_normals\" value=\"true\"/>")
        params.update(vertices=v, faces=f, filename=str(path))
    bsdf, emitter = None, None
    for c in p.objects:
        if c.tag == "emitter":
            if emitter is not None:
                raise ctx.error(c, "a shape can carry only one emitter")
            emitter = _parse_emitter(ctx, c)
        else:
            if bsdf is not None:
                raise ctx.error(c, "a shape can have only one bsdf")
            bsdf = _bsdf_or_ref(ctx, c)
    if bsdf is None:
        # Mitsuba 3: a shape without a bsdf is diffuse 0.5, but an emitter without one does not
        # reflect (checked with Mitsuba 3.9.1's direct integrator): black for emitters
        bsdf = BSDF("diffuse", {"reflectance": np.full(3, 0.0 if emitter is not None else 0.5)})
    flip = p.bool("flip_normals", False)
    # errors about to_world point at the transform (or at radius/radii, which scale it)
    where = {**p.props, "vertices": p.props.get("filename"),
             "to_world": p.props.get("to_world", p.props.get("radius", p.props.get("radii")))}
    return _build(ctx, el, {k: v for k, v in where.items() if v is not None},
                  lambda: Shape(t, m, bsdf, emitter, flip, params))


# ----------------------------------------------------------------------------- entry points
def _param_text(key: str, value: Any) -> str:
    """A ``params`` value as the text substituted for ``$key``."""
    name = f"params[{key!r}]"
    if isinstance(value, str):
        return value
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (numbers.Integral, np.integer)):
        return str(int(value))
    if isinstance(value, (numbers.Real, np.floating)):
        return repr(checks.real(value, name))
    if isinstance(value, (list, tuple, np.ndarray)):
        a = checks.finite_array(value, name)
        if a.ndim != 1 or a.size == 0:
            raise ValueError(f"{name} must be a string, a number or a flat list of numbers, got shape {a.shape}")
        return ", ".join(repr(float(x)) for x in a)
    raise TypeError(f"{name} must be a string, a number, a bool or a list of numbers, got {type(value).__name__}")


def _read_source(source: Any) -> tuple[str, str, Path]:
    """``(text, name, base folder)`` of an XML string or a scene file path."""
    if isinstance(source, str) and source.lstrip().startswith("<"):
        return source, "<string>", Path.cwd()
    if not isinstance(source, (str, os.PathLike)) or isinstance(source, bytes):
        raise TypeError(f"source must be a scene file path or an XML string, got {type(source).__name__}")
    if isinstance(source, str) and not source.strip():
        raise ValueError("source: empty string; give a scene file path or an XML string")
    path = Path(source)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise SceneError(f"{str(path)!r}: the scene file is not UTF-8 text") from None
    except OSError as exc:
        hint = ""
        from .builtin import list_builtin_scenes      # (builtin imports this module)

        if path.stem in list_builtin_scenes() and not path.exists():
            hint = f"; for the built-in scene use load_scene(builtin_scene_path({path.stem!r}))"
        raise SceneError(f"cannot read scene file {str(path)!r}: {exc.strerror or exc}{hint}") from None
    return text, str(path), path.parent


def load_scene(source: str | os.PathLike, params: dict[str, Any] | None = None) -> Scene:
    """Load a scene from a file path or an XML string (starting with ``<``).

    ``params`` override ``<default>`` values for ``$name`` substitution: a dict from
    parameter names the scene uses to strings, numbers, bools or lists of numbers
    (``"1, 2, 3"``).  ``TypeError``/``ValueError`` for a bad ``source`` or ``params``;
    :class:`SceneError` for anything wrong in the scene (see :mod:`vrlab.render.scene`),
    naming the parameters substituted into the element at fault.
    """
    if params is not None and not isinstance(params, Mapping):
        raise TypeError(f"params must be a dict of parameter values, got {type(params).__name__}")
    overrides = {}
    for k, v in (params or {}).items():
        if not isinstance(k, str):
            raise TypeError(f"params: key {k!r} must be a string (a parameter name)")
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", k):
            raise ValueError(f"params: key {k!r} is not a parameter name (letters, digits, _)")
        overrides[k] = _param_text(k, v)
    text, name, base = _read_source(source)
    root, lines, parents = _parse_xml(text, name)
    ctx = _Ctx(lines, parents, base, name)
    if root.tag != "scene":
        raise ctx.error(root, "the root element must be <scene version=\"3.x.y\">", ["scene"])
    ctx.check_attrs(root, ("version",))
    version = ctx.attr(root, "version")
    if not re.fullmatch(r"3(\.\d+){0,2}", version.strip()):
        raise ctx.error(root, f"scene version {version!r} is not supported", ["3.x.y"])
    referenced = set(re.findall(r"\$(\w+)", text))
    unused = sorted(set(overrides) - referenced)
    if unused:
        raise SceneError(f"{name}: params: parameter(s) {', '.join(map(repr, unused))} are not used by the "
                         f"scene (its $parameters: {', '.join(sorted(referenced)) or 'none'}); to change the "
                         "resolution of a scene without a parameter for it, edit scene.sensor "
                         "(dataclasses.replace) or use vrlab render --width/--height")
    for c in root:
        if c.tag == "default":
            ctx.check_attrs(c, ("name", "value"))
            n, v = c.get("name"), c.get("value")
            if n is None or v is None:
                raise ctx.error(c, "<default> needs both name= and value=")
            if n in ctx.vars:
                raise ctx.error(c, f"duplicate <default name=\"{n}\">")
            ctx.vars[n] = v
    ctx.vars.update(overrides)
    ctx.overridden = set(overrides)
    integrator, sensor, shapes = None, None, []
    top = ("default", "integrator", "sensor", "shape", "bsdf")
    for c in root:
        if c.tag == "default":
            continue
        if c.tag == "integrator":
            if integrator is not None:
                raise ctx.error(c, "more than one <integrator>")
            integrator = _parse_integrator(ctx, c)
        elif c.tag == "sensor":
            if sensor is not None:
                raise ctx.error(c, "more than one <sensor>")
            sensor = _parse_sensor(ctx, c)
        elif c.tag == "shape":
            shapes.append(_parse_shape(ctx, c))
        elif c.tag == "bsdf":
            bid = ctx.attr(c, "id", required=False)
            if bid is None:
                raise ctx.error(c, "a top-level <bsdf> needs an id= to be referenced")
            if bid in ctx.bsdfs:
                raise ctx.error(c, f"duplicate bsdf id '{bid}'")
            ctx.bsdfs[bid] = _parse_bsdf(ctx, c)
        elif c.tag == "emitter":
            raise ctx.error(c, "emitters are supported only as <emitter type=\"area\"> nested "
                               "inside a <shape>", ["area (inside a shape)"])
        else:
            raise ctx.error(c, "unsupported top-level element", [f"<{t}>" for t in top])
    if integrator is None:
        raise ctx.error(root, "an <integrator type=\"direct\"> is required (Mitsuba's default "
                              "is 'path')", ["direct"])
    if sensor is None:
        raise ctx.error(root, "a <sensor type=\"perspective\"> is required", ["perspective"])
    if not shapes:
        raise ctx.error(root, "the scene has no shapes")
    return Scene(integrator, sensor, shapes, name)
