"""The scenes shipped with vrlab (``vrlab/render/scenes/*.xml``): names, paths, their
descriptions (the ``<!-- vrlab: ... -->`` comment atop each file), a copy for editing, and
the Mitsuba 3 reference images of four of them (``scenes/mitsuba/``, 64 x 48, 16384 spp;
how they were made: ``scenes/mitsuba/README.md``)."""
from __future__ import annotations

import os
import re
from importlib import resources
from pathlib import Path

from .. import checks
from .loader import load_scene

__all__ = ["builtin_scene_path", "describe_builtin_scene", "export_builtin_scene", "list_builtin_scenes",
           "list_mitsuba_references", "mitsuba_reference"]


def _scenes_folder() -> Path:
    return Path(str(resources.files("vrlab.render") / "scenes"))


def list_builtin_scenes() -> list[str]:
    """Names (without ``.xml``) of the scenes shipped in ``vrlab/render/scenes``."""
    return sorted(p.name[:-4] for p in _scenes_folder().iterdir() if p.name.endswith(".xml"))


def builtin_scene_path(name: str) -> Path:
    """Path of a built-in scene file (``name`` with or without ``.xml``)."""
    if not isinstance(name, str):
        raise TypeError(f"name must be a built-in scene name (str), got {type(name).__name__}")
    stem = name[:-4] if name.endswith(".xml") else name
    names = list_builtin_scenes()
    if stem not in names:
        raise ValueError(f"name: unknown built-in scene {name!r}; available: {', '.join(names)}")
    return _scenes_folder() / f"{stem}.xml"


def describe_builtin_scene(name: str, *, full: bool = False) -> str:
    """The first sentence (``full``: all) of the ``<!-- vrlab: ... -->`` comment atop the
    built-in scene ``name``, the one place its description is written.  Errors for ``name``
    as in :func:`builtin_scene_path`; ``ValueError`` if the file has no such comment."""
    full, path = checks.flag(full, "full"), builtin_scene_path(name)
    m = re.search(r"<!--\s*vrlab:(.*?)-->", path.read_text(encoding="utf-8"), re.DOTALL)
    if m is None or not m.group(1).strip():
        raise ValueError(f"name: the built-in scene file {path.name} has no <!-- vrlab: ... --> description")
    text = " ".join(m.group(1).split())
    text = text[:1].upper() + text[1:]
    return text if full else re.split(r"(?<=[.!?])\s+(?=[A-Z])", text, maxsplit=1)[0]


def export_builtin_scene(name: str, folder: str | os.PathLike, *, overwrite: bool = False) -> list[Path]:
    """Copy the built-in scene ``name`` into ``folder`` (created if missing) for editing: ``NAME.xml``
    and the files it references by relative path (``obj`` meshes), so the copy loads as the
    original does.  Returns the paths written, the XML first.  ``FileExistsError`` instead of
    replacing a file unless ``overwrite``; ``TypeError``/``ValueError`` naming ``name``/``folder``."""
    import shutil

    overwrite, src = checks.flag(overwrite, "overwrite"), builtin_scene_path(name).resolve()
    if not isinstance(folder, (str, os.PathLike)) or isinstance(folder, bytes) or not str(folder).strip():
        raise (ValueError if isinstance(folder, str) else TypeError)(
            f"folder must be a folder path (a non-empty str or os.PathLike), got {folder!r}")
    folder, base = Path(folder), src.parent.resolve()
    files = {src: Path(src.name)}                  # source -> path relative to the folder
    for ref in load_scene(src).files:              # meshes, images, included files beside the scene go along
        ref = Path(ref).resolve()
        if ref not in files and ref.is_relative_to(base):
            files[ref] = ref.relative_to(base)
    if folder.exists() and not folder.is_dir():
        raise NotADirectoryError(f"folder: {str(folder)!r} exists and is not a folder")
    taken = [str(folder / rel) for rel in files.values() if (folder / rel).exists()]
    if taken and not overwrite:
        raise FileExistsError(f"folder: {', '.join(map(repr, taken))} exists already; remove it, choose "
                              "another folder or pass overwrite=True")
    for ref, rel in files.items():
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(ref, folder / rel)
    return [folder / rel for rel in files.values()]


def list_mitsuba_references() -> list[str]:
    """Names of the built-in scenes that have a stored Mitsuba 3 reference image."""
    return sorted(p.name[:-9] for p in (_scenes_folder() / "mitsuba").iterdir() if p.name.endswith("_mean.npy"))


def mitsuba_reference(name: str):
    """``(mean, stderr)``: Mitsuba 3's ``direct`` integrator on the built-in scene ``name`` at
    64 x 48, float32 ``(48, 64, 3)`` each (mean and standard error of 32 batches of 512 spp).
    ``ValueError`` naming ``name`` for a scene without one (see :func:`list_mitsuba_references`)."""
    import numpy as np

    if not isinstance(name, str):
        raise TypeError(f"name must be a built-in scene name (str), got {type(name).__name__}")
    names = list_mitsuba_references()
    if name not in names:
        raise ValueError(f"name: no Mitsuba reference for {name!r}; available: {', '.join(names)}")
    folder = _scenes_folder() / "mitsuba"
    return np.load(folder / f"{name}_mean.npy"), np.load(folder / f"{name}_stderr.npy")
