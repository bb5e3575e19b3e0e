"""The typed properties an element's ``from_props`` reads (:class:`Props`), and the
``<transform>`` operations. Parsing and the reading context are :mod:`vrlab.render.xml_reader`'s."""
from __future__ import annotations

import difflib
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np

from . import transforms as tf
from .registry import KINDS
from .xml_reader import Ctx, SceneError, check_version, parse_xml

__all__ = ["Ctx", "Props", "SceneError", "check_version", "parse_xml", "parse_transform", "xyz"]

PROP_TAGS = ("float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector", "transform")


class Props:
    """The children of one element, by name: properties (``<float name=..>``, ...), named
    nested objects and references (``<texture name="reflectance">``, ``<ref name=.. id=..>``)
    and unnamed nested objects.  The getters convert and check values and remember what
    was read; :meth:`check_unused` refuses the rest, naming it."""

    def __init__(self, ctx: Ctx, el: ET.Element, build):
        self.ctx, self.el = ctx, el
        self.plugin = el.get("type")
        self.values: dict[str, ET.Element] = {}
        self.named: dict[str, tuple[ET.Element, Any]] = {}
        self.objects: list[tuple[ET.Element, Any]] = []
        self.used: set[str] = set()
        self.asked: set[str] = set()          # names from_props asked about (has()) without reading them
        self.used_objects: set[int] = set()
        for c in el:
            if c.tag in PROP_TAGS:
                name = ctx.attr(c, "name")
                if name in self.values or name in self.named:
                    raise ctx.error(c, f"parameter '{name}' given twice")
                self.values[name] = c
            elif c.tag in KINDS or c.tag == "ref":
                obj = build(c)
                name = ctx.attr(c, "name", required=False)
                if name is not None:
                    if name in self.values or name in self.named:
                        raise ctx.error(c, f"parameter '{name}' given twice")
                    self.named[name] = (c, obj)
                else:
                    self.objects.append((c, obj))
            else:
                raise ctx.error(c, f"unsupported child of {self.what}",
                                [f"<{t}>" for t in PROP_TAGS + KINDS + ("ref",)])

    @classmethod
    def empty(cls, ctx: Ctx, el: ET.Element) -> "Props":
        """Props that name no parameter (for errors about the element as a whole)."""
        out = cls.__new__(cls)
        out.ctx, out.el, out.plugin = ctx, el, el.get("type")
        out.values, out.named, out.objects, out.used, out.used_objects = {}, {}, [], set(), set()
        return out

    @property
    def what(self) -> str:
        return f"{self.el.tag} '{self.plugin}'"

    def has(self, name: str) -> bool:
        """Is parameter ``name`` given?  (A parameter of the element: an unknown name's error
        lists it and may suggest it.)"""
        self.asked.add(name)
        return name in self.values or name in self.named

    def element(self, name: str) -> ET.Element | None:
        """The XML element of parameter ``name`` (for error messages), or None."""
        if name in self.values:
            return self.values[name]
        return self.named[name][0] if name in self.named else None

    def _prop(self, name: str, tags: tuple[str, ...], required: bool) -> ET.Element | None:
        self.used.add(name)
        if name in self.named:
            c = self.named[name][0]
            raise self.ctx.error(c, f"parameter '{name}' of {self.what} cannot be an object here",
                                 [f"<{t}>" for t in tags])
        c = self.values.get(name)
        if c is None:
            if required:
                given = [k for k in list(self.values) + list(self.named) if k not in self.used]
                close = difflib.get_close_matches(name, given, n=1, cutoff=0.6)
                hint = f" (is the given '{close[0]}' a typo of it?)" if close else ""
                raise self.ctx.error(self.el, f"missing required parameter '{name}'{hint}")
            return None
        if c.tag not in tags:
            raise self.ctx.error(c, f"parameter '{name}' of {self.what} cannot be <{c.tag}>",
                                 [f"<{t}>" for t in tags])
        return c

    def float(self, name: str, default: float | None = None) -> float:
        c = self._prop(name, ("float", "integer"), default is None)
        if c is None:
            return default
        self.ctx.check_attrs(c, ("name", "value"))
        return float(self.ctx.numbers(c, "value", (1,))[0])

    def int(self, name: str, default: int | None = None) -> int:
        c = self._prop(name, ("integer",), default is None)
        if c is None:
            return default
        self.ctx.check_attrs(c, ("name", "value"))
        text = self.ctx.attr(c, "value")
        if not re.fullmatch(r"\s*[+-]?\d+\s*", text):
            raise self.ctx.error(c, f"'{name}': value={text!r} is not an integer")
        return int(text)

    def bool(self, name: str, default: bool | None = None) -> bool:
        c = self._prop(name, ("boolean",), default is None)
        if c is None:
            return default
        self.ctx.check_attrs(c, ("name", "value"))
        text = self.ctx.attr(c, "value").strip().lower()
        if text not in ("true", "false"):
            raise self.ctx.error(c, f"'{name}': value={text!r} is not a boolean", ["true", "false"])
        return text == "true"

    def string(self, name: str, default: str | None = None, choices: tuple[str, ...] | None = None) -> str:
        c = self._prop(name, ("string",), default is None)
        if c is None:
            return default
        self.ctx.check_attrs(c, ("name", "value"))
        text = self.ctx.attr(c, "value")
        if choices is not None and text not in choices:
            raise self.ctx.error(c, f"unsupported value {text!r} for '{name}'", choices)
        return text

    def filename(self, name: str) -> Path:
        """A file parameter resolved against the scene folder and the ``<path>`` folders."""
        text = self.string(name)
        return self.ctx.resolve(self.values[name], text)

    def color(self, name: str, default: Any = None, *, kind: str = "reflectance", texture: bool = False):
        """A colour ``(3,)``: ``<rgb>``, ``<spectrum>`` (one value, or wavelength:value pairs
        converted as Mitsuba's RGB variants do, :mod:`vrlab.render.spectra`; ``kind`` is
        ``"reflectance"``, ``"emission"`` or ``"unbounded"``) or ``<float>``; with ``texture``
        also a nested or referenced ``<texture>`` (returned as the texture object)."""
        self.used.add(name)
        if name in self.named:
            c, obj = self.named[name]
            if not texture or getattr(obj, "kind", None) != "texture":
                raise self.ctx.error(c, f"parameter '{name}' of {self.what} cannot be "
                                        f"{'a ' + obj.kind if hasattr(obj, 'kind') else 'this object'}",
                                     ["<rgb>", "<spectrum>", "<float>"] + (["<texture>"] if texture else []))
            return obj
        c = self._prop(name, ("rgb", "spectrum", "float", "integer"), default is None)
        if c is None:
            return np.full(3, float(default)) if np.ndim(default) == 0 else np.asarray(default, float)
        return self._color_value(c, name, kind)

    def _color_value(self, c: ET.Element, name: str, kind: str) -> np.ndarray:
        if c.tag == "spectrum" and c.get("type") is not None:
            return self._spectrum_plugin(c, name, kind)
        if c.tag == "spectrum":
            self.ctx.check_attrs(c, ("name", "value", "filename"))
            from . import spectra

            try:
                if c.get("filename") is not None:
                    value = spectra.load_spd(self.ctx.resolve(c, self.ctx.attr(c, "filename")))
                else:
                    value = self.ctx.attr(c, "value")
                v = np.asarray(spectra.spectrum_property_rgb(value, kind=kind, warn=False), float)
            except (ValueError, OSError) as exc:
                raise self.ctx.error(c, f"'{name}': {exc}") from None
        else:
            self.ctx.check_attrs(c, ("name", "value"))
            counts = {"rgb": (1, 3)}.get(c.tag, (1,))
            v = np.broadcast_to(self.ctx.numbers(c, "value", counts), (3,)).astype(float)
        return v

    def _spectrum_plugin(self, c: ET.Element, name: str, kind: str) -> np.ndarray:
        """``<spectrum type=...>``: ``blackbody`` (``temperature``; an emission: Mitsuba's RGB
        variants load it but cannot render it, vrlab gives what its spectral variants render,
        :func:`vrlab.render.spectra.blackbody_rgb`), ``regular`` (``wavelength_min``,
        ``wavelength_max``, ``values``) and ``irregular`` (``wavelengths``, ``values``)."""
        from . import spectra

        self.ctx.check_attrs(c, ("name", "type"))
        t = self.ctx.attr(c, "type")
        sub = Props(self.ctx, c, lambda e: None)
        try:
            if t == "blackbody":
                if kind != "emission":
                    raise ValueError("a blackbody spectrum is an emission (radiance, irradiance, intensity)")
                value = spectra.blackbody_rgb(sub.float("temperature"))
            elif t == "regular":
                vals = self.ctx.numbers(sub._prop("values", ("string",), True), "value")
                lo, hi = sub.float("wavelength_min"), sub.float("wavelength_max")
                value = spectra.spectrum_to_rgb(np.linspace(lo, hi, len(vals)), vals, kind=kind, warn=False)
            elif t == "irregular":
                wl = self.ctx.numbers(sub._prop("wavelengths", ("string",), True), "value")
                vals = self.ctx.numbers(sub._prop("values", ("string",), True), "value")
                value = spectra.spectrum_to_rgb(wl, vals, kind=kind, warn=False)
            else:
                raise ValueError(f"unsupported spectrum type {t!r}; supported: blackbody, regular, irregular")
        except SceneError:
            raise
        except ValueError as exc:
            raise self.ctx.error(c, f"'{name}': {exc}") from None
        sub.check_unused()
        return np.asarray(value, float)

    def texture(self, name: str, default: Any = None, *, kind: str = "reflectance"):
        """A colour or a texture (:meth:`color` with ``texture=True``)."""
        return self.color(name, default, kind=kind, texture=True)

    def point(self, name: str, default: tuple[float, float, float] | None = None) -> np.ndarray:
        c = self._prop(name, ("point", "vector"), default is None)
        if c is None:
            return np.array(default, float)
        return xyz(self.ctx, c, 0.0, allow_uniform=False)

    vector = point

    def transform(self, name: str) -> np.ndarray:
        c = self._prop(name, ("transform",), False)
        return np.eye(4) if c is None else parse_transform(self.ctx, c)

    def object(self, name: str, kinds: tuple[str, ...], required: bool = False):
        """The nested object named ``name`` (one of ``kinds``), or None."""
        self.used.add(name)
        if name in self.values:
            c = self.values[name]
            raise self.ctx.error(c, f"parameter '{name}' of {self.what} must be an object",
                                 [f"<{k}>" for k in kinds])
        if name not in self.named:
            if required:
                raise self.ctx.error(self.el, f"missing required <{'/'.join(kinds)} name=\"{name}\">")
            return None
        c, obj = self.named[name]
        if obj.kind not in kinds:
            raise self.ctx.error(c, f"parameter '{name}' of {self.what} must be a {' or '.join(kinds)}, "
                                    f"got a {obj.kind}")
        return obj

    def scalar(self, name: str, default: float | None = None):
        """A scalar parameter that may also be a texture (a roughness, a weight, an opacity):
        the nested or referenced ``<texture name=...>``, else the ``<float>`` (or ``default``)."""
        if name in self.named:
            return self.object(name, ("texture",))
        return self.float(name, default)

    def children(self, kind: str, at_most: int | None = None) -> list:
        """The nested objects (and references) of ``kind``, in document order: the unnamed
        ones and, as in Mitsuba (which finds a shape's BSDF by its kind), named ones too."""
        named = {id(c) for c, _ in self.named.values()}
        out = [(c, o) for c in self.el for c, o in [self._built(c)] if o is not None and o.kind == kind
               and (id(c) in named or any(c is x for x, _ in self.objects))]
        if at_most is not None and len(out) > at_most:
            raise self.ctx.error(out[at_most][0], f"{self.what} takes at most {at_most} <{kind}>")
        for c, _ in out:
            self.used_objects.add(id(c))
            if c.get("name") is not None:
                self.used.add(self.ctx.attr(c, "name"))
        return [o for _, o in out]

    def _built(self, c: ET.Element):
        for x, o in self.objects:
            if x is c:
                return c, o
        for x, o in self.named.values():
            if x is c:
                return c, o
        return c, None

    def child(self, kind: str):
        """The one unnamed nested object of ``kind``, or None."""
        found = self.children(kind, at_most=1)
        return found[0] if found else None

    def parameters(self) -> list[str]:
        """The element's parameters: every name ``from_props`` read or asked about (:meth:`has`),
        given or not, sorted."""
        return sorted(self.used | self.asked)

    def check_unused(self, supported: list[str] | None = None) -> None:
        """Refuse the parameters and nested objects that ``from_props`` did not read; an unknown
        name's error suggests the close matches among all of the element's parameters
        (``difflib``; ``fvo`` -> ``fov``) and lists them all."""
        for name, c in list(self.values.items()) + [(n, c) for n, (c, _) in self.named.items()]:
            if name not in self.used:
                known = self.parameters() if supported is None else list(supported)
                close = difflib.get_close_matches(name, [k for k in known if k != name], n=3, cutoff=0.6)
                hint = f" (did you mean {' or '.join(repr(k) for k in close)}?)" if close else ""
                raise self.ctx.error(c, f"unknown parameter '{name}' for {self.what}{hint}", known or ["no parameters"])
        for c, obj in self.objects:
            if id(c) not in self.used_objects:
                raise self.ctx.error(c, f"{self.what} does not take a nested <{obj.kind}>")


def xyz(ctx: Ctx, el: ET.Element, default: float, allow_uniform: bool,
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


def parse_transform(ctx: Ctx, el: ET.Element) -> np.ndarray:
    """A ``<transform>``: its operations, each left-multiplying the matrix so far."""
    ctx.check_attrs(el, ("name",))
    ops = ("translate", "scale", "rotate", "lookat", "matrix")
    m = np.eye(4)
    for c in el:
        try:
            if c.tag == "translate":
                op = tf.translate(xyz(ctx, c, 0.0, allow_uniform=False))
            elif c.tag == "scale":
                op = tf.scale(xyz(ctx, c, 1.0, allow_uniform=True))
            elif c.tag == "rotate":
                if c.get("angle") is None:
                    raise ctx.error(c, "missing required attribute 'angle' (degrees)")
                axis = xyz(ctx, c, 0.0, allow_uniform=False, extra=("angle",))
                op = tf.rotate(axis, ctx.numbers(c, "angle", (1,))[0], normalize=False)    # as Mitsuba
            elif c.tag == "lookat":
                ctx.check_attrs(c, ("origin", "target", "up"))
                up = ctx.numbers(c, "up", (3,)) if c.get("up") is not None else _default_up(ctx, c)
                op = tf.look_at(ctx.numbers(c, "origin", (3,)), ctx.numbers(c, "target", (3,)), up)
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


def _default_up(ctx: Ctx, c: ET.Element) -> np.ndarray:
    """Mitsuba's ``lookat`` without ``up``: a vector orthogonal to the view direction
    (``coordinate_system(dir)``'s first tangent)."""
    d = ctx.numbers(c, "target", (3,)) - ctx.numbers(c, "origin", (3,))
    n = d / max(np.linalg.norm(d), 1e-300)
    sign = 1.0 if n[2] >= 0 else -1.0
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    return np.array([1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]])
