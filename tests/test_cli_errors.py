"""Bad input on the command line: one line on stderr naming the flag, exit 2 (usage) or 1
(failure), no traceback, and no work started; --debug, Ctrl-C and a closed stdout."""
import json
import subprocess
import sys

import numpy as np
import pytest

from conftest import run_cli
from vrlab.cli import main

TINY = ["--width", "8", "--height", "6", "--spp", "1", "--workers", "1", "--no-progress"]


def assert_one_line(err, prog, *names):
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].strip(), f"not one line: {err!r}"
    assert lines[0].startswith(f"{prog}: error: "), lines[0]
    assert "Traceback" not in err
    for name in names:
        assert name in lines[0], f"{name!r} not named in {lines[0]!r}"


@pytest.fixture
def no_work(monkeypatch):
    """Every entry into real work is recorded: a bad flag must stop before any of them."""
    calls = []

    def record(what):
        def fake(*a, **k):
            calls.append(what)
            raise AssertionError(f"{what} started")
        return fake
    monkeypatch.setattr("vrlab.render.render", record("render"))
    monkeypatch.setattr("vrlab.render.compare.compare", record("compare"))
    monkeypatch.setattr("vrlab.lab.run", record("lab.run"))
    monkeypatch.setattr("vrlab.demo.run_demo", record("run_demo"))
    return calls


# --------------------------------------------------------------------------- render: usage errors (2)
RENDER_USAGE = [
    (["--width", "0"], "--width"), (["--width", "-3"], "--width"), (["--width", "abc"], "--width"),
    (["--width", "1e3"], "--width"), (["--width", "99999"], "--width"), (["--height", "0"], "--height"),
    (["--height", ""], "--height"), (["--spp", "0"], "--spp"), (["--spp", "16.7"], "--spp"),
    (["--spp", "-1"], "--spp"), (["--spp", "99999999999999999999999"], "--spp"), (["--seed", "-1"], "--seed"),
    (["--seed", "x"], "--seed"), (["--seed", "2.5"], "--seed"), (["--exposure", "nan"], "--exposure"),
    (["--exposure", "inf"], "--exposure"), (["--exposure=-inf"], "--exposure"), (["--exposure", "0"], "--exposure"),
    (["--exposure", "-1"], "--exposure"), (["--exposure", "bright"], "--exposure"), (["--workers", "0"], "--workers"),
    (["--workers", "100000"], "--workers"), (["--emitter-samples", "-1"], "--emitter-samples"),
    (["--bsdf-samples", "1.5"], "--bsdf-samples"), (["--ris-candidates", "0"], "--ris-candidates"),
    (["--strategy", "best"], "--strategy"), (["--pixel-sampler", "x"], "--pixel-sampler"),
    (["--light-selection", "x"], "--light-selection"), (["--strategy", "light", "--emitter-samples", "0"],
                                                        "--emitter-samples"),
    (["--strategy", "bsdf", "--bsdf-samples", "0"], "--bsdf-samples"),
    (["--emitter-samples", "0", "--bsdf-samples", "0"], "--emitter-samples"),
    (["--compare", ""], "--compare"), (["--compare", "foo"], "--compare"), (["--compare", "bsdf,bsdf"], "--compare"),
    (["--compare", "bsdf,,light"], "--compare"), (["--compare", "bsdf", "--strategy", "light"], "--strategy"),
    (["--compare", "bsdf", "--checkpoint", "c.npz"], "--checkpoint"), (["--compare", "bsdf", "--stderr-out", "e.npy"],
                                                             "--stderr-out"),
    (["--equal-time"], "--equal-time"), (["-o", "img.txt"], "--output"), (["-o", "img"], "--output"),
    (["-o", ""], "--output"), (["--compare", "bsdf", "-o", "cmp.npy"], "--output"),
    (["--stderr-out", "err.jpg"], "--stderr-out"), (["-o", "a.npy", "--stderr-out", "a.npy", "--spp", "2"],
                                                   "--stderr-out"),
    (["--stderr-out", "err.npy", "--spp", "1"], "--stderr-out"), (["--reference", "ref.png"], "--reference"),
    (["--bogus"], "--bogus"),
]


@pytest.mark.parametrize("extra,flag", RENDER_USAGE, ids=[" ".join(a) for a, _ in RENDER_USAGE])
def test_render_usage_errors(extra, flag, capsys, tmp_path, monkeypatch, no_work):
    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli(capsys, ["render", "furnace", "--width", "8", "--height", "6"] + extra)
    assert code == 2 and out == ""
    assert_one_line(err, "vrlab render", flag)
    assert no_work == []


def test_render_scene_errors(capsys, tmp_path, no_work):
    code, _, err = run_cli(capsys, ["render"])
    assert code == 2 and "scene" in err
    assert_one_line(err, "vrlab render")
    code, _, err = run_cli(capsys, ["render", "no-such-scene"])
    assert code == 2
    assert_one_line(err, "vrlab render", "no-such-scene", "furnace")     # lists the built-in names
    code, _, err = run_cli(capsys, ["render", str(tmp_path / "missing.xml")])
    assert code == 1
    assert_one_line(err, "vrlab render", "missing.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text('<scene version="3.0.0">\n  <integrator type="direct"/>\n  <shape type="blob"/>\n</scene>\n')
    code, _, err = run_cli(capsys, ["render", str(bad)])
    assert code == 1
    assert_one_line(err, "vrlab render", "bad.xml", "blob", "line 3")   # element, line and file
    code, _, err = run_cli(capsys, ["render", str(tmp_path)])             # a folder, not a scene file
    assert code == 1
    assert_one_line(err, "vrlab render")
    assert no_work == []


def test_render_unwritable_or_missing_outputs_fail_before_rendering(capsys, tmp_path, no_work):
    (tmp_path / "file").write_text("x")
    (tmp_path / "dir.npy").mkdir()
    for flag, path in [("-o", tmp_path / "no" / "img.png"), ("--stderr-out", tmp_path / "no" / "err.npy"),
                       ("-o", tmp_path / "file" / "img.npy"), ("-o", tmp_path / "dir.npy")]:
        code, out, err = run_cli(capsys, ["render", "furnace", *TINY, "--spp", "2", flag, str(path)])
        assert code == 1 and out == ""
        assert_one_line(err, "vrlab render", flag)
    assert no_work == []


def test_render_reference_is_checked_before_rendering(capsys, tmp_path, no_work):
    good = np.ones((6, 8, 3), np.float32)
    cases = {"missing.npy": None, "folder.npy": "dir", "junk.npy": b"not an array",
             "shape.npy": np.ones((6, 9, 3)), "flat.npy": np.ones(10), "nan.npy": np.where(good > 0, np.nan, 0)}
    for name, content in cases.items():
        path = tmp_path / name
        if isinstance(content, str):
            path.mkdir()
        elif isinstance(content, bytes):
            path.write_bytes(content)
        elif content is not None:
            np.save(path, content)
        code, _, err = run_cli(capsys, ["render", "furnace", *TINY, "--reference", str(path)])
        assert code == 1, name
        assert_one_line(err, "vrlab render", "--reference")
    assert no_work == []


def test_exr_needs_openexr(capsys, tmp_path, no_work):
    import importlib.util
    if importlib.util.find_spec("OpenEXR") is not None:
        pytest.skip("OpenEXR is installed")
    code, _, err = run_cli(capsys, ["render", "furnace", *TINY, "-o", str(tmp_path / "img.exr")])
    assert code == 2
    assert_one_line(err, "vrlab render", "--output", "OpenEXR")


# --------------------------------------------------------------------------- lab
LAB = ["lab", "--integrand", "exp", "--estimators", "mc", "--n", "8,16", "--reps", "2"]
LAB_USAGE = [
    (["--n", "16.7"], "--n"), (["--n", "0"], "--n"), (["--n=-5"], "--n"), (["--n", ""], "--n"), (["--n", ","], "--n"),
    (["--n", "64,,256"], "--n"), (["--n", "64,64"], "--n"), (["--n", "abc"], "--n"), (["--n", str(2**31)], "--n"),
    (["--reps", "1"], "--reps"), (["--reps", "0"], "--reps"), (["--reps", "2.5"], "--reps"),
    (["--reps", "x"], "--reps"), (["--seed", "-1"], "--seed"), (["--seed", "nan"], "--seed"),
    (["--workers", "0"], "--workers"), (["--workers", "1.5"], "--workers"), (["--integrand", "nope"], "--integrand"),
    (["--integrand", "exp,exp"], "--integrand"), (["--integrand", ""], "--integrand"),
    (["--estimators", "nope"], "--estimators"), (["--estimators", "mc,mc"], "--estimators"),
    (["--estimators", ""], "--estimators"), (["--integrand", "step-x2", "--estimators", "cv"], "--estimators"),
    (["--estimators", "antithetic", "--n", "2,64"], "--n"), (["--estimators", "rqmc-sobol", "--n", "8"], "--n"),
    (["--csv", "rows.txt"], "--csv"), (["--plot", "conv.csv"], "--plot"), (["--plot", "conv"], "--plot"),
    (["--bogus"], "--bogus"),
]


@pytest.mark.parametrize("extra,flag", LAB_USAGE, ids=[" ".join(a) for a, _ in LAB_USAGE])
def test_lab_usage_errors(extra, flag, capsys, tmp_path, monkeypatch, no_work):
    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli(capsys, LAB + extra)
    assert code == 2 and out == ""
    assert_one_line(err, "vrlab lab", flag)
    assert no_work == []


def test_lab_needs_integrand_and_estimators(capsys, no_work):
    for argv in (["lab"], ["lab", "--integrand", "exp"], ["lab", "--estimators", "mc"]):
        code, _, err = run_cli(capsys, argv)
        assert code == 2
        assert_one_line(err, "vrlab lab", "--integrand", "--estimators")


def test_lab_output_folders_are_checked_first(capsys, tmp_path, no_work):
    for flag, name in [("--csv", "rows.csv"), ("--plot", "conv.png")]:
        code, _, err = run_cli(capsys, LAB + [flag, str(tmp_path / "missing" / name)])
        assert code == 1
        assert_one_line(err, "vrlab lab", flag, "missing")
    assert no_work == []


# --------------------------------------------------------------------------- demo, bench, global
@pytest.mark.parametrize("extra,flag", [(["--seed", "-1"], "--seed"), (["--seed", "1.5"], "--seed"),
                                        (["--seed", "abc"], "--seed"), (["--out", ""], "--out"),
                                        (["--quick=1"], "--quick")])
def test_demo_usage_errors(extra, flag, capsys, tmp_path, no_work):
    code, _, err = run_cli(capsys, ["demo", "--out", str(tmp_path / "d")] + extra)
    assert code == 2
    assert_one_line(err, "vrlab demo", flag)
    assert no_work == []


def test_demo_output_folder_failures(capsys, tmp_path, no_work):
    (tmp_path / "file").write_text("x")
    for out in (tmp_path / "file", tmp_path / "file" / "sub"):
        code, _, err = run_cli(capsys, ["demo", "--quick", "--out", str(out)])
        assert code == 1
        assert_one_line(err, "vrlab demo", "--out")
    assert no_work == []


@pytest.mark.parametrize("argv,names", [(["bench"], ["suite"]), (["bench", "nope"], ["suite", "nope"]),
                                        (["bench", "qmc", "--n", "5"], ["--n"]), (["bench", "qmc", "--quick=no"],
                                                                                  ["--quick"])])
def test_bench_usage_errors(argv, names, capsys):
    code, out, err = run_cli(capsys, argv)
    assert code == 2 and out == ""
    assert_one_line(err, "vrlab bench", *names)


@pytest.mark.parametrize("argv,prog,names", [([], "vrlab", ["COMMAND"]), (["nope"], "vrlab", ["nope"]),
                                             (["--bogus", "lab"], "vrlab", ["--bogus"])])
def test_global_usage_errors(argv, prog, names, capsys):
    code, _, err = run_cli(capsys, argv)
    assert code == 2
    assert_one_line(err, prog, *names)


def test_main_checks_argv():
    with pytest.raises(TypeError, match="argv"):
        main("render furnace")
    with pytest.raises(TypeError, match="argv"):
        main(["render", "furnace", "--spp", 4])


# --------------------------------------------------------------------------- errors while working
@pytest.mark.parametrize("exc,code,text", [(ValueError("spp must be >= 1"), 1, "spp must be >= 1"),
                                           (ZeroDivisionError("division by zero"), 1, "ZeroDivisionError"),
                                           (MemoryError(), 1, "out of memory"),
                                           (KeyboardInterrupt(), 130, "interrupted")])
def test_errors_while_working_are_one_line(exc, code, text, capsys, monkeypatch):
    def fail(*a, **k):
        raise exc
    monkeypatch.setattr("vrlab.render.render", fail)
    got, _, err = run_cli(capsys, ["render", "furnace", *TINY])
    assert got == code
    assert_one_line(err, "vrlab render", text)


def test_debug_shows_the_traceback_in_process(capsys, monkeypatch):
    def fail(*a, **k):
        raise ValueError("deep inside")
    monkeypatch.setattr("vrlab.render.render", fail)
    for argv in (["--debug", "render", "furnace", *TINY], ["render", "furnace", *TINY, "--debug"]):
        code, _, err = run_cli(capsys, argv)
        assert code == 1 and "Traceback" in err and "deep inside" in err
        assert err.splitlines()[-1] == "vrlab render: error: deep inside"


def test_closed_stdout_in_process_is_quiet(capsys, monkeypatch):
    def fail(*a, **k):
        raise BrokenPipeError(32, "Broken pipe")
    monkeypatch.setattr("vrlab.cli_lab._lab_list", fail)
    code, _, err = run_cli(capsys, ["lab", "--list"])
    assert code == 0 and err == ""


# --------------------------------------------------------------------------- valid input stays valid
def test_spp_1_gives_strict_json(capsys):
    code, out, err = run_cli(capsys, ["render", "furnace", *TINY, "--json"])
    assert code == 0 and "error" not in err
    res = json.loads(out, parse_constant=lambda c: pytest.fail(f"{c} in JSON"))
    assert res["mean_stderr"] is None and res["width"] == 8


def test_render_list_json(capsys):
    code, out, _ = run_cli(capsys, ["render", "--list", "--json"])
    assert code == 0 and "furnace" in json.loads(out)


# --------------------------------------------------------------------------- real processes
def _vrlab(*args, **kw):
    return subprocess.run([sys.executable, "-m", "vrlab", *args], capture_output=True, text=True, timeout=120, **kw)


def test_subprocess_errors_are_one_line_without_traceback(tmp_path):
    r = _vrlab("render", "furnace", "--width", "0")
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.strip() == "vrlab render: error: --width must be >= 1, got 0"
    r = _vrlab("render", str(tmp_path / "missing.xml"))
    assert r.returncode == 1
    assert_one_line(r.stderr, "vrlab render", "missing.xml")
    r = _vrlab("lab", "--integrand", "exp", "--estimators", "mc", "--n", "16.7")
    assert r.returncode == 2
    assert_one_line(r.stderr, "vrlab lab", "--n")


def test_subprocess_debug_shows_the_traceback(tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text('<scene version="3.0.0">\n  <shape type="blob"/>\n</scene>\n')
    r = _vrlab("--debug", "render", str(bad))
    assert r.returncode == 1 and "Traceback" in r.stderr
    assert r.stderr.splitlines()[-1].startswith("vrlab render: error: ")


def test_subprocess_closed_stdout_is_quiet():
    for args in (["render", "--list"], ["--help"]):
        p = subprocess.Popen([sys.executable, "-m", "vrlab", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        p.stdout.close()                     # the reader is gone before vrlab writes anything
        err = p.stderr.read()
        p.stderr.close()
        assert p.wait(timeout=120) == 0 and err == b"", err.decode()
    r = subprocess.run(["bash", "-c", f"'{sys.executable}' -m vrlab lab --list | head -1"],
                       capture_output=True, text=True, timeout=120)
    assert r.stdout.startswith("Estimator recipes") and r.stderr == ""


# --------------------------------------------------------------------------- render --gradient-domain
GD_USAGE = [
    (["--gradient-domain", "--spp", "1"], "--spp"), (["--gradient-domain", "--alpha", "0"], "--alpha"),
    (["--gradient-domain", "--alpha", "-0.5"], "--alpha"), (["--gradient-domain", "--alpha", "nan"], "--alpha"),
    (["--gradient-domain", "--alpha", "inf"], "--alpha"), (["--gradient-domain", "--alpha", "big"], "--alpha"),
    (["--gradient-domain", "--alpha", ""], "--alpha"), (["--gradient-domain", "--alpha", "1e-200"], "--alpha"),
    (["--gradient-domain", "--reconstruct", "l3"], "--reconstruct"),
    (["--gradient-domain", "--reconstruct", ""], "--reconstruct"),
    (["--alpha", "0.5"], "--alpha"), (["--reconstruct", "l1"], "--reconstruct"), (["--independent"], "--independent"),
    (["--gradient-domain", "--compare"], "--compare"), (["--gradient-domain", "--compare", "bsdf,light"], "--compare"),
    (["--gradient-domain", "--equal-time"], "--equal-time"),
    (["--gradient-domain", "-o", "gd.txt"], "--output"),
    (["--gradient-domain", "-o", "gd.npy", "--stderr-out", "gd_primal.npy"], "--stderr-out"),
]


@pytest.fixture
def no_gradient_work(no_work, monkeypatch):
    def fake(*a, **k):
        no_work.append("render_gradient_domain")
        raise AssertionError("render_gradient_domain started")
    monkeypatch.setattr("vrlab.render.render_gradient_domain", fake)
    return no_work


@pytest.mark.parametrize("extra,flag", GD_USAGE, ids=[" ".join(a) for a, _ in GD_USAGE])
def test_render_gradient_domain_usage_errors(extra, flag, capsys, tmp_path, monkeypatch, no_gradient_work):
    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli(capsys, ["render", "furnace", "--width", "8", "--height", "6", "--spp", "2"] + extra)
    assert code == 2 and out == ""
    assert_one_line(err, "vrlab render", flag)
    assert no_gradient_work == []


def test_render_gradient_domain_side_files_are_checked_first(capsys, tmp_path, no_gradient_work):
    (tmp_path / "gd_dx.npy").mkdir()                     # a folder where -o gd.npy writes |dx|
    code, out, err = run_cli(capsys, ["render", "furnace", *TINY, "--spp", "2", "--gradient-domain",
                                      "-o", str(tmp_path / "gd.npy")])
    assert code == 1 and out == ""
    assert_one_line(err, "vrlab render", "-o/--output", "gd_dx.npy")
    code, out, err = run_cli(capsys, ["render", "furnace", *TINY, "--spp", "2", "--gradient-domain",
                                      "-o", str(tmp_path / "no" / "gd.npy")])
    assert code == 1
    assert_one_line(err, "vrlab render", "-o/--output")
    assert no_gradient_work == []
