"""The one registry of named estimator recipes: the lab, the renderer's presets and both CLIs read it.

A recipe is a name standing for an estimator object (and, in the lab, a point set), built
where it is used:

- in the lab, ``recipe.lab(integrand, arg) -> (estimator, points)`` for the name
  ``name`` or ``name:arg`` (``ValueError`` saying why it does not apply to an integrand);
- in the renderer, ``recipe.render(emitter_samples, bsdf_samples, ris_candidates) ->
  (estimator, units per shading point)`` (:data:`vrlab.render.PRESETS` lists these names,
  ``vrlab render --strategy`` offers them with ``recipe.render_help``).

``recipes()`` returns ``{name: Recipe}`` in registration order; ``recipes("lab")`` /
``recipes("render")`` only those usable there.  A new estimator is one class plus one
``register_recipe`` call; its help text, its ``--strategy``/``--estimators`` entry and the
common checks of the test suite (:func:`vrlab.testing.check_estimator`, parametrised from
this registry) follow.  Estimator modules are imported when a recipe is built, so importing
the registry costs nothing.

=====================  ==================================================================  ======
recipe                 estimator                                                           where
=====================  ==================================================================  ======
``uniform``            ``MonteCarlo("uniform")``: directions uniform on the hemisphere      render
``cosine``             ``MonteCarlo("cosine")``                                             render
``bsdf``               ``MonteCarlo("bsdf")``                                               render
``light``              ``MonteCarlo("light")``                                              render
``mc``                 ``MonteCarlo()``: uniform sampling of the domain                     lab
``is:<t>``             ``MonteCarlo(integrand.techniques[t])``                              lab
``mis-<h>[:<a+b>]``    ``MIS(techniques, heuristic=h)``; h in balance, power, max, cutoff,  lab
                       optimal (Veach & Guibas 1995; Kondapaneni et al. 2019); balance,     render
                       power and optimal also render ``MIS(["light", "bsdf"],
                       fractions=[n_l, n_b])`` (optimal: fitted per pixel)
``mixture``            ``OneSampleMIS(["bsdf", "light"], probabilities=[n_b, n_l])``        render
``onesample[:<a+b>]``  ``OneSampleMIS(techniques)`` (Veach 1997, 9.2.4)                     lab
``defensive[:<a+b>]``  ``DefensiveMixture``: techniques mixed with uniform, as controls     lab
``antithetic``         ``Antithetic()``: pairs u, 1 - u                                     lab
``cv[:<a+b>]``         ``ControlVariate(h, int h)``: the integrand's named controls (all,   both
                       or a+b), else a known one; render: light sampling with the
                       closed-form Lambertian control, alpha = 1
``stratified``         ``Stratified()``: strata of the domain                               lab
``jittered``, ``lhs``  ``MonteCarlo()`` on jittered / Latin hypercube points                lab
``rqmc-sobol[:<R>]``   ``RQMC(MonteCarlo(), replicates=R)`` on scrambled Sobol' (Halton)    lab
``ris:<m>``            ``RIS(source, |f|, m)`` (Talbot et al. 2005); render: ``RIS("light",  both
                       target="unshadowed", m=M)``
``restir``             render: ``ReSTIR(candidates=M, neighbours=5, radius=3, mis="pairwise")``:  render
                       light-candidate reservoirs per pixel, spatial reuse within a tile
                       (Bitterli et al. 2020; Lin et al. 2022; ``vrlab.render.reuse``)
=====================  ==================================================================  ======
"""
from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import limits
from ._recipe_tools import (BIAS, _cls, _names, _positive_int, _probed, _techniques, check_bias,  # noqa: F401
                            check_recipe_names, ris_source_target)

__all__ = ["Recipe", "check_recipe_names", "recipes", "register_recipe", "MAX_RECIPE_ARG", "RQMC_REPLICATES", "RIS_DEFAULT_M", "BIAS", "check_bias",
           "DEFENSIVE_ALPHA"]

LabBuilder = Callable[[Any, "str | None"], tuple]
RenderBuilder = Callable[[int, int, int], tuple]

#: Default number of RQMC replicates (independent randomisations).
RQMC_REPLICATES = 8
#: Candidate count shown for ``ris`` in the lab's ``applicable``.
RIS_DEFAULT_M = 8
#: Mixture weight of the uniform component in ``defensive``.
DEFENSIVE_ALPHA = 0.1
#: Largest ``R`` of ``rqmc-*:<R>`` and ``m`` of ``ris:<m>`` (larger runs: build the estimator).
MAX_RECIPE_ARG = limits.MAX_CANDIDATES    # the :<int> of a recipe (RIS m, RQMC R)


@dataclass(frozen=True)
class Recipe:
    """A named recipe: ``name``, a one-line ``summary``, the estimator's ``module`` (under
    ``vrlab.estimators``), the lab builder ``lab(integrand, arg) -> (estimator, points)`` or
    None, whether it takes ``:arg`` (``arg`` = metavar, ``arg_required``), the render builder
    ``render(emitter_samples, bsdf_samples, ris_candidates) -> (estimator, units)`` or None,
    its ``render_help`` (the ``--strategy`` menu), ``needs``: the sample kind a render
    preset cannot do without (``"bsdf"``, ``"light"`` or None), and ``bias``: what the
    estimator it builds promises at every sample count it accepts (:data:`BIAS`)."""

    name: str
    summary: str
    module: str
    bias: str = "unbiased"
    lab: LabBuilder | None = None
    arg: str | None = None
    arg_required: bool = False
    render: RenderBuilder | None = None
    render_help: str | None = None
    needs: str | None = None
    #: the render settings the preset reads (``emitter_samples``, ``bsdf_samples``,
    #: ``ris_candidates``, ``light_selection``): a CLI warns about a flag no strategy in use reads
    uses: frozenset = frozenset(("emitter_samples", "bsdf_samples", "ris_candidates", "light_selection"))

    @property
    def bias_note(self) -> str:
        """``bias`` with its meaning, for help texts: "unbiased" / "consistent (bias -> 0 as
        n grows)" / "biased"."""
        return BIAS[self.bias]

    @property
    def base(self) -> str:          # the lab's historical name for ``name``
        return self.name

    @property
    def build(self) -> LabBuilder | None:
        return self.lab

    @property
    def pattern(self) -> str:
        if self.arg is None:
            return self.name
        return f"{self.name}:{self.arg}" if self.arg_required else f"{self.name}[:{self.arg}]"

    @property
    def available(self) -> bool:
        """Whether the estimator module can be imported in this installation."""
        try:
            importlib.import_module(f"vrlab.estimators.{self.module}")
        except ImportError:
            return False
        return True


_REGISTRY: dict[str, Recipe] = {}

def recipes(where: str | None = None) -> dict[str, Recipe]:
    """``{name: Recipe}`` of every registered recipe (a copy, in registration order);
    ``where="lab"`` or ``"render"``: only those with a builder there."""
    if where not in (None, "lab", "render"):
        raise ValueError(f"where: expected None, 'lab' or 'render', got {where!r}")
    return {k: r for k, r in _REGISTRY.items() if where is None or getattr(r, where) is not None}


def register_recipe(name: str, summary: str, module: str, *, bias: str, lab: LabBuilder | None = None,
                    arg: str | None = None, arg_required: bool = False, render: RenderBuilder | None = None,
                    render_help: str | None = None, needs: str | None = None, uses: Any = None) -> Recipe:
    """Add (or replace) recipe ``name``; returns it.  ``name``: non-empty, without ':', ',' or
    spaces; ``summary``, ``module``: strings; ``bias`` (required): ``"unbiased"``,
    ``"consistent"`` or ``"biased"``, what the estimator promises at every sample count it
    accepts (:data:`BIAS`); ``lab``/``render``: callables (at least one);
    ``arg``: None or a metavar string (required if ``arg_required``); ``needs``: None,
    ``"bsdf"`` or ``"light"``; ``uses``: the render settings the preset reads (default all of
    ``emitter_samples``, ``bsdf_samples``, ``ris_candidates``, ``light_selection``)."""
    check_recipe_names(name, summary, module, arg, arg_required)
    check_bias(bias)
    for key, fn in (("lab", lab), ("render", render)):
        if fn is not None and not callable(fn):
            raise TypeError(f"register({name!r}): the {key} builder must be callable, got {type(fn).__name__}")
    if lab is None and render is None:
        raise TypeError(f"register({name!r}): give a lab builder, a render builder or both")
    if render_help is not None and not isinstance(render_help, str):
        raise TypeError(f"render_help must be a string or None, got {type(render_help).__name__}")
    if needs not in (None, "bsdf", "light"):
        raise ValueError(f"needs: expected None, 'bsdf' or 'light', got {needs!r}")
    every = Recipe.__dataclass_fields__["uses"].default
    uses = every if uses is None else frozenset(uses)
    if not uses <= every:
        raise ValueError(f"uses: only {', '.join(sorted(every))}, got {sorted(uses)}")
    recipe = Recipe(name, summary, module, bias, lab, arg, bool(arg_required), render,
                    render_help if render_help is not None else (summary if render is not None else None), needs,
                    uses)
    _REGISTRY[name] = recipe
    return recipe


# -- render-only presets: one technique of the shading integrand ------------------------------------
def _technique_preset(name: str) -> RenderBuilder:
    def build(emitter_samples, bsdf_samples, ris_candidates):
        return _cls("importance", "MonteCarlo", name)(name), (emitter_samples if name == "light" else bsdf_samples)
    return build


for _name, _help, _needs in (("uniform", "directions uniform on the hemisphere", "bsdf"),
                             ("cosine", "directions ~ cos/pi", "bsdf"),
                             ("bsdf", "directions from the BSDF lobe", "bsdf"),
                             ("light", "a point on a light, see --light-selection", "light")):
    register_recipe(_name, f'MonteCarlo("{_name}"): {_help}', "importance", bias="unbiased", render=_technique_preset(_name),
                    render_help=_help, needs=_needs,
                    uses=("emitter_samples", "light_selection") if _name == "light" else ("bsdf_samples",))


# -- lab recipes (and the presets that share their name) -------------------------------------------
def _mc(integrand, arg):
    return _cls("importance", "MonteCarlo", "mc")(), None


register_recipe("mc", "MonteCarlo(): uniform sampling on the domain", "importance", bias="unbiased", lab=_mc)


def _is(integrand, arg):
    techs = getattr(integrand, "techniques", {}) or {}
    if arg not in techs:
        raise ValueError(f"is:{arg}: integrand {integrand.name!r} has no technique {arg!r}; "
                         f"it has {_names(techs)}")
    return _probed(_cls("importance", "MonteCarlo", f"is:{arg}"), integrand, [techs[arg]], techs[arg]), None


register_recipe("is", "MonteCarlo(techniques[t]): importance sampling with one technique", "importance", bias="unbiased", lab=_is,
                arg="<technique>", arg_required=True)

_SAMPLES_AND_LIGHTS = ("emitter_samples", "bsdf_samples", "light_selection")
_HEURISTICS = {"balance": "balance", "power": "power", "max": "maximum", "cutoff": "cutoff", "optimal": "optimal"}
_MIS_HELP = {"balance": "light and BSDF samples, MIS balance heuristic",
             "power": "light and BSDF samples, MIS power heuristic, as Mitsuba's direct integrator",
             "optimal": "light and BSDF samples, optimal MIS weights fitted per pixel, cross-fitted over 4 folds of "
                        "its samples with a ridge towards balance (Kondapaneni et al. 2019)"}


def _mis_builder(short: str, heuristic: str) -> LabBuilder:
    def build(integrand, arg):
        name = f"mis-{short}" + (f":{arg}" if arg else "")
        dists = _techniques(integrand, arg, name)
        return _probed(_cls("mis", "MIS", name), integrand, dists, dists, heuristic=heuristic), None
    return build


def _mis_preset(heuristic: str) -> RenderBuilder:
    ridge = {"optimal_ridge": 1.0} if heuristic == "optimal" else {}   # a pixel's few units: see MIS._regression

    def build(emitter_samples, bsdf_samples, ris_candidates):
        return _cls("mis", "MIS", f"mis-{heuristic}")(["light", "bsdf"], fractions=[emitter_samples, bsdf_samples],
                                                       heuristic=heuristic, **ridge), 1
    return build


for _short, _h in _HEURISTICS.items():
    register_recipe(f"mis-{_short}", f"MIS(techniques, heuristic={_h!r}): multi-sample MIS", "mis", bias="unbiased",
                    lab=_mis_builder(_short, _h), arg="<a+b>",
                    render=_mis_preset(_short) if _short in _MIS_HELP else None, render_help=_MIS_HELP.get(_short),
                    uses=_SAMPLES_AND_LIGHTS)


def _mixture(emitter_samples, bsdf_samples, ris_candidates):
    return _cls("onesample", "OneSampleMIS", "mixture")(["bsdf", "light"], probabilities=[bsdf_samples,
                                                                                          emitter_samples]), 1


register_recipe("mixture", "OneSampleMIS([bsdf, light], probabilities=[n_b, n_l]): one-sample mixture", "onesample", bias="unbiased",
                render=_mixture, render_help="one sample from 1/2 BSDF + 1/2 light", uses=_SAMPLES_AND_LIGHTS)


def _onesample(integrand, arg):
    name = "onesample" + (f":{arg}" if arg else "")
    dists = _techniques(integrand, arg, name)
    return _probed(_cls("onesample", "OneSampleMIS", name), integrand, dists, dists), None


register_recipe("onesample", "OneSampleMIS(techniques): one technique picked per sample, balance weights",
                "onesample", bias="unbiased", lab=_onesample, arg="<a+b>")


def _defensive(integrand, arg):
    name = "defensive" + (f":{arg}" if arg else "")
    techs = getattr(integrand, "techniques", {}) or {}
    if arg is None:
        arg = "+".join(t for t in techs if t != "uniform")
        if not arg:
            raise ValueError(f"{name}: integrand {integrand.name!r} has no non-uniform technique to defend")
    dists = _techniques(integrand, arg, name, at_least=1)
    return _cls("control", "DefensiveMixture", name)(dists, defensive=DEFENSIVE_ALPHA), None


register_recipe("defensive", f"DefensiveMixture(techniques, defensive={DEFENSIVE_ALPHA}): mixture with uniform, "
                "components as controls (Owen & Zhou 2000)", "control", bias="unbiased", lab=_defensive, arg="<a+b>")


def _antithetic(integrand, arg):
    return _cls("antithetic", "Antithetic", "antithetic")(), None


register_recipe("antithetic", "Antithetic(): pairs f(x(u)), f(x(1 - u)) (Hammersley & Morton 1956)", "antithetic", bias="unbiased",
                lab=_antithetic)


def _cv(integrand, arg):
    """The integrand's named controls (``integrand.controls``: all of them, or those of ``arg``
    "a+b"); without named controls the known one of ``integrands.controls.control_for``
    (``theory["cv:control"]`` or the catalogue's)."""
    from ..integrands.controls import control_for

    cv = _cls("control", "ControlVariate", "cv")
    named = dict(getattr(integrand, "controls", {}) or {})
    if arg or (named and "cv:control" not in (getattr(integrand, "theory", {}) or {})):
        chosen = [c for c in arg.split("+") if c] if arg else list(named)
        unknown = [c for c in chosen if c not in named]
        if unknown:
            raise ValueError(f"cv: integrand {integrand.name!r} has no control {', '.join(map(repr, unknown))}; "
                             f"it has {_names(named)}")
        return cv(chosen[0] if len(chosen) == 1 else chosen), None
    h, H, _ = control_for(integrand)
    return cv(h, H), None


def _cv_preset(emitter_samples, bsdf_samples, ris_candidates):
    return _cls("control", "ControlVariate", "cv")("lambertian", alpha=1.0, distribution="light"), emitter_samples


register_recipe("cv", "ControlVariate(h, int h): the integrand's named controls (all, or those of <a+b>), else a "
                "known control (exp: h = x, int h = 1/2)", "control", bias="unbiased", lab=_cv, arg="<a+b>",
                render=_cv_preset, render_help="light sampling with a closed-form Lambertian control variate",
                needs="light", uses=("emitter_samples", "light_selection"))


def _stratified(integrand, arg):
    return _cls("stratified", "Stratified", "stratified")(), None


register_recipe("stratified", "Stratified(): strata of the domain, proportional allocation", "stratified", bias="unbiased",
                lab=_stratified)


def _on_points(name: str, points: str) -> LabBuilder:
    def build(integrand, arg):
        return _cls("importance", "MonteCarlo", name)(), points
    return build


register_recipe("jittered", "MonteCarlo() on jittered points (points='stratified')", "importance", bias="unbiased",
                lab=_on_points("jittered", "stratified"))
register_recipe("lhs", "MonteCarlo() on Latin hypercube points (points='lhs')", "importance", bias="unbiased",
                lab=_on_points("lhs", "lhs"))


def _scrambled_halton(integrand):
    from ..points import Halton
    return Halton(int(integrand.uniform().dim_u), scramble=True, rng=0)


def _rqmc_builder(points: str) -> LabBuilder:
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


for _pts, _label in (("sobol", "Sobol'"), ("halton", "Halton")):
    register_recipe(f"rqmc-{_pts}", f"RQMC(MonteCarlo(), replicates=R): R scrambled {_label} sets "
                    f"(R = {RQMC_REPLICATES})", "rqmc", bias="unbiased", lab=_rqmc_builder(_pts), arg="<R>")


def _ris(integrand, arg):
    name = f"ris:{arg}"
    m = _positive_int(arg, name, None, "the candidate count m")
    source = (getattr(integrand, "techniques", {}) or {}).get("light", integrand.uniform())
    return _cls("ris", "RIS", name)(source, "|f|", m), None       # target |f|, resolved per integrand


def _ris_preset(emitter_samples, bsdf_samples, ris_candidates):
    return _cls("ris", "RIS", "ris")("light", target="unshadowed", m=ris_candidates), emitter_samples


register_recipe("ris", "RIS(source, |f|, m): resampled importance sampling with m candidates", "ris", bias="unbiased", lab=_ris,
                arg="<m>", arg_required=True, render=_ris_preset,
                render_help="resampled light candidates, see --ris-candidates", needs="light",
                uses=("emitter_samples", "light_selection", "ris_candidates"))


def _restir_preset(emitter_samples, bsdf_samples, ris_candidates):
    return _cls("restir", "ReSTIR", "restir")(candidates=ris_candidates, neighbours=5, radius=3.0, passes=1,
                                              mis="pairwise"), 1


register_recipe("restir", "ReSTIR(candidates=M, neighbours=5, radius=3, mis='pairwise'): per-pixel reservoirs of "
                "light candidates with spatial reuse (Bitterli et al. 2020; Lin et al. 2022)", "restir", bias="unbiased",
                render=_restir_preset,
                render_help="per-pixel RIS reservoirs of light candidates (--ris-candidates) with unbiased spatial "
                "reuse (pairwise MIS) among the pixels of a tile", needs="light",
                uses=("light_selection", "ris_candidates"))
