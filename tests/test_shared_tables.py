"""One resolver of ``points=`` names, one relMSE and one table of limits, shared by the library
and the CLI (issue 23, item 4)."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import vrlab
from conftest import run_cli
from vrlab import limits
from vrlab.estimators import MonteCarlo
from vrlab.metrics import REL_MSE_EPS, rel_mse, relative_squared_error
from vrlab.points import SetSampler
from vrlab.points.names import ALIASES, NAMES, canonical, is_independent

ROOT = Path(vrlab.__file__).parents[1]


@pytest.mark.parametrize("name", ["independent"] + [a for a, c in ALIASES.items() if c == "independent"])
def test_every_name_of_independent_points_is_independent_everywhere(name):
    est = MonteCarlo().estimate("sin", 1000, rng=0, points=name)
    assert "stderr_note" not in est.extra                       # "mc" used to get a false note
    assert SetSampler(name, 2, 8, rng=0).iid and is_independent(name) and canonical(name.upper()) == "independent"


@pytest.mark.parametrize("name", [n for n in NAMES if n != "independent"] + ["jittered", "cp"])
def test_other_point_sets_are_flagged(name):
    assert not is_independent(name)
    kw = {} if canonical(name) != "cranley-patterson" else {}
    est = MonteCarlo().estimate("sin", 1024, rng=0, points=name, **kw)
    assert "stderr_note" in est.extra


def test_unknown_point_set_names_are_refused_the_same_way(raises_naming):
    with raises_naming(ValueError, "points"):
        canonical("sobolev")
    with raises_naming(ValueError, "points"):
        SetSampler("sobolev", 2, 8, rng=0)


def test_one_relmse():
    from vrlab.render.image import rel_mse as render_rel_mse

    rng = np.random.default_rng(0)
    img, ref = rng.random((4, 5, 3)), rng.random((4, 5, 3))
    want = float(np.mean((img - ref) ** 2 / (ref**2 + 0.01)))   # the formula, written out once here
    assert rel_mse(img, ref) == pytest.approx(want, rel=1e-12) and REL_MSE_EPS == 0.01
    assert render_rel_mse(img, ref) == pytest.approx(want, rel=1e-12)
    assert rel_mse(img, ref, axis=-1).shape == (4, 5)
    np.testing.assert_allclose(relative_squared_error((img - ref) ** 2, ref).mean(), want, rtol=1e-12)
    mask = np.zeros((4, 5), bool)
    mask[1, 2] = True
    assert rel_mse(img, ref, mask=mask) == pytest.approx(float(np.mean((img[1, 2] - ref[1, 2]) ** 2
                                                                       / (ref[1, 2] ** 2 + 0.01))))


@pytest.mark.parametrize("kw, exc, names", [
    (dict(img=np.zeros((2, 2, 3)), ref=np.zeros((2, 3, 3))), ValueError, ["img", "ref"]),
    (dict(img=np.full((2, 2, 3), np.nan), ref=np.zeros((2, 2, 3))), ValueError, ["img"]),
    (dict(img=np.zeros((2, 2, 3)), ref=np.full((2, 2, 3), np.inf)), ValueError, ["ref"]),
    (dict(img=np.zeros((0, 3)), ref=np.zeros((0, 3))), ValueError, ["img", "ref"]),
    (dict(img="img", ref=np.zeros(3)), TypeError, ["img"]),
    (dict(img=np.zeros((2, 2, 3)), ref=np.zeros((2, 2, 3)), ref_err=np.zeros((2, 2))), ValueError, ["ref_err"]),
    (dict(img=np.zeros((2, 2, 3)), ref=np.zeros((2, 2, 3)), mask=np.zeros((2, 2), bool)), ValueError, ["mask"]),
    (dict(img=np.zeros((2, 2, 3)), ref=np.zeros((2, 2, 3)), mask=np.ones((3, 2), bool)), ValueError, ["mask"]),
    (dict(img=np.zeros((2, 2, 3)), ref=np.zeros((2, 2, 3)), mask=np.ones((2, 2), int)), ValueError, ["mask"]),
])
def test_relmse_refuses_bad_images_naming_them(raises_naming, kw, exc, names):
    """No silent NaN, empty mean or numpy broadcasting message: the argument is named."""
    with raises_naming(exc, *names):
        rel_mse(**kw)


def test_no_other_copy_of_the_relmse_formula():
    pattern = re.compile(r"\*\*\s*2\s*\+\s*(0\.01|1e-2|EPS)\)|ref\s*\*\s*ref\s*\+\s*0\.01")
    bad = []
    for folder in ("vrlab", "experiments", "benchmarks"):
        for path in (ROOT / folder).rglob("*.py"):
            if path.name == "metrics.py":
                continue
            code = "\n".join(line.split("#")[0] for line in path.read_text().splitlines())
            code = re.sub(r'""".*?"""', "", code, flags=re.S)
            bad += [f"{path.relative_to(ROOT)}: {m.group(0)}" for m in pattern.finditer(code)]
    assert not bad, bad


def test_one_table_of_limits(capsys):
    from vrlab import cli_args, cli_render, execution
    from vrlab.estimators import registry
    from vrlab.lab import runner
    from vrlab.render import film

    assert cli_render.SPP_MAX == film.MAX_SPP == limits.MAX_SPP
    assert cli_render.SIDE_MAX == limits.MAX_SIDE and cli_render.RIS_MAX == registry.MAX_RECIPE_ARG
    assert cli_args.WORKERS_MAX == execution.MAX_WORKERS == limits.max_workers()
    assert runner.MAX_N == limits.MAX_N
    code, out, err = run_cli(capsys, ["render", "furnace", "--spp", str(limits.MAX_SPP + 1)])
    assert code == 2 and "--spp" in err and str(limits.MAX_SPP) in err
    with pytest.raises(ValueError, match=f"spp.*{limits.MAX_SPP}"):
        vrlab.render.render("furnace", limits.MAX_SPP + 1)
    with pytest.raises(ValueError, match="ris_candidates"):
        vrlab.render.preset("ris", ris_candidates=limits.MAX_CANDIDATES + 1)
