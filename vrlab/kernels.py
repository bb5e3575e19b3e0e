"""Compiled kernels: the ``kernels`` switch, lazy loading of Numba code, the compile notice.

vrlab's hottest loops exist twice: as NumPy code, the reference ("oracle") that is always
there, and as serial Numba functions (``@njit(cache=True)``) in modules named ``*_kernel``
(vrlab issue 31).  One switch chooses between them::

    kernels="auto"    numba if it can be imported here, else numpy
    kernels="numba"   the compiled kernels (ValueError if numba cannot be imported)
    kernels="numpy"   the NumPy code

:func:`resolve_kernels` turns the switch into ``"numba"`` or ``"numpy"``; a class taking
``kernels=`` resolves it once, in ``__init__``.  Numba has wheels for CPython on Linux
x86-64/aarch64, macOS arm64 and Windows x86-64 (pyproject.toml installs it there only);
elsewhere "auto" is NumPy.

**Nothing at import.**  Importing vrlab imports no numba and compiles nothing: a kernel
module (which imports numba) is imported by :func:`load_kernel` when a kernel is first
asked for, and its functions are compiled (or loaded from numba's cache) for the
signatures the module lists in ``SIGNATURES`` then, all together.

**Compile notice.**  When that really compiles (first use on a machine, or after an
upgrade: numba broadcasts a ``"numba:compile"`` event for a compilation, none for a load
from its cache), one line goes to stderr, once per process::

    vrlab: compiling render kernels, once: about N s

with N the module's ``COMPILE_SECONDS`` (measured cold compile time).  Processes forked
after a load inherit the compiled code: load before forking workers
(:func:`load_kernels`) and they compile nothing.

**Serial only.**  No ``parallel=True``/``prange``: under Numba's OpenMP layer a prange
kernel hangs in a forked child, and vrlab forks its workers; parallelism comes from the
worker processes.

**Cache folder.**  ``cache=True`` writes the compiled code next to the module, in its
``__pycache__``.  Where that folder cannot be written (a read-only site-packages) numba
itself uses the user cache folder instead (its ``UserWideCacheLocator``:
``$XDG_CACHE_HOME/numba`` or ``~/.cache/numba`` on Linux, ``~/Library/Caches/numba`` on
macOS, ``%LOCALAPPDATA%\\numba\\numba\\Cache`` on Windows); the environment variable
``NUMBA_CACHE_DIR``, set by the user before starting Python, overrides both.  vrlab sets no
environment variable and leaves ``numba.config`` alone (it is process-wide: it would move
the cache of the user's own functions too).
"""
from __future__ import annotations

import functools
import importlib
import sys
from typing import Any, Callable

__all__ = ["KERNELS", "resolve_kernels", "numba_version", "load_kernel", "load_kernels"]

#: the values of the ``kernels`` switch
KERNELS = ("auto", "numba", "numpy")


@functools.lru_cache(maxsize=None)
def numba_version() -> str | None:
    """numba's version if it can be imported here (this imports it), else None."""
    try:
        import numba
    except Exception:           # not installed, or broken (e.g. built for another NumPy)
        return None
    return str(numba.__version__)


def resolve_kernels(value: Any, name: str = "kernels") -> str:
    """``"numba"`` or ``"numpy"`` for a value of the switch (see the module docstring).

    ``ValueError`` naming ``name`` for a value other than "auto", "numba", "numpy", or for
    "numba" where numba cannot be imported.  "numpy" imports nothing; "auto" and "numba"
    import numba (about 0.3 s, once per process) but compile nothing."""
    if not isinstance(value, str) or value not in KERNELS:
        raise ValueError(f"{name} must be one of 'auto', 'numba', 'numpy', got {value!r}")
    if value == "numpy":
        return "numpy"
    if numba_version() is not None:
        return "numba"
    if value == "auto":
        return "numpy"
    raise ValueError(f"{name}='numba': numba cannot be imported in this Python ({sys.executable}); "
                     "install it (pip install numba; wheels exist for CPython on Linux x86-64/aarch64, "
                     "macOS arm64 and Windows x86-64) or use kernels='auto' or 'numpy'")


def _notice(seconds: float, stream):
    """A numba event listener that prints the compile notice at the first compilation it sees
    (once per process)."""
    from numba.core import event

    class Notice(event.Listener):
        compiled = False

        def on_start(self, ev) -> None:
            if not self.compiled:
                self.compiled = True
                if not _state["notice"]:
                    _state["notice"] = True
                    print(f"vrlab: compiling render kernels, once: about {max(1, round(seconds))} s",
                          file=stream, flush=True)

        def on_end(self, ev) -> None:
            pass

    return Notice()


def load_kernels(*modules: str, stream=None) -> dict[str, Any]:
    """Import the kernel modules ``modules`` (dotted names, e.g.
    ``"vrlab.distributions.alias_kernel"``) and compile or load every function their
    ``SIGNATURES`` list; ``{module: module object}``.  Compiling prints the one-line notice
    (to ``stream``, default stderr) with the summed ``COMPILE_SECONDS`` of the modules
    still to load.  Cheap after the first call in a process."""
    todo = [m for m in modules if m not in _loaded]
    if todo:
        mods = [importlib.import_module(m) for m in todo]
        from numba.core import event

        seconds = sum(float(getattr(m, "COMPILE_SECONDS", 1.0)) for m in mods)
        with event.install_listener("numba:compile", _notice(seconds, sys.stderr if stream is None else stream)):
            for name, mod in zip(todo, mods):
                for fname, sigs in mod.SIGNATURES.items():
                    fn = getattr(mod, fname)
                    for sig in sigs if hasattr(fn, "compile") else ():    # (NUMBA_DISABLE_JIT: plain Python)
                        fn.compile(sig)
                _loaded[name] = mod
    return {m: _loaded[m] for m in modules}


def load_kernel(module: str, name: str) -> Callable:
    """The compiled function ``name`` of the kernel module ``module``, compiled (or loaded from
    the cache) on the first request in a process: see :func:`load_kernels`."""
    mod = load_kernels(module)[module]
    if name not in getattr(mod, "SIGNATURES", {}):
        raise ValueError(f"name: {module} has no kernel {name!r}; it has {sorted(mod.SIGNATURES)}")
    return getattr(mod, name)


#: kernel modules loaded in this process (a cache of compiled code, not a job's state)
_loaded: dict[str, Any] = {}
#: per process: whether the notice was printed
_state: dict[str, Any] = {"notice": False}
