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
=======================  ================================================  ====================
"""
from .antithetic import Antithetic
from .base import BiasWarning, Estimator, point_engine, support_probe, uniform_blocks
from .control import ControlVariate, DefensiveMixture
from .crn import CRNDifference, crn_difference
from .importance import MonteCarlo
from .metropolis import MetropolisHastings
from .mis import HEURISTICS, MIS, mis_weights
from .onesample import OneSampleMIS
from .ris import RIS, Reservoir
from .rqmc import RQMC
from .stratified import Stratified

__all__ = [
    "HEURISTICS", "MIS", "OneSampleMIS", "RIS", "Reservoir", "mis_weights",
    "Antithetic", "BiasWarning", "CRNDifference", "ControlVariate", "DefensiveMixture", "Estimator",
    "MetropolisHastings", "MonteCarlo", "RQMC", "Stratified", "crn_difference", "point_engine",
    "support_probe", "uniform_blocks",
]
