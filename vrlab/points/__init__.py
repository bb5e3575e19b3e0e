"""Point sets: the uniforms ``u`` of shape ``(n, d)`` that every vrlab estimator consumes.

Engines share the ``scipy.stats.qmc`` interface (``Cls(d, *, rng=None, ...)``,
``random(n)``, ``reset()``, ``fast_forward(n)``), so SciPy engines can be used
wherever a point set is expected.

=====================  ==============================  =====================================
class                  points                          module
=====================  ==============================  =====================================
``Independent``        i.i.d. uniforms (plain MC)      :mod:`vrlab.points.iid`
``Stratified``         jittered grid                   :mod:`vrlab.points.stratified`
``LatinHypercube``     McKay et al. 1979               :mod:`vrlab.points.lhs`
``Halton``             Halton 1960 (+ scrambles)       :mod:`vrlab.points.halton`
``Hammersley``         Hammersley 1964 (+ scrambles)   :mod:`vrlab.points.halton`
``Sobol``              SciPy's Sobol'                  :mod:`vrlab.points.sobol`
``CranleyPatterson``   random shift mod 1 (1976)       :mod:`vrlab.points.rotation`
=====================  ==============================  =====================================

Helpers: :func:`make_points` (by name), :func:`replicates` (independent randomised
copies, seeds from ``SeedSequence.spawn``), :func:`discrepancy`, :func:`radical_inverse`.
"""
from .base import PointSet
from .halton import Halton, Hammersley, first_primes, radical_inverse
from .iid import Independent
from .lhs import LatinHypercube
from .rotation import CranleyPatterson
from .sobol import Sobol
from .stratified import Stratified, balanced_strata
from .tools import POINT_SETS, discrepancy, make_points, replicates

__all__ = [
    "POINT_SETS",
    "CranleyPatterson",
    "Halton",
    "Hammersley",
    "Independent",
    "LatinHypercube",
    "PointSet",
    "Sobol",
    "Stratified",
    "balanced_strata",
    "discrepancy",
    "first_primes",
    "make_points",
    "radical_inverse",
    "replicates",
]
