"""The lab's view of the estimator recipes: ``"mis-balance:brdf+light"`` -> ``(estimator, points)``.

The recipes themselves live in the one registry :func:`vrlab.estimators.recipes` (also the
renderer's presets); this module names those with a lab builder.  A recipe name is ``base``
or ``base:arg``.  ``build(name, integrand)`` returns the estimator (settings only, see
:mod:`vrlab.estimators`) and the point set to pass as ``points=`` (a name or ``None`` for
independent uniforms), or raises ``ValueError`` saying why the recipe does not apply to
that integrand (no techniques, no known control variate, estimator module not
installed, techniques that cannot produce an integrand's point masses...).  ``register`` adds recipes of your own (to the same registry).  Arguments are
checked: recipe names are strings (an unknown one lists the recipes), integrands are
``Integrand`` objects or catalogue names, and a recipe's ``:<int>`` argument lies in
[1, ``MAX_RECIPE_ARG``].
"""
from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from typing import Any, Iterator

from ..estimators.registry import (DEFENSIVE_ALPHA, check_bias, MAX_RECIPE_ARG, RIS_DEFAULT_M, RQMC_REPLICATES,  # noqa: F401
                                  Recipe, check_recipe_names, recipes, register_recipe, ris_source_target)
from ..integrands.controls import CONTROLS, DISCONTINUOUS, control_for, is_smooth  # noqa: F401  (re-exported)
from ._args import lab_integrand as _integrand

Builder = Callable[[Any, "str | None"], tuple]


class _LabRecipes(Mapping):
    """``{name: Recipe}`` of the recipes with a lab builder: a live view of the registry."""

    def __getitem__(self, name: str) -> Recipe:
        return recipes("lab")[name]

    def __iter__(self) -> Iterator[str]:
        return iter(recipes("lab"))

    def __len__(self) -> int:
        return len(recipes("lab"))


RECIPES: Mapping[str, Recipe] = _LabRecipes()


def register(base: str, summary: str, module: str, *, bias: str, arg: str | None = None,
             arg_required: bool = False) -> Callable[[Builder], Builder]:
    """Decorator adding a lab recipe ``base[:arg]`` whose builder is ``f(integrand, arg)`` to the
    registry (:func:`vrlab.estimators.register_recipe` with ``lab=f``).

    ``base``: a non-empty string without ':', ',' or spaces; ``summary``, ``module``: strings;
    ``bias``: ``"unbiased"``, ``"consistent"`` or ``"biased"``; ``arg``: None or a string (required if ``arg_required``)."""
    check_recipe_names(base, summary, module, arg, arg_required)
    check_bias(bias)

    def deco(fn: Builder) -> Builder:
        if not callable(fn):
            raise TypeError(f"register({base!r}): the builder must be callable (integrand, arg) -> "
                            f"(estimator, points), got {type(fn).__name__}")
        register_recipe(base, summary, module, bias=bias, lab=fn, arg=arg, arg_required=arg_required)
        return fn
    return deco


# -- public API ---------------------------------------------------------------------------------
def _split(name: str, argname: str = "name") -> tuple[Recipe, str | None]:
    """The recipe and its ``:arg`` of a recipe name; errors start with ``argname``."""
    if not isinstance(name, str):
        raise TypeError(f"{argname}: a recipe name must be a string, got {type(name).__name__} "
                        f"(choose from {', '.join(r.pattern for r in RECIPES.values())})")
    base, sep, arg = name.strip().partition(":")
    if base not in RECIPES:
        raise ValueError(f"{argname}: unknown estimator recipe {name!r}; choose from "
                         + ", ".join(r.pattern for r in RECIPES.values()))
    recipe = RECIPES[base]
    if sep and recipe.arg is None:
        raise ValueError(f"{argname}: recipe {base!r} takes no ':' argument, got {name!r}")
    if recipe.arg_required and not arg:
        raise ValueError(f"{argname}: recipe {base!r} needs an argument: {recipe.pattern}")
    return recipe, (arg if sep else None)


def get_recipe(name: str) -> Callable[[Any], tuple]:
    """The recipe ``name`` as a function ``integrand -> (estimator, points)``.

    Raises ``ValueError`` for an unknown name (listing the recipes); the function raises
    ``ValueError`` when the recipe does not apply to the integrand it is given (an
    ``Integrand`` or a catalogue name).
    """
    recipe, arg = _split(name)

    def build_for(integrand):
        integrand = _integrand(integrand)
        built = recipe.build(integrand, arg)
        if integrand.atoms:
            # point masses: a recipe whose techniques cannot produce an atom (uniform sampling and
            # everything built on it) does not apply; the estimator's check says why
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                built[0].check(integrand)
        return built
    build_for.__name__ = name
    return build_for


def build(name: str, integrand) -> tuple[Any, Any]:
    """``(estimator, points)`` of recipe ``name`` for ``integrand`` (``ValueError`` if it does not apply)."""
    return get_recipe(name)(integrand)


def list_recipes() -> list[dict]:
    """One dict per recipe: ``recipe`` (pattern), ``summary``, ``module``, ``available``."""
    return [{"recipe": r.pattern, "summary": r.summary, "module": f"vrlab.estimators.{r.module}",
             "available": r.available} for r in RECIPES.values()]


def candidates(integrand) -> list[str]:
    """Concrete recipe names to try on ``integrand`` (``is:<t>`` for each technique, ``ris:8``...)."""
    out = []
    techs = list(getattr(_integrand(integrand), "techniques", {}) or {})
    for r in RECIPES.values():
        if r.base == "is":
            out += [f"is:{t}" for t in techs]
        elif r.arg_required:
            out.append(f"{r.base}:{RIS_DEFAULT_M}" if r.base == "ris" else r.base)
        else:
            out.append(r.base)
    return out


def explain(integrand) -> dict[str, str | None]:
    """``{recipe name: None if it applies, else the reason}`` over ``candidates(integrand)``."""
    integrand = _integrand(integrand)
    out: dict[str, str | None] = {}
    for name in candidates(integrand):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                build(name, integrand)
        except ValueError as exc:
            out[name] = str(exc)
        else:
            out[name] = None
    return out


def applicable(integrand) -> list[str]:
    """Recipe names that build for ``integrand`` (see ``explain`` for the reasons of the others)."""
    return [k for k, why in explain(integrand).items() if why is None]
