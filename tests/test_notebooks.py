"""The lecture notebooks and their experiment scripts run end to end.

Every notebook in ``vrlab/notebooks/`` is executed with nbclient (each ends with an
``assert`` that a measured quantity agrees with theory), from a copy made by ``vrlab
notebooks`` in a folder outside the checkout, so it imports the package as an installed user
has it; every module of :mod:`vrlab.experiments` writes its CSV tables and PNG figures
through ``main(out)``.
"""
from __future__ import annotations

import importlib
from pathlib import Path

import pytest

from conftest import run_cli
from vrlab.experiments import NAMES as SCRIPTS
from vrlab.experiments import export_notebooks, list_notebooks

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "vrlab" / "notebooks").glob("*.ipynb"))


def _load(name: str):
    return importlib.import_module(f"vrlab.experiments.{name}")


@pytest.mark.parametrize("name", SCRIPTS)
def test_experiment_main_writes_tables_and_figures(name, tmp_path):
    pytest.importorskip("matplotlib")
    res = _load(name).main(tmp_path / name)
    assert isinstance(res, dict)
    files = list((tmp_path / name).iterdir())
    assert any(f.suffix == ".csv" and f.stat().st_size > 0 for f in files), files
    assert any(f.suffix == ".png" and f.stat().st_size > 0 for f in files), files
    assert sorted(f.name for f in files) == res["files"]


def test_every_experiment_has_a_notebook():
    assert len(NOTEBOOKS) >= len(SCRIPTS)
    text = "".join(nb.read_text() for nb in NOTEBOOKS)
    for name in SCRIPTS:
        assert f"from vrlab.experiments import {name}" in text, name
    assert "sys.path" not in text, "notebooks import the installed package, not a checkout"
    assert [p.name for p in NOTEBOOKS] == list_notebooks()


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_executes(path, tmp_path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    nb = nbformat.read(path, as_version=4)
    assert all(not c.get("outputs") for c in nb.cells if c.cell_type == "code"), "commit notebooks without outputs"
    last = [c for c in nb.cells if c.cell_type == "code"][-1]
    assert "assert" in last.source, "a notebook must end with an assert against theory"
    # a copy outside the checkout, as `vrlab notebooks FOLDER` makes it; outputs beside it
    (copy,) = [p for p in export_notebooks(tmp_path / "nb") if p.name == path.name]
    monkeypatch.setenv("VRLAB_NB_OUT", str(tmp_path / "out"))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    client = nbclient.NotebookClient(nbformat.read(copy, as_version=4), timeout=120, kernel_name="python3",
                                     resources={"metadata": {"path": str(copy.parent)}})
    client.execute()


def test_package_data_ships_every_data_file():
    """A non-editable install carries the notebooks, the scenes and the Mitsuba references:
    every file under vrlab/ that is not Python source matches a package-data pattern."""
    import fnmatch
    import tomllib

    patterns = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["vrlab"]
    package = ROOT / "vrlab"
    data = [p.relative_to(package).as_posix() for p in package.rglob("*")
            if p.is_file() and p.suffix not in (".py", ".pyc") and "__pycache__" not in p.parts]
    assert len([d for d in data if d.endswith(".ipynb")]) == len(NOTEBOOKS) >= 11
    missed = [d for d in data if not any(fnmatch.fnmatch(d, pat) for pat in patterns)]
    assert not missed, f"not in [tool.setuptools.package-data]: {missed}"
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert any(req.startswith(("jupyterlab", "notebook")) for req in extras["notebooks"])


def test_vrlab_notebooks_command_copies_them_and_refuses_to_overwrite(tmp_path, capsys):
    code, out, err = run_cli(capsys, ["notebooks", str(tmp_path / "nb")])
    assert code == 0, err
    assert sorted(p.name for p in (tmp_path / "nb").iterdir()) == list_notebooks()
    assert f"jupyter lab {tmp_path / 'nb'}" in out
    assert (tmp_path / "nb" / NOTEBOOKS[3].name).read_bytes() == NOTEBOOKS[3].read_bytes()
    code, out, err = run_cli(capsys, ["notebooks", str(tmp_path / "nb")])
    assert code == 1 and "--force" in err and len(err.strip().splitlines()) == 1
    assert run_cli(capsys, ["notebooks", str(tmp_path / "nb"), "--force"])[0] == 0
    (tmp_path / "file").write_text("x")
    code, out, err = run_cli(capsys, ["notebooks", str(tmp_path / "file")])
    assert code == 1 and "folder" in err and "Traceback" not in err
    code, out, err = run_cli(capsys, ["notebooks", str(tmp_path / "file" / "below")])   # a file as parent
    assert code == 1 and err.count("\n") == 1 and "folder" in err and "Traceback" not in err


def test_notebooks_name_commands_an_installed_user_has():
    """A notebook points at ``python -m vrlab.experiments.NAME`` (installed with the package), not at
    ``experiments/NAME.py`` (only in the repository), and each NAME is a module that runs as one."""
    import re

    import vrlab.notebooks

    folder = Path(vrlab.notebooks.__file__).parent
    for name in list_notebooks():
        path = folder / name
        text = path.read_text()
        assert not re.search(r"`experiments/[a-z_]+\.py`", text), path
        for name in re.findall(r"python -m vrlab\.experiments\.([a-z_]+)", text):
            module = importlib.import_module(f"vrlab.experiments.{name}")
            assert '__name__ == "__main__"' in Path(module.__file__).read_text(), name
