"""Mitsuba 3 scene files -> vrlab scene objects, through the element registry only.

Reading (:mod:`vrlab.render.xml_reader`, :mod:`vrlab.render.xml_props`): the XML is parsed with line numbers; ``<include
filename>`` is replaced by the children of the included file's ``<scene>`` (recursively,
cycles refused), ``<path value>`` adds a search folder for files, ``<default name value>``
defines ``$name`` (``load_scene(params=...)`` overrides it).  Building: every object
element (``<shape>``, ``<bsdf>``, ``<texture>``, ...) is looked up by its tag (the kind)
and ``type`` in :func:`vrlab.render.registered`, its children are built first (a
``<ref id>`` builds the referenced object once, wherever it is defined), and
``cls.from_props(props)`` makes it; parameters it did not read are refused.  The scene
gets the top-level integrator, sensor, shapes and emitters; top-level objects of other
kinds need an ``id`` to be referenced.
"""
from __future__ import annotations

import numbers
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .. import checks

from .registry import KINDS, element_class, registered
from .scene import Scene, SceneError
from .xml_props import Ctx, Props, check_version, parse_xml

__all__ = ["load_scene"]

# plugins of Mitsuba 3 that vrlab does not render, with the reason (named in the error)
_REFUSED = {
    ("shape", "sdfgrid"): "signed distance fields are not supported",
}


def _make(ctx: Ctx, el: ET.Element, props: Props, make):
    """``make()``, with a constructor's ``ValueError``/``TypeError`` (its message starts with
    the parameter's name) turned into a :class:`SceneError` at that parameter's element."""
    try:
        return make()
    except SceneError:
        raise
    except (TypeError, ValueError) as exc:
        m = re.match(r"\w+", str(exc))
        target = props.element(m.group(0)) if m else None
        raise ctx.error(el if target is None else target, str(exc), scope=el) from None


def build(ctx: Ctx, el: ET.Element):
    """The object of an element (built once) or of a ``<ref id>``."""
    if el.tag == "ref":
        ctx.check_attrs(el, ("id", "name"))
        rid = ctx.attr(el, "id")
        if rid not in ctx.ids:
            raise ctx.error(el, f"unknown reference id '{rid}'", sorted(ctx.ids) or "no object has an id= yet")
        return build(ctx, ctx.ids[rid])
    key = id(el)
    if key in ctx.built:
        return ctx.built[key]
    if key in ctx.building:
        raise ctx.error(el, "the element refers to itself (a cycle of <ref>)")
    ctx.building.add(key)
    ctx.check_attrs(el, ("type", "id", "name"))
    kind = el.tag
    if el.get("type") is None:
        raise ctx.error(el, "missing required attribute 'type'", sorted(registered(kind)))
    t = ctx.attr(el, "type")
    cls = element_class(kind, t)
    if cls is None:
        why = _REFUSED.get((kind, t))
        raise ctx.error(el, f"unsupported {kind} type '{t}'" + (f" ({why})" if why else ""), sorted(registered(kind)))
    props = Props(ctx, el, lambda c: build(ctx, c))
    obj = _make(ctx, el, props, lambda: cls.from_props(props))
    props.check_unused()
    obj.id = ctx.attr(el, "id", required=False)
    ctx.built[key] = obj
    ctx.building.discard(key)
    return obj


# ----------------------------------------------------------------------------- reading
def _expand(ctx: Ctx, root: ET.Element, files: tuple[str, ...]) -> list[ET.Element]:
    """The top-level elements of ``root`` with ``<include>`` replaced by the included scene's
    top-level elements; ``<path>`` and ``<default>`` are consumed here."""
    out = []
    for c in root:
        ctx.parents[id(c)] = root
        if c.tag == "default":
            ctx.check_attrs(c, ("name", "value"))
            n, v = c.get("name"), c.get("value")
            if n is None or v is None:
                raise ctx.error(c, "<default> needs both name= and value=")
            if n in ctx.defaults:
                raise ctx.error(c, f"duplicate <default name=\"{n}\">")
            ctx.defaults.add(n)
            if n not in ctx.overridden:
                ctx.vars[n] = v
        elif c.tag == "path":
            ctx.check_attrs(c, ("value",))
            folder = Path(ctx.attr(c, "value"))
            ctx.paths.append(folder if folder.is_absolute() else ctx.base / folder)
        elif c.tag == "include":
            ctx.check_attrs(c, ("filename",))
            path = ctx.resolve(c, ctx.attr(c, "filename"))
            if str(path.resolve()) in files:
                raise ctx.error(c, f"the file {str(path)!r} includes itself")
            try:
                text = path.read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError) as exc:
                raise ctx.error(c, f"cannot read the included file {str(path)!r}: {exc}") from None
            sub = parse_xml(text, str(path), ctx)
            check_version(ctx, sub)
            ctx.parents[id(sub)] = c
            out += _expand(ctx, sub, files + (str(path.resolve()),))
        elif c.tag in KINDS:
            out.append(c)
        else:
            raise ctx.error(c, "unsupported top-level element",
                            [f"<{t}>" for t in ("default", "path", "include") + KINDS])
    return out


def _index_ids(ctx: Ctx, elements: list[ET.Element]) -> None:
    """Every object element with an ``id=``, anywhere in the (expanded) tree."""
    for top in elements:
        for e in top.iter():
            for c in e:
                ctx.parents.setdefault(id(c), e)
            if e.tag in KINDS and e.get("id") is not None:
                rid = ctx.attr(e, "id")
                if rid in ctx.ids:
                    raise ctx.error(e, f"duplicate id '{rid}'")
                ctx.ids[rid] = e


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
        shipped = Path(__file__).parent / "scenes" / f"{path.stem}.xml"     # a built-in scene's name
        if shipped.exists() and not path.exists():
            hint = f"; for the built-in scene use load_scene(builtin_scene_path({path.stem!r}))"
        raise SceneError(f"cannot read scene file {str(path)!r}: {exc.strerror or exc}{hint}") from None
    return text, str(path), path.parent


def load_scene(source: str | os.PathLike, params: dict[str, Any] | None = None) -> Scene:
    """Load a Mitsuba 3 scene from a file path or an XML string (starting with ``<``).

    ``params`` override ``<default>`` values for ``$name`` substitution: a dict from
    parameter names the scene uses to strings, numbers, bools or lists of numbers
    (``"1, 2, 3"``).  ``TypeError``/``ValueError`` for a bad ``source`` or ``params``;
    :class:`SceneError` for anything wrong in the scene (see :mod:`vrlab.render.scene`),
    naming the file, the element, its line and the parameters substituted into it.
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
    ctx = Ctx(base, name)
    ctx.vars.update(overrides)
    ctx.overridden = set(overrides)
    root = parse_xml(text, name, ctx)
    check_version(ctx, root)
    files = (str(Path(name).resolve()),) if name != "<string>" else ()
    top = _expand(ctx, root, files)
    referenced = set(re.findall(r"\$(\w+)", text)) | {m for e in top for x in e.iter() for v in x.attrib.values()
                                                      for m in re.findall(r"\$(\w+)", v)}
    unused = sorted(set(overrides) - referenced)
    if unused:
        raise SceneError(f"{name}: params: parameter(s) {', '.join(map(repr, unused))} are not used by the "
                         f"scene (its $parameters: {', '.join(sorted(referenced)) or 'none'}); to change the "
                         "resolution of a scene without a parameter for it, use scene.with_size(width, height) "
                         "or vrlab render --width/--height")
    _index_ids(ctx, top)
    integrator, sensors, shapes, emitters = None, [], [], []
    for c in top:
        obj = build(ctx, c)
        if c.tag == "integrator":
            if integrator is not None:
                raise ctx.error(c, "more than one <integrator>")
            integrator = obj
        elif c.tag == "sensor":
            sensors.append(obj)
        elif c.tag == "shape":
            shapes += _make(ctx, c, Props.empty(ctx, c), obj.scene_shapes)
        elif c.tag == "emitter":
            if getattr(obj, "is_area", False):
                raise ctx.error(c, "an area emitter must be nested inside a <shape>")
            emitters.append(obj)
        elif c.get("id") is None:
            raise ctx.error(c, f"a top-level <{c.tag}> needs an id= to be referenced")
    if integrator is None:
        raise ctx.error(root, "an <integrator> is required (Mitsuba's default is 'path' with infinite depth, "
                              "which vrlab does not render)", ["direct", "path (max_depth 1 or 2)", "moment"])
    if not sensors:
        raise ctx.error(root, "a <sensor> is required", sorted(registered("sensor")))
    if not shapes:
        raise ctx.error(root, "the scene has no shapes")
    # Mitsuba renders the first sensor by default
    scene = Scene(integrator, sensors[0], shapes, emitters, name)
    scene.files = list(ctx.files)
    return scene
