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
from .._lazy import lazy_attributes

# name -> submodule, loaded on first use (PEP 562: ``import vrlab.render`` needs none)
_WHERE = {
    "PointSet": "base", "Halton": "halton", "Hammersley": "halton", "first_primes": "halton",
    "radical_inverse": "halton", "Independent": "iid", "LatinHypercube": "lhs",
    "CranleyPatterson": "rotation", "Sobol": "sobol", "Stratified": "stratified",
    "balanced_strata": "stratified", "POINT_SETS": "tools", "discrepancy": "tools",
    "make_points": "tools", "replicates": "tools",
}

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


__getattr__, __dir__ = lazy_attributes(__name__, _WHERE, __all__)
