"""Argument checks of the chi-square harness (bins, charts, quadrature orders, names); those the
quadrature shares live in :mod:`vrlab.distributions.quadrature` and are imported from there.

Every error names the argument; the limits keep a mistyped size from allocating
gigabytes (the harness evaluates the pdf at every quadrature node at once).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from .. import checks
from .._rng import as_generator
from ..distributions.quadrature import real_values

#: Most samples ``chi2_gof`` draws.
MAX_SAMPLES = 10**8


def text(value: Any, name: str) -> str:
    """``value`` if it is a string (``TypeError`` otherwise)."""
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a string, got {checks.describe(value)}")
    return value


def draw_uniforms(dist, n: int, rng, points) -> np.ndarray:
    """``n`` rows of uniforms for ``dist``: from ``points.random(n)`` or from ``rng``."""
    gen = as_generator(rng)
    if points is None:
        dim_u = checks.integer(getattr(dist, "dim_u", None), "dist.dim_u", low=1)
        return gen.random((n, dim_u))
    if not callable(getattr(points, "random", None)):
        raise TypeError(f"points must be a point set with random(n) (e.g. vrlab.points.Sobol), "
                        f"got {checks.describe(points)}")
    u = checks.uniforms_array(points.random(n), "points")
    if u.ndim != 2 or u.shape[0] != n:
        raise ValueError(f"points: random({n}) returned shape {u.shape}, expected ({n}, d)")
    return u


def sample_points(dist, u: np.ndarray, n: int, chart) -> np.ndarray:
    """``dist.sample(u)`` as an (n, dim_x) float array (``ValueError`` naming dist otherwise)."""
    x = real_values(dist.sample(u), "dist.sample(u)")
    dim_x = getattr(chart, "dim_x", None)
    want = (n, dim_x) if isinstance(dim_x, (int, np.integer)) else None
    if x.ndim != 2 or x.shape[0] != n or (want is not None and x.shape != want):
        raise ValueError(f"dist: sample(u) returned shape {x.shape}, expected "
                         f"{want if want is not None else (n, 'dim_x')} for this chart")
    return x
