"""Render checkpoints: the per-pixel statistics after each finished spp batch, in one ``.npz``.

A render is a grid of units (tile, spp batch), each seeded by its position (see
:mod:`vrlab.render.film`).  After every batch of every tile is merged, the statistics
(whatever the estimator's ``accumulate`` returns, per tile and per estimate, saved as its
``state()`` and rebuilt by the estimator's ``statistics_from_state``) are written with ``numpy.savez`` to a temporary file in the checkpoint's folder, which then
replaces the checkpoint (``os.replace``, atomic on POSIX and Windows): a crash or a kill
leaves either the previous checkpoint or the new one, never half of one.

The file also holds a hash of everything that decides the numbers (the scene, the
estimator, its settings, the point set, the seed, the batch size and the kind of render)
and how many batches are done.  Loading refuses a checkpoint of a different render
(``ValueError`` naming ``checkpoint``).  A larger ``spp`` extends a finished checkpoint:
the new batches merge into the stored statistics (Chan et al.'s update), in batch order,
so the result equals the render made in one go with that ``spp``.
"""
from __future__ import annotations

import hashlib
import json
import os
import pickle
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from .. import checks

__all__ = ["load_checkpoint", "render_hash", "save_checkpoint"]

VERSION = 2


def render_hash(*parts: Any) -> str:
    """A SHA-256 of the pickled ``parts`` (scene, estimator, settings, seed...)."""
    h = hashlib.sha256()
    for part in parts:
        h.update(pickle.dumps(part, protocol=4))
    return h.hexdigest()


def check_path(path: Any) -> Path:
    return checks.file_path(path, "checkpoint", (".npz",))


def save_checkpoint(path: Path, digest: str, spp: int, batch: int, batches_done: int, stats: dict) -> None:
    """Write the statistics ``{tile: (stats per estimate)}`` atomically (see the module docstring)."""
    arrays: dict[str, np.ndarray] = {}
    for t, per in stats.items():
        for i, st in enumerate(per):
            arrays[f"t{t}_e{i}_"] = np.array(len(st.state()))      # marks estimate i of tile t
            for name, value in st.state().items():
                arrays[f"t{t}_e{i}_{name}"] = np.asarray(value)
    meta = {"version": VERSION, "hash": digest, "spp": spp, "batch": batch, "batches_done": batches_done,
            "tiles": sorted(stats)}
    arrays["meta"] = np.array(json.dumps(meta))
    fd, tmp = tempfile.mkstemp(suffix=".npz", prefix=path.name + ".", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez(f, **arrays)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def load_checkpoint(path: Path, digest: str, batch: int, spp: int, restore: Any) -> tuple[int, dict]:
    """``(batches done, {tile: stats per estimate})`` from a checkpoint of this render, or
    ``(0, {})`` if ``path`` does not exist; ``restore(state)`` rebuilds one statistics object
    (the estimator's ``statistics_from_state``).  ``ValueError`` naming ``checkpoint`` for a
    file that is not a vrlab checkpoint, holds another render, or cannot be extended to
    ``spp`` (more samples than asked for, or a partial last batch)."""
    if not path.exists():
        return 0, {}
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            if meta.get("version") != VERSION:
                raise ValueError("version")
            stats: dict = {}
            for t in meta["tiles"]:
                per, i = [], 0
                while f"t{t}_e{i}_" in data:
                    prefix = f"t{t}_e{i}_"
                    state = {key[len(prefix):]: data[key] for key in data.files
                             if key.startswith(prefix) and key != prefix}
                    state["kind"] = str(state.get("kind", ""))
                    per.append(restore(state))
                    i += 1
                stats[int(t)] = tuple(per)
    except (OSError, KeyError, ValueError, json.JSONDecodeError) as exc:
        raise ValueError(f"checkpoint: {str(path)!r} is not a vrlab render checkpoint ({exc})") from None
    if meta["hash"] != digest or meta["batch"] != batch:
        raise ValueError(f"checkpoint: {str(path)!r} holds a different render (scene, estimator, settings, seed or "
                         "batch size differ); use another file name, or delete it to start again")
    stored, done = int(meta["spp"]), int(meta["batches_done"])
    done_spp = min(done * batch, stored)
    if done_spp > spp:
        raise ValueError(f"checkpoint: {str(path)!r} already holds {done_spp} samples per pixel, more than spp = {spp}")
    if done_spp % batch and spp > done_spp:
        raise ValueError(f"checkpoint: {str(path)!r} ends with a partial batch ({done_spp} spp, batches of {batch}); "
                         f"it cannot be extended to spp = {spp}: extend checkpoints made with spp a multiple of "
                         f"the batch size")
    return done, stats
