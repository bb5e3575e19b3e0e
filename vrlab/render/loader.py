"""Mitsuba 3 XML subset -> vrlab scene objects: plugins and the ``load_scene`` entry point."""
from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ET
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from . import transforms as tf

from .scene import AreaEmitter, BSDF, Integrator, Scene, SceneError, Sensor, Shape
from .xml_props import _Ctx, _parse_xml, _Props


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
            raise ctx.error(el, f"'{name}' must be >= 0, got {v}")
    if es + bs == 0:
        raise ctx.error(el, "emitter_samples and bsdf_samples are both 0")
    return Integrator(t, es, bs)


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
    p.float("near_clip", 1e-2), p.float("far_clip", 1e4)
    spp, film = 4, None
    for c in p.objects:
        if any(o.tag == c.tag for o in p.objects if o is not c):
            raise ctx.error(c, f"more than one <{c.tag}> in the sensor")
        if c.tag == "sampler":
            ctx.check_attrs(c, ("type", "id", "name"))
            _check_type(ctx, c, ("independent",))
            sp = _Props(ctx, c, {"sample_count": ("integer",), "seed": ("integer",)})
            spp = sp.int("sample_count", 4)
            sp.int("seed", 0)
            if spp < 1:
                raise ctx.error(c, f"sample_count must be >= 1, got {spp}")
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
    if width < 1 or height < 1:
        raise ctx.error(film, f"width and height must be >= 1, got {width}x{height}")
    fp.string("pixel_format", "rgb", ("rgb",))
    fp.string("file_format", "openexr")
    if len(fp.objects) != 1:
        raise ctx.error(film, "exactly one <rfilter> is required (Mitsuba's default is gaussian)",
                        ["<rfilter type=\"box\"/>"])
    rf = fp.objects[0]
    ctx.check_attrs(rf, ("type", "id", "name"))
    _check_type(ctx, rf, ("box",))
    _Props(ctx, rf, {})
    m = p.transform("to_world")
    if not np.allclose(m[:3, :3].T @ m[:3, :3], np.eye(3), atol=1e-6) or np.any(m[3] != [0, 0, 0, 1]):
        raise ctx.error(p.props["to_world"], "the sensor to_world must be a rigid motion (no "
                        "scale, shear or projection), as in Mitsuba",
                        ["translate", "rotate", "lookat", "orthonormal matrix"])
    return Sensor(fov, axis, m, width, height, spp, "box")


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
        return BSDF(t, {"reflectance": p.rgb("reflectance", 0.5)})
    if t == "phong":
        p = _Props(ctx, el, {"diffuse_reflectance": col, "specular_reflectance": col,
                             "exponent": ("float", "integer")})
        n = p.float("exponent", 30.0)
        if n < 0:
            raise ctx.error(el, f"exponent must be >= 0, got {n}")
        return BSDF(t, {"diffuse_reflectance": p.rgb("diffuse_reflectance", 0.5),
                        "specular_reflectance": p.rgb("specular_reflectance", 0.2), "exponent": n})
    p = _Props(ctx, el, {"distribution": ("string",), "alpha": ("float",), "material": ("string",),
                         "sample_visible": ("boolean",)})
    dist = p.string("distribution", "beckmann", ("beckmann", "ggx"))
    alpha = p.float("alpha", 0.1)
    if not alpha > 0:
        raise ctx.error(el, f"alpha must be > 0, got {alpha}")
    p.string("material", "none", ("none",))
    if not p.has("sample_visible"):
        raise ctx.error(el, "set <boolean name=\"sample_visible\" value=\"false\"/> explicitly: "
                            "Mitsuba defaults to true (visible-normal sampling), vrlab samples the full "
                            "NDF", ["false"])
    if p.bool("sample_visible", False):
        raise ctx.error(p.props["sample_visible"], "sample_visible=true is not supported", ["false"])
    return BSDF(t, {"distribution": dist, "alpha": alpha, "sample_visible": False})


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
    return AreaEmitter(p.rgb("radiance", None))


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
            raise ctx.error(el, f"radius must be > 0, got {r}")
        m = m @ tf.translate(p.vector("center", (0, 0, 0))) @ tf.scale(r)
        g = m[:3, :3].T @ m[:3, :3]
        if not np.allclose(g, g[0, 0] * np.eye(3), rtol=1e-6, atol=1e-12 * g[0, 0]):
            raise ctx.error(el, "sphere to_world must be a similarity (no non-uniform scale or "
                                "shear); use the vrlab 'ellipsoid' shape", _SHAPE_TYPES)
    elif t == "ellipsoid":
        radii = p.vector("radii", (1, 1, 1))
        if np.any(radii <= 0):
            raise ctx.error(el, f"radii must be > 0, got {radii.tolist()}")
        m = m @ tf.translate(p.vector("center", (0, 0, 0))) @ tf.scale(radii)
    elif t == "obj":
        fname = p.string("filename", None)
        path = Path(fname) if os.path.isabs(fname) else ctx.base / fname
        try:
            v, f, has_vn = read_obj(path)
        except (OSError, ValueError) as exc:
            raise ctx.error(el, f"cannot read OBJ file: {exc}") from None
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
    return Shape(t, m, bsdf, emitter, p.bool("flip_normals", False), params)


def read_obj(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, bool]:
    """Tiny OBJ reader: ``(vertices (V,3), triangles (T,3) int, has_vertex_normals)``.

    Reads ``v`` and ``f`` lines (``f`` indices may be ``i``, ``i/t``, ``i//n``, ``i/t/n``,
    negative = relative); polygons are fan-triangulated; other lines are ignored.
    """
    verts: list[list[float]] = []
    faces: list[list[int]] = []
    has_vn = False
    with open(path, encoding="utf-8") as fh:
        for lineno, line in enumerate(fh, 1):
            tok = line.split()
            if not tok:
                continue
            try:
                if tok[0] == "v":
                    verts.append([float(x) for x in tok[1:4]])
                    if len(verts[-1]) != 3:
                        raise ValueError("vertex needs 3 coordinates")
                elif tok[0] == "vn":
                    has_vn = True
                elif tok[0] == "f":
                    idx = [int(t.split("/")[0]) for t in tok[1:]]
                    if len(idx) < 3:
                        raise ValueError("face needs >= 3 vertices")
                    idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
                    if any(not 0 <= i < len(verts) for i in idx):
                        raise ValueError("face index out of range")
                    faces += [[idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1)]
            except ValueError as exc:
                raise ValueError(f"{path}:{lineno}: {exc}") from None
    if not faces:
        raise ValueError(f"{path}: no faces")
    return np.array(verts, float), np.array(faces, int), has_vn


# ----------------------------------------------------------------------------- entry points
def load_scene(source: str | os.PathLike, params: dict[str, Any] | None = None) -> Scene:
    """Load a scene from a file path or an XML string (starting with ``<``).

    ``params`` override ``<default>`` values for ``$name`` substitution.
    """
    if isinstance(source, str) and source.lstrip().startswith("<"):
        text, name, base = source, "<string>", Path.cwd()
    else:
        path = Path(source)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise SceneError(f"cannot read scene file {str(path)!r}: {exc}") from None
        name, base = str(path), path.parent
    root, lines, parents = _parse_xml(text)
    ctx = _Ctx(lines, parents, base)
    if root.tag != "scene":
        raise ctx.error(root, "the root element must be <scene version=\"3.x.y\">", ["scene"])
    ctx.check_attrs(root, ("version",))
    version = ctx.attr(root, "version")
    if not re.fullmatch(r"3(\.\d+){0,2}", version.strip()):
        raise ctx.error(root, f"scene version {version!r} is not supported", ["3.x.y"])
    overrides = {k: str(v) for k, v in (params or {}).items()}
    referenced = set(re.findall(r"\$(\w+)", text))
    unused = sorted(set(overrides) - referenced)
    if unused:
        raise SceneError(f"{name}: parameter(s) {', '.join(map(repr, unused))} are not used by the scene "
                         f"(its $parameters: {', '.join(sorted(referenced)) or 'none'}); to change the "
                         "resolution of a scene without a parameter for it, edit scene.sensor "
                         "(dataclasses.replace) or use vrlab render --width/--height")
    for c in root:
        if c.tag == "default":
            ctx.check_attrs(c, ("name", "value"))
            n, v = c.get("name"), c.get("value")
            if n is None or v is None:
                raise ctx.error(c, "<default> needs both name= and value=")
            ctx.vars.setdefault(n, v)
    ctx.vars.update(overrides)
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


def list_builtin_scenes() -> list[str]:
    """Names (without ``.xml``) of the scenes shipped in ``vrlab/render/scenes``."""
    folder = resources.files("vrlab.render") / "scenes"
    return sorted(p.name[:-4] for p in folder.iterdir() if p.name.endswith(".xml"))


def builtin_scene_path(name: str) -> Path:
    """Path of a built-in scene file (``name`` with or without ``.xml``)."""
    stem = name[:-4] if name.endswith(".xml") else name
    names = list_builtin_scenes()
    if stem not in names:
        raise ValueError(f"unknown built-in scene {name!r}; available: {', '.join(names)}")
    return Path(str(resources.files("vrlab.render") / "scenes" / f"{stem}.xml"))
