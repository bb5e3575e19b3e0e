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

A large input common to every unit (a render's job: the scene's geometry, its BVH) is
``run_units(..., shared=value)``: each unit runs ``fn(value, *args[i])`` and carries only its
own small arguments, while the value reaches each worker process once (issue 35):

* the local pool's processes get it through their initialiser: inherited memory where they
  are forked, one unpickling per process where they are spawned;
* on Dask it is scattered once to every worker (``client.scatter(value, broadcast=True)``)
  and the units refer to its future, which is released at the end;
* any other executor's units carry a token only; a worker process that has not received
  that token yet answers :class:`Need` instead of a result, and the unit is sent again with
  the pickled value (at most ``parallelism(executor)`` such units in flight at once).

A worker process keeps what it received in :data:`RECEIVED`, one run's value at a time (a new
token replaces the old one; the calling process drops its own copy, if a thread executor made
one, at the end of the run), so the value is unpickled once per process and whatever it
builds lazily (Embree's scene) is built once per process, not once per unit.
"""
from __future__ import annotations

import io
import os
import pickle
import sys
import threading
import time
import uuid
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any

from . import checks, limits

__all__ = ["RECEIVED", "Need", "Received", "check_executor", "check_picklable", "forks_workers", "is_dask", "parallelism",
           "run_units", "worker_init"]

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


class _Discard:
    """A file that forgets what is written to it (a pickling test without the bytes)."""

    def write(self, b) -> int:
        return memoryview(b).nbytes          # protocol 5 writes large buffers as PickleBuffer


def check_picklable(obj: Any, executor: Any, what: str, hint: str, keep: bool = True) -> bytes | None:
    """``obj`` serialised as it will travel to a worker: by cloudpickle for Dask (which ships
    lambdas), by pickle for process pools.  ``TypeError`` "``what`` (reason); ``hint``" if it
    cannot be; returns the bytes, or with ``keep=False`` only checks (nothing is held)."""
    if is_dask(executor):
        import cloudpickle
        pickler = cloudpickle.Pickler
    else:
        pickler = pickle.Pickler
    try:
        if not keep:
            pickler(_Discard(), protocol=pickle.HIGHEST_PROTOCOL).dump(obj)
            return None
        buf = io.BytesIO()
        pickler(buf, protocol=pickle.HIGHEST_PROTOCOL).dump(obj)
        return buf.getvalue()
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


_NOTHING = object()         # no value (received or shared)


class Received:
    """What a worker process has received of a run's shared input: one run's value at a time,
    by the run's token (see the module docstring).  ``put`` keeps a value or its pickled
    ``data`` (unpickled by the first ``get``, under a lock: once per process); a new token
    replaces the previous run's value; ``drop(token)`` forgets it."""

    def __init__(self):
        self._lock = threading.Lock()
        self.token: str | None = None
        self._value: Any = _NOTHING
        self._data: bytes | None = None

    def put(self, token: str, value: Any = _NOTHING, data: bytes | None = None) -> None:
        with self._lock:
            if token != self.token:
                self.token, self._value, self._data = token, value, data

    def get(self, token: str) -> Any:
        """The value of run ``token``, or ``_NOTHING`` if this process has not received it."""
        with self._lock:
            if token != self.token:
                return _NOTHING
            if self._value is _NOTHING:
                self._value, self._data = pickle.loads(self._data), None
            return self._value

    def drop(self, token: str) -> None:
        with self._lock:
            if token == self.token:
                self.token, self._value, self._data = None, _NOTHING, None


#: this process's store of received shared inputs (in worker processes; the calling process's
#: stays empty but for a thread executor's run, dropped at its end)
RECEIVED = Received()


class Need:
    """A unit's answer from a worker process that has not received run ``token``'s shared input."""

    def __init__(self, token: str):
        self.token = token

    def __reduce__(self):
        return Need, (self.token,)


def _with_received(fn: Callable, token: str, data: bytes | None, *args):
    """In a worker: ``fn(shared value of run token, *args)``, or :class:`Need` without it."""
    if data is not None:
        RECEIVED.put(token, data=data)
    value = RECEIVED.get(token)
    return Need(token) if value is _NOTHING else fn(value, *args)


def worker_init(parent: int, token: str | None = None, box: list | None = None) -> None:
    """Initialiser of vrlab's own worker processes (local pools of the lab and the renderer):
    die with ``parent`` (the pid of the process that started the pool), keep freed NumPy
    temporaries for reuse (:func:`vrlab._alloc.keep_freed_memory`; numbers unchanged), and
    keep run ``token``'s shared input, ``box = [value]`` (forked: the parent's object) or
    ``[pickled bytes]`` (spawned: unpickled at the first unit).  The box is emptied so that
    the process's arguments do not hold a second copy."""
    from ._alloc import keep_freed_memory

    _die_with_parent(parent)
    keep_freed_memory()
    RECEIVED.__init__()              # a fresh lock: a forked copy of the parent's may be held
    if token is not None and box:
        value = box.pop()
        if isinstance(value, bytes):
            RECEIVED.put(token, data=value)
        else:
            RECEIVED.put(token, value)


def _start_method() -> str:
    import multiprocessing as mp

    return "fork" if "fork" in mp.get_all_start_methods() else "spawn"


def forks_workers() -> bool:
    """Whether vrlab's own pools fork their workers here (they inherit the parent's memory:
    what the parent builds before the pool starts is not rebuilt in each worker)."""
    return _start_method() == "fork"


def _local_pool(workers: int, token: str | None = None, shared: Any = _NOTHING) -> ProcessPoolExecutor:
    """vrlab's own pool of ``workers`` processes (forked where the platform allows), handed
    run ``token``'s ``shared`` value by their initialiser."""
    import multiprocessing as mp

    method = _start_method()
    box = None
    if shared is not _NOTHING:           # forked: the object itself (inherited); spawned: its pickle
        box = [shared if method == "fork" else pickle.dumps(shared, protocol=pickle.HIGHEST_PROTOCOL)]
    return ProcessPoolExecutor(workers, mp_context=mp.get_context(method), initializer=worker_init,
                               initargs=(os.getpid(), token, box))


class _Delivery:
    """How the units of one run reach a pool, with the shared input sent once per worker
    process (see the module docstring); ``close()`` ends what it started."""

    def __init__(self, fn: Callable, shared: Any, executor: Any, workers: int):
        self.fn, self.token, self.own = fn, uuid.uuid4().hex, executor is None
        self.mode = "plain" if shared is _NOTHING else "received" if self.own else \
            "dask" if is_dask(executor) else "ask"
        self.pool = _local_pool(workers, self.token, shared) if self.own else executor
        self.future = self.data = None
        if self.mode == "dask":
            # in a list of one: scatter would split a dict or list value into one future per item
            (self.future,) = executor._client.scatter([shared], broadcast=True, hash=False)
        elif self.mode == "ask":
            self.data = pickle.dumps(shared, protocol=pickle.HIGHEST_PROTOCOL)
        #: units in flight that carry the pickled value, and how many may
        self.carrying, self.limit = 0, parallelism(executor) if self.mode == "ask" else 0

    def submit(self, args: tuple, carry: bool = False):
        if self.mode == "plain":
            return self.pool.submit(self.fn, *args)
        if self.mode == "dask":
            return self.pool.submit(self.fn, self.future, *args)
        self.carrying += carry
        return self.pool.submit(_with_received, self.fn, self.token, self.data if carry else None, *args)

    def close(self) -> None:
        if self.own:
            self.pool.shutdown(wait=True, cancel_futures=True)
        if self.future is not None:
            self.future.release()
        RECEIVED.drop(self.token)           # a thread executor's copy in this process


def run_units(fn: Callable, args: Sequence[tuple], *, workers: int = 1, executor: Any = None,
              window: int | None = None, shared: Any = _NOTHING) -> Iterator[tuple[int, Any]]:
    """Run ``fn(*args[i])`` for every i (``fn(shared, *args[i])`` if ``shared`` is given:
    sent once per worker process, see the module docstring); yield ``(i, result)`` as units
    finish.

    ``workers``: local processes when ``executor`` is None (1: this process).  At most
    ``window`` units (default 4 x workers, at least 8) are in flight at once, so memory
    stays bounded however many units there are and results stream back as they come.
    A unit's exception propagates (the remaining units are cancelled).
    """
    workers = checks.integer(workers, "workers", low=1, high=MAX_WORKERS)
    executor = check_executor(executor)
    args = list(args)
    lead = () if shared is _NOTHING else (shared,)
    if executor is None and (workers == 1 or len(args) <= 1):
        for i, a in enumerate(args):
            yield i, fn(*lead, *a)
        return
    window = max(8, 4 * workers) if window is None else checks.integer(window, "window", low=1)
    send = _Delivery(fn, shared, executor, min(workers, len(args)))
    pending: dict = {}                  # future -> (unit, whether it carries the pickled value)
    try:
        todo = deque(range(len(args)))
        waiting: deque = deque()        # units answered Need while the carrying units were at their limit
        while todo or pending or waiting:
            while todo and len(pending) < window:
                i = todo.popleft()
                pending[send.submit(args[i])] = i, False
            done, _ = wait(list(pending), return_when=FIRST_COMPLETED)
            for fut in done:
                i, carried = pending.pop(fut)
                send.carrying -= carried
                res = fut.result()
                if not isinstance(res, Need):
                    yield i, res
                elif send.carrying < send.limit:
                    pending[send.submit(args[i], carry=True)] = i, True
                else:
                    waiting.append(i)
                if carried:             # a worker has it now: the waiting units may find it
                    todo.extendleft(reversed(waiting))
                    waiting.clear()
            if waiting and not pending:  # pragma: no cover - cannot happen: carrying < limit then
                todo.extendleft(reversed(waiting))
                waiting.clear()
    except BaseException:
        for fut in list(pending):
            fut.cancel()
        raise
    finally:
        send.close()
