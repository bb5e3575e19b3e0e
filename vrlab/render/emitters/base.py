"""The base of emitter elements, and what the renderer asks of an emitter that is not a shape.

Direct lighting at a point p integrates over x = (w, j), a direction and the light it
reaches.  The measure is solid angle for lights with an extent (area lights on shapes,
environment lights at infinity) and a counting measure for **delta lights** (a point, a
spot, a projector, a directional light): such a light reaches p from exactly one
direction, so its contribution is a sum, not an integral.  Every technique's density is
taken with respect to that one measure:

* the ``"light"`` technique picks light j with probability P_j, then for an extended
  light a direction with solid-angle density p_j(w): density P_j p_j(w); for a delta light
  the direction is fixed: density P_j (counting measure);
* a BSDF (or cosine, uniform) sample never lands on a delta light: its density there is 0.

So f/p, MIS weights (w_light = P_j / (P_j + 0) = 1 for a delta light, Veach's condition
"w_i = 0 wherever p_i = 0"), one-sample MIS, RIS and control variates all stay unbiased
with no special case; an estimator none of whose techniques reaches a delta light would
miss it, and the renderer refuses it, naming the light.

An emitter that is not attached to a shape implements, for reference points ``ref (m, 3)``
(float32 or float64, returned in their precision):

* ``sample(ref, u (m, 2)) -> (w, pdf, le, dist)``: unit directions towards the light, their
  density (solid angle; 1 for a delta light), the radiance arriving along w (for a delta
  light its intensity over the squared distance, falloff included), and the distance to
  the light (inf at infinity);
* ``pdf(ref, w)``: the solid-angle density of directions ``w`` (0 for a delta light);
* ``radiance(ref, w)``: the radiance arriving at ``ref`` along ``w`` from the light, as
  ``sample`` gives it (for an environment: its value towards -w);
* ``power(radius)``: an estimate of the emitted power for light selection by power
  (``radius``: of a sphere around the scene, for lights at infinity);
* ``is_delta``, ``is_infinite``; ``sampling_weight`` (Mitsuba's: selection probabilities are
  proportional to it, for every emitter);
* ``emission_cone()`` and ``light_bounds()``: what the light BVH (``light_selection="bvh"``)
  reads, with defaults (every direction; no bounds of its own).

Every emitter answers every one of these (the base class holds the defaults): lighting code
asks, it never probes with ``hasattr``.
"""
from __future__ import annotations

from typing import Any

from ... import checks
from ..registry import Element

__all__ = ["Emitter", "weight_param"]


def weight_param(value: Any) -> float:
    """``sampling_weight``: a finite number >= 0."""
    return checks.real(value, "sampling_weight", low=0)


class Emitter(Element):
    """Base of the emitter elements (see the module docstring).  ``is_area``: attached to a
    shape (``area``)."""

    kind = "emitter"
    is_area = False
    is_delta = False
    is_infinite = False
    sampling_weight = 1.0

    @property
    def type(self) -> str:
        """The Mitsuba plugin name."""
        return self.plugin_name

    def emission_cone(self) -> tuple | None:
        """``(w, cos_theta_o, cos_theta_e)``: pbrt-v4's orientation bounds of the directions a
        light at a point emits into (w the axis; it emits nowhere beyond theta_o + theta_e from
        w; the light BVH reads them), or None: every direction (the default)."""
        return None

    def light_bounds(self) -> tuple | None:
        """``(lo, hi, w, cos_theta_o, cos_theta_e)``: the light BVH's bounds of an emitter that has
        a place of its own (point, spot, projector: their position twice and
        :meth:`emission_cone`), or None (the default): an area emitter is bounded by its shape,
        a light at infinity by nothing."""
        return None
