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
``PaddedStratified``   padded jittered (PBRT 7.3)      :mod:`vrlab.points.pixel_sets`
``ShiftedCopies``      one set, a shift per copy       :mod:`vrlab.points.pixel_sets`
``SetSampler``         batches of copies (renderer)    :mod:`vrlab.points.pixel_sets`
=====================  ==============================  =====================================

Helpers: :func:`make_points` (by name), :func:`replicates` (independent randomised
copies, seeds from ``SeedSequence.spawn``), :func:`discrepancy`, :func:`radical_inverse`.

``Halton``, ``Sobol`` and ``LatinHypercube`` pass SciPy's own generic engine tests
(``tests/test_scipy_engines.py``): ``d >= 0``, ``optimization=`` (SciPy's optimisers),
``integers()``, ``random(n, workers=...)``, ``seed=`` as the legacy name of ``rng=``,
``Sobol.MAXDIM``, and a ``Generator``/``BitGenerator`` given as ``rng`` is not drawn from
directly: the engine spawns a child of it, as ``QMCEngine`` does.  Bad arguments raise
``ValueError``/``TypeError`` naming them (SciPy's types where SciPy has the argument:
``ValueError`` for a non-integer ``d``, bad ``workers``, ``strength`` or ``optimization``).

Differences from ``scipy.stats.qmc`` that remain by design
----------------------------------------------------------
* ``Halton`` and ``Hammersley`` are *unscrambled* by default (SciPy's Halton: scrambled);
  randomisation is asked for with ``scramble=True`` (random digit permutations) or
  ``"owen"`` (nested scrambling, not in SciPy).  Unscrambled points equal SciPy's bit for bit.
* Scrambled values differ from SciPy's for the same seed: the scrambles have the same
  distribution but are drawn by vrlab's own algorithms.  For bases above ``2**12``
  (``d > 564``) a digit permutation is a random affine map ``d -> (a d + c) mod b``: the
  same pairwise laws (so the same estimator mean and variance) without ``b``-entry
  tables, which is what lets ``d = 10^4`` run in little memory.
* ``Sobol`` defaults to ``bits=52`` when scrambled (SciPy: 30; see :class:`Sobol`).
* Seeds: an int, list of ints or ``SeedSequence`` seeds the engine's generator directly
  (``default_rng(seed)``, SciPy's legacy ``seed=int`` behaviour), for ``rng=`` and ``seed=``
  alike; SciPy's ``rng=int`` spawns a child first.  ``Sobol`` hands ``rng`` to SciPy, so
  ``Sobol(d, bits=b, rng=x)`` is ``scipy.stats.qmc.Sobol(d, bits=b, rng=x)``.
  ``numpy.random.RandomState`` is refused (``TypeError``): engines need a ``Generator``.
* ``workers`` is checked but the computation is single-threaded (same points).
* ``optimization="lloyd"`` is refused for ``d < 2`` at construction and for ``n < d + 1``
  points in a call (SciPy fails inside Qhull); ``random(0)`` returns an empty array.
* ``LatinHypercube`` also accepts vrlab's older ``centered=`` (``= not scramble``); its
  strength-2 (orthogonal-array) design is vrlab's own implementation of the published
  construction (Bose's OA, Tang 1993), with SciPy's rules and messages for ``n`` and ``d``.
* Limits that SciPy lacks, so that bad input fails fast instead of hanging or exhausting
  memory: ``random(n)`` with ``n <= 2**48``; point indices below ``2**62`` (Halton,
  Hammersley; ``2**32`` for ``"owen"``); ``Halton`` ``d <= 2**23``; ``R <= 2**20``
  replicates.  ``Sobol.fast_forward`` works for ``bits > 32`` too (SciPy 1.17 fails there).
"""
from .._lazy import lazy_attributes

# name -> submodule, loaded on first use (PEP 562: ``import vrlab.render`` needs none)
_WHERE = {
    "PointSet": "base", "Halton": "halton", "Hammersley": "halton", "first_primes": "halton",
    "radical_inverse": "halton", "Independent": "iid", "LatinHypercube": "lhs",
    "CranleyPatterson": "rotation", "PaddedStratified": "pixel_sets", "SetSampler": "pixel_sets",
    "ShiftedCopies": "pixel_sets", "Sobol": "sobol", "Stratified": "stratified",
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
    "PaddedStratified",
    "PointSet",
    "SetSampler",
    "ShiftedCopies",
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
