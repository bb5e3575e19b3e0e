"""Timing helper shared by the benchmarks."""
from __future__ import annotations

import gc
import time
from typing import Callable

import numpy as np


def race(fns: dict[str, Callable[[], object]], repeat: int) -> dict[str, float]:
    """Best wall time of ``repeat`` calls of each function.  The methods take turns
    (round robin, garbage collector paused), so a load spike on a shared machine
    hits them alike instead of one method's whole series."""
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
