"""Importance sampling basics (lecture 4): the variance of one sample and how p changes it.

Questions answered (tables in ``importance_sampling_*.csv``, figures ``*.png``):

* one-sample variance Var[f(X)/p(X)] = int f^2/p - I^2, measured against the closed forms
  of the catalogue integrands ``step-x2`` and ``sin``;
* the zero-variance density p* = f / I for f >= 0 (it needs I, the answer, to normalise);
* support matching: for f = x^2 1[x > 1/2] the uniform density on [1/2, 1] (B) beats the
  one on [0, 1] (A) by exactly (|A| - |B|) int f^2 = 31/320;
* sin x on [0, pi/2]: p1 = 2/pi against p2 = 8x/pi^2, and RMSE-vs-n convergence.

Run ``python -m vrlab.experiments.importance_sampling [--full] [--out DIR]``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import matplotlib.pyplot as plt
import pandas as pd

from vrlab import lab
from vrlab._rng import spawn
from vrlab.estimators import MonteCarlo
from vrlab.integrands import catalogue
from vrlab.integrands.theory import mc_variance
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure

from ._figures import convergence_panel

DEFAULT_OUT = Path("vrlab-out") / "importance_sampling"          # relative to the working folder


class StepX2Ideal:
    """The zero-variance density for x^2 1[x > 1/2]: p*(x) = x^2 / (7/24) on [1/2, 1] (length).

    Sampling by inversion: F(x) = (x^3 - 1/8) / (7/8), x = (1/8 + 7u/8)^(1/3).  Note that
    the normaliser 7/24 *is* the integral we wanted: building p* needs the answer.
    """

    dim_u = 1
    measure = "length"
    integral = 7 / 24

    def sample(self, u):
        u = np.asarray(u, float)
        return np.cbrt(1 / 8 + 7 / 8 * u[..., :1])

    def pdf(self, x):
        t = np.asarray(x, float)[..., 0]
        return np.where((t > 0.5) & (t <= 1.0), t * t / self.integral, 0.0)


def one_sample_variances(name: str, techniques: dict, n: int, reps: int, seed: int) -> pd.DataFrame:
    """Per technique: the one-sample variance measured ``reps`` times from ``n`` draws
    (mean and its standard error over the replicates) next to the closed form."""
    integrand = catalogue.get(name)
    rows = []
    for k, (label, dist) in enumerate(techniques.items()):
        est = MonteCarlo(dist, probe=False)
        v = np.array([est.estimate(integrand, n, rng=g).variance for g in spawn(np.random.SeedSequence([seed, k]), reps)])
        theory = 0.0 if isinstance(dist, StepX2Ideal) else integrand.theory.get(f"var:{label}")
        if theory is None:
            theory = mc_variance(integrand, dist)
        rows.append({"integrand": name, "technique": label, "n": n, "reps": reps,
                     "var_measured": v.mean(), "var_se": v.std(ddof=1) / np.sqrt(reps),
                     "var_theory": float(theory), "_samples": v})
    return pd.DataFrame(rows)


def support_difference(table: pd.DataFrame) -> dict:
    """Measured Var_A - Var_B for step-x2 against (|A| - |B|) int_B f^2 = (1 - 1/2) 31/160."""
    t = table[table["integrand"] == "step-x2"].set_index("technique")
    diffs = t.loc["uniform", "_samples"] - t.loc["half", "_samples"]   # paired by replicate index
    f2 = catalogue.get("step-x2").f2
    return {"diff_measured": float(diffs.mean()), "diff_se": float(diffs.std(ddof=1) / np.sqrt(len(diffs))),
            "diff_theory": (1.0 - 0.5) * f2}


COLOURS = {"f": "black", "uniform": "C0", "half": "C1", "ideal": "C2", "linear": "C3"}   # per technique
NAMES = {"uniform": "uniform", "half": "uniform on [½, 1]", "ideal": "p* = f / ∫f", "linear": "p ∝ x"}


def densities_figure(table: pd.DataFrame | None = None):
    """f and the densities of each technique; with ``table`` (``one_sample_variances`` rows)
    the measured one-sample variance of each in the legend."""
    var = {} if table is None else table.set_index(["integrand", "technique"])["var_measured"].to_dict()

    def label(integrand, technique, text):
        v = var.get((integrand, technique))
        return text if v is None else f"{text}: Var = {v:.3g}" if v > 1e-20 else f"{text}: Var = 0 (rounding)"

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    x = np.linspace(0, 1, 400)
    ax = axes[0]
    ax.plot(x, np.where(x > 0.5, x * x, 0), color=COLOURS["f"], lw=2, label="f = x² 1[x > ½]")
    ax.plot(x, np.ones_like(x), color=COLOURS["uniform"], label=label("step-x2", "uniform", "p_A uniform on [0, 1]"))
    ax.plot(x, np.where(x > 0.5, 2.0, 0), color=COLOURS["half"], label=label("step-x2", "half", "p_B uniform on [½, 1]"))
    ax.plot(x, StepX2Ideal().pdf(x[:, None]), "--", color=COLOURS["ideal"], label=label("step-x2", "ideal", NAMES["ideal"]))
    ax.set_title("step-x2: the integrand and three densities", fontsize=10)
    ax = axes[1]
    x = np.linspace(0, np.pi / 2, 400)
    ax.plot(x, np.sin(x), color=COLOURS["f"], lw=2, label="f = sin x")
    ax.plot(x, np.full_like(x, 2 / np.pi), color=COLOURS["uniform"], label=label("sin", "uniform", "p₁ = 2/π (uniform)"))
    ax.plot(x, 8 * x / np.pi**2, color=COLOURS["linear"], label=label("sin", "linear", "p₂ = 8x/π² (p ∝ x)"))
    ax.set_title("sin on [0, π/2]: uniform against p ∝ x", fontsize=10)
    for ax in axes:
        ax.set_xlabel("x (dimensionless)")
        ax.set_ylabel("f(x), p(x) (dimensionless)")
        ax.legend(fontsize=7.5, title="one-sample variance Var[f/p]" if var else None, title_fontsize=7.5)
    return fig


def convergence_figure(summary: pd.DataFrame, slopes: pd.DataFrame):
    """RMSE vs n per integrand; estimators are named ``"<integrand> <technique>"``."""
    integrands = list(dict.fromkeys(summary["integrand"]))
    fig, axes = plt.subplots(1, len(integrands), figsize=(5 * len(integrands), 4), squeeze=False)
    for ax, name in zip(axes[0], integrands):
        ests = list(dict.fromkeys(summary.loc[summary["integrand"] == name, "estimator"]))
        tech = {e: e.split()[-1] for e in ests}
        convergence_panel(ax, summary, slopes, name, ests, {e: COLOURS[t] for e, t in tech.items()},
                          {e: NAMES[t] for e, t in tech.items()})
        ax.set_title(f"{name}: RMSE against n", fontsize=10)
    fig.suptitle("importance sampling lowers the line; the slope stays that of Monte Carlo", fontsize=11)
    return fig


def gallery_numbers(out: str | Path) -> dict:
    """The gallery caption's numbers, from ``importance_sampling_variances.csv`` and ``_slopes.csv``."""
    v = pd.read_csv(Path(out) / "importance_sampling_variances.csv").set_index(["integrand", "technique"])
    s = pd.read_csv(Path(out) / "importance_sampling_slopes.csv")["slope"]
    uni, lin = v.loc[("sin", "uniform"), "var_measured"], v.loc[("sin", "linear"), "var_measured"]
    return {"sin_uniform": f"{uni:.3g}", "sin_linear": f"{lin:.3g}", "sin_ratio": f"{uni / lin:.0f}",
            "slope_lo": f"{s.min():.2f}", "slope_hi": f"{s.max():.2f}"}


def main(out: str | Path = DEFAULT_OUT, full: bool = False) -> dict:
    """Run every experiment, write CSV + PNG into ``out``, return the key numbers."""
    out = output_dir(out)
    n, reps = (200_000, 100) if full else (20_000, 30)
    step = catalogue.get("step-x2")
    sin = catalogue.get("sin")
    table = pd.concat([
        one_sample_variances("step-x2", {**step.techniques, "ideal": StepX2Ideal()}, n, reps, 1),
        one_sample_variances("sin", sin.techniques, n, reps, 2),
    ], ignore_index=True)
    se = table["var_se"].to_numpy()
    with np.errstate(divide="ignore", invalid="ignore"):
        table["z"] = np.where(se > 1e-12, (table["var_measured"] - table["var_theory"]) / se, np.nan)
    table.drop(columns="_samples").to_csv(out / "importance_sampling_variances.csv", index=False)
    diff = support_difference(table)
    pd.DataFrame([diff]).to_csv(out / "importance_sampling_support.csv", index=False)

    ns = [2**k for k in range(4, 17 if full else 13)]
    conv_reps = 200 if full else 40
    df = lab.run([(f"sin {k}", MonteCarlo(d, probe=False)) for k, d in sin.techniques.items()],
                 [sin], ns, conv_reps, rng=3)
    df2 = lab.run([(f"step-x2 {k}", MonteCarlo(d, probe=False)) for k, d in step.techniques.items()],
                  [step], ns, conv_reps, rng=4)
    summary = lab.summarize(pd.concat([df, df2], ignore_index=True))
    summary.to_csv(out / "importance_sampling_convergence.csv", index=False)
    slopes = lab.fit_slopes(summary)
    slopes.to_csv(out / "importance_sampling_slopes.csv", index=False)
    save_figure(convergence_figure(summary, slopes), out / "importance_sampling_convergence.png")
    save_figure(densities_figure(table), out / "importance_sampling_densities.png")

    v = table.set_index(["integrand", "technique"])
    return {
        "variances": table.drop(columns="_samples"),
        "support": diff,
        "slopes": slopes,
        "step_var_uniform": float(v.loc[("step-x2", "uniform"), "var_measured"]),
        "step_var_half": float(v.loc[("step-x2", "half"), "var_measured"]),
        "step_var_ideal": float(v.loc[("step-x2", "ideal"), "var_measured"]),
        "sin_var_uniform": float(v.loc[("sin", "uniform"), "var_measured"]),
        "sin_var_linear": float(v.loc[("sin", "linear"), "var_measured"]),
        "sin_var_linear_theory": float(v.loc[("sin", "linear"), "var_theory"]),
        "files": sorted(p.name for p in out.iterdir()),
    }


if __name__ == "__main__":
    experiment_cli(main, DEFAULT_OUT, __doc__)
