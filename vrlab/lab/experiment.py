"""The shared command line of the ``experiments/`` scripts.

Every script exposes ``main(out, full=False) -> dict`` and ends with
``experiment_cli(main, DEFAULT_OUT, __doc__)``: ``--full`` asks for publication-quality
sample counts, ``--out`` names the output folder; the tables (DataFrames) and numbers in
the returned dict are printed.
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Callable, Sequence

import pandas as pd

__all__ = ["experiment_cli", "output_dir", "save_figure"]


def output_dir(out: str | Path) -> Path:
    """``out`` as a ``Path``, created (with parents) if missing."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    return out


def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Lay out, write and close a matplotlib figure; returns ``Path(path)``."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return Path(path)


def experiment_cli(main: Callable[..., dict], default_out: str | Path, doc: str | None,
                   argv: Sequence[str] | None = None) -> dict:
    """Parse ``--full``/``--out``, run ``main`` and print what it returns."""
    ap = argparse.ArgumentParser(description=(doc or "").strip().splitlines()[0] if doc else None)
    ap.add_argument("--full", action="store_true", help="publication-quality sample counts")
    ap.add_argument("--out", default=str(default_out), help="output directory")
    args = ap.parse_args(argv)
    res = main(args.out, full=args.full)
    with pd.option_context("display.width", 200, "display.max_columns", 30):
        for key, value in res.items():
            if isinstance(value, pd.DataFrame):
                print(f"{key}:\n{value.to_string(index=False)}")
            elif isinstance(value, (int, float, str, dict, list, tuple)):
                print(f"{key}: {value}")
    print("wrote", args.out)
    return res
