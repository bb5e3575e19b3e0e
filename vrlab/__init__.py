"""vrlab: Monte Carlo estimators and variance reduction, as taught in rendering courses.

Layers: ``vrlab.points`` (uniforms), ``vrlab.distributions`` (warps with pdfs and
discrete sampling), ``vrlab.integrands`` (integrands with closed forms),
``vrlab.estimators`` (variance-reduction techniques), ``vrlab.lab`` (experiments),
``vrlab.testing`` (chi-square harness).  Every estimate is a deterministic function of
uniforms ``u``: randomness enters only through point sets seeded by ``rng``.
"""
import importlib

from . import distributions
from .distributions import AliasTable, CDFTable
from .estimate import Estimate, Moments

__version__ = "0.1.0"

_SUBMODULES = ("estimators", "integrands", "points", "testing")


def __getattr__(name: str):
    """Subpackages load on first use (``vrlab.testing`` needs scipy.stats, slow to import;
    ``vrlab.render`` needs few estimators): ``vrlab.estimators``, ``vrlab.Integrand``, ..."""
    if name in _SUBMODULES:
        return importlib.import_module(f".{name}", __name__)
    if name == "Integrand":
        return importlib.import_module(".integrands", __name__).Integrand
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__all__ = ["AliasTable", "CDFTable", "Estimate", "Integrand", "Moments", "distributions", "estimators",
           "integrands", "points", "testing", "__version__"]
