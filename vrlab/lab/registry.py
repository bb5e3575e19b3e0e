"""Named estimator recipes: ``"mis-balance:brdf+light"`` -> ``(estimator, points)`` for an integrand.

A recipe name is ``base`` or ``base:arg``.  ``build(name, integrand)`` returns the
estimator (settings only, see :mod:`vrlab.estimators`) and the point set to pass as
``points=`` (a name or ``None`` for independent uniforms), or raises ``ValueError``
saying why the recipe does not apply to that integrand (no techniques, no known
control variate, estimator module not installed...).

=====================  ===========================================================
recipe                 estimator
=====================  ===========================================================
``mc``                 ``MonteCarlo()``: uniform sampling of the domain
``is:<t>``             ``MonteCarlo(integrand.techniques[t])``
``mis-<h>[:<a+b>]``    ``MIS(techniques, heuristic=h)``; h in balance, power, max,
                       cutoff, optimal (Veach & Guibas 1995; Kondapaneni et al. 2019)
``onesample[:<a+b>]``  ``OneSampleMIS(techniques)`` (Veach 1997, 9.2.4)
``defensive[:<a+b>]``  ``DefensiveMixture``: techniques mixed with uniform, as controls
                       (Hesterberg 1995; Owen & Zhou 2000)
``antithetic``         ``Antithetic()``: pairs u, 1 - u
``cv``                 ``ControlVariate(h, int h)`` with a known control h
``stratified``         ``Stratified()``: strata of the domain
``jittered``           ``MonteCarlo()`` on ``points="stratified"``
``lhs``                ``MonteCarlo()`` on ``points="lhs"``
``rqmc-sobol[:<R>]``   ``RQMC(MonteCarlo(), replicates=R)`` on scrambled Sobol'
``rqmc-halton[:<R>]``  ``RQMC(MonteCarlo(), replicates=R)`` on scrambled Halton
``ris:<m>``            ``RIS(source, target, m)`` (Talbot et al. 2005)
=====================  ===========================================================

The estimator classes are imported when a recipe is built, so modules added to
:mod:`vrlab.estimators` later are picked up without changes here; ``register`` adds
recipes of your own.  Arguments are checked: recipe names are strings (an unknown one
lists the recipes), integrands are ``Integrand`` objects or catalogue names, and a
recipe's ``:<int>`` argument lies in [1, ``MAX_RECIPE_ARG``].
"""
from __future__ import annotations

import importlib
import inspect
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._args import lab_integrand as _integrand
from .controls import CONTROLS, DISCONTINUOUS, control_for, is_smooth  # noqa: F401  (re-exported)

Builder = Callable[[Any, "str | None"], tuple]

#: Default number of RQMC replicates (independent randomisations).
RQMC_REPLICATES = 8
#: Candidate count shown for ``ris`` in ``applicable``.
RIS_DEFAULT_M = 8
#: Mixture weight of the uniform component in ``defensive``.
DEFENSIVE_ALPHA = 0.1
#: Largest ``R`` of ``rqmc-*:<R>`` and ``m`` of ``ris:<m>`` (larger runs: build the estimator).
MAX_RECIPE_ARG = 4096


@dataclass(frozen=True)
class Recipe:
    """A recipe: ``base`` name, whether it takes ``:arg`` (``arg`` = metavar or None,
    ``arg_required``), a one-line ``summary``, the estimator's ``module`` and the builder
    ``build(integrand, arg) -> (estimator, points)``."""

    base: str
    summary: str
    module: str
    build: Builder
    arg: str | None = None
    arg_required: bool = False

    @property
    def pattern(self) -> str:
        if self.arg is None:
            return self.base
        return f"{self.base}:{self.arg}" if self.arg_required else f"{self.base}[:{self.arg}]"

    @property
    def available(self) -> bool:
        """Whether the estimator module can be imported in this installation."""
        try:
            importlib.import_module(f"vrlab.estimators.{self.module}")
        except ImportError:
            return False
        return True


RECIPES: dict[str, Recipe] = {}


def register(base: str, summary: str, module: str, *, arg: str | None = None,
             arg_required: bool = False) -> Callable[[Builder], Builder]:
    """Decorator adding a recipe ``base[:arg]`` whose builder is ``f(integrand, arg)``.

    ``base``: a non-empty string without ':', ',' or spaces; ``summary``, ``module``: strings;
    ``arg``: None or a string (required if ``arg_required``)."""
    for key, value in (("base", base), ("summary", summary), ("module", module)):
        if not isinstance(value, str):
            raise TypeError(f"{key} must be a string, got {type(value).__name__}")
    if not base or any(c in base for c in ":, \t\n"):
        raise ValueError(f"base: a recipe name must be non-empty, without ':', ',' or spaces, got {base!r}")
    if arg is not None and not isinstance(arg, str):
        raise TypeError(f"arg must be a string (e.g. '<m>') or None, got {type(arg).__name__}")
    if not isinstance(arg_required, (bool, np.bool_)):
        raise TypeError(f"arg_required must be True or False, got {type(arg_required).__name__}")
    if arg_required and arg is None:
        raise ValueError("arg_required: a recipe that needs an argument must name it (arg='<m>')")

    def deco(fn: Builder) -> Builder:
        if not callable(fn):
            raise TypeError(f"register({base!r}): the builder must be callable (integrand, arg) -> "
                            f"(estimator, points), got {type(fn).__name__}")
        RECIPES[base] = Recipe(base, summary, module, fn, arg, bool(arg_required))
        return fn
    return deco


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
            from ..estimators.base import support_probe
            support_probe(integrand, dists, label=" + ".join(type(d).__name__ for d in dists))
    return cls(*args, **kw)


# -- helpers on integrands -------------------------------------------------------------------
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


def _names(techs: dict) -> str:
    return ", ".join(map(repr, techs)) if techs else "none"


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


# -- the recipes ------------------------------------------------------------------------------
@register("mc", "MonteCarlo(): uniform sampling on the domain", "importance")
def _mc(integrand, arg):
    return _cls("importance", "MonteCarlo", "mc")(), None


@register("is", "MonteCarlo(techniques[t]): importance sampling with one technique", "importance",
          arg="<technique>", arg_required=True)
def _is(integrand, arg):
    techs = getattr(integrand, "techniques", {}) or {}
    if arg not in techs:
        raise ValueError(f"is:{arg}: integrand {integrand.name!r} has no technique {arg!r}; "
                         f"it has {_names(techs)}")
    return _probed(_cls("importance", "MonteCarlo", f"is:{arg}"), integrand, [techs[arg]], techs[arg]), None


_HEURISTICS = {"balance": "balance", "power": "power", "max": "maximum", "cutoff": "cutoff",
               "optimal": "optimal"}


def _mis_builder(short: str, heuristic: str) -> Builder:
    def build(integrand, arg):
        name = f"mis-{short}" + (f":{arg}" if arg else "")
        dists = _techniques(integrand, arg, name)
        return _probed(_cls("mis", "MIS", name), integrand, dists, dists, heuristic=heuristic), None
    return build


for _short, _h in _HEURISTICS.items():
    register(f"mis-{_short}", f"MIS(techniques, heuristic={_h!r}): multi-sample MIS", "mis",
             arg="<a+b>")(_mis_builder(_short, _h))


@register("onesample", "OneSampleMIS(techniques): one technique picked per sample, balance weights",
          "mis", arg="<a+b>")
def _onesample(integrand, arg):
    name = "onesample" + (f":{arg}" if arg else "")
    dists = _techniques(integrand, arg, name)
    return _probed(_cls("onesample", "OneSampleMIS", name), integrand, dists, dists), None


@register("defensive", f"DefensiveMixture(techniques, defensive={DEFENSIVE_ALPHA}): mixture with uniform, "
          "components as controls (Owen & Zhou 2000)", "control", arg="<a+b>")
def _defensive(integrand, arg):
    name = "defensive" + (f":{arg}" if arg else "")
    techs = getattr(integrand, "techniques", {}) or {}
    if arg is None:
        arg = "+".join(t for t in techs if t != "uniform")
        if not arg:
            raise ValueError(f"{name}: integrand {integrand.name!r} has no non-uniform technique to defend")
    dists = _techniques(integrand, arg, name, at_least=1)
    return _cls("control", "DefensiveMixture", name)(dists, defensive=DEFENSIVE_ALPHA), None


@register("antithetic", "Antithetic(): pairs f(x(u)), f(x(1 - u)) (Hammersley & Morton 1956)",
          "antithetic")
def _antithetic(integrand, arg):
    return _cls("antithetic", "Antithetic", "antithetic")(), None


@register("cv", "ControlVariate(h, int h): a known control (exp: h = x, int h = 1/2)", "control")
def _cv(integrand, arg):
    h, H, _ = control_for(integrand)
    return _cls("control", "ControlVariate", "cv")(h, H), None


@register("stratified", "Stratified(): strata of the domain, proportional allocation", "stratified")
def _stratified(integrand, arg):
    return _cls("stratified", "Stratified", "stratified")(), None


@register("jittered", "MonteCarlo() on jittered points (points='stratified')", "importance")
def _jittered(integrand, arg):
    return _cls("importance", "MonteCarlo", "jittered")(), "stratified"


@register("lhs", "MonteCarlo() on Latin hypercube points (points='lhs')", "importance")
def _lhs(integrand, arg):
    return _cls("importance", "MonteCarlo", "lhs")(), "lhs"


def _rqmc_builder(points: str) -> Builder:
    def build(integrand, arg):
        name = f"rqmc-{points}" + (f":{arg}" if arg else "")
        R = _positive_int(arg, name, RQMC_REPLICATES, "the number of replicates R")
        if R < 2:
            raise ValueError(f"{name}: needs R >= 2 replicates for a standard error")
        MC = _cls("importance", "MonteCarlo", name)
        # RQMC re-randomizes the template per replicate (spawned seeds); its own seed is unused
        pts = _scrambled_halton(integrand) if points == "halton" else points
        return _cls("rqmc", "RQMC", name)(base=MC(), replicates=R), pts
    return build


register("rqmc-sobol", f"RQMC(MonteCarlo(), replicates=R): R scrambled Sobol' sets (R = {RQMC_REPLICATES})",
         "rqmc", arg="<R>")(_rqmc_builder("sobol"))
def _scrambled_halton(integrand):
    from ..points import Halton
    return Halton(int(integrand.uniform().dim_u), scramble=True, rng=0)


register("rqmc-halton", f"RQMC(MonteCarlo(), replicates=R): R scrambled Halton sets (R = {RQMC_REPLICATES})",
         "rqmc", arg="<R>")(_rqmc_builder("halton"))


def ris_source_target(integrand) -> tuple[Any, Callable]:
    """RIS pieces: source = technique "light" if present, else uniform; target = |f|
    (the unshadowed contribution, as in Talbot et al. 2005 / ReSTIR)."""
    integrand = _integrand(integrand)
    techs = getattr(integrand, "techniques", {}) or {}
    source = techs.get("light", integrand.uniform())

    def target(x):
        return np.abs(integrand(x))
    return source, target


@register("ris", "RIS(source, |f|, m): resampled importance sampling with m candidates", "ris",
          arg="<m>", arg_required=True)
def _ris(integrand, arg):
    name = f"ris:{arg}"
    m = _positive_int(arg, name, None, "the candidate count m")
    source, target = ris_source_target(integrand)
    return _cls("ris", "RIS", name)(source, target, m), None


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
        return recipe.build(_integrand(integrand), arg)
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
