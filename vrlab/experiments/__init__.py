"""The lecture experiments behind the notebooks (``vrlab/notebooks``) and the README gallery.

One module per lecture question.  Each has ``main(out, full=False) -> dict``, which writes
its CSV tables and PNG figures into the folder ``out`` and returns the tables and numbers
(``"files"``: the names written); ``full=True`` asks for publication-quality sample counts.
Run one from a shell as ``python -m vrlab.experiments.NAME [--full] [--out FOLDER]``
(default folder: ``vrlab-out/NAME`` in the working folder).  Importing a module has no side
effects: figures are written with matplotlib's default (non-interactive when headless)
backend and closed.
"""

NAMES = ("importance_sampling", "cosine_sampling", "light_surfaces", "mis", "antithetic_crn",
         "control_variates", "ris", "sampling_patterns", "discrete_sampling", "metropolis_hastings",
         "gradient_domain", "environment_lighting", "restir")

__all__ = ["NAMES", "export_notebooks", "list_notebooks"]


def list_notebooks() -> list[str]:
    """File names of the lecture notebooks shipped with vrlab (``01_...ipynb`` to ``13_...``)."""
    from importlib import resources

    return sorted(p.name for p in resources.files("vrlab.notebooks").iterdir() if p.name.endswith(".ipynb"))


def export_notebooks(folder, *, overwrite: bool = False) -> list:
    """Copy the lecture notebooks into ``folder`` (created if missing), to open with Jupyter
    (``pip install "vrlab[notebooks]"``, then ``jupyter lab FOLDER``); returns the paths
    written.  They import vrlab and :mod:`vrlab.experiments` from the installed package and
    write their figures to ``vrlab-out/`` beside themselves.  ``FileExistsError`` instead of
    replacing a notebook unless ``overwrite``; ``TypeError``/``ValueError`` naming ``folder``."""
    import os
    import shutil
    from importlib import resources
    from pathlib import Path

    from .. import checks

    overwrite = checks.flag(overwrite, "overwrite")
    if not isinstance(folder, (str, os.PathLike)) or isinstance(folder, bytes) or not str(folder).strip():
        raise (ValueError if isinstance(folder, str) else TypeError)(
            f"folder must be a folder path (a non-empty str or os.PathLike), got {folder!r}")
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise NotADirectoryError(f"folder: {str(folder)!r} exists and is not a folder")
    names = list_notebooks()
    taken = [n for n in names if (folder / n).exists()]
    if taken and not overwrite:
        raise FileExistsError(f"folder: {str(folder)!r} already has {', '.join(taken[:3])}"
                              f"{' ...' if len(taken) > 3 else ''}; choose another folder or overwrite")
    source = resources.files("vrlab.notebooks")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for n in names:
            with resources.as_file(source / n) as path:
                shutil.copyfile(path, folder / n)
    except OSError as exc:
        raise ValueError(f"folder: cannot write the notebooks to {str(folder)!r} ({exc.strerror or exc})") from None
    return [folder / n for n in names]
