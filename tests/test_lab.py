"""The integral lab: recipes, runner (seeds, order and worker independence), summary, slopes, plots, CLI.

Modules that may not exist yet are guarded with ``pytest.importorskip``:
``vrlab.estimators.mis`` (mis-*, onesample) and ``vrlab.estimators.ris`` (ris:m).
"""
import json

import numpy as np
import pandas as pd
import pytest

from vrlab import lab
from vrlab.cli import main
from vrlab.estimators import MonteCarlo
from vrlab.integrands import Integrand, get
from vrlab.lab import registry
from vrlab.lab.runner import unit_seed

NUMERIC = ["value", "stderr", "exact", "error", "n_evals", "n_units"]


def _same_numbers(a: pd.DataFrame, b: pd.DataFrame) -> None:
    keys = ["estimator", "integrand", "n", "rep"]
    a = a.sort_values(keys).reset_index(drop=True)
    b = b.sort_values(keys).reset_index(drop=True)
    pd.testing.assert_frame_equal(a.drop(columns="seconds"), b.drop(columns="seconds"), check_exact=True)


# -- registry ---------------------------------------------------------------------------------
def test_recipes_build_estimator_and_points():
    exp = get("exp")
    est, pts = lab.build("mc", exp)
    assert isinstance(est, MonteCarlo) and est.distribution is None and pts is None
    est, pts = lab.build("is:linear", exp)
    assert est.distribution is exp.techniques["linear"] and pts is None
    assert lab.build("jittered", exp)[1] == "stratified"
    assert lab.build("lhs", exp)[1] == "lhs"


def test_list_recipes_and_applicable():
    patterns = {r["recipe"] for r in lab.list_recipes()}
    for p in ("mc", "is:<technique>", "mis-balance[:<a+b>]", "mis-max[:<a+b>]", "onesample[:<a+b>]", "antithetic",
              "cv[:<a+b>]", "stratified", "jittered", "lhs", "rqmc-sobol[:<R>]", "rqmc-halton[:<R>]", "ris:<m>"):
        assert p in patterns
    ok = lab.applicable(get("exp"))
    assert {"mc", "is:uniform", "is:linear", "jittered", "lhs"} <= set(ok)
    assert "is:brdf" not in ok
    why = lab.explain(get("glossy-light"))
    assert why["mc"] is None and why["is:brdf"] is None
    assert "no control variate" in why["cv"]


@pytest.mark.parametrize("name, match", [
    ("nope", "unknown estimator recipe 'nope'; choose from mc, is:<technique>"),
    ("mc:3", "takes no ':' argument"),
    ("is", "needs an argument"),
    ("ris", "needs an argument"),
])
def test_bad_recipe_names(name, match):
    with pytest.raises(ValueError, match=match):
        lab.get_recipe(name)


def test_recipe_does_not_apply():
    with pytest.raises(ValueError, match="has no technique 'brdf'; it has 'uniform', 'linear'"):
        lab.build("is:brdf", get("exp"))
    with pytest.raises(ValueError, match="no control variate known for integrand 'glossy-light'"):
        lab.build("cv", get("glossy-light"))
    with pytest.raises(ValueError, match="must be an integer"):
        lab.build("rqmc-sobol:x", get("exp"))


def test_cv_recipe_uses_known_control():
    pytest.importorskip("vrlab.estimators.control")
    est, _ = lab.build("cv", get("exp"))
    assert est.control_integral == pytest.approx(0.5)
    x = np.array([[0.25], [0.75]])
    np.testing.assert_allclose(est.control(x), [0.25, 0.75])
    # h and its integral agree for every built-in control (midpoint rule on a fine grid)
    for name, (h, H, _) in registry.CONTROLS.items():
        integrand = get(name)
        if integrand.bounds is None:
            continue
        k = 400
        g = (np.arange(k) + 0.5) / k
        mesh = np.stack(np.meshgrid(*[lo + (hi - lo) * g for lo, hi in integrand.bounds], indexing="ij"), -1)
        assert np.mean(h(mesh)) * integrand.volume == pytest.approx(H, rel=1e-4), name
    # a user integrand named like a catalogue one but with another integral gets no control
    with pytest.raises(ValueError, match="no control variate"):
        lab.build("cv", Integrand(lambda x: x[..., 0], [(0, 1)], 0.5, "exp"))
    given = Integrand(lambda x: x[..., 0] ** 2, [(0, 1)], 1 / 3, "x2", theory={"cv:control": (lambda x: x[..., 0], 0.5)})
    assert lab.build("cv", given)[0].control_integral == 0.5


def test_cv_recipe_uses_the_integrands_named_controls():
    """``Integrand(controls={name: (h, int h)})``: ``cv`` takes them all, ``cv:a`` the one named,
    and the estimate stays unbiased; a wrong integral for the control biases it (z-test fails)."""
    pytest.importorskip("vrlab.estimators.control")
    a = 1e-2
    peak = lambda x: 1 / (a + (x[..., 0] - 0.5) ** 2)                      # noqa: E731
    peak_int = 2 / np.sqrt(a) * np.arctan(0.5 / np.sqrt(a))

    def integrand(peak_integral):
        return Integrand(lambda x: peak(x) + 3 * x[..., 0], [(0, 1)], peak_int + 1.5, "peak+ramp",
                         controls={"peak": (peak, peak_integral), "ramp": (lambda x: x[..., 0], 0.5)})

    good = integrand(peak_int)
    both, one = lab.build("cv", good)[0], lab.build("cv:peak", good)[0]
    assert both.control == ["peak", "ramp"] and one.control == "peak"
    for est in (both, one):                     # f = peak + 3 ramp: with both controls, exact
        e = est.estimate(good, 20_000, rng=3)
        assert abs(e.value - good.exact) < 4 * e.stderr + 1e-12 * good.exact
    assert one.estimate(good, 20_000, rng=3).stderr < 0.1 * lab.build("mc", good)[0].estimate(good, 20_000, rng=3).stderr
    bad = integrand(1.05 * peak_int)                                        # the control's integral off by 5 %
    e = lab.build("cv:peak", bad)[0].estimate(bad, 20_000, rng=3)
    assert abs(e.value - bad.exact) > 4 * e.stderr
    with pytest.raises(ValueError, match="has no control 'nope'; it has 'peak', 'ramp'"):
        lab.build("cv:nope", good)


def test_mis_recipes():
    pytest.importorskip("vrlab.estimators.mis")
    g = get("glossy-light")
    for h in ("balance", "power", "max", "cutoff", "optimal"):
        assert lab.build(f"mis-{h}", g)[1] is None
    assert lab.build("mis-balance:brdf+light", g)[0] is not None
    with pytest.raises(ValueError, match="at least 2"):
        lab.build("mis-balance:brdf", g)
    with pytest.raises(ValueError, match="no technique 'nope'"):
        lab.build("mis-power:brdf+nope", g)
    df = lab.run(["mis-balance", "onesample"], ["glossy-light"], [256], 4, rng=1)
    assert np.isfinite(df["value"]).all()


def test_ris_recipe():
    pytest.importorskip("vrlab.estimators.ris")
    assert lab.build("ris:4", get("glossy-light"))[1] is None
    df = lab.run(["ris:4"], ["glossy-light"], [256], 3, rng=1)
    assert np.isfinite(df["value"]).all()


def test_rqmc_recipes_run():
    pytest.importorskip("vrlab.estimators.rqmc")
    df = lab.run(["rqmc-sobol", "rqmc-halton:4"], ["exp"], [64, 256], 3, rng=1)
    assert (df["class"] == "RQMC").all()
    assert set(df.loc[df.estimator == "rqmc-sobol", "n_units"]) == {8}
    assert set(df.loc[df.estimator == "rqmc-halton:4", "n_units"]) == {4}
    assert np.all(np.abs(df["error"]) < 0.05)


# -- runner -----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def small_run():
    return lab.run(["mc", "jittered", "is:linear"], ["exp", "sin"], [64, 256], 6, rng=7)


def test_run_shape_and_columns(small_run):
    df = small_run
    assert len(df) == 3 * 2 * 2 * 6
    for col in ("estimator", "integrand", "n", "rep", "value", "stderr", "exact", "error", "seconds", "n_evals",
                "n_units", "points", "class", "dim_u", "smooth", "probe"):
        assert col in df, col
    assert set(df["estimator"]) == {"mc", "jittered", "is:linear"}
    assert set(df["rep"]) == set(range(6))
    assert (df["n_evals"] == df["n"]).all()
    np.testing.assert_allclose(df["error"], df["value"] - df["exact"])
    assert df.loc[df.integrand == "exp", "exact"].iloc[0] == pytest.approx(np.e - 1)
    assert set(df.loc[df.estimator == "jittered", "points"]) == {"stratified"}
    assert (df.groupby(["estimator", "integrand", "n"]).size() == 6).all()


def test_same_seed_same_frame(small_run):
    again = lab.run(["mc", "jittered", "is:linear"], ["exp", "sin"], [64, 256], 6, rng=7)
    pd.testing.assert_frame_equal(small_run.drop(columns="seconds"), again.drop(columns="seconds"), check_exact=True)
    other = lab.run(["mc", "jittered", "is:linear"], ["exp", "sin"], [64, 256], 6, rng=8)
    assert not np.array_equal(small_run["value"], other["value"])
    ss = lab.run(["mc"], ["exp"], [64], 2, rng=np.random.SeedSequence(7))
    pd.testing.assert_frame_equal(ss.drop(columns="seconds"),
                                  small_run[(small_run.estimator == "mc") & (small_run.integrand == "exp")
                                            & (small_run.n == 64) & (small_run.rep < 2)]
                                  .reset_index(drop=True).drop(columns="seconds"), check_exact=True)


def test_order_and_subset_independence(small_run):
    # another order of estimators, integrands and counts, and a subset of everything
    part = lab.run(["is:linear", "mc"], ["sin", "exp"], [256, 64], 3, rng=7)
    ref = small_run[small_run.estimator.isin(["is:linear", "mc"]) & (small_run.rep < 3)]
    _same_numbers(ref[part.columns], part)


def test_workers_give_identical_results(small_run):
    par = lab.run(["mc", "jittered", "is:linear"], ["exp", "sin"], [64, 256], 6, rng=7, workers=2)
    _same_numbers(small_run, par)


def test_unit_seed_is_the_spawn_tree_child():
    root = np.random.SeedSequence(123)
    child = root.spawn(3)[2].spawn(5)[4]
    a = np.random.default_rng(unit_seed(np.random.SeedSequence(123), 2, 4)).random(4)
    np.testing.assert_array_equal(a, np.random.default_rng(child).random(4))


def test_crn_gives_common_numbers():
    df = lab.run(["mc", ("mc again", MonteCarlo())], ["exp"], [64], 3, rng=1, crn=True)
    a, b = (df[df.estimator == e]["value"].to_numpy() for e in ("mc", "mc again"))
    np.testing.assert_array_equal(a, b)
    indep = lab.run(["mc", ("mc again", MonteCarlo())], ["exp"], [64], 3, rng=1)
    a, b = (indep[indep.estimator == e]["value"].to_numpy() for e in ("mc", "mc again"))
    assert not np.array_equal(a, b)


def test_tuples_objects_and_skip():
    custom = Integrand(lambda x: 3 * x[..., 0] ** 2, [(0, 1)], 1.0, "cubic")
    df = lab.run([("plain", MonteCarlo()), ("strat", MonteCarlo(), "stratified"), "cv"],
                 [custom, "exp"], [64], 2, rng=0, skip=True)
    assert set(df["integrand"]) == {"cubic", "exp"}
    assert set(df.loc[df.integrand == "cubic", "estimator"]) == {"plain", "strat"}
    assert df.attrs["skipped"] == [{"estimator": "cv", "integrand": "cubic",
                                    "reason": df.attrs["skipped"][0]["reason"]}]
    with pytest.raises(ValueError, match="no control variate"):
        lab.run(["cv"], [custom], [64], 2)


def test_run_argument_errors():
    with pytest.raises(ValueError, match="unknown estimator recipe"):
        lab.run(["mc", "bogus"], ["exp"], [64], 2)
    with pytest.raises(ValueError, match="unknown integrand 'nope'"):
        lab.run(["mc"], ["nope"], [64], 2)
    with pytest.raises(ValueError, match="duplicate labels"):
        lab.run(["mc", "mc"], ["exp"], [64], 2)
    with pytest.raises(ValueError, match="reps"):
        lab.run(["mc"], ["exp"], [64], 0)
    with pytest.raises(TypeError, match="rng"):
        lab.run(["mc"], ["exp"], [64], 2, rng=np.random.default_rng(0))
    with pytest.raises(TypeError, match="cannot send"):
        lab.run([("lambda-f", MonteCarlo())], [Integrand(lambda x: x[..., 0], [(0, 1)], 0.5, "lin")],
                [64, 128], 2, workers=2)


def test_progress_callback_and_bar(capsys, monkeypatch):
    import io
    import sys

    from vrlab.lab.runner import ProgressBar

    seen = []
    lab.run(["mc"], ["exp"], [64, 128], 3, progress=lambda done, total: seen.append((done, total)))
    assert seen[-1] == (6, 6) and all(a[0] < b[0] for a, b in zip(seen, seen[1:]))
    lab.run(["mc"], ["exp"], [64], 3, progress=True)
    assert capsys.readouterr().err == ""             # stderr is not a terminal: quiet (tqdm's rule)

    class Terminal(io.StringIO):
        def isatty(self):
            return True
    tty = Terminal()
    monkeypatch.setattr(sys, "stderr", tty)
    lab.run(["mc"], ["exp"], [64], 3, progress=True)
    # the bar counts integrand evaluations: 3 repetitions x n = 64 samples, in samples/s
    assert "192/192" in tty.getvalue() and "samples/s" in tty.getvalue() and tty.getvalue().startswith("\rlab:")
    forced = io.StringIO()
    bar = ProgressBar(4, stream=forced, label="render", disable=False)
    bar.update(1)
    bar.update(bar.done + 2 - bar.done)
    assert bar.done == 3
    bar.update(1)
    assert "render" in forced.getvalue() and "4/4" in forced.getvalue() and forced.getvalue().endswith("\n")


# -- summary ----------------------------------------------------------------------------------
def test_summarize_by_hand():
    v = np.array([1.0, 1.2, 0.7, 1.1])
    s = np.array([0.1, 0.1, 0.1, 0.05])
    df = pd.DataFrame({"estimator": "e", "integrand": "i", "n": 10, "rep": range(4), "value": v,
                       "stderr": s, "exact": 1.0, "seconds": [0.1, 0.2, 0.3, 0.2]})
    row = lab.summarize(df).iloc[0]
    err = v - 1.0
    z = err / s
    assert row["reps"] == 4
    assert row["mean"] == pytest.approx(v.mean())
    assert row["bias"] == pytest.approx(v.mean() - 1.0)
    assert row["rmse"] == pytest.approx(np.sqrt(np.mean(err**2)))
    assert row["variance"] == pytest.approx(np.var(v, ddof=1))
    assert row["mean_stderr"] == pytest.approx(s.mean())
    assert row["z_std"] == pytest.approx(np.std(z, ddof=1))
    assert row["coverage"] == pytest.approx(np.mean(np.abs(err) <= 1.959963984540054 * s))
    assert row["coverage"] == 0.25      # only the exact first repetition lies within 1.96 stderr
    assert row["seconds"] == pytest.approx(0.2)
    assert row["efficiency"] == pytest.approx(1 / (np.var(v, ddof=1) * 0.2))
    # exact estimates with zero stderr count as covered, z = 0
    exact = df.assign(value=1.0, stderr=0.0)
    r2 = lab.summarize(exact).iloc[0]
    assert r2["coverage"] == 1.0 and r2["z_std"] == 0.0 and r2["rmse"] == 0.0


def test_summary_of_a_run_is_calibrated(small_run):
    s = lab.summarize(small_run)
    assert len(s) == 12
    mc = s[s.estimator == "mc"]
    assert np.all(np.abs(mc["bias"]) < 4 * np.sqrt(mc["variance"] / mc["reps"]))


def _synthetic(slope, cls="MonteCarlo", points="independent", dim_u=1, smooth=True, noise=0.0):
    n = np.array([64, 256, 1024, 4096])
    rmse = 3.0 * n ** slope * np.exp(noise * np.array([1, -1, 1, -1]))
    return pd.DataFrame({"estimator": "e", "integrand": "i", "n": n, "rmse": rmse, "class": cls,
                         "points": points, "dim_u": dim_u, "smooth": smooth})


def test_fit_slopes_on_synthetic_data():
    r = lab.fit_slopes(_synthetic(-0.75)).iloc[0]
    assert r["slope"] == pytest.approx(-0.75, abs=1e-12)
    assert r["intercept"] == pytest.approx(np.log(3.0), abs=1e-12)
    assert r["slope_se"] == pytest.approx(0.0, abs=1e-12)
    assert r["theory"] == -0.5 and r["points_used"] == 4
    noisy = lab.fit_slopes(_synthetic(-0.5, noise=0.05)).iloc[0]
    assert abs(noisy["slope"] + 0.5) < 0.05 and noisy["slope_se"] > 0


@pytest.mark.parametrize("cls, points, d, smooth, theory", [
    ("MonteCarlo", "independent", 2, True, -0.5),
    ("Antithetic", "independent", 1, True, -0.5),
    ("MonteCarlo", "stratified", 1, True, -1.5),
    ("MonteCarlo", "stratified", 2, True, -1.0),
    ("MonteCarlo", "stratified", 2, False, -0.75),
    ("Stratified", "independent", 1, True, -1.5),
    ("MonteCarlo", "lhs", 1, True, -1.5),
    ("MonteCarlo", "lhs", 2, True, -0.5),
    ("RQMC", "sobol", 2, True, -1.5),              # scrambled nets on smooth f: Owen 1997
    ("RQMC", "sobol", 1, True, -1.5),
    ("RQMC", "halton", 2, True, -1.0),             # not a net: Koksma-Hlawka
    ("RQMC", "sobol", 2, False, -0.5 - 1 / 6),     # discontinuous: He & Wang 2015
    ("RQMC", "halton", 2, False, -0.5 - 1 / 6),
])
def test_theoretical_slopes(cls, points, d, smooth, theory):
    assert lab.fit_slopes(_synthetic(-0.5, cls, points, d, smooth)).iloc[0]["theory"] == pytest.approx(theory)


def test_fitted_slopes_of_a_run():
    df = lab.run(["mc", "jittered"], ["exp"], [64, 256, 1024, 4096], 30, rng=2)
    sl = lab.fit_slopes(df).set_index("estimator")
    assert abs(sl.loc["mc", "slope"] + 0.5) < 0.2
    assert abs(sl.loc["jittered", "slope"] + 1.5) < 0.2
    assert sl.loc["jittered", "theory"] == -1.5


def test_equal_time(small_run):
    t = lab.equal_time(small_run)
    assert (t["reference"] == "mc").all()
    ref = t[t.estimator == "mc"]
    np.testing.assert_allclose(ref["efficiency_gain"], 1.0)
    row = t[(t.estimator == "jittered") & (t.integrand == "exp") & (t.n == 256)].iloc[0]
    mc = ref[(ref.integrand == "exp") & (ref.n == 256)].iloc[0]
    assert row["efficiency_gain"] == pytest.approx(mc["var_x_time"] / (row["variance"] * row["seconds"]))
    assert row["efficiency_gain"] > 10     # jittered on a smooth 1D integrand
    assert (lab.equal_time(small_run, reference="jittered")["reference"] == "jittered").all()
    with pytest.raises(ValueError, match="no estimator 'x'"):
        lab.equal_time(small_run, reference="x")


# -- plots ------------------------------------------------------------------------------------
def test_plots_are_written(small_run, tmp_path):
    zero = small_run.assign(value=small_run["exact"], stderr=0.0, estimator=small_run["estimator"] + "!")
    df = pd.concat([small_run, zero[zero.estimator == "mc!"]])   # an exact estimator (RMSE 0) too
    for fn, name in ((lab.convergence_plot, "conv.png"), (lab.efficiency_plot, "eff.png")):
        path = fn(df, tmp_path / name)
        assert path.exists() and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert path.stat().st_size > 10_000


#: many estimators on two integrands with different applicable sets, over less than a decade
#: of n (where log axes used to label crowded minor ticks)
MANY = ["mc", "is:linear", "is:brdf", "is:light", "mis-balance", "defensive", "antithetic", "cv", "jittered",
        "lhs", "stratified"]


@pytest.fixture(scope="module")
def many_run():
    return lab.run(MANY, ["exp", "glossy-light"], [16, 32, 64, 128], 4, rng=3, skip=True)


def _panels(fig):
    """Axes that hold curves or bars (colour bars and legends excluded)."""
    return [ax for ax in fig.axes if ax.lines or ax.patches]


def _colours_by_estimator(fig) -> dict:
    """estimator -> set of line colours over every panel (label ``estimator, slope (theory)``)."""
    from matplotlib.colors import to_hex

    seen: dict = {}
    for ax in _panels(fig):
        for line in ax.lines:
            seen.setdefault(line.get_label().split(",")[0], set()).add(to_hex(line.get_color()))
    return seen


def test_convergence_figure_small_multiples_keep_colours(many_run):
    from matplotlib.colors import to_hex

    fig = lab.plots.convergence_figure(many_run)
    panels = _panels(fig)
    assert len(panels) == len(fig.axes) >= 4             # small multiples, no empty cells
    for ax in panels:
        assert len(ax.lines) <= lab.plots.MAX_LINES, ax.get_title()
        assert ax.get_xlabel() and ax.get_ylabel() and ax.get_title()
        assert ax.get_legend() is not None
        assert ax.lines[0].get_label().startswith("mc,")   # the reference in every panel, black
        assert to_hex(ax.lines[0].get_color()) == "#000000"
    colours = _colours_by_estimator(fig)
    # every estimator that ran is drawn, each in one colour in every panel, no two alike
    assert set(colours) == set(many_run["estimator"])
    assert all(len(c) == 1 for c in colours.values()), colours
    assert len({next(iter(c)) for c in colours.values()}) == len(colours)
    # each integrand's estimators are all drawn (on its own panels)
    for name, g in many_run.groupby("integrand"):
        drawn = {line.get_label().split(",")[0] for ax in panels if ax.get_title().startswith(name + ":")
                 for line in ax.lines}
        assert drawn == set(g["estimator"]), name
    assert lab.plots.overlapping_tick_labels(fig) == []


def test_efficiency_figure_uses_the_convergence_colours(many_run):
    from matplotlib.colors import to_hex

    lines = {k: next(iter(v)) for k, v in _colours_by_estimator(lab.plots.convergence_figure(many_run)).items()}
    fig = lab.plots.efficiency_figure(many_run)
    for ax in _panels(fig):
        assert ax.get_xlabel() and ax.get_ylabel() and ax.get_title()
        names = {round(t.get_position()[1]): t.get_text() for t in ax.get_yticklabels()}
        assert len(ax.patches) == len(names) > 0
        for bar in ax.patches:
            name = names[round(bar.get_y() + bar.get_height() / 2)]
            assert to_hex(bar.get_facecolor()) == lines[name], name
    assert lab.plots.overlapping_tick_labels(fig) == []


def test_tidy_tick_labels_removes_overlaps():
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(2.5, 2), dpi=110)
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    ticks = np.arange(30)
    ax.set_xticks(ticks, [f"label {k}" for k in ticks])
    ax.set_yscale("log")
    ax.set_ylim(0.8, 1.6)                                 # log axis under one decade: labelled minor ticks
    ax.set_yticks(np.linspace(0.8, 1.6, 30), minor=True)
    ax.set_yticklabels([f"{v:.3f}" for v in np.linspace(0.8, 1.6, 30)], minor=True)
    assert len(lab.plots.overlapping_tick_labels(fig)) > 10
    fig.tight_layout()
    lab.plots.tidy_tick_labels(fig)
    assert lab.plots.overlapping_tick_labels(fig) == []
    kept = [t for t in ax.get_xticklabels() if t.get_text()]
    assert 2 <= len(kept) < 30 and kept[0].get_text() == "label 0"


def test_estimator_styles_follow_the_first_appearance():
    styles = lab.plots.estimator_styles(["cv", "mc", "lhs", "cv"])
    assert styles["mc"] == ("black", "o")
    assert styles["cv"] == (lab.plots.PALETTE[0], lab.plots.MARKERS[1])
    assert styles["lhs"] == (lab.plots.PALETTE[1], lab.plots.MARKERS[2])
    assert lab.plots.estimator_styles(["a", "b"])["a"] == ("black", "o")     # no mc: the first


# -- command line -----------------------------------------------------------------------------
def test_cli_list(capsys):
    assert main(["lab", "--list"]) == 0
    out = capsys.readouterr().out
    assert "mis-balance[:<a+b>]" in out and "glossy-light" in out and "is:brdf" in out
    assert main(["lab", "--list", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert "is:linear" in data["integrands"]["exp"]["applicable"]
    assert "cv" in data["integrands"]["glossy-light"]["not_applicable"]
    assert any(r["recipe"] == "ris:<m>" for r in data["recipes"])


def test_cli_run_json_csv_plot(capsys, tmp_path):
    csv, png = tmp_path / "runs.csv", tmp_path / "conv.png"
    rc = main(["lab", "--integrand", "exp", "--estimators", "mc,jittered,is:linear", "--n", "64,256",
               "--reps", "4", "--seed", "3", "--json", "--csv", str(csv), "--plot", str(png), "--no-progress"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "NaN" not in text and "Infinity" not in text        # strict JSON
    data = json.loads(text)
    assert {"summary", "slopes", "equal_time"} <= set(data)
    assert len(data["summary"]) == 6 and len(data["slopes"]) == 3
    runs = pd.read_csv(csv)
    assert len(runs) == 3 * 2 * 4
    assert png.exists()
    same = lab.run(["mc", "jittered", "is:linear"], ["exp"], [64, 256], 4, rng=3)
    np.testing.assert_array_equal(runs["value"].to_numpy(), same["value"].to_numpy())


def test_cli_plot_has_no_overlapping_ticks(capsys, tmp_path, monkeypatch):
    figures = []
    draw = lab.plots.convergence_figure

    def keep(*args, **kwargs):
        figures.append(draw(*args, **kwargs))
        return figures[-1]

    monkeypatch.setattr(lab.plots, "convergence_figure", keep)
    png = tmp_path / "conv.png"
    # three integrands over less than a decade of n: the case whose minor tick labels collided
    assert main(["lab", "--integrand", "exp,sin,glossy-light", "--estimators", "mc,antithetic,mis-balance",
                 "--n", "16,32,64,128", "--reps", "3", "--plot", str(png), "--no-progress"]) == 0
    capsys.readouterr()
    assert png.exists() and len(figures) == 1
    assert lab.plots.overlapping_tick_labels(figures[0]) == []
    assert all(len(ax.lines) <= lab.plots.MAX_LINES for ax in figures[0].axes)


def test_cli_run_table(capsys):
    assert main(["lab", "--integrand", "exp,sin", "--estimators", "mc,antithetic", "--n", "64,128",
                 "--reps", "3", "--workers", "1"]) == 0
    out = capsys.readouterr().out
    assert "RMSE slopes" in out and "antithetic" in out and "efficiency_gain" in out


@pytest.mark.parametrize("argv, match", [
    (["--integrand", "nope", "--estimators", "mc"], "unknown 'nope'; choose from sin, step-x2, exp"),
    (["--integrand", "exp", "--estimators", "mc,bogus"], "unknown estimator recipe 'bogus'; choose from mc"),
    (["--integrand", "glossy-light", "--estimators", "cv"], "no control variate"),
    (["--integrand", "exp", "--estimators", "mc", "--n", "64,x"], "--n"),
    (["--integrand", "exp", "--estimators", "mc", "--reps", "1"], "--reps"),
    (["--integrand", "exp"], "give --integrand and --estimators"),
])
def test_cli_errors(capsys, argv, match):
    with pytest.raises(SystemExit) as exc:
        main(["lab", *argv])
    assert exc.value.code == 2
    assert match in capsys.readouterr().err


def test_bench_cli_has_estimators_suite(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["bench", "--help"])
    assert exc.value.code == 0
    assert "estimators" in capsys.readouterr().out


def test_a_randomised_point_set_instance_is_rerandomised_per_unit():
    """A scrambled engine instance gives independent repetitions and the same numbers on
    every run (it is re-randomised from each unit's seed, not copied with its scramble)."""
    import vrlab.points as P
    from vrlab import lab
    from vrlab.estimators import MonteCarlo

    spec = [("halton", MonteCarlo(), P.Halton(2, scramble=True)), ("plain", MonteCarlo(), P.Halton(2))]
    a = lab.run(spec, ["smooth-2d"], [64], 6, rng=5)
    b = lab.run([("halton", MonteCarlo(), P.Halton(2, scramble=True)), ("plain", MonteCarlo(), P.Halton(2))],
                ["smooth-2d"], [64], 6, rng=5)
    assert np.array_equal(a["value"].to_numpy(), b["value"].to_numpy())
    scr = a.loc[a["estimator"] == "halton", "value"].to_numpy()
    det = a.loc[a["estimator"] == "plain", "value"].to_numpy()
    assert len(np.unique(scr)) == 6            # six independent scrambles
    assert len(np.unique(det)) == 1            # a deterministic set: the same points every time
