"""vrlab: Monte Carlo estimators and variance reduction, as taught in rendering courses.

Layers: ``vrlab.points`` (uniforms), ``vrlab.distributions`` (warps with pdfs and
discrete sampling), ``vrlab.integrands`` (integrands with closed forms),
``vrlab.estimators`` (variance-reduction techniques), ``vrlab.lab`` (experiments),
``vrlab.testing`` (chi-square harness).  Every estimate is a deterministic function of
uniforms ``u``: randomness enters only through point sets seeded by ``rng``.
"""
from . import distributions, estimators, integrands, points
from .distributions import AliasTable, CDFTable
from .estimate import Estimate, Moments
from .integrands import Integrand

__version__ = "0.1.0"


def __getattr__(name: str):
    """``vrlab.testing`` is imported on first use (it needs scipy.stats, slow to import)."""
    if name == "testing":
        import importlib

        return importlib.import_module(".testing", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["AliasTable", "CDFTable", "Estimate", "Integrand", "Moments", "distributions", "estimators",
           "integrands", "points", "testing", "__version__"]
