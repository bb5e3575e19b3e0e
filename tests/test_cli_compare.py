"""``vrlab render --compare``: every sampling flag reaches every compared render, the
reference is the file given or a render the command announces, --equal-time is a
deterministic cost model, progress bars, one-line usage errors."""
import json

import numpy as np
import pytest

from conftest import run_cli

# veach_mis: four lights of different power, so --light-selection matters
TINY = ["render", "veach_mis", "--width", "32", "--height", "24", "--spp", "4", "--reference-spp", "8",
        "--workers", "1", "--json"]


def compare_json(capsys, *extra):
    code, out, err = run_cli(capsys, [*TINY, *extra])
    assert code == 0, err
    return json.loads(out), err


def test_each_sampling_flag_reaches_each_compared_render(capsys, monkeypatch):
    import vrlab.render.compare as cmp

    calls = []
    real = cmp.render

    def spy(plan, **kw):                 # each render gets its resolved plan
        calls.append((plan, kw))
        return real(plan, **kw)
    monkeypatch.setattr(cmp, "render", spy)
    compare_json(capsys, "--compare", "light,ris", "--light-selection", "power", "--ris-candidates", "3",
                 "--pixel-sampler", "stratified", "--emitter-samples", "2", "--bsdf-samples", "3",
                 "--spp-batch", "2", "--seed", "5", "--workers", "2")
    (ref, _), *renders = calls
    assert ref.strategy == "mis-power" and ref.spp == 8 and ref.light_selection == "power"
    assert [(p.spp, p.strategy) for p, _ in renders] == [(4, "light"), (4, "ris")]
    for p, kw in renders:
        assert p.points == "stratified" and p.light_selection == "power" and p.ris_candidates == 3
        assert p.emitter_samples == 2 and p.bsdf_samples == 3 and p.workers == 2
        assert p.spp_batch == 2 and kw["rng"].entropy == [5, 0]


def test_sampling_flags_change_the_results(capsys):
    base, _ = compare_json(capsys, "--compare", "light,ris")
    power, _ = compare_json(capsys, "--compare", "light,ris", "--light-selection", "power")
    assert power["settings"]["light_selection"] == "power"
    assert power["rel_mse"]["light"] != base["rel_mse"]["light"]
    more, _ = compare_json(capsys, "--compare", "light,ris", "--ris-candidates", "2")
    assert more["rel_mse"]["ris"] != base["rel_mse"]["ris"] and more["rel_mse"]["light"] == base["rel_mse"]["light"]
    two, _ = compare_json(capsys, "--compare", "light,ris", "--emitter-samples", "2")
    assert two["rel_mse"]["light"] != base["rel_mse"]["light"] and two["settings"]["emitter_samples"] == 2
    sobol, _ = compare_json(capsys, "--compare", "light,ris", "--pixel-sampler", "sobol")
    assert sobol["rel_mse"]["light"] != base["rel_mse"]["light"]
    seeded, _ = compare_json(capsys, "--compare", "light,ris", "--seed", "1")
    assert seeded["rel_mse"]["light"] != base["rel_mse"]["light"]


def test_worker_count_does_not_change_the_numbers(capsys):
    one, _ = compare_json(capsys, "--compare", "light,mis-power")
    two, _ = compare_json(capsys, "--compare", "light,mis-power", "--workers", "2")
    assert two["settings"]["workers"] == 2
    assert two["rel_mse"] == one["rel_mse"] and two["spp"] == one["spp"]


def test_reference_file_is_used(capsys, tmp_path):
    from vrlab.render import builtin_scene_path, render

    rendered, err = compare_json(capsys, "--compare", "bsdf,light")
    ref = rendered["reference"]
    assert ref["source"] == "rendered" and ref["strategy"] == "mis-power" and ref["spp"] == 8
    assert "no --reference" in err and "mis-power at 8 spp" in err          # announced on stderr
    # the same reference as a file: the same numbers, and no announcement
    same = render(builtin_scene_path("veach_mis"), 8, "mis-power", rng=np.random.SeedSequence([0, 1]),
                  width=32, height=24).value
    np.save(tmp_path / "ref.npy", same)
    argv = [a for a in TINY if a not in ("--reference-spp", "8")]
    code, out, err = run_cli(capsys, [*argv, "--compare", "bsdf,light", "--reference", str(tmp_path / "ref.npy")])
    given = json.loads(out)
    assert code == 0 and "no --reference" not in err
    assert given["reference"] == {"source": "file", "file": str(tmp_path / "ref.npy")}
    assert given["rel_mse"] == pytest.approx(rendered["rel_mse"], rel=1e-6)
    np.save(tmp_path / "other.npy", 2 * same)
    code, out, _ = run_cli(capsys, [*argv, "--compare", "bsdf,light", "--reference", str(tmp_path / "other.npy")])
    assert code == 0 and json.loads(out)["rel_mse"]["light"] != given["rel_mse"]["light"]


def test_text_output_names_spp_seconds_and_reference(capsys, tmp_path):
    argv = [a for a in TINY if a != "--json"]
    code, out, err = run_cli(capsys, [*argv, "--compare", "bsdf,mis-power", "--equal-time",
                                      "-o", str(tmp_path / "cmp.png")])
    assert code == 0, err
    lines = out.splitlines()
    assert lines[0].startswith("reference: rendered, mis-power at 8 spp")
    assert lines[1].startswith("equal time")
    bsdf = next(line for line in lines if line.startswith("bsdf "))
    mis = next(line for line in lines if line.startswith("mis-power "))
    assert " 6 spp " in bsdf and " 4 spp " in mis and bsdf.count(" s ") == 1  # cost 3/2: round(4 x 3 / 2) = 6
    assert (tmp_path / "cmp.png").stat().st_size > 0


def test_equal_time_is_deterministic_and_follows_the_cost_model(capsys):
    from vrlab.render import builtin_scene_path
    from vrlab.render.compare import sample_cost

    argv = ["--compare", "bsdf,light,ris,mis-power", "--equal-time", "--ris-candidates", "4"]
    a, _ = compare_json(capsys, *argv)
    b, _ = compare_json(capsys, *argv)
    assert a["spp"] == b["spp"] and a["rel_mse"] == b["rel_mse"] and a["equal_time"]
    scene = builtin_scene_path("veach_mis")
    cost = {s: sample_cost(scene, s, ris_candidates=4) for s in a["spp"]}
    assert a["cost_per_sample"] == cost
    for s, n in a["spp"].items():
        assert n == max(1, round(4 * cost["mis-power"] / cost[s]))
    assert a["spp"]["mis-power"] == 4


def test_cost_model_closed_forms():
    from vrlab.render import builtin_scene_path
    from vrlab.render.compare import (CAMERA_COST, CANDIDATE_COST, CONTROL_COST, CONTROL_COST_PER_LIGHT,
                                      sample_cost)

    box = builtin_scene_path("cornell_box")          # one light, the scene's sample counts 1 and 1
    assert sample_cost(box, "light") == CAMERA_COST + 1
    assert sample_cost(box, "light", emitter_samples=3) == CAMERA_COST + 3
    assert sample_cost(box, "mis-power", emitter_samples=2, bsdf_samples=3) == CAMERA_COST + 5
    assert sample_cost(box, "mixture") == CAMERA_COST + 2
    assert sample_cost(box, "ris", ris_candidates=6) == CAMERA_COST + 1 + 6 * CANDIDATE_COST
    assert sample_cost(box, "cv") == CAMERA_COST + 1 + CONTROL_COST + CONTROL_COST_PER_LIGHT


def test_progress_bars_on_request_only(capsys):
    _, err = compare_json(capsys, "--compare", "bsdf,light", "--progress")
    for name in ("reference", "bsdf", "light"):
        assert f"{name}:" in err and "samples/s" in err      # the bars count pixel samples
    _, err = compare_json(capsys, "--compare", "bsdf,light")          # stderr is not a terminal here
    assert err.count("\n") == 1 and "no --reference" in err


@pytest.mark.parametrize("extra,flag", [
    (["--equal-time"], "--equal-time"), (["--reference-spp", "8"], "--reference-spp"),
    (["--compare", "bsdf", "--reference-spp", "0"], "--reference-spp"),
    (["--compare", "bsdf", "--reference-spp", "x"], "--reference-spp"),
    (["--compare", "bsdf", "--reference-spp", "8", "--reference", "ref.npy"], "--reference-spp"),
    (["--compare", "bsdf", "--strategy", "light"], "--strategy"),
    (["--compare", "bsdf", "--stderr-out", "e.npy"], "--stderr-out"),
    (["--compare", "bsdf", "--checkpoint", "c.npz"], "--checkpoint"),
    (["--compare", "bsdf", "--scheduler", "tcp://127.0.0.1:1"], "--scheduler"),
    (["--compare", "bsdf,nope"], "--compare"), (["--compare", "bsdf", "--ris-candidates", "0"], "--ris-candidates"),
    (["--compare", "light", "--emitter-samples", "0"], "--emitter-samples"),
    (["--compare", "bsdf", "-o", "cmp.npy"], "--output"),
], ids=lambda v: " ".join(v) if isinstance(v, list) else v)
def test_usage_errors_are_one_line_naming_the_flag(extra, flag, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("vrlab.render.compare.compare", lambda *a, **k: pytest.fail("compare started"))
    code, out, err = run_cli(capsys, ["render", "furnace", "--width", "8", "--height", "6", *extra])
    assert code == 2 and out == ""
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("vrlab render: error: ") and flag in lines[0], err


def test_every_compare_flag_has_help():
    import argparse

    from vrlab.cli import build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    render = sub.choices["render"]
    flags = {s: a.help for a in render._actions for s in a.option_strings}
    for flag in ("--compare", "--equal-time", "--reference-spp", "--reference"):
        assert flags[flag] and len(flags[flag]) > 20


def test_compare_figure_shares_one_auto_exposure_from_the_reference(tmp_path):
    import matplotlib.image as mpimg
    import numpy as np

    from vrlab.render.compare import compare_figure

    ref = np.full((24, 32, 3), 10.0)                  # bright: exposure 1 would clip every pixel
    res = {"images": {"a": ref.copy(), "b": 0.5 * ref}, "seconds": {"a": 1.0, "b": 1.0},
           "rel_mse": {"a": 0.0, "b": 0.2}, "reference": ref, "spp": 4}
    auto = mpimg.imread(compare_figure(res, tmp_path / "auto.png"))[..., :3]
    one = mpimg.imread(compare_figure(res, tmp_path / "one.png", exposure=1.0))[..., :3]
    # the panels are grey, not white, and panel b is darker than panel a: one shared scale
    grey = np.isclose(auto, auto[..., :1], atol=0.02).all(-1) & (auto.max(-1) < 0.98) & (auto.max(-1) > 0.2)
    assert grey.sum() > 0.5 * 2 * 24 * 32
    assert (one.max(-1) >= 0.99).mean() > (auto.max(-1) >= 0.99).mean()


def test_compare_figure_labels_each_panel_with_its_bias_status(tmp_path, monkeypatch):
    """Each panel's label starts with the strategy and the bias status its recipe states
    (``Recipe.bias``, read from the registry: a recipe whose bias changes shows the new one)."""
    from dataclasses import replace

    import vrlab.render.compare as cmp
    from vrlab.estimators import recipes, registry as reg

    labels = []
    monkeypatch.setattr(cmp, "panels_figure", lambda panels, path, **kw: labels.extend(p[0] for p in panels) or path)
    names = ["light", "mis-power", "restir"]
    img = np.ones((4, 6, 3))
    res = {"images": {s: img for s in names}, "seconds": dict.fromkeys(names, 1.0),
           "rel_mse": dict.fromkeys(names, 0.1), "reference": img, "spp": 4}
    cmp.compare_figure(res, tmp_path / "f.png")
    assert [label.split("\n")[0] for label in labels] == [f"{s} ({recipes('render')[s].bias})" for s in names]
    table = dict(reg._REGISTRY)
    table["restir"] = replace(table["restir"], bias="biased")
    monkeypatch.setattr(reg, "_REGISTRY", table)
    labels.clear()
    cmp.compare_figure(res, tmp_path / "f.png")
    assert labels[-1].startswith("restir (biased)\n")
