"""Halton / Hammersley generation: vrlab vs ``scipy.stats.qmc.Halton``, timed in one run.

Each timing builds the engine and draws ``n`` points (``Cls(d, scramble=..., rng=...)
.random(n)``), best of ``repeat`` runs with ``time.perf_counter``.  Unscrambled rows
compare against ``scipy.stats.qmc.Halton(scramble=False)``, scrambled rows (random
digit permutations, the same randomisation in both libraries) against
``scipy.stats.qmc.Halton(scramble=True)``.  Hammersley has no SciPy counterpart; it
is listed against the same SciPy Halton timing (same work: ``d - 1`` radical-inverse
coordinates plus one ``i/n``).
"""
from __future__ import annotations

import time
from collections.abc import Callable

from scipy.stats import qmc

from .. import checks
from ..points import Halton, Hammersley


def _best(fn: Callable[[int], object], repeat: int) -> float:
    best = float("inf")
    for r in range(repeat):
        t0 = time.perf_counter()
        fn(r)
        best = min(best, time.perf_counter() - t0)
    return best


def bench_qmc(quick: bool = False, *, dims: tuple[int, ...] = (2, 8, 32), repeat: int = 3) -> list[dict]:
    """Timing rows ``{"task", "d", "n", "vrlab_s", "peer", "peer_s", "speedup"}``.

    ``n = 2^20`` points (``2^16`` with ``quick=True``); ``speedup = peer_s / vrlab_s``
    (> 1: vrlab is faster).  Checked: ``quick`` a bool, ``dims`` a non-empty sequence of
    integers in [1, 1000], ``repeat`` an integer in [1, 1000].
    """
    from . import _quick

    quick = _quick(quick)
    if isinstance(dims, (str, bytes)) or not hasattr(dims, "__iter__") or not list(dims):
        raise TypeError(f"dims must be a non-empty sequence of dimensions, got {checks.describe(dims)}")
    dims = tuple(checks.integer(d, f"dims[{k}]", low=1, high=1000) for k, d in enumerate(dims))
    repeat = checks.integer(repeat, "repeat", low=1, high=1000)
    n = 1 << (16 if quick else 20)
    rows: list[dict] = []
    for scramble in (False, True):
        label = " scrambled" if scramble else ""
        for d in dims:
            peer = f"scipy.stats.qmc.Halton(scramble={scramble})"
            peer_s = _best(lambda r, d=d, s=scramble: qmc.Halton(d, scramble=s, rng=r).random(n), repeat)
            for task, cls in (("halton", Halton), ("hammersley", Hammersley)):
                vr_s = _best(lambda r, c=cls, d=d, s=scramble: c(d, scramble=s, rng=r).random(n), repeat)
                rows.append({"task": task + label, "d": d, "n": n, "vrlab_s": vr_s, "peer": peer,
                             "peer_s": peer_s, "speedup": peer_s / vr_s})
    return rows
