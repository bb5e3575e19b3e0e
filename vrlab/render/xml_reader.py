"""Reading Mitsuba XML: line-numbered parsing (expat), ``<scene version=..>``, and what the
reading of one scene knows (:class:`Ctx`: where each element came from, ``$defaults``, search
paths, the objects built so far). The typed properties are :mod:`vrlab.render.xml_props`'s."""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from xml.parsers import expat
from pathlib import Path
from typing import Any

import numpy as np


class SceneError(ValueError):
    """A scene file uses something outside the supported subset, or is malformed."""


_NUM = re.compile(r"[,\s]+")
_VAR = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")


class Ctx:
    """What the reading of one scene knows: where each element came from (file, line), the
    ``$name`` values, the search paths and the objects built so far (by element and id)."""

    def __init__(self, base: Path, source: str = "<string>"):
        self.where: dict[int, tuple[str, int]] = {}      # id(element) -> (file, line)
        self.parents: dict[int, ET.Element] = {}
        self.base, self.source = base, source
        self.paths: list[Path] = [base]
        self.vars: dict[str, str] = {}
        self.overridden: set[str] = set()               # names set through load_scene(params=...)
        self.defaults: set[str] = set()                 # names of the <default>s read so far
        self.ids: dict[str, ET.Element] = {}           # id= -> its element
        self.built: dict[int, Any] = {}                # id(element) -> the object built from it
        self.building: set[int] = set()
        self.files: list[Path] = []                    # every file the scene reads (includes, meshes, ...)
        self._seen: set[Path] = set()

    def describe(self, el: ET.Element) -> str:
        attrs = "".join(f' {k}="{el.get(k)}"' for k in ("type", "name", "id") if el.get(k) is not None)
        path, e = [], el
        while e is not None:
            path.append(e.tag)
            e = self.parents.get(id(e))
        src, line = self.where.get(id(el), (self.source, None))
        at = f" at line {line}" if line is not None else ""
        return f"<{el.tag}{attrs}>{at} of {src} (in {'/'.join(reversed(path))})"

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

    def resolve(self, el: ET.Element, filename: str) -> Path:
        """A file named in the scene: absolute, or relative to the scene's folder and the
        ``<path>`` folders (in the order given, the scene's own folder first)."""
        p = Path(filename)
        found = p if p.is_absolute() else next((f / p for f in self.paths if (f / p).exists()), self.base / p)
        if found not in self._seen:                    # (a set: scenes name hundreds of files)
            self._seen.add(found)
            self.files.append(found)
        return found


def parse_xml(text: str, source: str, ctx: Ctx) -> ET.Element:
    """An ElementTree built with expat, recording each element's file and line in ``ctx``."""
    builder = ET.TreeBuilder()
    parser = expat.ParserCreate()

    def start(tag: str, attrs: dict[str, str]) -> None:
        ctx.where[id(builder.start(tag, attrs))] = (source, parser.CurrentLineNumber)

    parser.StartElementHandler = start
    parser.EndElementHandler = builder.end
    try:
        parser.Parse(text, True)
        root = builder.close()
    except (expat.ExpatError, AssertionError) as exc:
        raise SceneError(f"{source}: not a well-formed XML scene: {exc}") from None
    return root


def check_version(ctx: Ctx, root: ET.Element) -> None:
    """``<scene version="2.x.y">`` or ``"3.x.y"`` (the same file format in Mitsuba 3)."""
    if root.tag != "scene":
        raise ctx.error(root, "the root element must be <scene version=\"3.x.y\">", ["scene"])
    ctx.check_attrs(root, ("version",))
    version = ctx.attr(root, "version")
    if not re.fullmatch(r"[23](\.\d+){0,2}", version.strip()):
        raise ctx.error(root, f"scene version {version!r} is not supported (Mitsuba 0.x scenes use other "
                              "parameter names)", ["2.x.y", "3.x.y"])
