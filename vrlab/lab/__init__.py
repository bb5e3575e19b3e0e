"""The integral lab: estimators x integrands x sample counts x repetitions -> tables and plots.

``run`` (tidy DataFrame, spawned seeds; local processes or a Dask cluster; resumable with
an SQLite ``store``), ``summarize``,
``fit_slopes``, ``equal_time``, ``convergence_plot``, ``efficiency_plot``; estimator
recipes by name in :mod:`vrlab.lab.registry` (``list_recipes``, ``applicable``, ``build``).
"""
from .plots import convergence_plot, efficiency_plot
from .registry import applicable, build, explain, get_recipe, list_recipes, register
from .runner import run
from .summary import equal_time, fit_slopes, summarize, theoretical_slope

__all__ = ["applicable", "build", "convergence_plot", "efficiency_plot", "equal_time", "explain",
           "fit_slopes", "get_recipe", "list_recipes", "register", "run", "summarize", "theoretical_slope"]
