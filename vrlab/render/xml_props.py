"""Reading Mitsuba XML: line-numbered parsing, $defaults, typed properties, transforms."""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from xml.parsers import expat
from pathlib import Path
from typing import Any

import numpy as np

from . import transforms as tf

from .scene import BSDF, SceneError


# ----------------------------------------------------------------------------- parsing
_PROP_TAGS = ("float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector",
              "transform")
_NUM = re.compile(r"[,\s]+")
_VAR = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")


class _Ctx:
    def __init__(self, lines: dict[int, int], parents: dict[int, ET.Element], base: Path,
                 source: str = "<string>"):
        self.lines, self.parents, self.base, self.source = lines, parents, base, source
        self.vars: dict[str, str] = {}
        self.overridden: set[str] = set()     # names set through load_scene(params=...)
        self.bsdfs: dict[str, BSDF] = {}

    def describe(self, el: ET.Element) -> str:
        attrs = "".join(f' {k}="{el.get(k)}"' for k in ("type", "name", "id") if el.get(k) is not None)
        path, e = [], el
        while e is not None:
            path.append(e.tag)
            e = self.parents.get(id(e))
        line = self.lines.get(id(el))
        where = f" at line {line}" if line is not None else ""
        return f"<{el.tag}{attrs}>{where} of {self.source} (in {'/'.join(reversed(path))})"

    def error(self, el: ET.Element, msg: str, supported: Any = None,
              scope: ET.Element | None = None) -> SceneError:
        """A :class:`SceneError` naming the file, the element and its line, the ``$name``
        parameters used in it (or in ``scope``, the plugin it belongs to, with their values)
        and what is supported."""
        text = f"{self.describe(el)}: {msg}"
        if supported is not None:
            items = supported if isinstance(supported, str) else ", ".join(supported)
            text += f"; supported: {items}"
        used = sorted({m for e in (scope if scope is not None else el).iter() for v in e.attrib.values()
                       for m in _VAR.findall(v) if m in self.vars})
        if used:
            notes = [f"${n} = {self.vars[n]!r}" + (" (from params)" if n in self.overridden else "")
                     for n in used]
            text += f" [parameters used here: {', '.join(notes)}]"
        return SceneError(text)

    def attr(self, el: ET.Element, key: str, required: bool = True) -> str | None:
        raw = el.get(key)
        if raw is None:
            if required:
                raise self.error(el, f"missing required attribute '{key}'")
            return None

        def sub(m: re.Match) -> str:
            if m.group(1) not in self.vars:
                raise self.error(el, f"undefined parameter '${m.group(1)}' in attribute '{key}'",
                                 sorted(self.vars) or "none defined (use <default name=.. value=../>)")
            return self.vars[m.group(1)]
        return _VAR.sub(sub, raw)

    def numbers(self, el: ET.Element, key: str, count: tuple[int, ...] | None = None) -> np.ndarray:
        text = self.attr(el, key)
        try:
            vals = np.array([float(t) for t in _NUM.split(text.strip()) if t], float)
        except ValueError:
            raise self.error(el, f"attribute {key}={text!r} is not a list of numbers") from None
        if not np.all(np.isfinite(vals)) or (count is not None and vals.size not in count):
            want = " or ".join(map(str, count)) if count else "finite"
            raise self.error(el, f"attribute {key}={text!r}: expected {want} finite numbers")
        return vals

    def check_attrs(self, el: ET.Element, allowed: tuple[str, ...]) -> None:
        extra = sorted(set(el.attrib) - set(allowed))
        if extra:
            raise self.error(el, f"unknown attribute(s) {', '.join(extra)}", allowed)


def _parse_xml(text: str, source: str = "<string>") -> tuple[ET.Element, dict[int, int], dict[int, ET.Element]]:
    """Build an ElementTree with expat, recording each element's line number."""
    lines: dict[int, int] = {}
    builder = ET.TreeBuilder()
    parser = expat.ParserCreate()

    def start(tag: str, attrs: dict[str, str]) -> None:
        lines[id(builder.start(tag, attrs))] = parser.CurrentLineNumber

    parser.StartElementHandler = start
    parser.EndElementHandler = builder.end
    try:
        parser.Parse(text, True)
        root = builder.close()
    except (expat.ExpatError, AssertionError) as exc:
        raise SceneError(f"{source}: not a well-formed XML scene: {exc}") from None
    parents = {id(c): p for p in root.iter() for c in p}
    return root, lines, parents


class _Props:
    """Children of a plugin element: named properties and nested objects, checked by name."""

    def __init__(self, ctx: _Ctx, el: ET.Element, allowed: dict[str, tuple[str, ...]],
                 objects: tuple[str, ...] = ()):
        self.ctx, self.el = ctx, el
        self.props: dict[str, ET.Element] = {}
        self.objects: list[ET.Element] = []
        what = f"{el.tag} '{el.get('type')}'"
        supported = [f"{n} ({'/'.join(k)})" for n, k in allowed.items()] + [f"<{o}>" for o in objects]
        supported = supported or ["no parameters"]
        for c in el:
            if c.tag in objects:
                self.objects.append(c)
                continue
            if c.tag not in _PROP_TAGS:
                if c.get("name") in allowed:
                    raise ctx.error(c, f"parameter '{c.get('name')}' of {what} cannot be <{c.tag}>",
                                    [f"<{k}>" for k in allowed[c.get("name")]])
                raise ctx.error(c, f"unsupported child of {what}", supported)
            name = ctx.attr(c, "name")
            if name not in allowed:
                raise ctx.error(c, f"unknown parameter '{name}' for {what}", supported)
            if c.tag not in allowed[name]:
                raise ctx.error(c, f"parameter '{name}' of {what} cannot be <{c.tag}>",
                                [f"<{k}>" for k in allowed[name]])
            if name in self.props:
                raise ctx.error(c, f"parameter '{name}' given twice")
            self.props[name] = c

    def has(self, name: str) -> bool:
        return name in self.props

    def float(self, name: str, default: float | None = None) -> float:
        c = self.props.get(name)
        if c is None:
            if default is None:
                raise self.ctx.error(self.el, f"missing required parameter '{name}'")
            return default
        self.ctx.check_attrs(c, ("name", "value"))
        return float(self.ctx.numbers(c, "value", (1,))[0])

    def int(self, name: str, default: int) -> int:
        c = self.props.get(name)
        if c is None:
            return default
        self.ctx.check_attrs(c, ("name", "value"))
        text = self.ctx.attr(c, "value")
        if not re.fullmatch(r"\s*[+-]?\d+\s*", text):
            raise self.ctx.error(c, f"'{name}': value={text!r} is not an integer")
        return int(text)

    def bool(self, name: str, default: bool) -> bool:
        c = self.props.get(name)
        if c is None:
            return default
        self.ctx.check_attrs(c, ("name", "value"))
        text = self.ctx.attr(c, "value").strip().lower()
        if text not in ("true", "false"):
            raise self.ctx.error(c, f"'{name}': value={text!r} is not a boolean", ["true", "false"])
        return text == "true"

    def string(self, name: str, default: str | None, choices: tuple[str, ...] | None = None) -> str:
        c = self.props.get(name)
        if c is None:
            if default is None:
                raise self.ctx.error(self.el, f"missing required parameter '{name}'")
            return default
        self.ctx.check_attrs(c, ("name", "value"))
        text = self.ctx.attr(c, "value")
        if choices is not None and text not in choices:
            raise self.ctx.error(c, f"unsupported value {text!r} for '{name}'", choices)
        return text

    def rgb(self, name: str, default: float | None) -> np.ndarray:
        c = self.props.get(name)
        if c is None:
            if default is None:
                raise self.ctx.error(self.el, f"missing required parameter '{name}'")
            return np.full(3, float(default))
        self.ctx.check_attrs(c, ("name", "value"))
        counts = {"rgb": (1, 3), "spectrum": (1,), "float": (1,)}[c.tag]
        v = self.ctx.numbers(c, "value", counts)
        if np.any(v < 0):
            raise self.ctx.error(c, f"'{name}' must be non-negative, got {self.ctx.attr(c, 'value')!r}")
        return np.broadcast_to(v, (3,)).astype(float)

    def vector(self, name: str, default: tuple[float, float, float]) -> np.ndarray:
        c = self.props.get(name)
        if c is None:
            return np.array(default, float)
        return _xyz(self.ctx, c, 0.0, allow_uniform=False)

    def transform(self, name: str) -> np.ndarray:
        c = self.props.get(name)
        return np.eye(4) if c is None else _parse_transform(self.ctx, c)


def _xyz(ctx: _Ctx, el: ET.Element, default: float, allow_uniform: bool,
         extra: tuple[str, ...] = ()) -> np.ndarray:
    """A 3-vector from ``value="x, y, z"`` or ``x= y= z=`` attributes."""
    ctx.check_attrs(el, ("name", "value", "x", "y", "z") + extra)
    if el.get("value") is not None:
        if any(el.get(k) is not None for k in "xyz"):
            raise ctx.error(el, "give either value= or x=/y=/z=, not both")
        v = ctx.numbers(el, "value", (1, 3) if allow_uniform else (3,))
        return np.broadcast_to(v, (3,)).astype(float)
    if not any(el.get(k) is not None for k in "xyz"):
        raise ctx.error(el, "missing value= (or x=, y=, z=)")
    return np.array([ctx.numbers(el, k, (1,))[0] if el.get(k) is not None else default
                     for k in "xyz"])


def _parse_transform(ctx: _Ctx, el: ET.Element) -> np.ndarray:
    ctx.check_attrs(el, ("name",))
    ops = ("translate", "scale", "rotate", "lookat", "matrix")
    m = np.eye(4)
    for c in el:
        try:
            if c.tag == "translate":
                op = tf.translate(_xyz(ctx, c, 0.0, allow_uniform=False))
            elif c.tag == "scale":
                op = tf.scale(_xyz(ctx, c, 1.0, allow_uniform=True))
            elif c.tag == "rotate":
                if c.get("angle") is None:
                    raise ctx.error(c, "missing required attribute 'angle' (degrees)")
                axis = _xyz(ctx, c, 0.0, allow_uniform=False, extra=("angle",))
                op = tf.rotate(axis, ctx.numbers(c, "angle", (1,))[0])
            elif c.tag == "lookat":
                ctx.check_attrs(c, ("origin", "target", "up"))
                op = tf.look_at(*(ctx.numbers(c, k, (3,)) for k in ("origin", "target", "up")))
            elif c.tag == "matrix":
                ctx.check_attrs(c, ("value",))
                op = tf.matrix(ctx.numbers(c, "value", (16, 9)))
            else:
                raise ctx.error(c, "unsupported transform operation", ops)
        except SceneError:
            raise
        except ValueError as exc:
            raise ctx.error(c, str(exc)) from None
        m = op @ m
    if abs(np.linalg.det(m[:3, :3])) < 1e-300:
        raise ctx.error(el, f"the transform '{el.get('name')}' is singular (a zero scale?)")
    return m
