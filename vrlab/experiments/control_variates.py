"""Control variates (lecture 000): alpha = 1 against the optimal alpha, and when either pays off.

Setting of the lecture: f and a control h with the same variance sigma^2 and correlation rho.
Per sample (N samples, H = int h known):

* plain Monte Carlo                      Var = sigma^2
* alpha = 1, f - h + H                   Var = 2 sigma^2 (1 - rho)
* optimal alpha = Cov(f, h) / Var(h)     Var = sigma^2 (1 - rho^2)

Two ways to compare:

* equal N (h is free):  alpha = 1 wins iff rho > 1/2; the optimal alpha wins iff rho != 0.
* equal cost (evaluating h costs as much as f, so plain MC gets 2N samples, variance
  sigma^2 / (2N)): alpha = 1 wins iff rho > 3/4 (the lecture's condition);
  the optimal alpha wins iff 1 - rho^2 < 1/2, i.e. |rho| > 1/sqrt(2) ~ 0.707.
  (The slide concludes |corr| > 1/4 from corr^2 > 1/2; the square root gives 1/sqrt(2).)

The sweep uses f(u) = 1 + sqrt(12)(u1 - 1/2) and h_rho(u) = rho sqrt(12)(u1 - 1/2)
+ sqrt(1 - rho^2) sqrt(12)(u2 - 1/2) on [0, 1]^2: Var f = Var h = 1, corr = rho, int h = 0.
Golden numbers: e^x on [0, 1] with control h = x gives beta* = 1.6903, 1 - rho^2 = 0.01628.

Run ``python -m vrlab.experiments.control_variates [--full] [--out DIR]``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import matplotlib.pyplot as plt
import pandas as pd

from vrlab import Integrand, lab
from vrlab._rng import spawn
from vrlab.estimators import ControlVariate, MonteCarlo
from vrlab.integrands import catalogue
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure

from ._figures import convergence_panel

DEFAULT_OUT = Path("vrlab-out") / "control_variates"          # relative to the working folder
S12 = np.sqrt(12.0)
THRESHOLDS = {"alpha1_equal_n": 0.5, "alpha1_equal_cost": 0.75, "optimal_equal_cost": float(1 / np.sqrt(2))}


def sweep_integrand() -> Integrand:
    """f(u) = 1 + sqrt(12)(u1 - 1/2) on [0, 1]^2: mean 1, variance 1."""
    return Integrand(lambda x: 1.0 + S12 * (x[..., 0] - 0.5), [(0, 1), (0, 1)], 1.0, "linear-2d", f2=2.0)


def control(rho: float):
    """h_rho with Var h = 1, corr(f, h) = rho, int h = 0."""
    c = np.sqrt(max(0.0, 1.0 - rho * rho))
    return lambda x: S12 * (rho * (x[..., 0] - 0.5) + c * (x[..., 1] - 0.5))


def theory_variances(rho):
    rho = np.asarray(rho, float)
    return {"plain": np.ones_like(rho), "alpha1": 2 * (1 - rho), "optimal": 1 - rho**2}


def correlation_sweep(rhos, n: int, reps: int, seed: int) -> pd.DataFrame:
    """Per rho: measured per-sample variances (mean over ``reps`` runs of ``n`` samples)."""
    f = sweep_integrand()
    rows = []
    for i, rho in enumerate(rhos):
        ests = {"plain": MonteCarlo(), "alpha1": ControlVariate(control(rho), 0.0, alpha=1.0),
                "optimal": ControlVariate(control(rho), 0.0, alpha="optimal")}
        gens = spawn(np.random.SeedSequence([seed, i]), reps)
        th = theory_variances(rho)
        for name, est in ests.items():
            v = np.array([est.estimate(f, n, rng=g).variance for g in gens])
            rows.append({"rho": rho, "estimator": name, "var_measured": v.mean(),
                         "var_se": v.std(ddof=1) / np.sqrt(reps), "var_theory": float(th[name])})
    return pd.DataFrame(rows)


def crossings(table: pd.DataFrame) -> dict:
    """Measured rho where each comparison flips (linear interpolation of the variance ratios)."""
    w = table.pivot(index="rho", columns="estimator", values="var_measured").sort_index()
    r = w.index.to_numpy()

    def last_crossing(ratio, level):
        s = np.sign(ratio - level)
        k = np.nonzero(np.diff(s) != 0)[0]
        if not len(k):
            return np.nan
        k = k[-1]
        return float(r[k] + (level - ratio[k]) * (r[k + 1] - r[k]) / (ratio[k + 1] - ratio[k]))
    a1 = (w["alpha1"] / w["plain"]).to_numpy()
    op = (w["optimal"] / w["plain"]).to_numpy()
    return {"alpha1_equal_n": last_crossing(a1, 1.0), "alpha1_equal_cost": last_crossing(a1, 0.5),
            "optimal_equal_cost": last_crossing(op, 0.5)}


def exp_golden(n: int, reps: int, seed: int) -> dict:
    """e^x with control h = x: fitted alpha and variance factor against beta* and 1 - rho^2."""
    f = catalogue.get("exp")
    est = ControlVariate(lambda x: x[..., 0], 0.5, alpha="optimal")
    res = [est.estimate(f, n, rng=g) for g in spawn(seed, reps)]
    alpha = np.array([r.extra["alpha"] for r in res])
    factor = np.array([r.extra["variance_factor"] for r in res])
    values = np.array([r.value for r in res])
    return {"alpha_mean": float(alpha.mean()), "alpha_se": float(alpha.std(ddof=1) / np.sqrt(reps)),
            "alpha_theory": float(f.theory["cv_x:beta"]),
            "factor_mean": float(factor.mean()), "factor_se": float(factor.std(ddof=1) / np.sqrt(reps)),
            "factor_theory": float(f.theory["cv_x:factor"]),
            "value_mean": float(values.mean()), "value_se": float(values.std(ddof=1) / np.sqrt(reps)),
            "exact": float(f.exact), "n": n, "reps": reps}


COLOURS = {"plain": "black", "alpha1": "C0", "optimal": "C1"}
LABELS = {"plain": "plain MC", "alpha1": "α = 1", "optimal": "optimal α"}
CONVERGENCE = {"plain MC": "plain", "CV alpha=1": "alpha1", "CV optimal": "optimal"}   # estimator -> key


def sweep_figure(table: pd.DataFrame, cross: dict | None = None):
    """Per-sample variance against rho at equal N and at equal cost (h costs as much as f, so
    plain MC gets 2N samples: its variance halves), theory lines and measured points (2 se);
    arrows at the measured crossings (``crossings``) with the theory in brackets."""
    fig, axes = plt.subplots(1, 2, figsize=(11.5, 4.3))
    rho = np.linspace(-1, 1, 401)
    th = theory_variances(rho)
    for ax, cost in zip(axes, (1.0, 2.0)):
        for name, colour in COLOURS.items():
            t = table[table["estimator"] == name]
            scale = 1 / cost if name == "plain" else 1.0
            label = LABELS[name] + (" with 2N samples" if name == "plain" and cost == 2 else "")
            ax.plot(rho, th[name] * scale, color=colour, lw=1, label=label)
            ax.errorbar(t["rho"], t["var_measured"] * scale, 2 * t["var_se"] * scale, fmt="o", ms=3, color=colour)
        ax.set_xlabel("correlation ρ of f and h (dimensionless)")
        ax.set_ylim(0, 4)
        ax.legend(fontsize=8, loc="upper center", title="lines: theory, dots: measured ± 2 se", title_fontsize=7.5)
    axes[0].set_ylabel("variance × N, relative to σ² = Var f")
    axes[1].set_ylabel("variance × N at equal cost (σ² = 1)")
    axes[0].set_title("equal N (h is free)", fontsize=10)
    axes[1].set_title("equal cost (h costs as much as f)", fontsize=10)
    cross = cross or {}
    for ax, key, name, y, text_y in ((axes[0], "alpha1_equal_n", "α = 1", 1.0, 2.3),
                                     (axes[1], "alpha1_equal_cost", "α = 1", 0.5, 2.7),
                                     (axes[1], "optimal_equal_cost", "optimal α", 0.5, 1.9)):
        r = cross.get(key, np.nan)
        if np.isfinite(r):
            ax.annotate(f"{name} wins for ρ > {r:.2f}\n(theory {THRESHOLDS[key]:.3g})", xy=(r, y),
                        xytext=(0.3, text_y), fontsize=8, arrowprops={"arrowstyle": "->", "lw": 0.8})
    fig.suptitle("control variates: α = 1 against the optimal α, variance per sample", fontsize=11)
    return fig


def convergence_figure(summary: pd.DataFrame, slopes: pd.DataFrame):
    """RMSE vs n of plain MC and the two control variates on e^x (control h = x)."""
    fig, ax = plt.subplots(figsize=(6, 4.4))
    names = [e for e in CONVERGENCE if e in set(summary["estimator"])]
    convergence_panel(ax, summary, slopes, summary["integrand"].iloc[0], names,
                      {e: COLOURS[CONVERGENCE[e]] for e in names}, {e: LABELS[CONVERGENCE[e]] for e in names})
    ax.set_title("e^x on [0, 1], control h = x: RMSE against n", fontsize=10)
    return fig


def gallery_numbers(out: str | Path) -> dict:
    """The gallery caption's numbers, from ``control_variates_thresholds.csv``."""
    t = pd.read_csv(Path(out) / "control_variates_thresholds.csv").set_index("comparison")
    return {f"{k}{suffix}": f"{t.loc[k, col]:.2f}" for k in t.index
            for suffix, col in (("", "rho_measured"), ("_theory", "rho_theory"))}


def main(out: str | Path = DEFAULT_OUT, full: bool = False) -> dict:
    """Run the sweep and the e^x check, write CSV + PNG into ``out``, return the key numbers."""
    out = output_dir(out)
    rhos = np.round(np.linspace(-1, 1, 41 if full else 21), 6)
    n, reps = (20_000, 50) if full else (4_000, 10)
    table = correlation_sweep(rhos, n, reps, 10)
    table.to_csv(out / "control_variates_sweep.csv", index=False)
    cross = crossings(table)
    pd.DataFrame([{"comparison": k, "rho_measured": v, "rho_theory": THRESHOLDS[k]} for k, v in cross.items()]
                 ).to_csv(out / "control_variates_thresholds.csv", index=False)
    save_figure(sweep_figure(table, cross), out / "control_variates_sweep.png")
    golden = exp_golden(1000, 400 if full else 100, 11)
    pd.DataFrame([golden]).to_csv(out / "control_variates_exp.csv", index=False)

    f = catalogue.get("exp")
    ns = [2**k for k in range(4, 17 if full else 13)]
    df = lab.run([("plain MC", MonteCarlo()),
                  ("CV alpha=1", ControlVariate(lambda x: x[..., 0], 0.5, alpha=1.0)),
                  ("CV optimal", ControlVariate(lambda x: x[..., 0], 0.5, alpha="optimal"))],
                 [f], ns, 200 if full else 40, rng=12)
    summary = lab.summarize(df)
    summary.to_csv(out / "control_variates_convergence.csv", index=False)
    slopes = lab.fit_slopes(summary)
    save_figure(convergence_figure(summary, slopes), out / "control_variates_convergence.png")
    return {"sweep": table, "crossings": cross, "thresholds": dict(THRESHOLDS), "exp": golden,
            "slopes": slopes, "files": sorted(p.name for p in out.iterdir())}


if __name__ == "__main__":
    experiment_cli(main, DEFAULT_OUT, __doc__)
