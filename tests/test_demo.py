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
