"""The result store of a resumable lab sweep: one SQLite file (the standard library's ``sqlite3``).

``vrlab.lab.run(..., store="runs.sqlite")`` writes each finished work unit (a block of
repetitions of one estimator x integrand x n) to the file in one transaction, as soon as the
unit comes back.  Rerunning the same sweep with the same store runs only the repetitions
that are not in it; the seeds are per repetition (:mod:`vrlab.lab.runner`), so the final
table is the one an uninterrupted run gives, whatever was killed, when and where.

Layout (format 1)::

    meta(key TEXT PRIMARY KEY, value TEXT)      -- 'format', 'hash', 'settings'
    rows(estimator TEXT, integrand TEXT, n INTEGER, rep INTEGER, result TEXT,
         PRIMARY KEY (estimator, integrand, n, rep))

``result`` is the JSON list ``[value, stderr, seconds, n_evals, n_units]`` of one repetition
(Python's ``json`` writes floats as their shortest round-trip text, so they read back bit
for bit; a NaN standard error is ``NaN``).  The other columns of the table (exact value,
points, class, parameters) are recomputed from the sweep's settings.

``settings`` is the canonical JSON of what determines the numbers: the estimators (labels,
recipe names or class, scalar parameters and points of estimator objects), the integrands
(catalogue names, or name, dimension, domain and exact value of objects), the sample counts,
repetitions, root seed, ``crn``, ``chunk`` and ``skip``; ``hash`` is its SHA-256.  Workers,
executor and progress are not part of it: they do not change the numbers.  A store whose
hash differs is refused (:class:`StoreMismatch`), so two sweeps are never mixed.  Objects
are identified by those descriptions, not by their code: changing a user function without
renaming anything is not detected.

The file runs in WAL mode with ``synchronous=NORMAL``: a committed unit survives the death of
the process (SIGKILL included); a power cut may lose the last units, never the file.
"""
from __future__ import annotations

import hashlib
import json
import os
import sqlite3
from pathlib import Path
from typing import Any

import numpy as np

from .. import checks

__all__ = ["FORMAT", "ResultStore", "StoreError", "StoreMismatch", "describe_estimator", "describe_integrand",
           "settings_hash", "store_path"]

FORMAT = "1"
SUFFIXES = (".sqlite",)
_TABLES = {"meta", "rows"}


class StoreError(ValueError):
    """The store file cannot be used (not a vrlab store, unreadable, not writable)."""


class StoreMismatch(StoreError):
    """The store holds the results of a different sweep."""


def _canonical(settings: dict) -> str:
    return json.dumps(settings, sort_keys=True, separators=(",", ":"), default=str)


def settings_hash(settings: dict) -> str:
    """SHA-256 (hex) of the canonical JSON of ``settings``."""
    return hashlib.sha256(_canonical(settings).encode("utf-8")).hexdigest()


def _short(value: Any, width: int = 60) -> str:
    text = json.dumps(value, sort_keys=True, default=str)
    return text if len(text) <= width else text[:width - 3] + "..."


def _differences(stored: dict, given: dict) -> str:
    keys = sorted(set(stored) | set(given))
    diff = [f"{k} {_short(stored.get(k))} there, {_short(given.get(k))} here" for k in keys
            if stored.get(k) != given.get(k)]
    return "; ".join(diff) or "its settings hash differs"


class ResultStore:
    """An open store at ``path`` (created if missing) for the sweep described by ``settings``.

    ``done()``: the stored repetitions ``{(estimator, integrand, n, rep): (value, stderr,
    seconds, n_evals, n_units)}``; ``add(rows)``: one transaction for a finished unit;
    ``close()``.  Errors (:class:`StoreError`, a ``ValueError``) name ``store``.
    """

    def __init__(self, path: Any, settings: dict):
        self.path = checks.file_path(path, "store", SUFFIXES)
        given = json.loads(_canonical(settings))
        digest = settings_hash(settings)
        try:
            self._con = sqlite3.connect(os.fspath(self.path), timeout=60, isolation_level=None)
        except sqlite3.Error as exc:
            raise StoreError(f"store: cannot open {str(self.path)!r} ({exc})") from None
        try:
            self._open(given, digest)
        except sqlite3.Error as exc:
            self._con.close()
            raise StoreError(f"store: {str(self.path)!r} cannot be used as a lab store ({exc})") from None
        except StoreError:
            self._con.close()
            raise

    def _open(self, given: dict, digest: str) -> None:
        con = self._con
        tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        if tables and not _TABLES <= tables:
            raise StoreError(f"store: {str(self.path)!r} is an SQLite file but not a vrlab lab store "
                             f"(it has the tables {sorted(tables)})")
        con.execute("PRAGMA journal_mode=WAL")
        con.execute("PRAGMA synchronous=NORMAL")
        con.execute("BEGIN IMMEDIATE")
        try:
            con.execute("CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
            con.execute("CREATE TABLE IF NOT EXISTS rows (estimator TEXT NOT NULL, integrand TEXT NOT NULL, "
                        "n INTEGER NOT NULL, rep INTEGER NOT NULL, result TEXT NOT NULL, "
                        "PRIMARY KEY (estimator, integrand, n, rep))")
            con.executemany("INSERT OR IGNORE INTO meta (key, value) VALUES (?, ?)",
                            [("format", FORMAT), ("hash", digest), ("settings", _canonical(given))])
            meta = dict(con.execute("SELECT key, value FROM meta"))
            con.execute("COMMIT")
        except BaseException:
            if con.in_transaction:
                con.execute("ROLLBACK")
            raise
        if meta.get("format") != FORMAT:
            raise StoreError(f"store: {str(self.path)!r} has store format {meta.get('format')!r}; "
                             f"this vrlab reads format {FORMAT!r}")
        if meta.get("hash") != digest:
            try:
                stored = json.loads(meta.get("settings", "{}"))
            except ValueError:
                stored = {}
            raise StoreMismatch(f"store: the store {str(self.path)!r} holds a different sweep: "
                                f"{_differences(stored, given)}; give another file, or delete this one "
                                "to start over")

    def done(self) -> dict[tuple, tuple]:
        """Every stored repetition, keyed by ``(estimator, integrand, n, rep)``."""
        out = {}
        for est, integrand, n, rep, result in self._con.execute(
                "SELECT estimator, integrand, n, rep, result FROM rows"):
            value, stderr, seconds, n_evals, n_units = json.loads(result)
            out[est, integrand, int(n), int(rep)] = (float(value), float(stderr), float(seconds),
                                                     int(n_evals), int(n_units))
        return out

    def add(self, rows: list[tuple]) -> None:
        """Write ``[(estimator, integrand, n, rep, (value, stderr, seconds, n_evals, n_units))]``
        in one transaction (a unit is stored whole or not at all)."""
        con = self._con
        con.execute("BEGIN IMMEDIATE")
        try:
            con.executemany("INSERT OR REPLACE INTO rows (estimator, integrand, n, rep, result) "
                            "VALUES (?, ?, ?, ?, ?)",
                            [(e, i, int(n), int(r), json.dumps(list(res))) for e, i, n, r, res in rows])
            con.execute("COMMIT")
        except BaseException:
            if con.in_transaction:
                con.execute("ROLLBACK")
            raise

    def count(self) -> int:
        """How many repetitions are stored."""
        return int(self._con.execute("SELECT COUNT(*) FROM rows").fetchone()[0])

    def close(self) -> None:
        self._con.close()

    def __enter__(self) -> "ResultStore":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def store_path(path: Any) -> Path:
    """``path`` checked as a store file name (``.sqlite`` in an existing folder), naming ``store``."""
    return checks.file_path(path, "store", SUFFIXES)


# -- what identifies a sweep ----------------------------------------------------------------------
def describe_estimator(label: str, spec, points_name: str) -> dict:
    """An estimator in a store's settings: its label and recipe name, or for an object its
    class, scalar ``get_params()`` and points (``points_name``)."""
    if isinstance(spec, str):
        return {"label": label, "recipe": spec}
    est = spec[0]
    try:
        params = est.get_params()
    except (AttributeError, TypeError):
        params = {}
    scalars = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in params.items()
               if isinstance(v, (bool, int, float, str, np.bool_, np.integer, np.floating))}
    return {"label": label, "class": f"{type(est).__module__}.{type(est).__qualname__}", "params": scalars,
            "points": points_name}


def describe_integrand(spec, integrand) -> dict:
    """An integrand in a store's settings: its catalogue name, or for an object its name,
    dimension, domain and exact value."""
    if isinstance(spec, str):
        return {"name": spec}
    domain = integrand.domain if isinstance(integrand.domain, str) else np.asarray(integrand.domain).tolist()
    exact = integrand.exact
    exact = None if exact is None else np.asarray(exact, float).tolist()
    return {"name": integrand.name, "dim": int(integrand.dim), "domain": domain, "exact": exact}
