"""``vrlab demo`` without running it whole: headers before work, the stderr trust flags
against their closed forms and on simulated honest / overconfident errors, the plain (not
squared) centred discrepancy, and a failing background figure.  The full quick run is
``tests/test_cli.py::test_quick_demo_writes_its_outputs``."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from vrlab import demo
from vrlab import points as P

HEADERS = {"warp_table": "Warps:", "discrepancy_table": "Point sets:", "speed_tables": "Speed:",
           "lab_section": "Lab:", "render_section": "Renderer:"}


def test_each_header_prints_before_its_work_starts(monkeypatch, capsys, tmp_path):
    printed, order = [], []

    def stub(name, result):
        def work(*args, **kwargs):
            printed.append(capsys.readouterr().out)
            order.append(name)
            # the section's header is already out, the next section's is not
            assert HEADERS[name] in printed[-1], (name, printed[-1])
            later = list(HEADERS.values())[list(HEADERS).index(name) + 1:]
            assert not any(h in "".join(printed) for h in later)
            return result
        return work

    monkeypatch.setattr(demo, "warp_table", stub("warp_table", (pd.DataFrame({"warp": ["w"]}), [])))
    monkeypatch.setattr(demo, "discrepancy_table", stub("discrepancy_table", pd.DataFrame({64: [0.1]})))
    monkeypatch.setattr(demo, "speed_tables", stub("speed_tables", {"qmc": pd.DataFrame({"task": ["halton"]})}))
    monkeypatch.setattr(demo, "lab_section", stub("lab_section", {}))
    monkeypatch.setattr(demo, "render_section", stub("render_section", pd.DataFrame({"strategy": ["bsdf"]})))
    monkeypatch.setattr(demo, "draw_warps", lambda *a: None)
    monkeypatch.setattr(demo, "draw_point_sets", lambda *a: None)
    summary = demo.run_demo(tmp_path, quick=True)
    assert order == list(HEADERS)
    assert set(summary["sections"]) >= {"warps", "point sets", "speed", "lab", "render"}


def test_trust_thresholds_are_the_chi_square_band_and_binomial_quantile():
    reps, rows = 12, 20
    th = demo.trust_thresholds(reps, 2 * rows)
    alpha = 1 - 0.99 ** (1 / (2 * rows))
    assert th["alpha"] == pytest.approx(alpha, rel=1e-12)
    q = stats.chi2.ppf([alpha / 2, 1 - alpha / 2], reps - 1) / (reps - 1)
    assert (th["z_lo"], th["z_hi"]) == pytest.approx(tuple(np.sqrt(q)), rel=1e-10)
    k = round(th["min_cover"] * reps)
    # the smallest count of covering intervals that binomial chance allows at level alpha
    assert stats.binom.cdf(k, reps, 0.95) >= alpha > stats.binom.cdf(k - 1, reps, 0.95)


def test_stderr_flags_mark_overconfident_and_conservative_rows():
    th = demo.trust_thresholds(40, 10)
    table = pd.DataFrame({
        "reps": [40] * 5,
        "z_std": [1.0, th["z_hi"] * 1.05, 1.0, th["z_lo"] * 0.5, np.nan],
        "coverage": [0.95, 0.95, th["min_cover"] - 1 / 40, 1.0, np.nan],
    })
    assert list(demo.stderr_flags(table)) == ["", "!", "!", "~", ""]


def _simulated_tables(scale: float, tables: int = 300, rows: int = 30, reps: int = 12) -> pd.DataFrame:
    """Lab tables whose z-scores are N(0, scale^2): scale 1 means honest standard errors."""
    z = scale * np.random.default_rng(5).standard_normal((tables, rows, reps))
    return pd.DataFrame({"table": np.repeat(np.arange(tables), rows), "reps": reps,
                         "z_std": z.std(axis=2, ddof=1).ravel(),
                         "coverage": (np.abs(z) <= stats.norm.ppf(0.975)).mean(axis=2).ravel()})


def test_stderr_flags_rarely_fire_on_honest_errors_and_catch_overconfident_ones():
    honest = _simulated_tables(1.0)
    flagged = sum((demo.stderr_flags(t) != "").any() for _, t in honest.groupby("table"))
    # 1 % family-wise per table: about 3 of 300 tables; 12 is far in the binomial tail
    assert flagged <= 12
    # stderr 2.5 times too small (z_std ~ 2.5): most rows are caught, none called conservative
    over = _simulated_tables(2.5)
    flags = np.concatenate([demo.stderr_flags(t).to_numpy() for _, t in over.groupby("table")])
    assert (flags == "!").mean() > 0.7 and not (flags == "~").any()
    # stderr ten times too large: every row is called conservative
    under = _simulated_tables(0.1)
    flags = np.concatenate([demo.stderr_flags(t).to_numpy() for _, t in under.groupby("table")])
    assert (flags == "~").all()


def _cd_squared(x: np.ndarray) -> float:
    """Hickernell's centred L2 discrepancy squared, from its closed form."""
    n, d = x.shape
    a = np.abs(x - 0.5)
    first = (13 / 12) ** d
    second = 2 / n * np.prod(1 + 0.5 * a - 0.5 * a**2, axis=1).sum()
    pair = 1 + 0.5 * a[:, None, :] + 0.5 * a[None, :, :] - 0.5 * np.abs(x[:, None, :] - x[None, :, :])
    return float(first - second + np.prod(pair, axis=2).sum() / n**2)


def test_discrepancy_table_reports_cd_not_its_square():
    table = demo.discrepancy_table(seed=3, ns=(64,))
    x = P.Hammersley(2).random(64)          # deterministic: the demo's own set
    assert table.loc["hammersley", 64] == pytest.approx(np.sqrt(_cd_squared(x)), rel=1e-9)


def _fail(path):
    raise RuntimeError("boom")


def test_a_failing_background_figure_is_reported_by_name(tmp_path):
    painter = demo._Painter()
    painter.draw("ok.png", lambda: (tmp_path / "ok.png").write_text("x"))
    painter.draw("broken.png", _fail, tmp_path / "broken.png")
    with pytest.raises(RuntimeError, match="broken.png") as info:
        painter.wait()
    assert "ok.png" not in str(info.value) and (tmp_path / "ok.png").exists()


# -- figures ------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def warp_panels():
    from vrlab import _demo_samplers as S

    return S.warp_table(seed=4, n=6000)[1]


def _plot_axes(fig):
    """The axes of a figure other than colour bars (which carry one label, checked apart)."""
    return [ax for ax in fig.axes if not hasattr(ax, "_colorbar")]


def _assert_labelled(fig):
    from vrlab.lab.plots import overlapping_tick_labels

    for ax in _plot_axes(fig):
        assert ax.get_xlabel().strip() and ax.get_ylabel().strip() and ax.get_title().strip(), ax.get_title()
        assert "(" in ax.get_xlabel() and "(" in ax.get_ylabel(), (ax.get_xlabel(), ax.get_ylabel())    # units
    for ax in fig.axes:
        if hasattr(ax, "_colorbar"):
            assert ax.get_ylabel().strip()
    assert overlapping_tick_labels(fig) == []


def test_warps_figure_fills_its_grid_and_shows_each_pdf(warp_panels):
    from matplotlib.colors import to_hex

    from vrlab import _demo_samplers as S

    fig = S.warps_figure(warp_panels)
    axes = _plot_axes(fig)
    rows, cols = axes[0].get_subplotspec().get_gridspec().get_geometry()
    assert len(axes) == rows * cols                     # no empty cells
    assert fig.legends, "the figure has no legend"
    _assert_labelled(fig)
    expected = to_hex(S.EXPECTED)
    images = [ax.images[0] for ax in axes if ax.images]
    assert len(images) == 2 and images[0].get_clim() == images[1].get_clim()    # samples | pdf, one scale
    for ax in axes:
        if ax.images:
            continue
        # every histogram of samples has the density its pdf predicts beside it
        assert ax.patches and any(to_hex(line.get_color()) == expected for line in ax.lines), ax.get_title()
    titles = " ".join(ax.get_title() for ax in axes)
    for name in ("disk", "triangle", "image luminance 2D: samples", "image luminance 2D: pdf"):
        assert name in titles


def test_chart_marginals_match_their_closed_forms():
    from vrlab import _demo_samplers as S
    from vrlab import distributions as D
    from vrlab import testing as T

    # uniform disk: s = r^2 is uniform, so the radius has density 2 r; the angle 1 / (2 pi) per radian
    u, f = S._chart_marginal(D.Disk(), T.DiskChart(), 0)
    np.testing.assert_allclose(f, 1.0, rtol=1e-9)
    u, f = S._chart_marginal(D.Disk(), T.DiskChart(), 1)
    np.testing.assert_allclose(f, 1.0, rtol=1e-9)
    # uniform triangle: the barycentric weight b of a vertex has density 2 (1 - b)
    tri = ((0, 0), (1, 0), (0.3, 0.9))
    u, f = S._chart_marginal(D.Triangle(*tri), T.TriangleChart(*tri), 0)
    np.testing.assert_allclose(f, 2 * (1 - u), rtol=1e-9)
    # box light by area: each face's share of the atlas coordinate is its area over the total
    half = (1.0, 0.5, 0.25)
    u, f = S._chart_marginal(D.BoxSurface((0, 0, 0), half), T.box_surface_chart((0, 0, 0), half), 0)
    areas = np.repeat([4 * half[1] * half[2], 4 * half[0] * half[2], 4 * half[0] * half[1]], 2)
    share = [f[(u >= k / 6) & (u < (k + 1) / 6)].mean() / 6 for k in range(6)]   # f is constant per face
    np.testing.assert_allclose(share, areas / areas.sum(), rtol=1e-9)


def test_point_sets_figure_is_labelled():
    from vrlab import _demo_samplers as S

    _assert_labelled(S.point_sets_figure(seed=1))


def test_veach_figure_shares_one_auto_exposure(monkeypatch, tmp_path):
    """The three panels share the auto exposure of the reference, and the figure's title says
    so exactly once (the demo's title does not repeat what compare_figure appends)."""
    import vrlab.render.compare as C
    from vrlab.render.image import auto_exposure

    seen = {}
    real_compare = C.compare

    def compare(*args, **kwargs):
        seen["reference"] = kwargs["reference"]
        return real_compare(*args, **kwargs)

    def panels(items, path, *, title, exposure):
        seen.update(title=title, exposure=exposure, images=len(items))
        return path

    monkeypatch.setattr(C, "compare", compare)
    monkeypatch.setattr(C, "panels_figure", panels)
    demo.render_section(tmp_path, seed=3, quick=True)
    assert seen["images"] == 3
    assert seen["exposure"] == pytest.approx(auto_exposure(seen["reference"]), rel=1e-12)
    assert seen["exposure"] != 1.0 and "exposure: auto, shared" in seen["title"]
    assert seen["title"].count(f"{seen['exposure']:.3g}") == 1 and seen["title"].count("exposure:") == 1


def test_theory_notes_give_the_rate_for_each_estimator_and_integrand():
    """The demo's theory lines come from lab.fit_slopes: scrambled Sobol' RQMC on the smooth
    integrands (Owen's -3/2) and on the discontinuous glossy-light (He & Wang) on lines of
    their own, each naming the rows it applies to."""
    from vrlab.lab import fit_slopes
    from vrlab.lab.summary import theoretical_slope

    rows = []
    for integrand, smooth in (("exp", True), ("sin", True), ("glossy-light", False)):
        for est, cls, pts in (("mc", "MonteCarlo", "independent"), ("rqmc-sobol", "RQMC", "sobol")):
            for k, n in enumerate((64, 256, 1024)):
                for rep in range(2):
                    rows.append({"estimator": est, "integrand": integrand, "n": n, "rep": rep, "value": 1.0,
                                 "stderr": 0.1, "exact": 1.0, "error": 0.1 * (1 + rep) / 2 ** k, "seconds": 0.1,
                                 "n_evals": n, "n_units": n, "class": cls, "points": pts,
                                 "dim_u": 1 if integrand != "glossy-light" else 2, "smooth": smooth})
    lines = demo.theory_notes(fit_slopes(pd.DataFrame(rows)))
    smooth_rate, note = theoretical_slope("RQMC", "sobol", 1, True)
    assert smooth_rate == -1.5
    assert f"  -1.5: {note}: rqmc-sobol on exp, sin" in lines
    assert any(line.startswith("  -0.667: ") and line.endswith("rqmc-sobol on glossy-light") for line in lines)
    assert any(line.startswith("  -0.5: ") and "mc on exp, sin, glossy-light" in line for line in lines)


def test_a_chi_square_message_keeps_small_expected_counts():
    """A cell's expected count of 0.005 prints as 0.005, not 0.0."""
    from vrlab.testing.chisquare import GofResult

    res = GofResult("x", 12.0, 3, 0.01, 100, 100.0, 0, [((1, 2), 3, 0.005), ((0, 0), 40, 25.25)])
    text = res.message()
    assert "observed 3, expected 0.005" in text and "observed 40, expected 25.2" in text
