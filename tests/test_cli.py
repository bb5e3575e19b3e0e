"""The command line: subcommands listed, the quick demo writes its figures and tables."""
import json
import subprocess
import sys

import pandas as pd
import pytest

from vrlab.cli import main


def test_help_lists_subcommands():
    out = subprocess.run([sys.executable, "-m", "vrlab", "--help"], capture_output=True, text=True, check=True).stdout
    for cmd in ("demo", "bench", "lab"):
        assert cmd in out


def test_unknown_subcommand_is_an_error():
    with pytest.raises(SystemExit) as exc:
        main(["render-everything"])
    assert exc.value.code == 2


def test_quick_demo_writes_its_outputs(tmp_path, capsys):
    assert main(["demo", "--quick", "--out", str(tmp_path), "--json"]) == 0
    out = capsys.readouterr().out
    summary = json.loads(out[out.rindex("\n{") + 1:])  # the JSON summary comes last
    expected = {"warps.png", "warps_gof.csv", "point_sets.png", "discrepancy.csv", "sampler_speed.csv",
                "convergence.png", "lab_summary.csv"}
    assert expected <= set(summary["files"])
    gof = pd.read_csv(tmp_path / "warps_gof.csv")
    # every warp's pdf integrates to 1 and no warp is rejected at the corrected level
    assert (abs(gof["pdf_integral"] - 1) < 2e-3).all()
    assert (gof["p_value"] > 1e-4).all()
