"""The shared command line of the :mod:`vrlab.experiments` modules.

Every script exposes ``main(out, full=False) -> dict`` and ends with
``experiment_cli(main, DEFAULT_OUT, __doc__)``: ``--full`` asks for publication-quality
sample counts, ``--out`` names the output folder; the tables (DataFrames) and numbers in
the returned dict are printed.  Arguments are checked (errors name them): paths are
``str``/``Path``, a figure path has a suffix matplotlib writes and an existing folder,
``dpi`` lies in (0, 1200], ``main`` is callable and returns a dict.
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Callable, Sequence

import pandas as pd

from .. import checks
from ._args import out_path

__all__ = ["experiment_cli", "output_dir", "save_figure"]


def output_dir(out: str | Path) -> Path:
    """``out`` as a ``Path``, created (with parents) if missing (``ValueError`` if it is a file)."""
    if not isinstance(out, (str, os.PathLike)) or isinstance(out, bytes):
        raise TypeError(f"out must be a folder path (str or pathlib.Path), got {checks.describe(out)}")
    if str(out) == "":
        raise ValueError("out: give a folder name, got ''")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"out: {str(out)!r} exists and is not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"out: cannot create the folder {str(out)!r} ({exc.strerror or exc})") from None
    return out


def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Lay out (``tight_layout``, unless the figure has a layout engine), write and close a
    matplotlib figure; returns ``Path(path)``."""
    import matplotlib.pyplot as plt

    if not (callable(getattr(fig, "savefig", None)) and callable(getattr(fig, "tight_layout", None))):
        raise TypeError(f"fig must be a matplotlib Figure, got {checks.describe(fig)}")
    path = out_path(path)
    dpi = checks.real(dpi, "dpi", low=0.0, high=1200.0, low_open=True)

    if fig.get_layout_engine() is None:      # a figure with its own layout engine keeps it
        fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return Path(path)


def experiment_cli(main: Callable[..., dict], default_out: str | Path, doc: str | None,
                   argv: Sequence[str] | None = None) -> dict:
    """Parse ``--full``/``--out``, run ``main`` and print what it returns."""
    if not callable(main):
        raise TypeError(f"main must be callable (out, full=False) -> dict, got {checks.describe(main)}")
    if not isinstance(default_out, (str, os.PathLike)) or isinstance(default_out, bytes):
        raise TypeError(f"default_out must be a folder path (str or Path), got {checks.describe(default_out)}")
    if doc is not None and not isinstance(doc, str):
        raise TypeError(f"doc must be a string or None, got {checks.describe(doc)}")
    if argv is not None and (isinstance(argv, (str, bytes)) or not all(isinstance(a, str) for a in argv)):
        raise TypeError(f"argv must be a list of strings or None, got {checks.describe(argv)}")
    ap = argparse.ArgumentParser(description=(doc or "").strip().splitlines()[0] if doc else None)
    ap.add_argument("--full", action="store_true", help="publication-quality sample counts")
    ap.add_argument("--out", default=str(default_out), help="output directory")
    args = ap.parse_args(argv)
    res = main(args.out, full=args.full)
    if not isinstance(res, dict):
        raise TypeError(f"main must return a dict of results, got {type(res).__name__}")
    with pd.option_context("display.width", 200, "display.max_columns", 30):
        for key, value in res.items():
            if isinstance(value, pd.DataFrame):
                print(f"{key}:\n{value.to_string(index=False)}")
            elif isinstance(value, (int, float, str, dict, list, tuple)):
                print(f"{key}: {value}")
    print("wrote", args.out)
    return res
