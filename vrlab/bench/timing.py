"""Timing helper shared by the benchmarks."""
from __future__ import annotations

import gc
import time
from typing import Callable

import numpy as np

from .. import checks


def race(fns: dict[str, Callable[[], object]], repeat: int) -> dict[str, float]:
    """Best wall time of ``repeat`` calls of each function.  The methods take turns
    (round robin, garbage collector paused), so a load spike on a shared machine
    hits them alike instead of one method's whole series.  ``fns``: a non-empty dict of
    callables; ``repeat``: an integer in [1, 1000]."""
    if not isinstance(fns, dict) or not fns:
        raise TypeError(f"fns must be a non-empty dict of name -> callable, got {checks.describe(fns)}")
    bad = [k for k, f in fns.items() if not callable(f)]
    if bad:
        raise TypeError(f"fns: {bad[0]!r} is not callable")
    repeat = checks.integer(repeat, "repeat", low=1, high=1000)
    best = dict.fromkeys(fns, np.inf)
    gc.collect()
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        for _ in range(repeat):
            for name, fn in fns.items():
                t0 = time.perf_counter()
                fn()
                best[name] = min(best[name], time.perf_counter() - t0)
    finally:
        if was_enabled:
            gc.enable()
    return best
