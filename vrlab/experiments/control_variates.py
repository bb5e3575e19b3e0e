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
import pandas as pd


import matplotlib.pyplot as plt

from vrlab import Integrand, lab
from vrlab._rng import spawn
from vrlab.estimators import ControlVariate, MonteCarlo
from vrlab.integrands import catalogue
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure

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


def plot_sweep(table: pd.DataFrame, path: Path) -> Path:
    fig, ax = plt.subplots(figsize=(6.4, 4))
    rho = np.linspace(-1, 1, 401)
    th = theory_variances(rho)
    for name, color in (("plain", "k"), ("alpha1", "C0"), ("optimal", "C1")):
        t = table[table["estimator"] == name]
        ax.plot(rho, th[name], color=color, lw=1, label=f"{name} (theory)")
        ax.errorbar(t["rho"], t["var_measured"], 2 * t["var_se"], fmt="o", ms=3, color=color)
    ax.axhline(0.5, color="k", ls=":", lw=1, label="plain MC with 2N samples")
    for r, txt, y in ((0.5, "1/2", 3.6), (0.75, "3/4", 3.6), (1 / np.sqrt(2), "1/√2", 3.2)):
        ax.axvline(r, color="0.6", lw=0.6)
        ax.text(r, y, txt, fontsize=8, ha="center", backgroundcolor="w")
    ax.set_xlabel("correlation ρ of f and h")
    ax.set_ylabel("variance per sample (σ² = 1)")
    ax.set_ylim(0, 4)
    ax.legend(fontsize=8, loc="center left")
    ax.set_title("control variates: α = 1 vs optimal α")
    return save_figure(fig, path, dpi=120)


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
    plot_sweep(table, out / "control_variates_sweep.png")
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
    lab.convergence_plot(summary, out / "control_variates_convergence.png", title="e^x, control h = x")
    return {"sweep": table, "crossings": cross, "thresholds": dict(THRESHOLDS), "exp": golden,
            "slopes": lab.fit_slopes(summary), "files": sorted(p.name for p in out.iterdir())}


if __name__ == "__main__":
    experiment_cli(main, DEFAULT_OUT, __doc__)
