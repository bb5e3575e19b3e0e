"""One way to run work units: in this process, in local worker processes, or on any
``concurrent.futures``-style executor (a ``ProcessPoolExecutor``, a Dask ``Client``).

A work unit is a picklable call ``fn(*args)`` whose randomness comes from a seed that is
part of its arguments (spawned per unit, never per worker), so the results do not depend
on where or in which order units run.  :func:`run_units` yields ``(index, result)`` as
units finish; callers place results by index.  ``vrlab.lab.run`` and
``vrlab.render.render`` both send their units through it.

* ``executor=None, workers=1``: in this process, one unit after the other;
* ``executor=None, workers=k``: a local ``ProcessPoolExecutor`` of k processes (forked where
  the platform allows, else spawned), shut down at the end.  Its processes are vrlab's own:
  their initialiser (:func:`worker_init`) makes them end within about a second when the
  parent process dies by any signal, SIGKILL included (Linux: ``PR_SET_PDEATHSIG``; every
  platform: a watchdog thread that sees the parent change), and keeps freed NumPy
  temporaries for reuse (:mod:`vrlab._alloc`);
* ``executor=`` an object with ``submit`` (a ``concurrent.futures.Executor``), or a Dask
  ``distributed.Client`` (its ``get_executor()`` is used): the caller's, left running.
"""
from __future__ import annotations

import os
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any

from . import checks, limits

__all__ = ["check_executor", "check_picklable", "is_dask", "parallelism", "run_units", "worker_init"]

#: seconds between two looks of a worker's watchdog at its parent process
WATCH_PARENT_SECONDS = 0.25

MAX_WORKERS = limits.max_workers()   # vrlab.limits: the same bound for the lab, the renderer and the CLI


def is_dask(executor: Any) -> bool:
    """True for a Dask ``distributed.Client`` or its executor (their classes live in ``distributed``)."""
    return executor is not None and type(executor).__module__.startswith("distributed")


def parallelism(executor: Any) -> int:
    """How many units an executor runs at once: a Dask client's worker threads, a pool's
    processes (at least 1)."""
    client = getattr(executor, "_client", None) if not callable(getattr(executor, "nthreads", None)) else executor
    if client is not None and callable(getattr(client, "nthreads", None)):
        try:
            return max(1, sum(client.nthreads().values()))
        except Exception:   # noqa: BLE001 - a scheduler that does not answer: plan for one
            return 1
    return max(1, int(getattr(executor, "_max_workers", 1) or 1))


def check_picklable(obj: Any, executor: Any, what: str, hint: str) -> bytes:
    """``obj`` serialised as it will travel to a worker: by cloudpickle for Dask (which ships
    lambdas), by pickle for process pools.  ``TypeError`` "``what`` (reason); ``hint``" if it
    cannot be; returns the bytes (pickle them once, send them to every unit)."""
    import pickle

    if is_dask(executor):
        import cloudpickle
        dumps = cloudpickle.dumps
    else:
        dumps = pickle.dumps
    try:
        return dumps(obj)
    except (pickle.PicklingError, AttributeError, TypeError) as exc:
        raise TypeError(f"{what} ({exc}); {hint}") from None


def check_executor(executor: Any, name: str = "executor"):
    """``executor`` as a ``concurrent.futures``-style executor (a Dask ``Client`` becomes its
    ``get_executor()``), or None; ``TypeError`` naming ``name`` otherwise."""
    if executor is None:
        return None
    if callable(getattr(executor, "get_executor", None)) and is_dask(executor):
        return executor.get_executor()
    if not callable(getattr(executor, "submit", None)):
        raise TypeError(f"{name}: expected a concurrent.futures.Executor, a dask.distributed.Client or None, "
                        f"got {type(executor).__name__}")
    return executor


def _die_with_parent(parent: int) -> None:
    """End this process when ``parent`` dies: the kernel's parent-death signal where there is one
    (Linux ``prctl(PR_SET_PDEATHSIG, SIGKILL)``), and a daemon thread that exits the process as
    soon as its parent is no longer ``parent`` (reparented: the parent died, by any signal)."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes
            import signal

            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL))     # 1 = PR_SET_PDEATHSIG
        except (OSError, AttributeError):      # pragma: no cover - no prctl: the watchdog remains
            pass
    if os.getppid() != parent:                 # the parent died before the signal was armed
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(WATCH_PARENT_SECONDS)
            if os.getppid() != parent:
                os._exit(1)
    threading.Thread(target=watch, name="vrlab-watch-parent", daemon=True).start()


def worker_init(parent: int) -> None:
    """Initialiser of vrlab's own worker processes (local pools of the lab and the renderer):
    die with ``parent`` (the pid of the process that started the pool), and keep freed
    NumPy temporaries for reuse (:func:`vrlab._alloc.keep_freed_memory`; numbers unchanged)."""
    from ._alloc import keep_freed_memory

    _die_with_parent(parent)
    keep_freed_memory()


def _local_pool(workers: int) -> ProcessPoolExecutor:
    import multiprocessing as mp

    ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
    return ProcessPoolExecutor(workers, mp_context=ctx, initializer=worker_init, initargs=(os.getpid(),))


def run_units(fn: Callable, args: Sequence[tuple], *, workers: int = 1, executor: Any = None,
              window: int | None = None) -> Iterator[tuple[int, Any]]:
    """Run ``fn(*args[i])`` for every i; yield ``(i, result)`` as units finish.

    ``workers``: local processes when ``executor`` is None (1: this process).  At most
    ``window`` units (default 4 x workers, at least 8) are in flight at once, so memory
    stays bounded however many units there are and results stream back as they come.
    A unit's exception propagates (the remaining units are cancelled).
    """
    workers = checks.integer(workers, "workers", low=1, high=MAX_WORKERS)
    executor = check_executor(executor)
    args = list(args)
    if executor is None and (workers == 1 or len(args) <= 1):
        for i, a in enumerate(args):
            yield i, fn(*a)
        return
    own = executor is None
    pool = _local_pool(min(workers, len(args))) if own else executor
    window = max(8, 4 * workers) if window is None else checks.integer(window, "window", low=1)
    try:
        pending: dict = {}
        todo: Iterable = iter(enumerate(args))
        for i, a in todo:
            pending[pool.submit(fn, *a)] = i
            if len(pending) >= window:
                break
        while pending:
            done, _ = wait(list(pending), return_when=FIRST_COMPLETED)
            for fut in done:
                i = pending.pop(fut)
                yield i, fut.result()
            for i, a in todo:
                pending[pool.submit(fn, *a)] = i
                if len(pending) >= window:
                    break
    except BaseException:
        for fut in list(pending):
            fut.cancel()
        raise
    finally:
        if own:
            pool.shutdown(wait=True, cancel_futures=True)
