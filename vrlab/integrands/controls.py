"""Known control variates and smoothness of the catalogue integrands (used by the ``cv`` recipe
of :mod:`vrlab.estimators.registry` and the lab's slopes).

``control_for(integrand)`` gives ``(h, int h, description)`` for the ``cv`` recipe and
``is_smooth(integrand)`` selects the theoretical convergence slope; both take an
``Integrand`` or a catalogue name (``TypeError``/``ValueError`` naming ``integrand``).
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .lookup import as_integrand as _integrand


def _box_coordinate(k: int):
    def h(x):
        return x[..., k]
    h.__name__ = f"x{k}"
    return h


def _hemisphere_cos(w):
    return np.clip(w[..., 2], 0.0, None)


def _taylor_sin(x):   # sin x ~ x (first Taylor term) on [0, pi/2]
    return x[..., 0]


def _taylor_smooth_2d(x):   # e^x sin(pi y) ~ (1 + x) sin(pi y)
    return (1.0 + x[..., 0]) * np.sin(np.pi * x[..., 1])


#: Known controls h with their integrals for catalogue integrands (name -> (h, int h, what)).
#: exp: h = x (lecture; beta* = 1.69, variance factor 1 - rho^2 = 0.0163); sin: h = x
#: (first Taylor term); smooth-2d: h = (1 + x) sin(pi y); cos8-hemisphere: h = cos(theta).
CONTROLS: dict[str, tuple[Callable, float, str]] = {
    "exp": (_box_coordinate(0), 0.5, "h = x"),
    "sin": (_taylor_sin, np.pi**2 / 8, "h = x"),
    "smooth-2d": (_taylor_smooth_2d, 3 / np.pi, "h = (1 + x) sin(pi y)"),
    "cos8-hemisphere": (_hemisphere_cos, np.pi, "h = cos(theta)"),
}


def control_for(integrand) -> tuple[Callable, float, str]:
    """A control variate ``(h, int h, description)`` for ``integrand``.

    ``integrand.theory["cv:control"] = (h, integral)`` wins; otherwise a catalogue
    integrand (same name and same exact value) gets its entry of ``CONTROLS``.
    """
    integrand = _integrand(integrand)
    given = getattr(integrand, "theory", {}).get("cv:control")
    if given is not None:
        h, H = given[:2]
        return h, float(H), getattr(h, "__name__", "theory control")
    name = getattr(integrand, "name", None)
    if name in CONTROLS:
        from .catalogue import CATALOGUE
        ref = CATALOGUE[name]() if name in CATALOGUE else None
        if ref is None or (integrand.exact is not None and np.isclose(ref.exact, integrand.exact)):
            return CONTROLS[name]
    raise ValueError(f"cv: no control variate known for integrand {name!r}; name one in its controls "
                     "({name: (h, integral of h)}) or put (h, integral of h) in integrand.theory['cv:control'] "
                     "(known for: " + ", ".join(CONTROLS) + ")")


#: Catalogue integrands with discontinuities (lower convergence rates of stratified/QMC points).
DISCONTINUOUS = frozenset({"step-x2", "disk-indicator", "glossy-light"})


def is_smooth(integrand) -> bool:
    """``integrand.theory["smooth"]`` if given, else False for the known discontinuous ones."""
    integrand = _integrand(integrand)
    flag = getattr(integrand, "theory", {}).get("smooth")
    return bool(flag) if flag is not None else getattr(integrand, "name", None) not in DISCONTINUOUS
