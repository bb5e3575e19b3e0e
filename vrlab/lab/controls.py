"""The catalogue's known control variates and smoothness: moved to :mod:`vrlab.integrands.controls`
(the ``cv`` recipe of :mod:`vrlab.estimators.registry` needs them below the lab); re-exported here."""
from ..integrands.controls import CONTROLS, DISCONTINUOUS, control_for, is_smooth

__all__ = ["CONTROLS", "DISCONTINUOUS", "control_for", "is_smooth"]
