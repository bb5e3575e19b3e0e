"""Argument checks of the lab's tables and figures: data frames, flags, output paths.

Errors name the argument (``df``, ``path``...) and say what is allowed.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np
import pandas as pd

from .. import checks


flag = checks.flag


def optional_text(value: Any, name: str) -> str | None:
    """``None`` or a string."""
    if value is not None and not isinstance(value, str):
        raise TypeError(f"{name} must be a string or None, got {checks.describe(value)}")
    return value


def frame(df: Any, columns: Sequence[str], name: str = "df", *, numeric: Sequence[str] = ()) -> pd.DataFrame:
    """``df`` if it is a non-empty DataFrame with ``columns``, the ``numeric`` ones holding numbers."""
    if not isinstance(df, pd.DataFrame):
        raise TypeError(f"{name} must be a pandas DataFrame (from vrlab.lab.run or summarize), "
                        f"got {checks.describe(df)}")
    missing = [c for c in columns if c not in df]
    if missing:
        raise ValueError(f"{name}: missing columns {missing} (expected a vrlab.lab.run DataFrame)")
    if len(df) == 0:
        raise ValueError(f"{name}: the table has no rows")
    for c in numeric:
        col = df[c]
        if pd.api.types.is_bool_dtype(col) or not pd.api.types.is_numeric_dtype(col):
            raise TypeError(f"{name}: column {c!r} must hold numbers, got dtype {col.dtype}")
    return df


def column_check(df: pd.DataFrame, column: str, ok: np.ndarray, what: str, name: str = "df") -> None:
    """``ValueError`` naming the first row of ``df[column]`` where ``ok`` is False."""
    bad = ~np.asarray(ok, bool)
    if bad.any():
        row = int(np.argmax(bad))
        value = df[column].iloc[row]
        value = value.item() if isinstance(value, np.generic) else value
        raise ValueError(f"{name}: column {column!r} must be {what}; row {row} has {value!r}")


def out_path(path: Any, name: str = "path") -> Path:
    """``path`` to write a figure to: a suffix matplotlib can write (``.png``, ``.pdf``,
    ``.svg``...), in a folder that exists (:func:`vrlab.checks.file_path`)."""
    from matplotlib.backend_bases import FigureCanvasBase

    kinds = sorted("." + k for k in FigureCanvasBase.get_supported_filetypes())
    return checks.file_path(path, name, kinds)


def lab_integrand(integrand, name: str = "integrand"):
    """An ``Integrand`` (catalogue names are looked up); ``TypeError``/``ValueError`` naming ``name``."""
    from ..integrands import CATALOGUE, Integrand

    if isinstance(integrand, Integrand):
        return integrand
    if isinstance(integrand, str):
        if integrand not in CATALOGUE:
            raise ValueError(f"{name}: unknown integrand {integrand!r}; choose from {', '.join(CATALOGUE)}")
        return CATALOGUE[integrand]()
    raise TypeError(f"{name} must be a vrlab Integrand or a catalogue name, got {type(integrand).__name__}")
