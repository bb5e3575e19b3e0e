"""Estimators: objects holding settings that turn uniforms into an ``Estimate``.

=======================  ================================================  ====================
estimator                technique                                         module
=======================  ================================================  ====================
``MonteCarlo``           importance sampling (uniform by default)          ``importance``
``Antithetic``           pairs u, 1 - u                                    ``antithetic``
``ControlVariate``       f - alpha (h - H), alpha fixed or regressed       ``control``
``DefensiveMixture``     mixture IS + components as controls (Owen-Zhou)   ``control``
``CRNDifference``        int f_a - int f_b with common random numbers      ``crn``
``Stratified``           strata in u, proportional / Neyman allocation     ``stratified``
``RQMC``                 replicated randomised QMC                         ``rqmc``
``MetropolisHastings``   MH chains with small and large steps              ``metropolis``
``MIS``                  multi-sample MIS (balance, power, max, cutoff,    ``mis``
                         optimal)
``OneSampleMIS``         one technique per sample (mixture for balance)    ``onesample``
``RIS``                  resampled importance sampling, reservoirs         ``ris``
``ReSTIR``               reservoirs per pixel, spatial reuse across the    ``restir``
                         elements of a batched integrand (pairwise,
                         balance or 1/M weights)
=======================  ================================================  ====================

``recipes()`` is the one registry of named recipes (:mod:`vrlab.estimators.registry`): the
lab's estimator names, the renderer's presets and both CLIs read it; ``register_recipe`` adds
one.  The estimator protocol every estimator follows is documented on :class:`Estimator`.
"""
from .._lazy import lazy_attributes

# name -> submodule; loaded on first use (PEP 562) so that ``import vrlab.render``, which
# needs only ``mis`` and ``ris``, does not pay for every estimator module
_WHERE = {
    "Antithetic": "antithetic", "BiasWarning": "base", "Estimator": "base", "point_engine": "base",
    "support_probe": "base", "uniform_blocks": "base", "ControlVariate": "control",
    "DefensiveMixture": "control", "CRNDifference": "crn", "crn_difference": "crn",
    "MonteCarlo": "importance", "MetropolisHastings": "metropolis", "HEURISTICS": "mis", "MIS": "mis",
    "mis_weights": "mis", "OneSampleMIS": "onesample", "RIS": "ris", "Reservoir": "ris", "RQMC": "rqmc",
    "ReSTIR": "restir", "Stratified": "stratified", "Recipe": "registry", "recipes": "registry",
    "register_recipe": "registry",
}

__all__ = [
    "HEURISTICS", "MIS", "OneSampleMIS", "RIS", "ReSTIR", "Reservoir", "mis_weights",
    "Antithetic", "BiasWarning", "CRNDifference", "ControlVariate", "DefensiveMixture", "Estimator",
    "MetropolisHastings", "MonteCarlo", "RQMC", "Stratified", "crn_difference", "point_engine",
    "support_probe", "uniform_blocks", "Recipe", "recipes", "register_recipe",
]


__getattr__, __dir__ = lazy_attributes(__name__, _WHERE, __all__)
