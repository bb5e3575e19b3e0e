"""Helpers of the recipe builders (:mod:`vrlab.estimators.registry`): estimator classes by module,
integrand techniques by name, ``:<int>`` arguments, the support probe run once per build."""
from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import limits

MAX_RECIPE_ARG = limits.MAX_CANDIDATES


def _cls(module: str, name: str, recipe: str):
    """``vrlab.estimators.<module>.<name>``, or ValueError if it is not there (yet)."""
    full = f"vrlab.estimators.{module}"
    try:
        mod = importlib.import_module(full)
    except ModuleNotFoundError as exc:
        if exc.name not in (full, "vrlab.estimators"):
            raise
        raise ValueError(f"{recipe}: needs {full}.{name}, which is not available in this installation") from None
    try:
        return getattr(mod, name)
    except AttributeError:
        raise ValueError(f"{recipe}: {full} has no {name}") from None


def _probed(cls, integrand, dists: list, *args, **kw):
    """``cls(*args, **kw)`` with the support probe run once here instead of in every ``estimate``
    (``probe=False`` when the class takes it): a lab run calls ``estimate`` hundreds of times."""
    try:
        takes_probe = "probe" in inspect.signature(cls).parameters
    except (TypeError, ValueError):
        takes_probe = False
    if takes_probe:
        kw["probe"] = False
        if dists and integrand.dim <= 3:
            from .base import support_probe
            support_probe(integrand, dists, label=" + ".join(type(d).__name__ for d in dists))
    return cls(*args, **kw)


def _names(techs: dict) -> str:
    return ", ".join(map(repr, techs)) if techs else "none"


def _techniques(integrand, arg: str | None, recipe: str, at_least: int = 2) -> list:
    techs = dict(getattr(integrand, "techniques", {}) or {})
    if arg:
        chosen = [t for t in arg.split("+") if t]
        unknown = [t for t in chosen if t not in techs]
        if unknown:
            raise ValueError(f"{recipe}: integrand {integrand.name!r} has no technique "
                             f"{', '.join(map(repr, unknown))}; it has {_names(techs)}")
        twice = sorted({t for t in chosen if chosen.count(t) > 1})
        if twice:
            raise ValueError(f"{recipe}: technique {', '.join(map(repr, twice))} given twice")
    else:
        chosen = list(techs)
    if len(chosen) < at_least:
        raise ValueError(f"{recipe}: needs at least {at_least} sampling techniques, integrand "
                         f"{integrand.name!r} has {_names(techs)}")
    return [techs[t] for t in chosen]


def _positive_int(arg: str | None, recipe: str, default: int | None, what: str) -> int:
    if arg is None or arg == "":
        if default is None:
            raise ValueError(f"{recipe}: give {what} as {recipe.split(':')[0]}:<int>")
        return default
    try:
        k = int(arg)
    except ValueError:
        raise ValueError(f"{recipe}: {what} must be an integer, got {arg!r}") from None
    if not 1 <= k <= MAX_RECIPE_ARG:
        raise ValueError(f"{recipe}: {what} must be >= 1 and <= {MAX_RECIPE_ARG}, got {k}")
    return k


def ris_source_target(integrand) -> tuple[Any, Callable]:
    """RIS pieces: source = technique "light" if present, else uniform; target = |f|
    (the unshadowed contribution, as in Talbot et al. 2005 / ReSTIR)."""
    from ..integrands.lookup import as_integrand

    integrand = as_integrand(integrand)
    techs = getattr(integrand, "techniques", {}) or {}
    source = techs.get("light", integrand.uniform())

    def target(x):
        return np.abs(integrand(x))
    return source, target


#: The bias statuses a recipe states, with their meaning.
#: ``unbiased``: E[estimate] = integral at every n (spp) the estimator accepts;
#: ``consistent``: biased at finite n, the bias vanishing as n grows (error bars then
#: measure the spread only); ``biased``: a bias that does not vanish with n.
BIAS = {"unbiased": "unbiased at every sample count",
        "consistent": "consistent: biased at finite n, the bias -> 0 as n grows",
        "biased": "biased: the bias does not vanish as n grows"}


def check_bias(bias: Any) -> str:
    """``bias``: one of :data:`BIAS`'s keys (``TypeError``/``ValueError`` naming ``bias``)."""
    if not isinstance(bias, str):
        raise TypeError(f"bias: expected one of {', '.join(map(repr, BIAS))}, got {type(bias).__name__}")
    if bias not in BIAS:
        raise ValueError(f"bias: expected one of {', '.join(map(repr, BIAS))}, got {bias!r}")
    return bias


def check_recipe_names(name: Any, summary: Any, module: Any, arg: Any = None, arg_required: Any = False) -> None:
    """The checks of :func:`register_recipe` on its names (errors name ``base``, ``summary``,
    ``module``, ``arg``, ``arg_required``)."""
    for key, value in (("base", name), ("summary", summary), ("module", module)):
        if not isinstance(value, str):
            raise TypeError(f"{key} must be a string, got {type(value).__name__}")
    if not name or any(c in name for c in ":, \t\n"):
        raise ValueError(f"base: a recipe name must be non-empty, without ':', ',' or spaces, got {name!r}")
    if arg is not None and not isinstance(arg, str):
        raise TypeError(f"arg must be a string (e.g. '<m>') or None, got {type(arg).__name__}")
    if not isinstance(arg_required, (bool, np.bool_)):
        raise TypeError(f"arg_required must be True or False, got {type(arg_required).__name__}")
    if arg_required and arg is None:
        raise ValueError("arg_required: a recipe that needs an argument must name it (arg='<m>')")
