"""The ``vrlab`` command line: ``vrlab demo``, ``vrlab lab``, ``vrlab render``, ``vrlab bench``
and ``vrlab notebooks``.

Errors: every flag is checked before any work starts (:mod:`vrlab.cli_args`), and an
error is one line on stderr, ``vrlab render: error: --width must be >= 1, got 0``,
never a traceback.  Exit status 0 on success; 2 for a usage error (an unknown flag, a
bad flag value or combination: argparse's convention); 1 for a failure (an input file
missing, unreadable or malformed, an output folder missing or not writable, a scene
that fails to load, an error while working); 130 after Ctrl-C.  When the reader of
stdout goes away early (``vrlab lab --list | head -1``) the rest of the output is
dropped quietly with status 0: whether the pipe breaks at all depends on timing (short
output fits the pipe's buffer), and 0 keeps the status the same either way, so
``set -o pipefail`` scripts do not fail at random.  ``--debug``
(``vrlab --debug render ...`` or ``vrlab render ... --debug``) prints the traceback
before that line.  In process, :func:`main` returns 0 and raises ``SystemExit`` with
the status otherwise, as argparse does.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import os
import signal
import sys
import traceback
import warnings
from typing import Sequence

from .cli_args import Failure, UsageError, output_folder, seed

#: the wall-time budgets of ``vrlab demo --quick`` and ``vrlab demo`` on 2 cores, in seconds (issue
#: 15): ``vrlab demo --help`` states them and ``benchmarks/bench_demo.py`` measures against them
DEMO_BUDGET_S = {"quick": 10.0, "full": 120.0}

EPILOG = """\
errors: one line on stderr, e.g. "vrlab render: error: --width must be >= 1, got 0".
exit status: 0 success; 2 usage error (unknown flag, bad value or combination; every
flag is checked before any work starts); 1 failure (input file missing or unreadable,
output folder missing or not writable, a scene that fails to load, an error while
working); 130 interrupted (Ctrl-C); 0 when stdout is closed early ("| head -1"): the
rest of the output is dropped quietly.
--debug (before or after COMMAND) shows the Python traceback of an error."""

_QUIET_TYPES = (ValueError, TypeError, OSError, Failure)   # their message says it all


class _Formatter(argparse.RawDescriptionHelpFormatter):
    """Descriptions and epilogs as written; option help wrapped without breaking flag names
    at their hyphens ("--light-selection" stays whole)."""

    def _split_lines(self, text, width):
        import textwrap

        return textwrap.wrap(" ".join(text.split()), width, break_on_hyphens=False)


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (no usage block): raised as UsageError."""

    def error(self, message: str):
        raise UsageError(message, prog=self.prog)


def _cmd_demo(args: argparse.Namespace) -> int:
    root, out = seed(args.seed), output_folder(args.out, "--out")
    from .demo import run_demo

    if args.json:                   # stdout: only the JSON; the text report goes to stderr
        with contextlib.redirect_stdout(sys.stderr):
            summary = run_demo(out, seed=root, quick=args.quick)
        print(json.dumps(summary, indent=2, default=float))
        return 0
    run_demo(out, seed=root, quick=args.quick)
    return 0


def _cmd_bench(args: argparse.Namespace) -> int:
    import pandas as pd

    from .bench import run

    def progress(part, done, total):          # on stderr: the races take up to a minute
        if done < total:
            print(f"vrlab bench: timing {part} ({done + 1}/{total}) ...", file=sys.stderr, flush=True)

    rows = run(args.suite, quick=args.quick, progress=progress)
    if args.json:
        print(json.dumps(rows, indent=2, default=float))
        return 0
    table = pd.DataFrame(rows)
    with pd.option_context("display.width", 160, "display.max_columns", 20):
        for k, part in enumerate(dict.fromkeys(table["suite"])):
            # one table per part, only its own columns (the parts' columns differ: no NaN cells)
            print(("\n" if k else "") + f"{part}:")
            part_table = pd.DataFrame([{k: v for k, v in r.items() if k != "suite"} for r in rows
                                       if r["suite"] == part])
            print(part_table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    return 0


def _cmd_notebooks(args: argparse.Namespace) -> int:
    import importlib.util

    from .experiments import export_notebooks

    try:
        paths = export_notebooks(args.folder, overwrite=args.force)
    except FileExistsError:
        raise Failure(f"{args.folder!r} already has vrlab's notebooks; --force replaces them, or choose "
                      "another folder") from None
    print(f"wrote {len(paths)} notebooks to {args.folder}")
    if importlib.util.find_spec("jupyterlab") is None:
        print('install Jupyter first: pip install "vrlab[notebooks]"')
    print(f"open them with: jupyter lab {args.folder}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``vrlab`` and its subcommands (errors raise :class:`UsageError`)."""
    from . import cli_lab, cli_render

    parser = _Parser(prog="vrlab", epilog=EPILOG, formatter_class=_Formatter,
                     description="Monte Carlo estimators and variance reduction for rendering: samplers,\n"
                                 "warps, the integral lab, a direct-lighting renderer, benchmarks.")
    parser.add_argument("--debug", action="store_true", help="on an error, show the Python traceback")
    from . import __version__
    parser.add_argument("--version", action="version", version=f"vrlab {__version__}",
                        help="print vrlab's version and exit")
    common = _Parser(add_help=False)
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                        help="on an error, show the Python traceback (same as vrlab --debug COMMAND)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser,
                                help="one of these (vrlab COMMAND --help explains it):")
    kw = dict(parents=[common], epilog=EPILOG, formatter_class=_Formatter)

    demo = sub.add_parser("demo", help="run the showcase on built-in defaults and write figures and tables",
                          description="Draw every warp's samples against its pdf, compare point sets\n"
                                      "(discrepancy) and samplers (speed); writes PNG and CSV files.", **kw)
    demo.add_argument("--out", default="vrlab-demo",
                      help="output folder, created if missing (default: %(default)s)")
    demo.add_argument("--seed", default="2026", help="root seed of every random number, 0 .. 2**128-1: the same "
                                                     "seed gives the same figures and tables (default: %(default)s)")
    demo.add_argument("--quick", action="store_true",
                      help=f"smaller sample counts, for a first look (time budget on 2 cores: under "
                           f"{DEMO_BUDGET_S['quick']:g} s; the full demo under {DEMO_BUDGET_S['full'] / 60:g} min; "
                           "benchmarks/bench_demo.py in the repository measures both against it)")
    demo.add_argument("--json", action="store_true", help="print a JSON summary of what was written (stdout: only "
                                                          "the JSON; the text report goes to stderr)")
    demo.set_defaults(func=_cmd_demo, parser=demo)

    cli_lab.add_parser(sub, **kw)

    bench = sub.add_parser("bench", help="time vrlab side by side with its peers (NumPy, SciPy)",
                           description="Benchmarks reported as ratios against the peers, in one run.", **kw)
    bench.add_argument("suite", choices=["sampling", "qmc", "discrete", "estimators"], metavar="suite",
                       help="what to time. qmc: Halton/Hammersley against scipy.stats.qmc; discrete: the alias "
                            "table against NumPy's choice, SciPy's alias urn and searchsorted; sampling: qmc and "
                            "discrete; estimators: estimator overhead against bare NumPy and peak memory")
    bench.add_argument("--quick", action="store_true", help="smaller sizes (seconds, for a smoke run)")
    bench.add_argument("--json", action="store_true", help="print the rows as JSON")
    bench.set_defaults(func=_cmd_bench, parser=bench)

    cli_render.add_parser(sub, **kw)

    from .experiments import list_notebooks

    books = list_notebooks()
    topics = [n.split("_", 1)[1].removesuffix(".ipynb").replace("_", " ") for n in (books[0], books[-1])]
    nbs = sub.add_parser("notebooks", help="copy the lecture notebooks into a folder, to open with Jupyter",
                         description=f"Copy the {len(books)} lecture notebooks ({topics[0]} ... {topics[1]})\n"
                                     "into FOLDER. Open them with: jupyter lab FOLDER (Jupyter comes\n"
                                     'with: pip install "vrlab[notebooks]"). Each notebook runs its experiment\n'
                                     "from the installed package and writes its figures to vrlab-out/.", **kw)
    nbs.add_argument("folder", nargs="?", default="vrlab-notebooks",
                     help="where to write them, created if missing (default: %(default)s)")
    nbs.add_argument("--force", action="store_true", help="replace notebooks already in the folder")
    nbs.set_defaults(func=_cmd_notebooks, parser=nbs)
    return parser


# ----------------------------------------------------------------------------- error handling
def _one_line(text: str) -> str:
    return " ".join(part.strip() for part in str(text).splitlines() if part.strip())


def _say(prog: str, kind: str, text: str) -> None:
    with contextlib.suppress(OSError, ValueError):      # stderr itself may be closed
        print(f"{prog}: {kind}: {_one_line(text)}", file=sys.stderr, flush=True)


def _message(exc: BaseException, debug: bool) -> str:
    text = _one_line(str(exc))
    hint = "" if debug else " (--debug shows the traceback)"
    if isinstance(exc, MemoryError):
        return "out of memory" + (f" ({text})" if text else "") + hint
    if isinstance(exc, _QUIET_TYPES) and text:
        return text
    return f"{type(exc).__name__}: {text or 'no message'}{hint}"


def _stdout_closed() -> bool:
    """Whether stdout is a pipe whose reader has gone (POLLERR); True when it cannot be told."""
    try:
        import select

        poll = select.poll()
        poll.register(sys.stdout.fileno(), select.POLLOUT)
        return any(ev & select.POLLERR for _, ev in poll.poll(0))
    except (AttributeError, OSError, ValueError, ImportError):
        return True


def _drop_stdout() -> None:
    """Point stdout at /dev/null so that the final flush at exit cannot fail again."""
    with contextlib.suppress(AttributeError, OSError, ValueError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)


@contextlib.contextmanager
def _quiet_workers():
    """Ctrl-C: the main process raises KeyboardInterrupt; forked worker processes (which
    inherit this handler) leave at once without printing their own tracebacks."""
    main_pid = os.getpid()

    def on_sigint(signum, frame):
        if os.getpid() != main_pid:
            os._exit(130)
        raise KeyboardInterrupt

    try:
        previous = signal.signal(signal.SIGINT, on_sigint)
    except (ValueError, OSError):           # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _warning_printer(prog: str, debug: bool):
    def show(message, category, filename, lineno, file=None, line=None):
        where = f" at {filename}:{lineno}" if debug else ""
        _say(prog, "warning", f"{message} ({category.__name__}{where})")
    return show


def _check_argv(argv) -> list[str] | None:
    if argv is None:
        return None
    if isinstance(argv, (str, bytes)) or not isinstance(argv, Sequence):
        raise TypeError(f"argv must be a list of strings (or None for sys.argv[1:]), got {type(argv).__name__}")
    bad = [a for a in argv if not isinstance(a, str)]
    if bad:
        raise TypeError(f"argv must be a list of strings, got {bad[0]!r} ({type(bad[0]).__name__})")
    return list(argv)


def _run(argv: list[str] | None, state: dict) -> int:
    parser = build_parser()
    try:
        args, extra = parser.parse_known_args(argv)
        if extra:                            # after COMMAND: reported by its parser ("vrlab render: ...")
            words = sys.argv[1:] if argv is None else argv
            after = args.command in words and extra[0] in words and words.index(extra[0]) > words.index(args.command)
            (args.parser if after else parser).error(f"unrecognized arguments: {' '.join(extra)}")
    except SystemExit:                       # --help printed: flush it while we can report a closed pipe
        sys.stdout.flush()
        raise
    state["debug"] = bool(getattr(args, "debug", False))
    if args.command is None:
        raise UsageError("give a COMMAND: demo, lab, render, bench or notebooks (vrlab --help explains them)")
    state["prog"] = f"vrlab {args.command}"
    with _quiet_workers(), warnings.catch_warnings():
        warnings.showwarning = _warning_printer(state["prog"], state["debug"])
        code = args.func(args)
    sys.stdout.flush()
    return code


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``vrlab`` on ``argv`` (default ``sys.argv[1:]``): returns 0 on success, raises
    ``SystemExit`` with status 2 (usage), 1 (failure) or 130 (Ctrl-C) after one line on
    stderr; returns 0 quietly when stdout is closed early (see the module docstring)."""
    argv = _check_argv(argv)
    state = {"prog": "vrlab", "debug": False}
    try:
        try:
            return _run(argv, state)
        except BrokenPipeError:
            if not _stdout_closed():
                raise
            _drop_stdout()
            return 0
    except SystemExit:
        raise
    except BaseException as exc:
        if not isinstance(exc, Exception) and not isinstance(exc, KeyboardInterrupt):
            raise                            # GeneratorExit and the like: not ours to report
        if state["debug"]:
            traceback.print_exc()
        if isinstance(exc, KeyboardInterrupt):
            _say(state["prog"], "error", "interrupted")
            raise SystemExit(130) from None
        if isinstance(exc, UsageError):
            _say(exc.prog or state["prog"], "error", str(exc) or "bad usage")
            raise SystemExit(2) from None
        _say(state["prog"], "error", _message(exc, state["debug"]))
        raise SystemExit(1) from None


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
