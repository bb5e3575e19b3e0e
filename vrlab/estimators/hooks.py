"""The two parts of the estimator protocol: the core that the lab and the renderer share, and
the renderer's hooks (``docs/design.md``, "The estimator protocol").

:class:`~vrlab.estimators.Estimator` holds the core (:data:`CORE`: settings, ``dim_u``,
``unit_values``, the fold ``unit_outputs`` -> ``accumulate`` -> ``summarize``/``details``,
``estimate``...) and inherits the renderer's hooks from :class:`RenderHooks`
(:data:`RENDER_HOOKS`): the cost model of ``--compare`` (``traced_per_unit``,
``candidates_per_unit``, ``closed_form_per_unit``), the light a pixel sample sees directly
(``add_emitted``) and reuse across the pixels of a block (``spatial`` and the ``spatial_*``
methods).  The lab never asks for a hook; every hook has a default, so an estimator written
for the lab renders unchanged.

:func:`protocol_problems` checks what an estimator overrides against the documented protocol
(``vrlab.testing.check_estimator`` runs it as its ``protocol`` check): an overridden method
keeps the documented parameters (names and kinds, ``self`` included), a count stays an integer
(``evals_per_unit``, ``min_units`` >= 1; ``candidates_per_unit`` >= 0), a flag a bool, and a
spatial estimator overrides the three ``spatial_*`` methods.
"""
from __future__ import annotations

import inspect

import numpy as np

__all__ = ["CORE", "RENDER_HOOKS", "RenderHooks", "protocol_problems"]

#: the members the lab and the renderer share (defined on ``Estimator``)
CORE = ("get_params", "clone", "label", "dim_u", "unit_values", "check", "unit_dim", "unit_outputs",
        "accumulate", "summarize", "details", "statistics_from_state", "fold", "units_for", "estimate",
        "to_estimate", "evals_per_unit", "per_unit", "min_units")
#: the members only the renderer asks for (defined on ``RenderHooks``)
RENDER_HOOKS = ("add_emitted", "traced_per_unit", "candidates_per_unit", "closed_form_per_unit", "spatial",
                "spatial_check", "spatial_dim", "spatial_outputs")
#: attributes (or properties) of the protocol: integer counts with their least value, and flags
_COUNTS = {"evals_per_unit": 1, "min_units": 1, "candidates_per_unit": 0}
_FLAGS = ("per_unit", "closed_form_per_unit", "spatial")
_SPATIAL = ("spatial_check", "spatial_dim", "spatial_outputs")


class RenderHooks:
    """The renderer's hooks of the estimator protocol, each with its default (module docstring).

    ================================  ==========================================================
    ``add_emitted(outputs, emitted)``  the light the pixel sample sees directly added to the unit
                                       outputs (default: to column 0)
    ``traced_per_unit()``              evaluations per unit the renderer traces a shadow ray for
                                       (default ``evals_per_unit``)
    ``candidates_per_unit``            cheap evaluations per unit without a ray (RIS's m; 0)
    ``closed_form_per_unit``           True when each unit also evaluates a closed-form control
    ``spatial``                        True for reuse across the pixels of a block (ReSTIR): the
                                       renderer calls ``spatial_check``/``spatial_dim``/
                                       ``spatial_outputs(view, u (N, B, dim))`` (N units over B
                                       pixels, ``view`` a :class:`vrlab.render.reuse.BlockPixels`)
                                       -> ``(3, N, B, c)`` instead of ``check``/``unit_dim``/
                                       ``unit_outputs``
    ================================  ==========================================================
    """

    #: cheap evaluations per unit that trace no ray (RIS candidates against an unshadowed target)
    candidates_per_unit: int = 0
    #: True when a unit also evaluates a closed-form control integral (the renderer's cost model)
    closed_form_per_unit: bool = False
    #: True when a unit reuses samples across the pixels of a block (ReSTIR): the renderer
    #: calls the ``spatial_*`` hooks, not one unit per shading point
    spatial: bool = False

    def traced_per_unit(self) -> int:
        """Integrand evaluations per unit that the renderer traces a shadow ray for
        (default ``evals_per_unit``; a one-sample mixture traces one direction but weighs it
        with every technique)."""
        return int(self.evals_per_unit)

    def add_emitted(self, outputs: np.ndarray, emitted: np.ndarray) -> np.ndarray:
        """The renderer's unit outputs ``(..., m, c)`` with the light the pixel sample sees
        directly, ``emitted (..., m)`` (a term common to every technique), added: by default to
        column 0.  An estimator that fits coefficients may keep it apart (a last column) so
        that the fit is not driven by it."""
        outputs[..., 0] += emitted
        return outputs

    def spatial_check(self, integrand) -> None:
        """Spatial hook: validate settings against the renderer's integrand."""
        raise TypeError(f"estimator: {self.label} is not spatial (spatial = False)")

    def spatial_dim(self, integrand) -> int:
        """Spatial hook: uniforms per pixel sample of one spatial unit."""
        raise TypeError(f"estimator: {self.label} is not spatial (spatial = False)")

    def spatial_outputs(self, view, u: np.ndarray) -> np.ndarray:
        """Spatial hook: outputs ``(3, N, B, c)`` of N independent units over B pixels."""
        raise TypeError(f"estimator: {self.label} is not spatial (spatial = False)")


def _shape(fn) -> list[tuple]:
    return [(p.name, p.kind) for p in inspect.signature(fn).parameters.values()]


def protocol_problems(estimator, base: type | None = None) -> list[str]:
    """What ``estimator`` overrides against the protocol of ``base`` (default: the class in its
    MRO that defines ``CORE``, :class:`~vrlab.estimators.Estimator`) breaks: one line per
    problem, empty if none."""
    cls, out = type(estimator), []
    if base is None:
        base = next((c for c in reversed(cls.__mro__) if "CORE" in vars(c)), None)
        if base is None:
            return [f"{cls.__name__} is no vrlab.estimators.Estimator"]
    for name in CORE + RENDER_HOOKS:
        documented = inspect.getattr_static(base, name)
        if not callable(documented) or isinstance(documented, property):
            continue
        mine = inspect.getattr_static(cls, name)
        if mine is documented:
            continue
        if not callable(mine):
            out.append(f"{name}: the protocol's method is replaced by {type(mine).__name__} {mine!r}")
        elif _shape(mine) != _shape(documented):
            group = "renderer hook" if name in RENDER_HOOKS else "core method"
            out.append(f"{name}{inspect.signature(mine)}: the {group} is documented as "
                       f"{name}{inspect.signature(documented)}")
    for name, least in _COUNTS.items():
        v = getattr(estimator, name)
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) or v < least:
            out.append(f"{name} must be an integer >= {least}, got {v!r}")
    for name in _FLAGS:
        if not isinstance(getattr(estimator, name), (bool, np.bool_)):
            out.append(f"{name} must be True or False, got {getattr(estimator, name)!r}")
    if getattr(estimator, "spatial", False) is True:
        missing = [n for n in _SPATIAL if inspect.getattr_static(cls, n) is inspect.getattr_static(base, n)]
        if missing:
            out.append(f"spatial = True but {', '.join(missing)} not overridden")
    return out
