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
                "convergence.png", "lab_summary.csv", "veach_mis.png", "veach_mis.csv"}
    assert expected <= set(summary["files"])
    gof = pd.read_csv(tmp_path / "warps_gof.csv")
    # every warp's pdf integrates to 1 and no warp is rejected at the corrected level
    assert (abs(gof["pdf_integral"] - 1) < 2e-3).all()
    assert (gof["p_value"] > 1e-4).all()


def test_render_cli_writes_images_and_rel_mse(tmp_path, capsys):
    import numpy as np

    out, err = tmp_path / "img.npy", tmp_path / "err.npy"
    args = ["render", "furnace", "--spp", "4", "--width", "16", "--height", "12", "--seed", "3",
            "-o", str(out), "--stderr-out", str(err), "--json"]
    assert main(args) == 0
    first = json.loads(capsys.readouterr().out)
    img = np.load(out)
    assert img.shape == (12, 16, 3) and img.dtype == np.float32 and np.load(err).shape == (12, 16, 3)
    assert first["samples_per_second"] > 0
    # the same seed reproduces the image: relMSE against itself is exactly 0
    assert main(args[:-1] + ["--reference", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["rel_mse"] == 0.0
    assert main(["render", "furnace", "--spp", "2", "--width", "8", "--height", "6",
                 "-o", str(tmp_path / "img.png")]) == 0
    assert (tmp_path / "img.png").stat().st_size > 0
    with pytest.raises(ValueError, match="unknown built-in scene"):
        main(["render", "no-such-scene"])


def test_render_cli_counts_workers_and_progress(tmp_path, capsys):
    import numpy as np

    base = ["render", "many_lights", "--spp", "2", "--width", "40", "--height", "30", "--seed", "5",
            "--strategy", "ris", "--ris-candidates", "4", "--emitter-samples", "2", "--json"]
    a, b = tmp_path / "a.npy", tmp_path / "b.npy"
    assert main(base + ["-o", str(a), "--progress"]) == 0
    captured = capsys.readouterr()
    assert "render [" in captured.err and "1200/1200" in captured.err
    assert main(base + ["-o", str(b), "--workers", "2", "--no-progress"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["workers"] == 2
    np.testing.assert_array_equal(np.load(a), np.load(b))
    with pytest.raises(ValueError, match="emitter_samples"):
        main(["render", "furnace", "--spp", "1", "--width", "4", "--height", "3", "--strategy", "light",
              "--emitter-samples", "0"])


def test_rel_mse_and_srgb():
    import numpy as np

    from vrlab.render.image import rel_mse, srgb_encode

    ref = np.full((2, 2, 3), 1.0)
    assert rel_mse(ref * 1.1, ref) == pytest.approx(0.01 / 1.01)
    assert srgb_encode(np.array([0.0, 0.0031308, 1.0, 2.0])) == pytest.approx([0, 0.04045, 1, 1], abs=1e-5)
    with pytest.raises(ValueError, match="shape"):
        rel_mse(ref, ref[0])


def test_render_compare_ranks_strategies_like_veach(tmp_path, capsys):
    # on the glossy plates, MIS beats both single techniques at equal spp (Veach 1997, fig. 9.2)
    assert main(["render", "veach_mis", "--spp", "4", "--width", "48", "--height", "36", "--compare",
                 "-o", str(tmp_path / "cmp.png"), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    err = res["rel_mse"]
    assert err["mis-power"] < err["light"] < err["bsdf"]
    assert (tmp_path / "cmp.png").exists()


def test_render_compare_equal_time(tmp_path, capsys):
    assert main(["render", "cornell_box", "--spp", "8", "--width", "24", "--height", "18", "--compare",
                 "cosine,cv", "--equal-time", "-o", str(tmp_path / "eq.png"), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["spp"]["cv"] == 8 and res["spp"]["cosine"] >= 1 and set(res["rel_mse"]) == {"cosine", "cv"}
    assert (tmp_path / "eq.png").stat().st_size > 0
