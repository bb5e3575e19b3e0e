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
import pandas as pd


import matplotlib.pyplot as plt

from vrlab import lab
from vrlab._rng import spawn
from vrlab.estimators import MonteCarlo
from vrlab.integrands import catalogue
from vrlab.integrands.theory import mc_variance
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure

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


def plot_densities(path: Path) -> Path:
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
    x = np.linspace(0, 1, 400)
    ax = axes[0]
    ax.plot(x, np.where(x > 0.5, x * x, 0), "k", lw=2, label="f = x² 1[x>1/2]")
    ax.plot(x, np.ones_like(x), label="p_A uniform [0,1]")
    ax.plot(x, np.where(x > 0.5, 2.0, 0), label="p_B uniform [1/2,1]")
    ax.plot(x, StepX2Ideal().pdf(x[:, None]), "--", label="p* = f / (7/24)")
    ax.set_title("step-x2 and its densities")
    ax.legend(fontsize=8)
    ax = axes[1]
    x = np.linspace(0, np.pi / 2, 400)
    ax.plot(x, np.sin(x), "k", lw=2, label="f = sin x")
    ax.plot(x, np.full_like(x, 2 / np.pi), label="p1 = 2/π")
    ax.plot(x, 8 * x / np.pi**2, label="p2 = 8x/π²")
    ax.set_title("sin on [0, π/2]")
    ax.legend(fontsize=8)
    return save_figure(fig, path, dpi=120)


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
    lab.convergence_plot(summary, out / "importance_sampling_convergence.png", title="importance sampling")
    plot_densities(out / "importance_sampling_densities.png")

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
