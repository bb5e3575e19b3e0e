"""``sphere`` (Mitsuba 3): ``center`` (default origin) and ``radius`` (default 1), composed
into ``to_world`` as ``to_world @ T(center) @ S(radius)``; ``to_world`` must be a
similarity.  Lights sample it by the cone it subtends (``SphereCone``); seen from a point
with the whole sphere above its horizon, int cos dw = pi (r/d)^2 cos(theta_c) (the cone
of a sphere is a disk light of solid angle pi sin^2 alpha seen at cos theta_c)."""
from __future__ import annotations

from typing import Any

import numpy as np

from ... import checks
from ..._vec import dot, norm
from ..registry import register
from .ellipsoid import Ellipsoid

__all__ = ["Sphere", "sphere_cos_integral"]


def sphere_cos_integral(center, radius, ref, n) -> tuple[np.ndarray, np.ndarray]:
    """``(I, valid)``: I = pi (r/d)^2 cos(theta_c) = int cos dw over a sphere's cone where the
    whole sphere is above the horizon of (``ref``, ``n``); broadcasts."""
    v = center - ref
    d = norm(v)
    h = dot(v, n)
    valid = (d > radius) & (h >= radius)
    safe = np.where(valid, d, 1.0)
    return np.where(valid, np.pi * (radius / safe) ** 2 * h / safe, 0.0), valid


@register("shape", "sphere")
class Sphere(Ellipsoid):
    """Mitsuba's ``sphere``: ``center`` (3,), ``radius`` > 0, and the common shape parameters
    (an ellipsoid of equal radii whose ``to_world`` is a similarity)."""

    def __init__(self, *, center: Any = (0.0, 0.0, 0.0), radius: float = 1.0, **common):
        r = checks.real(radius, "radius", low=0, low_open=True)
        super().__init__(center=center, radii=(r, r, r), **common)
        self._check_similarity()

    @classmethod
    def from_props(cls, p) -> Sphere:
        return cls(center=p.point("center", (0, 0, 0)), radius=p.float("radius", 1.0), **cls.common(p))

    def _check_similarity(self) -> None:
        g = self.to_world[:3, :3].T @ self.to_world[:3, :3]
        if np.abs(g - g[0, 0] * np.eye(3)).max() > 1e-6 * g[0, 0]:
            raise ValueError("to_world of a sphere must be a similarity (no non-uniform scale or shear); "
                             "use the vrlab 'ellipsoid' shape")

    def validate(self) -> None:
        super().validate()
        self._check_similarity()

    def sphere(self) -> tuple[np.ndarray, float]:
        """(center, radius) in world space."""
        return self.center, float(np.linalg.norm(self.to_world[:3, 0]))

    @property
    def sphere_light(self) -> tuple[np.ndarray, float]:
        return self.sphere()

    @property
    def area(self) -> float:
        return float(4 * np.pi * self.sphere()[1] ** 2)

    @property
    def bound_radius(self) -> float:
        return self.sphere()[1]

    def cos_integral(self, ref, n):
        c, r = self.sphere()
        return sphere_cos_integral(c, r, ref, n)
