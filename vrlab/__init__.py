"""vrlab: Monte Carlo estimators and variance reduction, as taught in rendering courses.

Layers: ``vrlab.points`` (uniforms), ``vrlab.distributions`` (warps with pdfs and
discrete sampling), ``vrlab.testing`` (chi-square harness).
"""
from . import distributions, testing

__version__ = "0.1.0"
__all__ = ["distributions", "testing", "__version__"]
