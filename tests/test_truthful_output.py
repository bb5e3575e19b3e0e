"""What the commands say is true (issue 23, item 9): --version, demo --json is only JSON (tested in
test_cli), a render without -o says nothing was saved, inapplicable flags are warned about,
--gradient-domain solves and shows only the reconstruction asked for (L1 says when it starts), the lab
flags untrustworthy error bars and names its bigger-is-better columns, slopes need 3 sample counts."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

import vrlab
from conftest import run_cli
from vrlab import lab

RENDER = ["render", "furnace", "--spp", "2", "--width", "4", "--height", "3", "--workers", "1", "--no-progress"]


def test_version(capsys):
    code, out, _ = run_cli(capsys, ["--version"])
    assert code == 0 and out.strip() == f"vrlab {vrlab.__version__}"


def test_a_render_without_output_says_so(capsys, tmp_path):
    code, out, err = run_cli(capsys, RENDER)
    assert code == 0 and "output=None" in out and "not saved" in err
    code, out, err = run_cli(capsys, RENDER + ["--json"])
    assert json.loads(out)["output"] is None
    code, out, err = run_cli(capsys, RENDER + ["-o", str(tmp_path / "x.npy")])
    assert "not saved" not in err and (tmp_path / "x.npy").exists()


@pytest.mark.parametrize("extra, flag", [(["--ris-candidates", "4"], "--ris-candidates"),
                                         (["--strategy", "bsdf", "--emitter-samples", "2"], "--emitter-samples"),
                                         (["--strategy", "light", "--bsdf-samples", "2"], "--bsdf-samples"),
                                         (["--strategy", "cosine", "--light-selection", "power"], "--light-selection"),
                                         (["--exposure", "2"], "--exposure")])
def test_inapplicable_flags_are_warned_about(capsys, extra, flag):
    code, out, err = run_cli(capsys, RENDER + extra)
    assert code == 0 and f"warning: {flag}" in err, err


@pytest.mark.parametrize("extra", [["--strategy", "ris", "--ris-candidates", "4"],
                                   ["--strategy", "bsdf", "--bsdf-samples", "2"],
                                   ["--compare", "light,ris", "--ris-candidates", "4", "--reference-spp", "2"]])
def test_applicable_flags_are_not(capsys, extra, tmp_path):
    code, out, err = run_cli(capsys, RENDER + extra + ["-o", str(tmp_path / ("x.png" if "--compare" in extra
                                                                             else "x.npy"))])
    assert code == 0 and "warning" not in err, err


def test_gradient_domain_runs_and_times_only_what_it_needs(capsys, tmp_path, monkeypatch):
    from vrlab.render import gradient

    calls = []
    real = gradient.GradientDomainRender.reconstruct if hasattr(gradient, "GradientDomainRender") else None
    GD = ["render", "furnace", "--gradient-domain", "--spp", "2", "--width", "6", "--height", "4", "--workers", "1",
          "--no-progress", "--json"]
    code, out, _ = run_cli(capsys, GD)
    res = json.loads(out)
    assert code == 0 and set(res["reconstruct_seconds"]) == {"l2"}          # no figure: L1 not run
    code, out, _ = run_cli(capsys, GD + ["--reconstruct", "l1"])
    assert set(json.loads(out)["reconstruct_seconds"]) == {"l1"}
    code, out, err = run_cli(capsys, GD + ["-o", str(tmp_path / "gd.npy")])
    assert set(json.loads(out)["reconstruct_seconds"]) == {"l2"}           # the figure: L2 only, L1 not solved
    assert "L1" not in err
    labels = []
    monkeypatch.setattr("vrlab.render.compare.panels_figure",
                        lambda panels, path, **kw: labels.extend(p[0] for p in panels) or path)
    for norm in ("l2", "l1"):
        labels.clear()
        code, out, err = run_cli(capsys, GD + ["--reconstruct", norm, "-o", str(tmp_path / f"{norm}.npy")])
        assert set(json.loads(out)["reconstruct_seconds"]) == {norm}
        assert [label for label in labels if "reconstruction" in label] == [f"{norm.upper()} reconstruction, alpha = 0.2"]
        assert ("solving the L1 reconstruction" in err) == (norm == "l1")    # the long solve says it starts
    del calls, real


def test_lab_flags_untrustworthy_error_bars_and_names_its_columns(capsys):
    code, out, _ = run_cli(capsys, ["lab", "--estimators", "mc,is:brdf", "--integrand", "glossy-light", "--n",
                                    "64,256,1024", "--reps", "40", "--no-progress"])
    assert code == 0
    assert "! stderr too small" in out                     # is:brdf misses the small bright light (as in the demo)
    assert "variance_reduction" in out and "efficiency_gain" in out and "bigger is better" in out
    assert "relative_variance" not in out


def test_equal_time_columns_are_bigger_is_better():
    df = lab.run(["mc", "jittered"], ["exp"], [256], 8, rng=1)
    eq = lab.equal_time(df).set_index("estimator")
    assert eq.loc["jittered", "variance_reduction"] > 10 and eq.loc["mc", "variance_reduction"] == 1
    assert eq.loc["jittered", "efficiency_gain"] > 1


def test_slopes_need_three_sample_counts(capsys):
    df = lab.run(["mc"], ["exp"], [64, 256], 6, rng=1)
    s = lab.fit_slopes(df).iloc[0]
    assert np.isnan(s["slope"]) and "needs >= 3" in s["slope_note"]
    s3 = lab.fit_slopes(lab.run(["mc"], ["exp"], [64, 256, 1024], 6, rng=1)).iloc[0]
    assert np.isfinite(s3["slope"]) and np.isfinite(s3["slope_se"]) and s3["slope_note"] == ""
    code, out, _ = run_cli(capsys, ["lab", "--estimators", "mc", "--integrand", "exp", "--n", "64,256", "--reps",
                                    "4", "--no-progress"])
    assert code == 0 and "need at least 3 sample counts" in out
    assert isinstance(pd.DataFrame(), pd.DataFrame)


def test_bench_sampling_prints_one_table_per_suite_with_progress(capsys):
    code, out, err = run_cli(capsys, ["bench", "sampling", "--quick"])
    assert code == 0 and "timing qmc (1/2)" in err and "timing discrete (2/2)" in err
    assert out.startswith("qmc:") and "\ndiscrete:" in out and "NaN" not in out


def test_the_stderr_mark_appears_where_error_bars_are_off():
    """The lab's marks (vrlab.lab.trust) follow the ratio of reported variance to the spread
    over repetitions, (mean stderr / sd of the values)^2 = 1 / z_std^2 for honest bars: a
    cell whose ratio is below 0.7 is marked '!' (is:brdf misses the small bright light), one
    within [0.7, 1.4] is not."""
    from vrlab.lab.trust import stderr_flags

    s = lab.summarize(lab.run(["mc", "is:brdf"], ["glossy-light"], [64, 256, 1024], 40, rng=0))
    ratio = 1.0 / s["z_std"] ** 2
    flags = stderr_flags(s)
    off = ratio < 0.7
    assert off.any() and (~off).any()
    assert (flags[off] == "!").all(), s.assign(ratio=ratio, flag=flags)
    assert (flags[(ratio >= 0.7) & (ratio <= 1.4)] == "").all(), s.assign(ratio=ratio, flag=flags)
