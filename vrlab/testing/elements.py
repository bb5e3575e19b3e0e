"""What ``check_bsdf`` and ``check_emitter`` share: building an element from a registered name
(or class) and keyword parameters, the ``params`` check (bad parameters refused, naming them),
the Mitsuba 3 plugin dict of the same element, and a chart turned towards a direction.

**Parameters.**  A parameter may be given as a plugin dict ``{"type": "roughconductor",
"alpha": 0.3}``: it is built through the registry (a BSDF, else a texture of that name), and the
Mitsuba comparison gets the same dict.  A vrlab object (an instance) is used as it is, but then
Mitsuba's element cannot be built from the parameters and that comparison is skipped.

**params check.**  For every constructor parameter whose value (given, or the default) is a
real number or a real array: NaN must be refused (``ValueError``/``TypeError`` naming the
parameter), and so must -1 unless the class lists the parameter in ``SIGNED_PARAMS`` (a
parameter that may be negative or is clamped, as Mitsuba clamps a mask's opacity) or it is a
position, a direction or a transform (``POINT_PARAMS``, ``to_world``, ``to_uv``); a string
parameter must refuse ``"no-such-value"``, a boolean one the string ``"yes"``.
"""
from __future__ import annotations

import inspect
from typing import Any

import numpy as np

from ..distributions import to_local, to_world

__all__ = ["RotatedChart", "build_element", "check_params", "mitsuba_spec", "NoSpec", "unit_rows"]

BAD_STRING = "no-such-value"
#: parameters whose 3 numbers are a point or a vector for Mitsuba, not a colour
POINT_PARAMS = ("position", "direction", "center", "origin", "target", "up")


class NoSpec(ValueError):
    """The parameters cannot be written as a Mitsuba plugin dict (the reason is the message)."""


class RotatedChart:
    """``chart`` (a cap about +z) with its pole turned to the unit ``axis``: a cap at a lobe's peak
    resolves it (and the chi-square harness's quadrature with it)."""

    def __init__(self, chart, axis):
        self.chart, self.axis = chart, np.asarray(axis, float) / np.linalg.norm(axis)
        self.p, self.dim_x = chart.p, chart.dim_x

    def to_param(self, x):
        return self.chart.to_param(to_local(np.asarray(x, float), self.axis))

    def from_param(self, s):
        return to_world(self.chart.from_param(s), self.axis)

    def jacobian(self, s):
        return self.chart.jacobian(s)


def unit_rows(n: int, seed: int, *, upper: bool = False) -> np.ndarray:
    """``n`` random unit vectors (uniform on the sphere, or on the upper hemisphere z > 0.02)."""
    v = np.random.default_rng(seed).normal(size=(n, 3))
    if upper:
        v[:, 2] = np.abs(v[:, 2]) + 0.02 * np.linalg.norm(v, axis=-1)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _element_from_dict(spec: dict):
    from ..render import registered

    spec = dict(spec)
    name = spec.pop("type")
    for kind in ("bsdf", "texture", "emitter"):
        cls = registered(kind).get(name)
        if cls is not None:
            return cls(**{k: _built(v) for k, v in spec.items()})
    raise ValueError(f"params: no registered bsdf, texture or emitter is named {name!r}")


def _built(value: Any) -> Any:
    return _element_from_dict(value) if isinstance(value, dict) and "type" in value else value


def build_element(kind: str, name_or_class: Any, params: dict, who: str):
    """``(cls, element)``: the class registered as ``name_or_class`` (or that class, a subclass
    of the kind's base) built with ``params`` (plugin dicts built through the registry); or an
    element instance given as it is (``cls`` None).  ``TypeError``/``ValueError`` naming
    ``name_or_class``."""
    from ..render import registered
    from ..render.registry import Element

    if isinstance(name_or_class, Element):
        if name_or_class.kind != kind or params:
            raise TypeError(f"name_or_class: expected a {kind} name, class or instance (an instance without "
                            f"parameters), got {type(name_or_class).__name__} with {sorted(params)}")
        return None, name_or_class
    if isinstance(name_or_class, str):
        table = registered(kind)
        if name_or_class not in table:
            raise ValueError(f"name_or_class: no {kind} is registered as {name_or_class!r}; registered: "
                             f"{', '.join(sorted(table))}")
        cls = table[name_or_class]
    elif isinstance(name_or_class, type) and issubclass(name_or_class, Element) and name_or_class.kind == kind:
        cls = name_or_class
    else:
        raise TypeError(f"name_or_class: expected a registered {kind} name or a {kind} element class, got "
                        f"{name_or_class!r}")
    try:
        return cls, cls(**{k: _built(v) for k, v in params.items()})
    except (TypeError, ValueError) as exc:
        raise AssertionError(f"{who}[params]: {cls.__name__}(**{params!r}) is refused: {exc}") from None


def _real(value: Any) -> bool:
    if isinstance(value, (bool, np.bool_)) or value is None or isinstance(value, str):
        return False
    try:
        a = np.asarray(value)
    except Exception:  # noqa: BLE001 - anything that is not an array is no real value
        return False
    return a.dtype.kind in "iuf" and a.size > 0


def _bad_values(name: str, value: Any, signed: tuple) -> list:
    if isinstance(value, (bool, np.bool_)):
        return ["yes"]
    if isinstance(value, str):
        return [BAD_STRING]
    if _real(value):
        a = np.asarray(value, float)
        out = [np.full_like(a, np.nan) if a.ndim else float("nan")]
        if name not in signed:
            out.append(np.full_like(a, -1.0) if a.ndim else -1.0)
        return out
    return []


def check_params(cls, params: dict, who: str) -> str:
    """The ``params`` check (module docstring); ``AssertionError`` starting ``who[params]``."""
    if cls is None:
        return "skipped: an instance was given, not a class and its parameters"
    signed = tuple(getattr(cls, "SIGNED_PARAMS", ())) + POINT_PARAMS + ("to_world", "to_uv")
    sig = inspect.signature(cls.__init__)
    tried = 0
    for name, p in sig.parameters.items():
        if name == "self" or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        value = params.get(name, p.default)
        if value is inspect.Parameter.empty:
            continue
        for bad in _bad_values(name, value, signed):
            tried += 1
            kw = {k: _built(v) for k, v in {**params, name: bad}.items()}
            try:
                cls(**kw)
            except (TypeError, ValueError) as exc:
                if name not in str(exc):
                    raise AssertionError(f"{who}[params]: {cls.__name__}({name}={bad!r}) is refused, but the "
                                         f"message does not name {name!r}: {exc}") from None
                continue
            except Exception as exc:  # noqa: BLE001 - the wrong kind of error is the finding
                raise AssertionError(f"{who}[params]: {cls.__name__}({name}={bad!r}) raised {type(exc).__name__}: "
                                     f"{exc} instead of a ValueError/TypeError naming {name!r}") from None
            raise AssertionError(f"{who}[params]: {cls.__name__}({name}={bad!r}) was accepted; a bad value must "
                                 f"raise ValueError/TypeError naming {name!r} (list a parameter that may be "
                                 "negative in the class's SIGNED_PARAMS)")
    return "ok" if tried else "skipped: no number, string or flag parameter to try"


def _spec_value(key: str, value: Any) -> Any:
    from ..render.registry import Element

    if isinstance(value, dict) and "type" in value:
        return {k: (v if k == "type" else _spec_value(k, v)) for k, v in value.items()}
    if isinstance(value, Element):
        raise NoSpec(f"parameter {key!r} is a vrlab object ({type(value).__name__}); give it as a plugin dict "
                     "to compare with Mitsuba")
    if isinstance(value, (bool, np.bool_, str)):
        return value if isinstance(value, str) else bool(value)
    a = np.asarray(value, float)
    if a.ndim == 0:
        return float(a)
    if a.shape == (3,):
        return a.tolist() if key in POINT_PARAMS else {"type": "rgb", "value": a.tolist()}
    if a.shape == (4, 4):
        import mitsuba as mi

        return mi.ScalarTransform4f(a.tolist())
    raise NoSpec(f"parameter {key!r} of shape {a.shape} has no Mitsuba form here")


def mitsuba_spec(name: str, params: dict, rename: dict | None = None) -> dict:
    """The Mitsuba plugin dict of element ``name`` with ``params`` (numbers as floats, RGB triples
    as ``rgb``, 4 x 4 matrices as transforms, plugin dicts nested); ``rename`` maps vrlab
    parameter names to Mitsuba's.  ``NoSpec`` when a parameter has no such form."""
    rename = rename or {}
    return {"type": name, **{rename.get(k, k): _spec_value(k, v) for k, v in params.items()}}


def mitsuba_available() -> str | None:
    """None if Mitsuba 3 with a scalar RGB variant imports, else why not."""
    try:
        import mitsuba as mi
    except ImportError:
        return "skipped: Mitsuba 3 is not installed"
    if "scalar_rgb" not in mi.variants():
        return "skipped: Mitsuba 3 has no scalar_rgb variant"
    return None
