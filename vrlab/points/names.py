"""The one resolver of point-set names, shared by estimators, the renderer and the CLIs.

Canonical names and their aliases (case-insensitive, spaces as '-'):
``independent`` (``iid``, ``random``, ``mc``, ``uniform``), ``stratified`` (``jittered``),
``lhs`` (``latin``, ``latin-hypercube``...), ``halton``, ``hammersley``, ``sobol``,
``cranley-patterson`` (``cp``, ``rotation``).  :func:`canonical` maps a name to its canonical
form (``ValueError`` naming the argument for an unknown one); :func:`is_independent` says
whether a ``points=`` value gives i.i.d. uniforms, so that every caller agrees on when a
standard error is valid.  This module imports no engine.
"""
from __future__ import annotations

from typing import Any

__all__ = ["ALIASES", "NAMES", "canonical", "is_independent"]

#: canonical point-set names (the classes are in :data:`vrlab.points.tools.POINT_SETS`)
NAMES = ("independent", "stratified", "lhs", "halton", "hammersley", "sobol", "cranley-patterson")
#: alias -> canonical name
ALIASES = {
    "iid": "independent", "random": "independent", "mc": "independent", "uniform": "independent",
    "jittered": "stratified", "latin": "lhs", "latinhypercube": "lhs", "latin-hypercube": "lhs",
    "latin_hypercube": "lhs", "cp": "cranley-patterson", "cranleypatterson": "cranley-patterson",
    "cranley_patterson": "cranley-patterson", "rotation": "cranley-patterson",
}


def canonical(name: Any, arg: str = "points") -> str:
    """The canonical point-set name of ``name`` (a name or an alias); ``TypeError`` for a
    non-string, ``ValueError`` for an unknown name, both starting with ``arg``."""
    if not isinstance(name, str):
        raise TypeError(f"{arg} must be a string naming a point set, got {type(name).__name__}")
    key = name.strip().lower().replace(" ", "-")
    key = ALIASES.get(key, key)
    if key not in NAMES:
        raise ValueError(f"{arg}: unknown point set {name!r}; allowed names: {', '.join(sorted(NAMES) + sorted(ALIASES))}")
    return key


def is_independent(points: Any) -> bool:
    """True when ``points`` gives i.i.d. uniforms: None, an array of the caller's uniforms (assumed
    independent, as documented), a name resolving to ``independent``, or the ``Independent``
    class or an instance of it."""
    import numpy as np

    if points is None or isinstance(points, np.ndarray):
        return True
    if isinstance(points, str):
        try:
            return canonical(points) == "independent"
        except ValueError:
            return False
    from .iid import Independent

    return points is Independent or isinstance(points, Independent) or (
        isinstance(points, type) and issubclass(points, Independent))
