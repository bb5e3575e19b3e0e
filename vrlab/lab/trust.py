"""Stderr trust flags of a lab summary: are an estimator's error bars honest?

If an estimator's standard errors are honest, its R repetitions give z_r = (F_r - I) /
stderr_r about N(0, 1): (R - 1) z_std^2 ~ chi^2_{R-1}, and the count K of 95 % intervals
F_r +- 1.96 stderr_r that hold I is Binomial(R, 0.95).  Each (estimator, integrand, n) row
gets two tests at the Sidak level alpha = 1 - 0.99^(1 / (2 rows)), so that with honest errors
*any* flag in the table has a chance of at most about 1 %:

* ``!`` stderr too small, the error bars cannot be trusted: z_std above the upper end of the
  chi-square band ``std_band(R, alpha)`` (:mod:`vrlab.significance`), or P(K <= k) < alpha
  for the observed count k.  Typical cause: a heavy tail that R samples of n rarely reach.
* ``~`` stderr far too large: z_std below the band's lower end (safe but uninformative
  intervals: jittered and Latin hypercube errors reported as if i.i.d.).

``vrlab demo`` and ``vrlab lab`` print them the same way (column ``flag`` and the notes under
the table).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..significance import sidak_threshold, std_band

__all__ = ["FLAG_FAMILY_ALPHA", "flag_notes", "stderr_flags", "trust_thresholds"]

#: Family-wise chance of a false flag in a table (see the module docstring).
FLAG_FAMILY_ALPHA = 0.01


def trust_thresholds(reps: int, tests: int, family_alpha: float = FLAG_FAMILY_ALPHA) -> dict:
    """Thresholds of the stderr trust flags for R = ``reps`` repetitions when the table holds
    ``tests`` tests (2 per row): ``alpha`` (Sidak per-test level), ``z_lo``, ``z_hi`` (the
    chi-square band of z_std) and ``min_cover`` (the smallest count of covering intervals,
    as a share of R, that binomial chance allows at level alpha)."""
    from scipy import stats

    alpha = sidak_threshold(family_alpha, tests)
    z_lo, z_hi = std_band(reps, alpha)
    k = np.arange(reps + 1)
    allowed = k[stats.binom.cdf(k, reps, 0.95) >= alpha]
    return {"alpha": alpha, "z_lo": z_lo, "z_hi": z_hi, "min_cover": int(allowed[0]) / reps}


def stderr_flags(table: pd.DataFrame, family_alpha: float = FLAG_FAMILY_ALPHA) -> pd.Series:
    """Per row of a lab summary (columns ``reps``, ``z_std``, ``coverage``): ``"!"`` if the
    stderr is too small to trust, ``"~"`` if it is far too large, ``""`` otherwise (the rule
    and its levels are in the module docstring; a NaN z_std or coverage tests nothing)."""
    reps = table["reps"].to_numpy(int)
    z, cover = table["z_std"].to_numpy(float), table["coverage"].to_numpy(float)
    th = {r: trust_thresholds(int(r), 2 * len(table), family_alpha) for r in np.unique(reps)}
    hi, lo, least = (np.array([th[r][k] for r in reps]) for k in ("z_hi", "z_lo", "min_cover"))
    small = (z > hi) | (cover < least - 1e-12)
    large = ~small & (z < lo)
    flags = np.where(small, "!", np.where(large, "~", ""))
    return pd.Series(flags, index=table.index, name="flag", dtype=object)


def _worst(flags: pd.Series) -> str:
    return "!" if (flags == "!").any() else "~" if (flags == "~").any() else ""


def flag_notes(flagged: pd.DataFrame, th: dict, reps: int) -> list[str]:
    """One line per kind of flag: the thresholds and who got it at which n."""
    notes = []
    for mark, text in (("!", f"stderr too small, error bars not to be trusted (z_std > {th['z_hi']:.2f} or "
                             f"coverage < {th['min_cover']:.2f})"),
                       ("~", f"stderr far too large, safe but uninformative (z_std < {th['z_lo']:.2f})")):
        rows = flagged[flagged["flag"] == mark]
        if len(rows):
            who = "; ".join(f"{e} on {i} (n = {', '.join(str(n) for n in g['n'])})"
                            for (i, e), g in rows.groupby(["integrand", "estimator"], sort=False))
            notes.append(f"{mark} {text}: {who}")
    if notes:
        notes.append(f"  (R = {reps}, every n of the sweep tested; with honest errors any flag has a "
                     f"{FLAG_FAMILY_ALPHA:.0%} chance; rule: vrlab.lab.trust)")
    return notes
