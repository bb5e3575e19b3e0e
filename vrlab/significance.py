"""Significance levels shared by the test tools and the lab (a shared helper of every layer).

* ``sidak_threshold(alpha, m)``: the per-test level 1 - (1 - alpha)^(1/m) that keeps the
  family-wise error rate of ``m`` independent tests at ``alpha`` (Šidák 1967).
* ``std_band(r, alpha)``: for r independent N(0, 1) values the sample standard deviation s
  satisfies (r - 1) s^2 ~ chi^2_{r-1}; the band [sqrt(q_lo), sqrt(q_hi)] with
  q = chi2.ppf([alpha/2, 1 - alpha/2], r - 1) / (r - 1) holds with probability 1 - alpha.
  Used to check that z-scores of an estimator have spread 1 (calibrated stderr).

:mod:`vrlab.testing` (the chi-square harness, ``vrlab.testing.stats``) and :mod:`vrlab.lab.trust`
(the stderr trust flags) both use them.  Arguments are checked (errors name them): ``alpha`` in
(0, 1), ``m >= 1``, ``r >= 2``.
"""
from __future__ import annotations

import numpy as np

from . import checks

__all__ = ["sidak_threshold", "std_band"]


def _alpha(alpha) -> float:
    return checks.real(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)


def sidak_threshold(alpha: float, m: int) -> float:
    """Per-test level that keeps the family-wise error rate at ``alpha`` (in (0, 1)) over
    ``m >= 1`` tests."""
    alpha, m = _alpha(alpha), checks.integer(m, "m", low=1)
    return 1.0 - (1.0 - alpha) ** (1.0 / m)


def std_band(r: int, alpha: float = 1e-3) -> tuple[float, float]:
    """Band for the sample std of ``r`` standard normal values (chi-square, r - 1 dof)."""
    from scipy import stats  # slow to import: on first use

    r = checks.integer(r, "r", low=2)
    alpha = _alpha(alpha)
    q = stats.chi2.ppf([alpha / 2, 1 - alpha / 2], r - 1) / (r - 1)
    return float(np.sqrt(q[0])), float(np.sqrt(q[1]))
