"""Bad input to the lab, its tables and figures, and the benchmarks API: clear errors naming the argument.

Every check here runs before any estimate, so the module is fast.
"""
import io

import numpy as np
import pandas as pd
import pytest

from vrlab import bench, lab
from vrlab.bench.discrete import bench_discrete
from vrlab.bench.estimators import bench_estimators, memory_rows, overhead_rows
from vrlab.bench.qmc import bench_qmc
from vrlab.bench.timing import race
from vrlab.estimators import MonteCarlo
from vrlab.integrands import Integrand
from vrlab.lab import experiment, registry
from vrlab.lab.runner import ProgressBar


def _table(**changes) -> pd.DataFrame:
    """A small valid run table: one estimator, one integrand, n = 10 and 20, two repetitions each."""
    df = pd.DataFrame({"estimator": "e", "integrand": "i", "n": [10, 10, 20, 20], "rep": [0, 1, 0, 1],
                       "value": [1.0, 1.1, 1.0, 0.95], "stderr": 0.1, "exact": 1.0, "seconds": 0.1})
    return df.assign(**changes)


# -- run ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("kw, exc, name", [
    ({"estimators": []}, ValueError, "estimators"),
    ({"estimators": 5}, TypeError, "estimators"),
    ({"estimators": ["nope"]}, ValueError, "estimators"),
    ({"estimators": [3]}, TypeError, "estimators"),
    ({"estimators": ["mc", " mc"]}, ValueError, "estimators"),
    ({"estimators": [("", MonteCarlo())]}, ValueError, "estimators"),
    ({"estimators": [("x", object())]}, TypeError, "estimators"),
    ({"estimators": [("x", MonteCarlo(), "bogus-points")]}, ValueError, "estimators"),
    ({"estimators": ["cv"], "integrands": ["glossy-light"]}, ValueError, "estimators"),
    ({"integrands": []}, ValueError, "integrands"),
    ({"integrands": ["nope"]}, ValueError, "integrands"),
    ({"integrands": [3]}, TypeError, "integrands"),
    ({"integrands": 3}, TypeError, "integrands"),
    ({"integrands": ["exp", "exp"]}, ValueError, "integrands"),
    ({"ns": [16.7]}, TypeError, "ns"),
    ({"ns": [64.0]}, TypeError, "ns"),
    ({"ns": []}, ValueError, "ns"),
    ({"ns": [0]}, ValueError, "ns"),
    ({"ns": [-64]}, ValueError, "ns"),
    ({"ns": [64, 64]}, ValueError, "ns"),
    ({"ns": "64"}, TypeError, "ns"),
    ({"ns": [np.nan]}, TypeError, "ns"),
    ({"ns": [True]}, TypeError, "ns"),
    ({"ns": [2**40]}, ValueError, "ns"),
    ({"reps": 1}, ValueError, "reps"),
    ({"reps": 0}, ValueError, "reps"),
    ({"reps": 2.0}, TypeError, "reps"),
    ({"reps": "3"}, TypeError, "reps"),
    ({"reps": 10**9}, ValueError, "reps"),
    ({"workers": 0}, ValueError, "workers"),
    ({"workers": 1.5}, TypeError, "workers"),
    ({"workers": 10**6}, ValueError, "workers"),
    ({"rng": -1}, ValueError, "rng"),
    ({"rng": True}, TypeError, "rng"),
    ({"rng": "seed"}, TypeError, "rng"),
    ({"rng": 1.5}, TypeError, "rng"),
    ({"skip": "no"}, TypeError, "skip"),
    ({"crn": 1}, TypeError, "crn"),
    ({"progress": "yes"}, TypeError, "progress"),
    ({"chunk": 0}, ValueError, "chunk"),
    ({"chunk": 2.5}, TypeError, "chunk"),
])
def test_run_bad_arguments(raises_naming, kw, exc, name):
    args = {"estimators": ["mc"], "integrands": ["exp"], "ns": [64], "reps": 2}
    args.update(kw)
    pos = [args.pop(k) for k in ("estimators", "integrands", "ns", "reps")]
    with raises_naming(exc, name):
        lab.run(*pos, **args)


def test_run_lists_the_valid_names(raises_naming):
    with raises_naming(ValueError, "estimators") as info:
        lab.run(["mc", "bogus"], ["exp"], [64], 2)
    assert "choose from mc, is:<technique>" in str(info.value)
    with raises_naming(ValueError, "integrands") as info:
        lab.run(["mc"], ["nope"], [64], 2)
    assert "sin, step-x2, exp" in str(info.value)


def test_run_with_nothing_applicable_is_an_error_not_an_empty_table(raises_naming):
    with raises_naming(ValueError, "estimators", "integrands"):
        lab.run(["cv"], ["glossy-light"], [64], 2, skip=True)


def test_run_stops_on_a_non_finite_estimate(raises_naming):
    class Broken:
        """An estimator whose estimate is NaN (no Integrand check can see it)."""

        def estimate(self, integrand, n, rng=None, points=None):
            return type("E", (), {"value": float("nan"), "stderr": 0.0, "seconds": 0.0, "n_evals": n, "n": n})()

    with raises_naming(ValueError, "estimators") as info:
        lab.run([("broken", Broken())], ["exp"], [8], 2)
    assert "'broken'" in str(info.value) and "nan" in str(info.value)


# -- registry -----------------------------------------------------------------------------------
@pytest.mark.parametrize("name, exc", [("nope", ValueError), ("", ValueError), (3, TypeError), (None, TypeError),
                                       ("mc:3", ValueError), ("ris", ValueError)])
def test_get_recipe_bad_names(raises_naming, name, exc):
    with raises_naming(exc, "name"):
        lab.get_recipe(name)


@pytest.mark.parametrize("recipe, integrand, exc, name", [
    ("mc", 3, TypeError, "integrand"),
    ("mc", "nope", ValueError, "integrand"),
    ("nope", "exp", ValueError, "name"),
    ("ris:100000000", "glossy-light", ValueError, "ris:100000000"),
    ("rqmc-sobol:0", "exp", ValueError, "rqmc-sobol:0"),
    ("mis-balance:brdf+brdf", "glossy-light", ValueError, "brdf"),
])
def test_build_bad_arguments(raises_naming, recipe, integrand, exc, name):
    with raises_naming(exc, name):
        lab.build(recipe, integrand)


def test_build_accepts_a_catalogue_name():
    est, pts = lab.build("is:linear", "exp")
    assert isinstance(est, MonteCarlo) and pts is None


@pytest.mark.parametrize("fn", [lab.explain, lab.applicable, registry.candidates, registry.control_for,
                                registry.is_smooth, registry.ris_source_target])
@pytest.mark.parametrize("bad, exc", [(None, TypeError), (3.0, TypeError), ("nope", ValueError)])
def test_integrand_helpers_bad_integrand(raises_naming, fn, bad, exc):
    with raises_naming(exc, "integrand"):
        fn(bad)


@pytest.mark.parametrize("args, kw, exc, name", [
    (("a:b", "s", "importance"), {}, ValueError, "base"),
    (("", "s", "importance"), {}, ValueError, "base"),
    ((3, "s", "importance"), {}, TypeError, "base"),
    (("x", 3, "importance"), {}, TypeError, "summary"),
    (("x", "s", None), {}, TypeError, "module"),
    (("x", "s", "importance"), {"arg": 3}, TypeError, "arg"),
    (("x", "s", "importance"), {"arg_required": "yes"}, TypeError, "arg_required"),
    (("x", "s", "importance"), {"arg_required": True}, ValueError, "arg_required"),
    (("x", "s", "importance"), {"bias": "small"}, ValueError, "bias"),
    (("x", "s", "importance"), {"bias": None}, TypeError, "bias"),
])
def test_register_bad_arguments(raises_naming, args, kw, exc, name):
    with raises_naming(exc, name):
        lab.register(*args, **{"bias": "unbiased", **kw})


def test_register_needs_a_callable_builder(raises_naming):
    with raises_naming(TypeError, "register"):
        lab.register("never-added", "s", "importance", bias="unbiased")(42)
    assert "never-added" not in registry.RECIPES


# -- tables -------------------------------------------------------------------------------------
@pytest.mark.parametrize("df, exc", [
    ([1, 2], TypeError),
    (None, TypeError),
    (_table().iloc[:0], ValueError),
    (_table().drop(columns="value"), ValueError),
    (_table(value="a"), TypeError),
    (_table(value=[1.0, np.nan, 1.0, 1.0]), ValueError),
    (_table(value=[1.0, np.inf, 1.0, 1.0]), ValueError),
    (_table(n=[10, 10, 0, 0]), ValueError),
    (_table(seconds=-1.0), ValueError),
    (_table(stderr=-0.1), ValueError),
    (_table(exact=np.inf), ValueError),
    (_table().iloc[[0, 2]], ValueError),                 # one repetition: no variance
    (pd.concat([_table(), _table()]), ValueError),       # the same (estimator, integrand, n, rep) twice
])
def test_summarize_bad_tables(raises_naming, df, exc):
    with raises_naming(exc, "df"):
        lab.summarize(df)


@pytest.mark.parametrize("fn", [lab.fit_slopes, lab.equal_time])
@pytest.mark.parametrize("df, exc", [
    (pd.DataFrame(), ValueError),
    ("table", TypeError),
    (pd.DataFrame({"estimator": "e", "integrand": "i", "n": [0, 10], "rmse": [1.0, 0.5], "variance": 1.0,
                   "seconds": 1.0, "efficiency": 1.0}), ValueError),
    (pd.DataFrame({"estimator": "e", "integrand": "i", "n": [10, 20], "rmse": ["a", "b"], "variance": ["a", "b"],
                   "seconds": 1.0, "efficiency": 1.0}), TypeError),
])
def test_slopes_and_equal_time_bad_tables(raises_naming, fn, df, exc):
    with raises_naming(exc, "df"):
        fn(df)


def test_equal_time_bad_reference(raises_naming):
    with raises_naming(TypeError, "reference"):
        lab.equal_time(_table(), reference=3)
    with raises_naming(ValueError, "reference"):
        lab.equal_time(_table(), reference="zz")


@pytest.mark.parametrize("args, kw, exc, name", [
    ((3, "independent", 1), {}, TypeError, "cls"),
    (("MonteCarlo", 3, 1), {}, TypeError, "points"),
    (("MonteCarlo", "independent", 1.5), {}, TypeError, "dim_u"),
    (("MonteCarlo", "independent", "2"), {}, TypeError, "dim_u"),
    (("MonteCarlo", "independent", 1, "yes"), {}, TypeError, "smooth"),
    (("Stratified", "independent", 1), {"fixed_strata": 1}, TypeError, "fixed_strata"),
])
def test_theoretical_slope_bad_arguments(raises_naming, args, kw, exc, name):
    with raises_naming(exc, name):
        lab.theoretical_slope(*args, **kw)


# -- figures ------------------------------------------------------------------------------------
@pytest.mark.parametrize("fn", [lab.convergence_plot, lab.efficiency_plot])
def test_plot_paths(raises_naming, tmp_path, fn):
    for bad, exc in ((tmp_path / "x.foo", ValueError), (tmp_path / "x", ValueError),
                     (tmp_path / "missing" / "x.png", ValueError), (tmp_path, ValueError),
                     (3, TypeError), (None, TypeError), (b"x.png", TypeError)):
        with raises_naming(exc, "path"):
            fn(_table(), bad)
    with raises_naming(ValueError, "df"):
        fn(_table().iloc[:0], tmp_path / "x.png")
    assert not any(tmp_path.iterdir())          # nothing was written


def test_plot_options(raises_naming, tmp_path):
    with raises_naming(TypeError, "title"):
        lab.convergence_plot(_table(), tmp_path / "c.png", title=3)
    with raises_naming(ValueError, "df"):     # no exact values: nothing to draw
        lab.convergence_plot(_table(exact=np.nan), tmp_path / "c.png")
    with raises_naming(ValueError, "n"):
        lab.efficiency_plot(_table(), tmp_path / "e.png", n=7)
    with raises_naming(TypeError, "n"):
        lab.efficiency_plot(_table(), tmp_path / "e.png", n=10.5)
    with raises_naming(ValueError, "reference"):
        lab.efficiency_plot(_table(), tmp_path / "e.png", reference="zz")
    assert lab.efficiency_plot(_table(), tmp_path / "e.png", n=10).exists()


def test_experiment_helpers(raises_naming, tmp_path):
    with raises_naming(TypeError, "out"):
        experiment.output_dir(3)
    with raises_naming(ValueError, "out"):
        experiment.output_dir("")
    (tmp_path / "file").write_text("x")
    with raises_naming(ValueError, "out"):
        experiment.output_dir(tmp_path / "file")
    with raises_naming(TypeError, "fig"):
        experiment.save_figure("figure", tmp_path / "a.png")
    from matplotlib.figure import Figure
    for kw, exc, name in (({"path": tmp_path / "a.nope"}, ValueError, "path"),
                          ({"path": tmp_path / "no" / "a.png"}, ValueError, "path"),
                          ({"path": tmp_path / "a.png", "dpi": 0}, ValueError, "dpi"),
                          ({"path": tmp_path / "a.png", "dpi": np.nan}, ValueError, "dpi"),
                          ({"path": tmp_path / "a.png", "dpi": "high"}, TypeError, "dpi")):
        with raises_naming(exc, name):
            experiment.save_figure(Figure(), **kw)
    with raises_naming(TypeError, "main"):
        experiment.experiment_cli(3, tmp_path, None, argv=[])
    with raises_naming(TypeError, "argv"):
        experiment.experiment_cli(lambda out, full=False: {}, tmp_path, None, argv="--full")
    with raises_naming(TypeError, "main"):
        experiment.experiment_cli(lambda out, full=False: None, tmp_path, None, argv=[])


def test_progress_bar_arguments(raises_naming):
    for kw, exc, name in (({"total": -1}, ValueError, "total"), ({"total": 2.5}, TypeError, "total"),
                          ({"total": 3, "width": 0}, ValueError, "width"),
                          ({"total": 3, "label": 3}, TypeError, "label"),
                          ({"total": 3, "stream": "stderr"}, TypeError, "stream"),
                          ({"total": 3, "disable": "yes"}, TypeError, "disable")):
        with raises_naming(exc, name):
            ProgressBar(**kw)
    bar = ProgressBar(3, stream=io.StringIO())
    with raises_naming(ValueError, "k"):
        bar.update(-1)


# -- benchmarks ---------------------------------------------------------------------------------
@pytest.mark.parametrize("suite, kw, exc, name", [
    ("nope", {}, ValueError, "suite"),
    ("", {}, ValueError, "suite"),
    (3, {}, TypeError, "suite"),
    (None, {}, TypeError, "suite"),
    ("qmc", {"quick": "yes"}, TypeError, "quick"),
    ("estimators", {"quick": 1}, TypeError, "quick"),
])
def test_bench_run_bad_arguments(raises_naming, suite, kw, exc, name):
    with raises_naming(exc, name) as info:
        bench.run(suite, **kw)
    if name == "suite":
        assert "'sampling', 'qmc', 'discrete', 'estimators'" in str(info.value)


@pytest.mark.parametrize("call, exc, name", [
    (lambda: bench_qmc(dims=()), TypeError, "dims"),
    (lambda: bench_qmc(dims=(0,)), ValueError, "dims"),
    (lambda: bench_qmc(dims=(2.5,)), TypeError, "dims"),
    (lambda: bench_qmc(repeat=0), ValueError, "repeat"),
    (lambda: bench_qmc(quick="no"), TypeError, "quick"),
    (lambda: bench_discrete(repeat=-1), ValueError, "repeat"),
    (lambda: bench_discrete(seed=-1), ValueError, "seed"),
    (lambda: bench_discrete(seed=1.5), TypeError, "seed"),
    (lambda: bench_estimators(quick=None), TypeError, "quick"),
    (lambda: overhead_rows(0), ValueError, "n"),
    (lambda: overhead_rows(10**12), ValueError, "n"),
    (lambda: overhead_rows(1000, repeat=0), ValueError, "repeat"),
    (lambda: memory_rows(2.5), TypeError, "n"),
    (lambda: race({}, 1), TypeError, "fns"),
    (lambda: race({"a": 3}, 1), TypeError, "fns"),
    (lambda: race({"a": lambda: None}, 0), ValueError, "repeat"),
])
def test_bench_functions_bad_arguments(raises_naming, call, exc, name):
    with raises_naming(exc, name):
        call()


def test_a_user_integrand_with_nan_values_stops_the_run():
    nan_f = Integrand(lambda x: x[..., 0] * np.nan, [(0, 1)], 0.5, "nan-f")
    with pytest.raises(ValueError, match="nan-f"):
        lab.run(["mc"], [nan_f], [16], 2)
