"""Strategy names as presets: the recipes of :func:`vrlab.estimators.recipes` with a render builder.

With n_l = ``emitter_samples`` and n_b = ``bsdf_samples`` (the scene's integrator
settings, Mitsuba's defaults 1 and 1) and M = ``ris_candidates``:

==================  ================================================================  =========
name                estimator                                                         units
==================  ================================================================  =========
``"uniform"``       ``MonteCarlo("uniform")``                                          n_b
``"cosine"``        ``MonteCarlo("cosine")``                                           n_b
``"bsdf"``          ``MonteCarlo("bsdf")``                                             n_b
``"light"``         ``MonteCarlo("light")``                                            n_l
``"mis-balance"``   ``MIS(["light", "bsdf"], fractions=[n_l, n_b], heuristic="balance")``  1
``"mis-power"``     ``MIS(["light", "bsdf"], fractions=[n_l, n_b], heuristic="power")``    1
``"mixture"``       ``OneSampleMIS(["bsdf", "light"], probabilities=[n_b, n_l])``          1
``"cv"``            ``ControlVariate("lambertian", alpha=1.0, distribution="light")``    n_l
``"ris"``           ``RIS("light", target="unshadowed", m=M)``                           n_l
``"restir"``        ``ReSTIR(candidates=M, neighbours=5, radius=3, mis="pairwise")``     1
==================  ================================================================  =========

"units" is the number of the estimator's sample units averaged at each shading point
(one camera ray): the scene's sample counts.  ``"mis-power"`` is Mitsuba's ``direct``
integrator (Veach's power heuristic, beta = 2); ``"mixture"`` the Russian lecture's
one-sample mixture (1/2 BSDF + 1/2 light for one sample of each); ``"ris"`` Talbot et
al. (2005) with the unshadowed target; ``"cv"`` light sampling with the closed-form
unoccluded Lambertian part as a control variate, alpha = 1; ``"restir"`` per-pixel
reservoirs of M light candidates with spatial reuse among the pixels of a tile
(:mod:`vrlab.render.reuse`).  :data:`PRESETS` is a live view
of the registry: a recipe registered with a render builder is a preset at once.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Iterator

from .. import checks, limits

__all__ = ["PRESETS", "check_sample_counts", "preset", "preset_help"]


def _render_recipes() -> dict:
    from ..estimators.registry import recipes     # loaded on first use: importing the renderer stays cheap
    return recipes("render")


class _Presets(Sequence):
    """The preset names, in registration order: a live, read-only view of the registry."""

    def __getitem__(self, i):
        return tuple(_render_recipes())[i]

    def __len__(self) -> int:
        return len(_render_recipes())

    def __iter__(self) -> Iterator[str]:
        return iter(tuple(_render_recipes()))

    def __contains__(self, name: object) -> bool:
        return name in _render_recipes()

    def __repr__(self) -> str:
        return repr(tuple(self))


PRESETS: Sequence[str] = _Presets()


def preset_help() -> dict[str, str]:
    """``{preset name: one-line help}`` (the ``--strategy`` menu of ``vrlab render``)."""
    return {name: r.render_help for name, r in _render_recipes().items()}


def check_sample_counts(name: str, emitter_samples: int, bsdf_samples: int) -> None:
    """``ValueError`` naming ``bsdf_samples`` / ``emitter_samples`` when preset ``name`` has
    no sample of the kind it needs (the recipe's ``needs``: BSDF-only presets need a BSDF
    sample; light, ris and cv a light sample; every preset at least one sample)."""
    needs = _render_recipes()[name].needs if name in PRESETS else None
    if needs == "bsdf" and bsdf_samples < 1:
        raise ValueError(f"bsdf_samples: strategy {name!r} needs bsdf_samples >= 1, got {bsdf_samples}")
    if needs == "light" and emitter_samples < 1:
        raise ValueError(f"emitter_samples: strategy {name!r} needs emitter_samples >= 1, got {emitter_samples}")
    if emitter_samples + bsdf_samples < 1:
        raise ValueError("emitter_samples and bsdf_samples are both 0: nothing to sample")


def preset(name: str, *, emitter_samples: int = 1, bsdf_samples: int = 1, ris_candidates: int = 8) -> tuple[Any, int]:
    """``(estimator, units)``: the estimator object strategy ``name`` stands for (see the
    module table) and the number of its units per shading point."""
    name = checks.choice(name, "estimator", tuple(PRESETS))
    n_l = checks.integer(emitter_samples, "emitter_samples", low=0, high=limits.MAX_SAMPLES)
    n_b = checks.integer(bsdf_samples, "bsdf_samples", low=0, high=limits.MAX_SAMPLES)
    check_sample_counts(name, n_l, n_b)
    m = checks.integer(ris_candidates, "ris_candidates", low=1, high=limits.MAX_CANDIDATES)
    return _render_recipes()[name].render(n_l, n_b, m)
