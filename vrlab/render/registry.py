"""The registry of scene elements: one class per Mitsuba 3 plugin, looked up by kind and name.

Every element a scene file can name (``<shape type="sphere">``, ``<bsdf type="diffuse">``,
...) is a class registered once, under its Mitsuba 3 plugin name, with the decorator
:func:`register`; the loader (:func:`vrlab.render.load_scene`) finds the class through
:func:`registered` and builds it with ``cls.from_props(props)``, so it has no per-type
branches.  A user registers an element of their own the same way::

    from vrlab.render import register
    from vrlab.render.bsdfs import BSDFModel

    @register("bsdf", "halfdiffuse")
    class HalfDiffuse(BSDFModel):
        ...

after which ``<bsdf type="halfdiffuse">`` loads.  Kinds are those of Mitsuba 3:
``shape``, ``emitter``, ``bsdf``, ``texture``, ``volume`` (3D grids that the ``volume``
texture reads), ``sensor``, ``film``, ``rfilter``, ``sampler`` and ``integrator``.

The registry is a table of classes (as Mitsuba's plugin manager), filled when the
element packages are imported; it carries no job state.
"""
from __future__ import annotations

import importlib
import re
import sys
from pathlib import Path
from typing import Any, ClassVar

__all__ = ["KINDS", "Element", "element_class", "lazy_package", "register", "registered"]

KINDS = ("shape", "emitter", "bsdf", "texture", "volume", "sensor", "film", "rfilter", "sampler", "integrator")

# the package of each kind's built-in elements (imported on first lookup)
_PACKAGES = {"shape": "shapes", "emitter": "emitters", "bsdf": "bsdfs", "texture": "textures", "volume": "volumes",
             "sensor": "sensors", "film": "sensors", "rfilter": "sensors", "sampler": "sensors",
             "integrator": "integrators"}
_TABLE: dict[str, dict[str, type]] = {k: {} for k in KINDS}
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class Element:
    """Base of every scene element.

    Subclasses set ``kind`` (through their kind's base class) and get ``plugin_name`` from
    :func:`register`.  ``from_props(props)`` builds the element from a scene file's
    properties (:class:`vrlab.render.xml_props.Props`: typed getters that remember what
    was read, so that an unknown parameter is refused by the loader); the constructor
    takes the same parameters as keyword arguments and checks them, raising
    ``TypeError``/``ValueError`` whose message starts with the parameter's name.
    ``id`` is the scene file's ``id=`` (None when built in Python).
    """

    kind: ClassVar[str] = ""
    plugin_name: ClassVar[str | None] = None
    id: str | None = None

    @classmethod
    def from_props(cls, props: Any) -> Element:   # pragma: no cover - every element overrides it
        raise NotImplementedError(f"{cls.__name__} cannot be read from a scene file")

    def validate(self) -> None:
        """Check the element's settings again (after a change in place); default: nothing."""

    def __repr__(self) -> str:
        return f"{type(self).__name__}(plugin={self.plugin_name!r}, id={self.id!r})"


def register(kind: str, name: str, *, replace: bool = False):
    """Class decorator: register ``cls`` as the element ``name`` of ``kind``.

    ``cls`` must subclass :class:`Element` with ``cls.kind == kind`` (subclass the kind's
    base class: :class:`vrlab.render.shapes.Shape`, :class:`vrlab.render.bsdfs.BSDFModel`,
    ...).  A name that is already taken by another class is refused unless ``replace``.
    """
    if kind not in KINDS:
        raise ValueError(f"kind: unknown element kind {kind!r}; allowed: {', '.join(KINDS)}")
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise ValueError(f"name: {name!r} is not a plugin name (letters, digits and _, not starting with a digit)")

    def decorate(cls: type) -> type:
        if not isinstance(cls, type) or not issubclass(cls, Element):
            raise TypeError(f"register({kind!r}, {name!r}): expected a subclass of vrlab.render.Element, got {cls!r}")
        if cls.kind != kind:
            raise TypeError(f"register({kind!r}, {name!r}): {cls.__name__} is a {cls.kind or 'kind-less'} element; "
                            f"subclass the {kind} base class")
        old = element_class(kind, name) if name not in _TABLE[kind] else _TABLE[kind][name]
        if old is not None and old is not cls and not replace and old.__qualname__ != cls.__qualname__:
            raise ValueError(f"name: the {kind} {name!r} is already registered ({old.__module__}.{old.__qualname__}); "
                             "pass replace=True to replace it")
        cls.plugin_name = name
        _TABLE[kind][name] = cls
        return cls

    return decorate


_ALL = re.compile(r"^__all__\s*=\s*\[(.*?)\]", re.S | re.M)
_REGISTER = re.compile(r"^@register\(\s*\"(\w+)\"\s*,\s*\"(\w+)\"", re.M)
_INDEX: dict[str, tuple[dict[str, str], dict[tuple[str, str], str]]] = {}


def _index(package: str) -> tuple[dict[str, str], dict[tuple[str, str], str]]:
    """``({public name: module}, {(kind, plugin name): module})`` of an element package, read
    from its modules' ``__all__`` and ``@register`` lines without importing them (importing
    every element of a kind costs start-up time that a scene using three of them, and every
    worker process, would pay)."""
    if package not in _INDEX:
        names: dict[str, str] = {}
        plugins: dict[tuple[str, str], str] = {}
        folder = Path(sys.modules[package].__file__).parent
        for f in sorted(folder.glob("*.py")):
            if f.name == "__init__.py":
                continue
            text = f.read_text(encoding="utf-8")
            m = _ALL.search(text)
            for name in re.findall(r"[\"'](\w+)[\"']", m.group(1)) if m else ():
                names[name] = f.stem
            for kind, plugin in _REGISTER.findall(text):
                plugins[(kind, plugin)] = f.stem
        _INDEX[package] = (names, plugins)
    return _INDEX[package]


def lazy_package(package: str):
    """``(__getattr__, __dir__)`` for an element package: every public name of its modules
    (and ``__all__``), imported from its module on first use (:func:`_index`, itself read on
    first use: a worker process that unpickles two elements reads no other module)."""

    def __getattr__(name: str):
        names = _index(package)[0]
        if name == "__all__":
            return sorted(names)
        if name in names:
            value = getattr(importlib.import_module(f"{package}.{names[name]}"), name)
            setattr(sys.modules[package], name, value)
            return value
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(_index(package)[0]))

    return __getattr__, __dir__


_LOADED: set[str] = set()


def _load_builtins(kind: str) -> None:
    """Import every built-in element module of ``kind`` (their ``@register`` runs)."""
    pkg = f"vrlab.render.{_PACKAGES[kind]}"
    if (pkg, kind) not in _LOADED:
        _LOADED.add((pkg, kind))
        importlib.import_module(pkg)
        for (k, _), module in _index(pkg)[1].items():
            if k == kind:
                importlib.import_module(f"{pkg}.{module}")


def registered(kind: str) -> dict[str, type]:
    """``{plugin name: class}`` of every registered element of ``kind`` (a copy)."""
    if kind not in KINDS:
        raise ValueError(f"kind: unknown element kind {kind!r}; allowed: {', '.join(KINDS)}")
    _load_builtins(kind)
    return dict(_TABLE[kind])


def element_class(kind: str, name: str) -> type | None:
    """The class registered as ``name`` of ``kind``, or None; a built-in element's module is
    imported on first use, alone."""
    if kind not in KINDS:
        raise ValueError(f"kind: unknown element kind {kind!r}; allowed: {', '.join(KINDS)}")
    if name not in _TABLE[kind]:
        pkg = f"vrlab.render.{_PACKAGES[kind]}"
        importlib.import_module(pkg)
        module = _index(pkg)[1].get((kind, name))
        if module is not None:
            importlib.import_module(f"{pkg}.{module}")
    return _TABLE[kind].get(name)
