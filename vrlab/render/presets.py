"""Strategy names as presets: each name stands for an estimator object of :mod:`vrlab.estimators`.

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
``"ris"``           ``RIS("light", target="unshadowed", m=M)``                           n_l
``"cv"``            ``ControlVariate("lambertian", alpha=1.0, distribution="light")``    n_l
==================  ================================================================  =========

"units" is the number of the estimator's sample units averaged at each shading point
(one camera ray): the scene's sample counts.  ``"mis-power"`` is Mitsuba's ``direct``
integrator (Veach's power heuristic, beta = 2); ``"mixture"`` the Russian lecture's
one-sample mixture (1/2 BSDF + 1/2 light for one sample of each); ``"ris"`` Talbot et
al. (2005) with the unshadowed target; ``"cv"`` light sampling with the closed-form
unoccluded Lambertian part as a control variate, alpha = 1.
"""
from __future__ import annotations

from typing import Any

from .. import checks

__all__ = ["PRESETS", "check_sample_counts", "preset"]

PRESETS = ("uniform", "cosine", "bsdf", "light", "mis-balance", "mis-power", "mixture", "ris", "cv")
_BSDF_ONLY = ("uniform", "cosine", "bsdf")


def check_sample_counts(name: str, emitter_samples: int, bsdf_samples: int) -> None:
    """``ValueError`` naming ``bsdf_samples`` / ``emitter_samples`` when preset ``name`` has
    no sample of the kind it needs (BSDF-only presets need a BSDF sample; light, ris and
    cv a light sample; every preset at least one sample)."""
    if name in _BSDF_ONLY and bsdf_samples < 1:
        raise ValueError(f"bsdf_samples: strategy {name!r} needs bsdf_samples >= 1, got {bsdf_samples}")
    if name in ("light", "ris", "cv") and emitter_samples < 1:
        raise ValueError(f"emitter_samples: strategy {name!r} needs emitter_samples >= 1, got {emitter_samples}")
    if emitter_samples + bsdf_samples < 1:
        raise ValueError("emitter_samples and bsdf_samples are both 0: nothing to sample")


def preset(name: str, *, emitter_samples: int = 1, bsdf_samples: int = 1, ris_candidates: int = 8) -> tuple[Any, int]:
    """``(estimator, units)``: the estimator object strategy ``name`` stands for (see the
    module table) and the number of its units per shading point."""
    name = checks.choice(name, "estimator", PRESETS)
    n_l = checks.integer(emitter_samples, "emitter_samples", low=0)
    n_b = checks.integer(bsdf_samples, "bsdf_samples", low=0)
    check_sample_counts(name, n_l, n_b)
    # one estimator module per preset (``vrlab render``'s start-up time is benchmarked)
    if name in _BSDF_ONLY or name == "light":
        from ..estimators.importance import MonteCarlo
        return MonteCarlo(name), (n_l if name == "light" else n_b)
    if name.startswith("mis-"):
        from ..estimators.mis import MIS
        return MIS(["light", "bsdf"], fractions=[n_l, n_b], heuristic=name[4:]), 1
    if name == "mixture":
        from ..estimators.onesample import OneSampleMIS
        return OneSampleMIS(["bsdf", "light"], probabilities=[n_b, n_l]), 1
    if name == "ris":
        from ..estimators.ris import RIS
        m = checks.integer(ris_candidates, "ris_candidates", low=1)
        return RIS("light", target="unshadowed", m=m), n_l
    from ..estimators.control import ControlVariate
    return ControlVariate("lambertian", alpha=1.0, distribution="light"), n_l
