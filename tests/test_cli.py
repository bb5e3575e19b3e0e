"""The command line: subcommands listed, the quick demo writes its figures and tables."""
import json
import os
import subprocess
import sys

import pandas as pd
import pytest

from vrlab.cli import main


def test_help_lists_subcommands():
    out = subprocess.run([sys.executable, "-m", "vrlab", "--help"], capture_output=True, text=True, check=True).stdout
    for cmd in ("demo", "bench", "lab", "render"):
        assert cmd in out
    assert "exit status" in out and "--debug" in out


def test_unknown_subcommand_is_an_error():
    with pytest.raises(SystemExit) as exc:
        main(["render-everything"])
    assert exc.value.code == 2


def test_quick_demo_writes_its_outputs(tmp_path, capsys):
    assert main(["demo", "--quick", "--out", str(tmp_path), "--json"]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)                 # stdout is only the JSON ...
    out = captured.err                                 # ... the text report went to stderr
    expected = {"warps.png", "warps_gof.csv", "point_sets.png", "discrepancy.csv", "speed_qmc.csv",
                "convergence.png", "efficiency.png", "lab_summary.csv", "lab_table.csv", "veach_mis.png",
                "veach_mis.csv"}
    assert expected <= set(summary["files"])
    # the sampler races are their own table: no column of NaN from another suite
    assert not pd.read_csv(tmp_path / "speed_qmc.csv").isna().all().any()
    # BRDF sampling misses the small bright light in most repetitions at n = 1024: its stderr is flagged
    table = pd.read_csv(tmp_path / "lab_table.csv", keep_default_na=False)
    row = table[(table["integrand"] == "glossy-light") & (table["estimator"] == "is:brdf")]
    assert list(row["flag"]) == ["!"] and "! stderr too small" in out
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
    with pytest.raises(SystemExit) as exc:
        main(["render", "no-such-scene"])
    assert exc.value.code == 2 and "neither a file nor a built-in scene" in capsys.readouterr().err


def test_render_cli_counts_workers_and_progress(tmp_path, capsys):
    import numpy as np

    base = ["render", "many_lights", "--spp", "2", "--width", "40", "--height", "30", "--seed", "5",
            "--strategy", "ris", "--ris-candidates", "4", "--emitter-samples", "2", "--json"]
    a, b = tmp_path / "a.npy", tmp_path / "b.npy"
    assert main(base + ["-o", str(a), "--progress"]) == 0
    captured = capsys.readouterr()
    assert "render:" in captured.err and "2.40k/2.40k" in captured.err and "samples/s" in captured.err  # samples
    assert main(base + ["-o", str(b), "--workers", "2", "--no-progress"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["workers"] == 2
    np.testing.assert_array_equal(np.load(a), np.load(b))
    with pytest.raises(SystemExit) as exc:
        main(["render", "furnace", "--spp", "1", "--width", "4", "--height", "3", "--strategy", "light",
              "--emitter-samples", "0"])
    assert exc.value.code == 2 and "--emitter-samples" in capsys.readouterr().err


@pytest.mark.parametrize("name, points", [(None, "independent"), ("independent", "independent"), ("stratified", "stratified"),
                                          ("sobol", "sobol"), ("halton", "halton")])
def test_render_cli_pixel_sampler_is_render_points(name, points, tmp_path, capsys, monkeypatch):
    """--pixel-sampler NAME reaches render() as points= (by name: vrlab.points.names resolves it), the
    strategy as the estimator preset; the image is the Estimate's value."""
    import numpy as np

    import vrlab.render
    from vrlab.render import render as real_render

    calls = []

    def spy(*args, **kwargs):
        calls.append((args, kwargs))
        return real_render(*args, **kwargs)
    monkeypatch.setattr(vrlab.render, "render", spy)
    out = tmp_path / "img.npy"
    argv = ["render", "furnace", "--spp", "2", "--width", "6", "--height", "4", "--seed", "7", "--workers", "1",
            "--strategy", "cosine", "--no-progress", "-o", str(out)]
    assert main(argv + ([] if name is None else ["--pixel-sampler", name])) == 0
    capsys.readouterr()
    (args, kwargs), = calls
    plan = args[0]                                    # the command's render plan, resolved once
    assert plan.strategy == "cosine" and plan.points == points and plan.workers == 1 and kwargs["rng"] == 7
    monkeypatch.undo()
    expected = real_render(plan.scene, 2, "cosine", rng=kwargs["rng"], points=points, workers=1)
    np.testing.assert_array_equal(np.load(out), expected.value)


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


def _exit_code(argv):
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


def test_render_list_describes_each_scene(capsys):
    from vrlab.render import list_builtin_scenes
    from vrlab.render.builtin import describe_builtin_scene

    assert main(["render", "--list"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    for name in list_builtin_scenes():
        first = next(line for line in lines if line.startswith(name + " "))
        assert describe_builtin_scene(name).split()[0] in first          # the summary starts on its line
        assert " ".join(describe_builtin_scene(name).split()) in " ".join(out.split())
    assert "--export" in out
    assert main(["render", "--list", "--json"]) == 0
    table = json.loads(capsys.readouterr().out)
    assert list(table) == list_builtin_scenes()
    for name, entry in table.items():
        assert entry["summary"] == describe_builtin_scene(name)
        assert entry["description"] == describe_builtin_scene(name, full=True)
        assert entry["file"].endswith(f"{name}.xml")


def test_render_export_writes_a_scene_that_renders(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["render", "--export", "cornell_box"]) == 0                 # default: the current folder
    out = capsys.readouterr().out
    assert "cornell_box.xml" in out and "vrlab render cornell_box.xml" in out
    assert (tmp_path / "cornell_box.xml").is_file()
    assert main(["render", "--export", "veach_mis.xml", "--to", "edit/here", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["scene"] == "veach_mis" and res["files"] == [os.path.join("edit", "here", "veach_mis.xml")]
    assert main(["render", res["files"][0], "--spp", "1", "--width", "8", "--height", "6", "--workers", "1",
                 "--no-progress", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["width"] == 8


@pytest.mark.parametrize("argv,code,names", [
    (["--export", "nope"], 2, ["--export", "veach_mis"]),
    (["--export", ""], 2, ["--export"]),
    (["--export", "furnace,veach_mis"], 2, ["--export"]),
    (["--export", "furnace", "--spp", "4"], 2, ["--spp", "--export"]),
    (["--export", "furnace", "--no-progress"], 2, ["--no-progress"]),
    (["furnace", "--export", "furnace"], 2, ["--export", "furnace"]),
    (["--to", "x"], 2, ["--to", "--export"]),
    (["--list", "--export", "furnace"], 2, ["--list", "--export"]),
    (["--export", "furnace", "--to", "FILE"], 1, ["--to", "not a folder"]),
    (["--export", "furnace", "--to", "DONE"], 1, ["--to", "furnace.xml", "not replaced"]),
])
def test_render_export_errors(argv, code, names, tmp_path, capsys):
    (tmp_path / "FILE").write_text("")
    (tmp_path / "DONE").mkdir()
    (tmp_path / "DONE" / "furnace.xml").write_text("my edits")
    argv = [str(tmp_path / a) if a in ("FILE", "DONE") else a for a in argv]
    assert _exit_code(["render", *argv]) == code
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("vrlab render: error: "), err
    for name in names:
        assert name in err, (name, err)
    assert (tmp_path / "DONE" / "furnace.xml").read_text() == "my edits"
    assert not (tmp_path / "x").exists()


# --------------------------------------------------------------------------- --gradient-domain
GD = ["render", "cornell_box", "--gradient-domain", "--spp", "4", "--width", "16", "--height", "12", "--seed", "3",
      "--workers", "1", "--no-progress"]


def _pad(diff, shape):
    import numpy as np

    out = np.zeros(shape, np.float32)
    out[: diff.shape[0], : diff.shape[1]] = np.abs(diff)
    return out


@pytest.mark.parametrize("extra, alpha, norm, common", [([], 0.2, "l2", True),
                                                        (["--reconstruct", "l1", "--alpha", "0.5"], 0.5, "l1", True),
                                                        (["--independent"], 0.2, "l2", False)])
def test_render_cli_gradient_domain_writes_its_files(extra, alpha, norm, common, tmp_path, capsys):
    """-o OUT.npy holds the chosen reconstruction of render_gradient_domain at the same seed;
    OUT_primal, OUT_dx, OUT_dy its primal and |differences| padded to (H, W); OUT_panels.png."""
    import matplotlib.image
    import numpy as np

    from vrlab.render import render_gradient_domain

    out = tmp_path / "gd.npy"
    assert main(GD + extra + ["-o", str(out), "--stderr-out", str(tmp_path / "err.npy"), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    gd = render_gradient_domain("cornell_box", 4, rng=3, width=16, height=12, common=common)
    assert res["alpha"] == alpha and res["reconstruct"] == norm and res["common"] is common
    files = {k: np.load(res[k]) for k in ("output", "primal_output", "dx_output", "dy_output", "stderr_output")}
    assert all(img.shape == (12, 16, 3) for img in files.values())
    assert res["output"] == str(out) and res["dx_output"] == str(tmp_path / "gd_dx.npy")
    np.testing.assert_array_equal(files["output"], gd.reconstruct(alpha, norm).astype(np.float32))
    np.testing.assert_array_equal(files["primal_output"], gd.primal.value)
    np.testing.assert_array_equal(files["stderr_output"], gd.primal.stderr)
    np.testing.assert_array_equal(files["dx_output"], _pad(gd.dx.value, (12, 16, 3)))
    np.testing.assert_array_equal(files["dy_output"], _pad(gd.dy.value, (12, 16, 3)))
    assert files["dx_output"][:, -1].max() == 0 and files["dy_output"][-1].max() == 0
    assert files["dx_output"].max() > 0 and files["dy_output"].max() > 0
    assert res["figure"] == str(tmp_path / "gd_panels.png")
    fig = matplotlib.image.imread(res["figure"])
    assert fig.shape[1] > 2 * fig.shape[0]             # three panels side by side: a wide figure


def test_render_cli_gradient_domain_json_and_reference(tmp_path, capsys):
    """--reference: rel_mse of primal and of the --reconstruct norm equal image.rel_mse of the
    images written; the other norm is not solved, with -o (the figure) or without."""
    import numpy as np

    from vrlab.render import render_gradient_domain
    from vrlab.render.image import rel_mse

    ref = tmp_path / "ref.npy"
    assert main(["render", "cornell_box", "--spp", "16", "--width", "16", "--height", "12", "--seed", "99",
                 "--workers", "1", "--no-progress", "-o", str(ref)]) == 0
    capsys.readouterr()
    out = tmp_path / "gd.png"
    assert main(GD + ["--reconstruct", "l2", "-o", str(out), "--reference", str(ref), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert {"scene", "spp", "seconds", "alpha", "reconstruct", "output", "primal_output", "dx_output", "dy_output",
            "figure", "rel_mse"} <= set(res)
    assert res["spp"] == 4 and res["seconds"] > 0 and set(res["rel_mse"]) == {"primal", "l2"}
    assert all((tmp_path / f"gd{tag}.png").stat().st_size > 0 for tag in ("", "_primal", "_dx", "_dy", "_panels"))
    reference = np.load(ref)
    gd = render_gradient_domain("cornell_box", 4, rng=3, width=16, height=12)
    expected = {"primal": gd.primal.value, "l2": gd.reconstruct(0.2, "l2")}
    for key, img in expected.items():
        assert res["rel_mse"][key] == pytest.approx(rel_mse(img, reference), rel=1e-6), key
    assert len(set(res["rel_mse"].values())) == 2         # two different images, two errors
    # the same numbers from the .npy files the command writes
    assert main(GD + ["-o", str(tmp_path / "gd.npy"), "--reference", str(ref), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["rel_mse"]["l2"] == pytest.approx(rel_mse(np.load(res["output"]), reference), rel=1e-5)
    assert res["rel_mse"]["primal"] == pytest.approx(rel_mse(np.load(res["primal_output"]), reference), rel=1e-6)
    assert set(res["reconstruct_seconds"]) == {"l2"}      # the figure shows the l2 one: L1 is not solved
    # without --json: one line of key=value; without -o only the norm asked for is solved and timed
    assert main(GD + ["--reference", str(ref)]) == 0
    line = capsys.readouterr().out.strip()
    assert len(line.splitlines()) == 1 and "rel_mse_l2=" in line and "reconstruct=l2" in line
    assert "rel_mse_l1" not in line and "reconstruct_seconds_l2=" in line and "reconstruct_seconds_l1" not in line


def test_render_cli_gradient_domain_progress(capsys):
    assert main(GD[:-1] + ["--progress"]) == 0
    captured = capsys.readouterr()
    assert "gradient-domain" in captured.err and "samples/s" in captured.err and "spp=4" in captured.out


# -- render: --exposure -------------------------------------------------------------------------
def _white(path) -> float:
    """Share of the pixels of a PNG that are pure white (all three channels at 255)."""
    import matplotlib.image

    return float((matplotlib.image.imread(path)[..., :3] == 1.0).all(-1).mean())


def test_render_png_exposure_auto_by_default(tmp_path, capsys):
    import numpy as np

    from vrlab.render.image import auto_exposure

    base = ["render", "many_lights", "--spp", "4", "--width", "80", "--height", "60", "--seed", "2",
            "--no-progress", "--json"]
    assert main(base + ["-o", str(tmp_path / "img.npy")]) == 0
    assert "exposure" not in json.loads(capsys.readouterr().out)      # no PNG, no exposure used
    linear = np.load(tmp_path / "img.npy")
    assert main(base + ["-o", str(tmp_path / "auto.png")]) == 0     # the default is auto
    auto = json.loads(capsys.readouterr().out)
    assert auto["exposure"] == pytest.approx(auto_exposure(linear), rel=1e-12)
    assert main(base + ["-o", str(tmp_path / "named.png"), "--exposure", "auto"]) == 0
    assert json.loads(capsys.readouterr().out)["exposure"] == auto["exposure"]
    assert main(base + ["-o", str(tmp_path / "one.png"), "--exposure", "1"]) == 0
    assert json.loads(capsys.readouterr().out)["exposure"] == 1.0
    # the lights seen directly clip, the lit floor does not: at most 3% white, against many more at 1
    assert _white(tmp_path / "auto.png") <= 0.03
    assert _white(tmp_path / "one.png") > 0.1
    assert (tmp_path / "auto.png").read_bytes() == (tmp_path / "named.png").read_bytes()


@pytest.mark.parametrize("value", ["0", "-2", "nan", "bright", ""])
def test_render_bad_exposure_is_a_one_line_usage_error(value, capsys, tmp_path):
    code = None
    try:
        code = main(["render", "furnace", "--width", "8", "--height", "6", "--exposure", value,
                     "-o", str(tmp_path / "x.png")])
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err
    assert "--exposure" in lines[0] and "auto" in lines[0] and not (tmp_path / "x.png").exists()


def test_phase_lines_only_for_slow_steps(capsys):
    """A step before the first sample is said on stderr once it has taken ``after`` seconds
    (then its duration when it ends); a quicker step, or without progress output, says nothing."""
    import time

    from vrlab.cli_render_settings import Phase

    with Phase(True, "loading big.xml", after=0.0) as ph:
        for _ in range(1000):                      # the timer thread says the first line
            if ph.said:
                break
            time.sleep(0.01)
    ph.stop()                                      # a second stop says nothing more
    err = capsys.readouterr().err.splitlines()
    assert err[0] == "vrlab render: loading big.xml ..."
    assert err[1].startswith("vrlab render: loading big.xml: done after ") and err[1].endswith(" s")
    assert len(err) == 2
    with Phase(True, "quick", after=3600):
        pass
    with Phase(False, "hidden", after=0.0):
        time.sleep(0.05)
    assert capsys.readouterr().err == ""
