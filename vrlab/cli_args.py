"""Flag values of the ``vrlab`` command line, checked before any work starts.

Flags arrive as text; each function here turns one into a value or raises, with a
message that starts with the flag's name:

* :class:`UsageError` (exit status 2) when the text itself is wrong: not a number,
  out of range, NaN, an unknown or repeated name, an empty list, a wrong file suffix,
  flags that do not go together;
* :class:`Failure` (exit status 1) when the file system says no: an input file missing
  or unreadable, an output folder missing or not writable.
"""
from __future__ import annotations

import contextlib
import importlib.util
import os
import tempfile
from pathlib import Path
from typing import Iterable

from . import checks, limits

SEED_MAX = 2**128 - 1        # seeds are SeedSequence entropy: 0 .. 2**128 - 1
WORKERS_MAX = limits.max_workers()   # worker processes: vrlab.limits, as the library


class UsageError(Exception):
    """A flag value or combination that is wrong whatever the machine: exit status 2."""

    def __init__(self, message: str, prog: str | None = None):
        super().__init__(message)
        self.prog = prog


class Failure(Exception):
    """A file that cannot be read or written, found while checking the flags: exit status 1."""


def _show(text: str) -> str:
    text = repr(text)
    return text if len(text) <= 42 else text[:38] + "...'"


def _text(text: object, flag: str) -> str:
    if not isinstance(text, str):
        raise UsageError(f"{flag} must be given as text, got {type(text).__name__}")
    if not text.strip():
        raise UsageError(f"{flag} must not be empty")
    return text.strip()


def integer(text: str | None, flag: str, *, low: int | None = None, high: int | None = None,
            high_text: str | None = None) -> int | None:
    """The integer ``text`` within ``[low, high]`` (``None`` passes through: flag not given).
    Each bound has its own message ("--width must be >= 1, got 0"); ``high_text`` spells
    the upper one (``"2**128-1"``)."""
    if text is None:
        return None
    raw = _text(text, flag)
    digits = raw[1:] if raw[:1] in "+-" else raw
    if not digits.isdigit() or not digits.isascii():
        raise UsageError(f"{flag} must be an integer, got {_show(text)}")
    size = len(digits.lstrip("0"))
    if size > 60:                           # far outside every bound used here (and int() caps digits)
        sign = "negative " if raw.startswith("-") else ""
        bound = f">= {low}" if sign and low is not None else f"<= {high_text or high}" if high is not None \
            else "at most 60 digits long"
        raise UsageError(f"{flag} must be {bound}, got a {sign}{size}-digit number")
    k = int(raw)
    if low is not None and k < low:
        raise UsageError(f"{flag} must be >= {low}, got {k}")
    if high is not None and k > high:
        raise UsageError(f"{flag} must be <= {high_text or high}, got {k}")
    return k


def real(text: str | None, flag: str, **bounds) -> float | None:
    """The finite number ``text`` within ``bounds`` (see :func:`vrlab.checks.real`)."""
    if text is None:
        return None
    raw = _text(text, flag)
    try:
        x = float(raw)
    except ValueError:
        raise UsageError(f"{flag} must be a number, got {_show(text)}") from None
    try:
        return checks.real(x, flag, **bounds)
    except (TypeError, ValueError) as exc:
        raise UsageError(str(exc)) from None


def names(text: str | None, flag: str, allowed: Iterable[str] | None = None) -> list[str]:
    """Comma-separated names: at least one, none empty or repeated, each in ``allowed`` if given."""
    if text is None:
        raise UsageError(f"{flag} is required")
    raw = _text(text, flag)
    items = [t.strip() for t in raw.split(",")]
    if "" in items:
        raise UsageError(f"{flag}: empty entry in {_show(text)} (give NAME,NAME,... without blank entries)")
    for k, item in enumerate(items):
        if item in items[:k]:
            raise UsageError(f"{flag}: {item!r} is given twice")
    if allowed is not None:
        allowed = list(allowed)
        for item in items:
            if item not in allowed:
                raise UsageError(f"{flag}: unknown {item!r}; choose from {', '.join(allowed)}")
    return items


def integers(text: str | None, flag: str, *, low: int | None = None, high: int | None = None) -> list[int]:
    """Comma-separated integers in ``[low, high]``: at least one, none repeated."""
    items = names(text, flag)
    out = []
    for item in items:
        try:
            out.append(integer(item, flag, low=low, high=high))
        except UsageError as exc:
            raise UsageError(f"{exc} (in {_show(text)})" if len(items) > 1 else str(exc)) from None
    return out


def seed(text: str | None, flag: str = "--seed") -> int | None:
    """A root seed: an integer in 0 .. 2**128 - 1."""
    return integer(text, flag, low=0, high=SEED_MAX, high_text="2**128-1")


def workers(text: str | None, flag: str = "--workers") -> int | None:
    """A worker-process count: 1 .. 256."""
    return integer(text, flag, low=1, high=WORKERS_MAX)


def _path(text: str | None, flag: str) -> Path:
    _text(text, flag)
    if "\x00" in text:
        raise UsageError(f"{flag}: a file name cannot contain a NUL character")
    return Path(text)


def _suffix(path: Path, flag: str, suffixes: Iterable[str]) -> str:
    suffixes = tuple(suffixes)
    suffix = path.suffix.lower()
    if suffix not in suffixes:
        got = repr(path.suffix) if path.suffix else "no suffix"
        raise UsageError(f"{flag}: {str(path)!r} must end in {', '.join(suffixes)}; got {got}")
    if suffix == ".exr" and importlib.util.find_spec("OpenEXR") is None:
        raise UsageError(f"{flag}: writing .exr needs the OpenEXR package (pip install OpenEXR); "
                         "use .npy for the linear image")
    return suffix


def _writable_folder(folder: Path, flag: str, what: str) -> None:
    if not folder.exists():
        raise Failure(f"{flag}: the folder {str(folder)!r} of {what} does not exist")
    if not folder.is_dir():
        raise Failure(f"{flag}: {str(folder)!r} (the folder of {what}) is not a folder")
    try:                                    # a real probe: os.access is blind to root and read-only mounts
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise Failure(f"{flag}: cannot write into the folder {str(folder)!r} for {what} "
                      f"({exc.strerror or exc})") from None


def output_file(text: str | None, flag: str, suffixes: Iterable[str]) -> Path | None:
    """A file to write: suffix in ``suffixes`` (lower case, with the dot), an existing writable
    folder, and not an existing folder or read-only file."""
    if text is None:
        return None
    path = _path(text, flag)
    _suffix(path, flag, suffixes)
    _writable_folder(path.parent, flag, repr(str(path)))
    if path.is_dir():
        raise Failure(f"{flag}: {str(path)!r} is a folder, not a file")
    if path.exists():
        try:                                # append mode: opens for writing, changes nothing
            with open(path, "ab"):
                pass
        except OSError as exc:
            raise Failure(f"{flag}: {str(path)!r} exists and is not writable ({exc.strerror})") from None
    return path


def output_folder(text: str | None, flag: str) -> Path:
    """A folder to write into (the command creates it, with its parents, if missing): a
    folder if it exists, else its nearest existing parent must be a writable folder."""
    path = _path(text, flag)
    if path.exists() and not path.is_dir():
        raise Failure(f"{flag}: {str(path)!r} exists and is not a folder")
    parent = path.absolute()
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise Failure(f"{flag}: cannot create {str(path)!r}: {str(parent)!r} is not a folder")
    _writable_folder(parent, flag, repr(str(path)))
    return path


def input_file(text: str | None, flag: str, suffixes: Iterable[str] | None = None) -> Path | None:
    """An existing, readable file (suffix in ``suffixes`` if given)."""
    if text is None:
        return None
    path = _path(text, flag)
    if suffixes is not None:
        _suffix(path, flag, suffixes)
    if not path.exists():
        raise Failure(f"{flag}: no such file {str(path)!r}")
    if not path.is_file():
        raise Failure(f"{flag}: {str(path)!r} is not a file")
    try:
        with open(path, "rb"):
            pass
    except OSError as exc:
        raise Failure(f"{flag}: {str(path)!r} is not readable ({exc.strerror})") from None
    return path


def distinct(flag_paths: dict[str, Path | None]) -> None:
    """Two output flags must not name the same file (one would overwrite the other)."""
    seen: dict[Path, str] = {}
    for flag, path in flag_paths.items():
        if path is None:
            continue
        key = Path(os.path.abspath(path))
        if key in seen:
            raise UsageError(f"{flag} and {seen[key]} name the same file {str(path)!r}")
        seen[key] = flag


SCHEDULER_TIMEOUT = 10.0     # seconds for a Dask scheduler (--scheduler) to connect and answer as one
WORKER_WAIT = 60.0           # seconds to wait for a first worker at a scheduler that has none


def scheduler_address(text: str | None, flag: str = "--scheduler") -> str | None:
    """A Dask scheduler address (``tcp://HOST:PORT``, ``HOST:PORT``, another Dask scheme),
    checked for form; ``UsageError`` if it is malformed or Dask is not installed."""
    if text is None:
        return None
    if not isinstance(text, str) or not text.strip():
        raise UsageError(f"{flag} must not be empty (give e.g. tcp://127.0.0.1:8786)")
    text = text.strip()
    try:
        from distributed.comm.addressing import parse_address, parse_host_port
        from distributed.comm.registry import backends
    except ImportError:
        raise UsageError(f"{flag} needs dask.distributed: pip install 'vrlab[distributed]'") from None
    try:
        scheme, loc = parse_address(text)
        if scheme not in backends:
            raise ValueError(f"unknown scheme {scheme!r}; Dask knows {', '.join(sorted(backends))}")
        if scheme != "inproc":
            parse_host_port(loc)
    except (ValueError, TypeError) as exc:
        raise UsageError(f"{flag}: {text!r} is not a scheduler address ({exc}); give e.g. "
                           "tcp://127.0.0.1:8786") from None
    return text


def _probe_scheduler(address: str, timeout: float) -> str:
    """The ``type`` a Dask server at ``address`` reports for itself (``"Scheduler"`` for a
    scheduler), asked with Dask's own ``identity`` call; the whole exchange (connect, send,
    read) is bounded by ``timeout`` seconds.  ``Failure`` if nothing answers as a Dask server
    (a closed port, an HTTP server, an unroutable address, garbage on the wire)."""
    import asyncio

    from distributed.core import rpc

    async def ask() -> dict:
        r = rpc(address, timeout=timeout)
        try:
            return await r.identity()
        finally:
            await r.close_rpc()

    try:
        info = asyncio.run(asyncio.wait_for(ask(), timeout))
    except (asyncio.TimeoutError, TimeoutError):
        raise Failure(f"no Dask scheduler answered within {timeout:g} s") from None
    except BaseException as exc:   # noqa: BLE001 - HTTP replies decode as huge frames (MemoryError) etc.
        if isinstance(exc, KeyboardInterrupt):
            raise
        lines = str(exc).splitlines()
        text = getattr(exc, "strerror", None) or (lines[0] if lines else "")
        what = "its reply is not Dask's" if isinstance(exc, (MemoryError, ValueError, TypeError, KeyError)) \
            else "the exchange failed"
        raise Failure(f"{what} ({type(exc).__name__}{': ' + text[:100] if text else ''})") from None
    if not isinstance(info, dict):
        raise Failure("not a Dask scheduler (its answer is not Dask's)")
    return str(info.get("type", "unknown"))


@contextlib.contextmanager
def connect_scheduler(address: str, flag: str = "--scheduler", timeout: float | None = None,
                      worker_wait: float | None = None):
    """A ``distributed.Client`` on the scheduler at ``address``, closed at the end (the
    scheduler and its workers keep running).

    ``Failure`` (one line naming ``flag`` and the address, exit status 1, no traceback) when
    nothing answers as a Dask scheduler within ``timeout`` seconds (default
    ``SCHEDULER_TIMEOUT``): a closed port, an HTTP server (a dashboard), an unroutable
    address, another Dask server.  A scheduler without workers is said so on stderr, and the
    work waits at most ``worker_wait`` seconds (default ``WORKER_WAIT``) for a first one,
    else ``Failure``."""
    import socket
    import sys

    from distributed import Client
    from distributed.comm.addressing import parse_address, parse_host_port

    timeout = SCHEDULER_TIMEOUT if timeout is None else timeout
    worker_wait = WORKER_WAIT if worker_wait is None else worker_wait
    scheme, loc = parse_address(address)
    if scheme in ("tcp", "tls"):            # probe first: a failed Client leaves noise at exit
        host, port = parse_host_port(loc)
        try:
            socket.create_connection((host, port), timeout=timeout).close()
        except OSError as exc:
            reason = f"no answer within {timeout:g} s" if isinstance(exc, socket.timeout) else (exc.strerror or str(exc))
            raise Failure(f"{flag}: cannot reach a Dask scheduler at {address!r} ({reason})") from None
    try:
        kind = _probe_scheduler(address, timeout)
    except Failure as exc:
        raise Failure(f"{flag}: {address!r} does not answer as a Dask scheduler: {exc}") from None
    if kind != "Scheduler":
        raise Failure(f"{flag}: {address!r} is a Dask {kind}, not a scheduler; give the scheduler's address")
    try:
        client = Client(address, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise Failure(f"{flag}: cannot connect to a Dask scheduler at {address!r} ({exc})") from None
    try:
        if not client.scheduler_info().get("workers"):
            print(f"vrlab: {flag} {address} has no workers yet; waiting up to {worker_wait:g} s for one",
                  file=sys.stderr, flush=True)
            try:
                client.wait_for_workers(1, timeout=worker_wait)
            except (TimeoutError, OSError) as exc:
                raise Failure(f"{flag}: no worker joined the Dask scheduler at {address!r} within "
                              f"{worker_wait:g} s ({type(exc).__name__})") from None
        yield client
    finally:
        client.close()
