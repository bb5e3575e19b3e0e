"""Discrete sampling side by side: vrlab's alias and CDF tables against NumPy and SciPy.

Peers: ``numpy.random.Generator.choice(n, size, p=...)`` (CDF + binary search),
``scipy.stats.sampling.DiscreteAliasUrn`` (UNU.RAN's alias-urn method, C) and a
plain ``np.cumsum`` (the build step of any CDF table).  Sampling times for vrlab
*include* drawing the uniforms (``rng.random(size)``), as the peers draw their own.
Each time is the best of ``repeat`` runs (``time.perf_counter``, methods taking
turns); ``ratio_vs_vrlab`` is a method's time over ``vrlab AliasTable``'s for the
same task and ``n`` (> 1: vrlab is faster).  Weights: ``u**2`` for uniform ``u``
(fixed seed).  ``note`` carries warnings a peer printed (UNU.RAN reports round-off
trouble for large tables).  Builds also time ``AliasTable(w, kernels="numpy")``: the default
("auto") builds tables of 2^18 weights or more with the compiled kernel (``vrlab.kernels``);
the kernel is compiled or loaded before the timing.
"""
from __future__ import annotations

import warnings

import numpy as np

from .. import checks
from ..distributions.discrete import AliasTable, CDFTable
from .timing import race as _race

OURS = "vrlab AliasTable"
#: the alias table built by its NumPy code (OURS is kernels="auto": the compiled build from 2^18 weights)
OURS_NUMPY = "vrlab AliasTable kernels=numpy"


def _sci(x: int) -> str:
    """10**7 -> "1e7"."""
    e = round(float(np.log10(x)))
    return f"1e{e}" if 10**e == x else str(x)


def _rows(task: str, n: int, times: dict[str, float], notes: dict[str, str]) -> list[dict]:
    ref = times[OURS]
    return [{"task": task, "n": n, "method": m, "seconds": s, "ratio_vs_vrlab": s / ref,
             "note": notes.get(m, "")} for m, s in times.items()]


def _urn(w: np.ndarray, seed) -> tuple[object, str]:
    """SciPy's alias urn and a note if UNU.RAN warned while building it (it reports
    round-off trouble for large tables)."""
    from scipy.stats.sampling import DiscreteAliasUrn

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        urn = DiscreteAliasUrn(w, random_state=seed)
    msgs = {str(c.message).rsplit(" : ", 1)[-1].strip() for c in caught}
    return urn, ("UNU.RAN warned: " + "; ".join(sorted(msgs))) if msgs else ""


def _sample_times(w: np.ndarray, draws: int, repeat: int, seed: int) -> tuple[dict[str, float], dict[str, str]]:
    n = len(w)
    p = w / w.sum()
    alias, cdf = AliasTable(w), CDFTable(w)
    urn, note = _urn(w, np.random.default_rng(seed + 1))
    gen = np.random.default_rng(seed + 2)
    times = _race({
        OURS: lambda: alias.sample(gen.random(draws)),
        "vrlab CDFTable": lambda: cdf.sample(gen.random(draws)),
        "scipy DiscreteAliasUrn": lambda: urn.rvs(draws),
        "numpy Generator.choice": lambda: gen.choice(n, size=draws, p=p),
    }, repeat)
    return times, {"scipy DiscreteAliasUrn": note}


def _build_times(w: np.ndarray, repeat: int, seed: int) -> tuple[dict[str, float], dict[str, str]]:
    notes: set[str] = set()
    times = _race({
        OURS: lambda: AliasTable(w),
        OURS_NUMPY: lambda: AliasTable(w, kernels="numpy"),
        "vrlab CDFTable": lambda: CDFTable(w),
        "scipy DiscreteAliasUrn": lambda: notes.add(_urn(w, seed)[1]),
        "numpy cumsum": lambda: np.cumsum(w),
    }, repeat)
    return times, {"scipy DiscreteAliasUrn": "; ".join(sorted(notes - {""}))}


def bench_discrete(quick: bool = False, *, repeat: int = 3, seed: int = 2026) -> list[dict]:
    """Timings of discrete sampling and table building, vrlab vs peers.

    Full: 10^7 draws at n = 64, 10^4, 10^6 and builds at n = 10^6, 10^7.
    ``quick``: 10^6 draws at n = 64, 10^4, 10^5 and builds at n = 10^5, 10^6 (seconds).
    Rows: ``{"task", "n", "method", "seconds", "ratio_vs_vrlab", "note"}``.  Checked:
    ``quick`` a bool, ``repeat`` in [1, 1000], ``seed`` an integer >= 0.
    """
    from . import _quick

    quick = _quick(quick)
    repeat = checks.integer(repeat, "repeat", low=1, high=1000)
    seed = checks.integer(seed, "seed", low=0, high=2**62)
    draws = 10**6 if quick else 10**7
    sample_sizes = (64, 10**4, 10**5) if quick else (64, 10**4, 10**6)
    build_sizes = (10**5, 10**6) if quick else (10**6, 10**7)
    rng = np.random.default_rng(seed)
    AliasTable(np.arange(1.0, 2.0**18 + 1))     # compile or load the kernel outside the timings
    rows: list[dict] = []
    for n in sample_sizes:
        rows += _rows(f"sample {_sci(draws)} draws", n, *_sample_times(rng.random(n) ** 2, draws, repeat, seed))
    for n in build_sizes:
        rows += _rows("build table", n, *_build_times(rng.random(n) ** 2, repeat, seed))
    return rows
