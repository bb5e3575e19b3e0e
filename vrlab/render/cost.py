"""Counted cost: what a render did, per pixel sample, in units any renderer shares.

Seconds depend on the machine and on how the work is coded (NumPy or compiled kernels);
counts of operations do not.  Each work unit of a render (tile x spp batch) owns one
:class:`Cost`, passed down to the code that does the work, which adds the rows it
processes (``len`` of the arrays of a vectorised call, never a Python loop over samples);
the unit returns it with its statistics and :func:`vrlab.render.film.execute` sums the
units' counts (integers: exact, the same for any worker count, executor or order).

The counters (:data:`COUNTERS`), each a number of rows (one ray, one sample, one point):

``camera_rays``     closest-hit rays from the camera, one per pixel sample
``closest_rays``    closest-hit rays leaving a surface (``DirectLighting.trace``: a BSDF or
                    other directional sample finding the light it reaches; vrlab splits it
                    into an emitter query and a blocker test, counted as the one ray a
                    renderer traces)
``shadow_rays``     any-hit (shadow) rays towards a known light point
                    (``DirectLighting.unblocked``: light samples, ReSTIR's reconnections)
``bsdf_samples``    directions drawn from a BSDF (the ``"bsdf"`` technique and its lobes;
                    the cosine and uniform warps are not BSDF samples)
``bsdf_evals``      the BSDF's value and/or density at a direction it did not sample,
                    counted once per point (as Mitsuba's ``eval_pdf``): a sample includes
                    its own value and density
``emitter_samples`` light samples: a light chosen and a point / direction on it, with its
                    radiance and density
``emitter_evals``   a light's radiance and/or density at a point its light technique did
                    not sample, once per point that reaches a light (a BSDF sample that
                    hits one, the chosen sample of RIS, a ReSTIR reconnection); the radiance
                    seen by camera rays is not counted
``light_walks``     light-BVH traversals (``light_selection="bvh"``): one per light sample
                    and one per selection pmf of a reached light (uniform and power
                    selection are table lookups: none)

``samples`` counts the pixel samples the counts belong to (a gradient-domain sample
evaluates three pixels: its counts are for all three).  A closed-form control variate's
integral over the lights is not counted.

A weighted cost per sample, ``sum_k w_k count_k / samples``, ranks strategies at equal
counted cost (``compare(..., equal_cost=True)``); :data:`DEFAULT_WEIGHTS`: 1 per ray of
each kind, :data:`EVAL_WEIGHT` = 0.1 per BSDF or emitter sample or evaluation and
:data:`WALK_WEIGHT` = 0.25 per light-BVH walk (in production renderers a ray costs about
ten times a BSDF or emitter evaluation; a light-BVH walk visits O(log L) nodes with an
importance bound each).  :func:`cost_weights` reads user weights by counter name or by the
groups ``rays``, ``evals``, ``samples`` (a group first, then names override it).
"""
from __future__ import annotations

import dataclasses
import numbers
from typing import Any

__all__ = ["COUNTERS", "Cost", "DEFAULT_WEIGHTS", "GROUPS", "cost_weights", "parse_cost_weights"]

COUNTERS = ("camera_rays", "closest_rays", "shadow_rays", "bsdf_samples", "bsdf_evals", "emitter_samples",
            "emitter_evals", "light_walks")
EVAL_WEIGHT = 0.1
WALK_WEIGHT = 0.25
DEFAULT_WEIGHTS = {"camera_rays": 1.0, "closest_rays": 1.0, "shadow_rays": 1.0, "bsdf_samples": EVAL_WEIGHT,
                   "bsdf_evals": EVAL_WEIGHT, "emitter_samples": EVAL_WEIGHT, "emitter_evals": EVAL_WEIGHT,
                   "light_walks": WALK_WEIGHT}
#: names that set several weights at once
GROUPS = {"rays": ("camera_rays", "closest_rays", "shadow_rays"), "evals": ("bsdf_evals", "emitter_evals"),
          "samples": ("bsdf_samples", "emitter_samples")}


@dataclasses.dataclass
class Cost:
    """The counts of one work unit, or of a whole render (see the module docstring)."""

    samples: int = 0
    camera_rays: int = 0
    closest_rays: int = 0
    shadow_rays: int = 0
    bsdf_samples: int = 0
    bsdf_evals: int = 0
    emitter_samples: int = 0
    emitter_evals: int = 0
    light_walks: int = 0

    def add(self, other: "Cost") -> "Cost":
        """Add ``other``'s counts to these, in place; returns self."""
        for f in ("samples",) + COUNTERS:
            setattr(self, f, getattr(self, f) + getattr(other, f))
        return self

    def totals(self) -> dict[str, int]:
        """``{counter: count}`` over every sample (the counters of :data:`COUNTERS`)."""
        return {k: int(getattr(self, k)) for k in COUNTERS}

    def per_sample(self) -> dict[str, float]:
        """``{counter: count / samples}`` (0 without samples)."""
        n = max(self.samples, 1)
        return {k: v / n for k, v in self.totals().items()}

    def weighted(self, weights: dict | None = None) -> float:
        """The weighted cost per sample, ``sum_k w_k count_k / samples`` (``weights``:
        :func:`cost_weights`' output; None: :data:`DEFAULT_WEIGHTS`)."""
        w = DEFAULT_WEIGHTS if weights is None else weights
        return sum(w[k] * v for k, v in self.per_sample().items())

    def report(self, weights: dict | None = None) -> dict:
        """What ``Estimate.extra["cost"]`` and ``--json`` hold: ``samples``, ``totals``,
        ``per_sample``, the ``weights`` and the ``weighted_per_sample`` cost."""
        w = dict(DEFAULT_WEIGHTS if weights is None else weights)
        return {"samples": int(self.samples), "totals": self.totals(), "per_sample": self.per_sample(),
                "weights": w, "weighted_per_sample": self.weighted(w)}


def cost_weights(weights: Any = None, name: str = "cost_weights") -> dict[str, float]:
    """Every counter's weight: :data:`DEFAULT_WEIGHTS` updated by ``weights`` (None, or a
    mapping from counter names or :data:`GROUPS` names to finite numbers >= 0; groups are
    applied first, counter names after).  ``TypeError`` / ``ValueError`` naming ``name``."""
    out = dict(DEFAULT_WEIGHTS)
    if weights is None:
        return out
    if not isinstance(weights, dict):
        raise TypeError(f"{name} must be a dict of weights by counter name, got {type(weights).__name__}")
    known = tuple(GROUPS) + COUNTERS
    for key, value in sorted(weights.items(), key=lambda kv: kv[0] not in GROUPS):
        if key not in known:
            raise ValueError(f"{name}: unknown counter {key!r}; known: {', '.join(known)}")
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise TypeError(f"{name}: the weight of {key!r} must be a number, got {value!r}")
        v = float(value)
        if not (v >= 0 and v < float("inf")):
            raise ValueError(f"{name}: the weight of {key!r} must be a finite number >= 0, got {value!r}")
        for k in GROUPS.get(key, (key,)):
            out[k] = v
    if not any(out.values()):
        raise ValueError(f"{name}: every weight is 0; give some counter a positive weight")
    return out


def parse_cost_weights(text: str, name: str = "--cost-weights") -> dict[str, float]:
    """Weights from ``"NAME=W,NAME=W"`` text (the command line's), checked by
    :func:`cost_weights`: ``ValueError`` naming ``name`` for an item that is not NAME=number,
    a name given twice, an unknown name or a bad number."""
    out: dict[str, Any] = {}
    items = [s.strip() for s in str(text).split(",")]
    if not any(items):
        raise ValueError(f"{name}: expected NAME=WEIGHT,... (e.g. rays=1,evals=0.1), got {text!r}")
    for item in items:
        key, eq, value = item.partition("=")
        key, value = key.strip(), value.strip()
        if not eq or not key:
            raise ValueError(f"{name}: expected NAME=WEIGHT, got {item!r}")
        if key in out:
            raise ValueError(f"{name}: {key!r} is given twice")
        try:
            out[key] = float(value)
        except ValueError:
            raise ValueError(f"{name}: the weight of {key!r} must be a number, got {value!r}") from None
    try:
        return cost_weights(out, name)
    except TypeError as exc:
        raise ValueError(str(exc)) from None
