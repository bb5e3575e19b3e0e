"""Antithetic variates and common random numbers: correlation as a variance-reduction tool.

Questions answered (tables in ``antithetic_crn_*.csv``, figures ``*.png``):

* the variance of a pair mean, Var[(Y + Y')/2] = sigma^2 (1 + rho) / 2: at equal cost
  (n evaluations = n/2 pairs) antithetic sampling multiplies the Monte Carlo variance by
  1 + rho, rho = Corr(f(U), f(1 - U));
* a monotone function (e^x: 1 + rho = 0.03233, closed form) against a function symmetric
  about 1/2 (sin(pi x): f(1 - x) = f(x), rho = 1, factor 2 -- antithetic sampling doubles
  the variance);
* common random numbers for a difference of two integrals, int e^x - int e^(1.1 x):
  Var[f_a - f_b] = Var f_a + Var f_b - 2 Cov(f_a, f_b), measured with shared and with
  independent uniforms;
* the lecture's f(X), f(-X) and vrlab's u -> 1 - u: for X = F^-1(u) with a pdf symmetric
  about m, F^-1(1 - u) = 2m - X (checked on warps with and without that symmetry);
* antithetic direct lighting (:mod:`vrlab.experiments.antithetic_crn_render`): cosine pairs
  against independent cosine samples at equal cost, the per-pixel factor 1 + rho next to
  its closed form.

Run ``python -m vrlab.experiments.antithetic_crn [--full] [--out DIR]``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd


import matplotlib.pyplot as plt

from vrlab._rng import spawn
from vrlab.distributions import CosineHemisphere, TruncatedNormal
from vrlab.estimators import Antithetic, MonteCarlo, crn_difference
from vrlab.estimators.antithetic import reflect
from vrlab.experiments import antithetic_crn_render as render_study
from vrlab.experiments.antithetic_crn_render import COLORS
from vrlab.integrands import Integrand, catalogue
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure

DEFAULT_OUT = Path("vrlab-out") / "antithetic_crn"          # relative to the working folder
E = np.e
EXP = "e^x (catalogue 'exp')"


def _exp_theta(theta: float) -> Integrand:
    return Integrand(lambda x, t=theta: np.exp(t * x[..., 0]), [(0, 1)], exact=(np.exp(theta) - 1) / theta,
                     name=f"exp({theta:g} x)")


def test_functions() -> dict:
    """Integrands on [0, 1] with the closed-form antithetic factor 1 + rho."""
    # e^x: Var = (e^2 - 1)/2 - (e - 1)^2, Cov(e^U, e^(1-U)) = e - (e - 1)^2
    var_exp = (E**2 - 1) / 2 - (E - 1) ** 2
    rho_exp = (E - (E - 1) ** 2) / var_exp
    return {
        "x (linear)": (Integrand(lambda x: x[..., 0], [(0, 1)], exact=0.5, name="x"), 0.0),
        "x^2": (Integrand(lambda x: x[..., 0] ** 2, [(0, 1)], exact=1 / 3, name="x^2"), 1 / 8),
        EXP: (catalogue.get("exp"), 1 + rho_exp),
        "sin(pi x)": (Integrand(lambda x: np.sin(np.pi * x[..., 0]), [(0, 1)], exact=2 / np.pi, name="sin(pi x)"), 2.0),
        "sin(2 pi x)^2 + x": (Integrand(lambda x: np.sin(2 * np.pi * x[..., 0]) ** 2 + x[..., 0], [(0, 1)],
                                        exact=1.0, name="mixed"), None),
    }


def antithetic_table(n: int, reps: int, seed: int = 1) -> pd.DataFrame:
    """Factor (stderr_anti / stderr_mc)^2 at equal evaluations, mean over ``reps`` runs."""
    rows = []
    for k, (label, (f, theory)) in enumerate(test_functions().items()):
        gens = spawn(np.random.SeedSequence([seed, k]), 2 * reps)
        mc = np.array([MonteCarlo(probe=False).estimate(f, n, rng=g).stderr ** 2 for g in gens[:reps]])
        an = np.array([Antithetic(probe=False).estimate(f, n, rng=g).stderr ** 2 for g in gens[reps:]])
        if theory is None:  # midpoint rule: 1 + Cov(f(x), f(1-x)) / Var f(x)
            x = (np.arange(200_000) + 0.5) / 200_000
            y, y2 = f.f(x[:, None]), f.f(1 - x[:, None])
            theory = 1 + (np.mean(y * y2) - y.mean() ** 2) / y.var()
        ratio = an.mean() / mc.mean()
        # delta method on a ratio of two independent means
        with np.errstate(invalid="ignore", divide="ignore"):
            se = ratio * np.sqrt((an.std(ddof=1) / an.mean()) ** 2 / reps + (mc.std(ddof=1) / mc.mean()) ** 2 / reps)
        rows.append({"function": label, "n": n, "reps": reps, "factor_measured": ratio, "factor_se": se,
                     "factor_theory": theory, "rho_measured": ratio - 1})
    return pd.DataFrame(rows)


def crn_table(ns: list[int], reps: int, theta: float = 1.1, seed: int = 2) -> tuple[pd.DataFrame, dict]:
    a, b = _exp_theta(1.0), _exp_theta(theta)
    exact = a.exact - b.exact

    def m2(t):  # int_0^1 e^(t x) dx
        return (np.exp(t) - 1) / t
    var_a, var_b = m2(2) - m2(1) ** 2, m2(2 * theta) - m2(theta) ** 2
    cov = m2(1 + theta) - m2(1) * m2(theta)
    theory = {"common": var_a + var_b - 2 * cov, "independent": var_a + var_b}   # per pair
    rows = []
    for k, n in enumerate(ns):
        for j, common in enumerate((True, False)):
            label = "common" if common else "independent"
            es = [crn_difference(a, b, n, rng=g, common=common)
                  for g in spawn(np.random.SeedSequence([seed, k, j]), reps)]
            vals = np.array([e.value for e in es])
            pair_var = np.array([e.stderr**2 for e in es]) * (n // 2)
            rows.append({"numbers": label, "n": n, "reps": reps, "mean": vals.mean(), "exact": exact,
                         "rmse": np.sqrt(np.mean((vals - exact) ** 2)),
                         "pair_var_measured": pair_var.mean(),
                         "pair_var_se": pair_var.std(ddof=1) / np.sqrt(reps),
                         "pair_var_theory": theory[label]})
    theory_out = {"var_a": var_a, "var_b": var_b, "cov": cov, "exact": exact, **theory}
    return pd.DataFrame(rows), {k: float(v) for k, v in theory_out.items()}


def reflection_table(n: int = 100_000, seed: int = 4) -> pd.DataFrame:
    """vrlab's antithetic partner u -> 1 - u (``reflect``) against the point reflection
    x -> 2m - x about the centre m = F^-1(1/2): the largest |x(1 - u) - (2m - x(u))| over ``n``
    uniforms, for warps whose pdf is symmetric about m and for two that are not.  For the
    direction warps m is the normal and the reflection acts on the tangent coordinates:
    (x, y, z) -> (-x, -y, z)."""
    u1 = np.random.default_rng(seed).random((n, 1))
    u2 = np.random.default_rng(seed + 1).random((n, 2))
    cases = [("truncated normal N(0.5, 0.15) on [0, 1]", TruncatedNormal(0.5, 0.15, 0, 1), u1, True),
             ("truncated normal N(0.3, 0.15) on [0, 1]", TruncatedNormal(0.3, 0.15, 0, 1), u1, False),
             ("cosine hemisphere, concentric disk (the renderer's)", CosineHemisphere("disk"), u2, True),
             ("cosine hemisphere, inversion", CosineHemisphere("inversion"), u2, False)]
    rows = []
    for label, dist, u, symmetric in cases:
        x, x_anti = np.asarray(dist.sample(u), float), np.asarray(dist.sample(reflect(u)), float)
        if x.shape[-1] == 3:               # directions: mirror the tangent part about the normal
            mirrored = x * np.array([-1.0, -1.0, 1.0])
            centre = "normal (0, 0, 1)"
        else:
            m = float(np.asarray(dist.sample(np.full((1, 1), 0.5)), float).ravel()[0])
            mirrored, centre = 2 * m - x, f"{m:.4f}"
        rows.append({"warp": label, "pdf symmetric about centre": symmetric, "centre m": centre,
                     "max |x(1-u) - (2m - x(u))|": float(np.max(np.abs(x_anti - mirrored)))})
    return pd.DataFrame(rows)


def plot_pairs(path: Path, seed: int = 3) -> Path:
    """f(U) against f(1 - U) for a monotone and a symmetric f, and the one-sample values of a
    difference with common and with independent uniforms (same bins)."""
    u = np.random.default_rng(seed).random(400)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    for ax, (label, g) in zip(axes, [("e^x", np.exp), ("sin(πx)", lambda x: np.sin(np.pi * x))]):
        ax.scatter(g(u), g(1 - u), s=4, color=COLORS["antithetic"])
        ax.set_xlabel("f(U) (dimensionless)"), ax.set_ylabel("f(1 − U) (dimensionless)")
        ax.set_title(f"antithetic pairs, f = {label}: corr = {np.corrcoef(g(u), g(1 - u))[0, 1]:+.3f}", fontsize=9)
    ax = axes[2]
    a, b = np.exp(u), np.exp(1.1 * u)
    b_ind = np.exp(1.1 * np.random.default_rng(seed + 1).random(400))
    bins = np.histogram_bin_edges(np.concatenate([a - b, a - b_ind]), bins=40)
    ax.hist(a - b_ind, bins=bins, alpha=0.55, density=True, color=COLORS["independent"], label="independent U, U'")
    ax.hist(a - b, bins=bins, alpha=0.75, density=True, color=COLORS["common"], label="common U' = U")
    ax.set_xlabel("one-sample value e^U − e^(1.1 U') (dimensionless)")
    ax.set_ylabel("probability density (1 / unit)")
    ax.set_title(f"CRN: {len(u)} one-sample differences, same {len(bins) - 1} bins", fontsize=9)
    ax.legend(fontsize=8)
    return save_figure(fig, path, dpi=110)


def plot_crn(table: pd.DataFrame, path: Path) -> Path:
    fig, ax = plt.subplots(figsize=(5.6, 4))
    for label, g in table.groupby("numbers"):
        ax.loglog(g["n"], g["rmse"], "o-", color=COLORS[label], label=f"{label} uniforms")
        ax.loglog(g["n"], np.sqrt(g["pair_var_theory"] / (g["n"] // 2)), "k:", lw=0.8)
    ax.set_xlabel("n (evaluations of both integrands)"); ax.set_ylabel("RMSE of the difference (dimensionless)")
    ax.set_title("CRN: ∫e^x − ∫e^(1.1x), common vs independent (dotted: theory)", fontsize=9)
    ax.legend()
    return save_figure(fig, path, dpi=110)


def gallery_numbers(out: str | Path) -> dict:
    """The gallery caption's numbers, read from the CSV files of :func:`main`."""
    out = Path(out)
    r = pd.read_csv(out / "antithetic_crn_render.csv").set_index("pixels")
    a = pd.read_csv(out / "antithetic_crn_factors.csv").set_index("function")
    c = pd.read_csv(out / "antithetic_crn_difference.csv").groupby("numbers")["pair_var_measured"].mean()
    res = {"spp": int(r["spp"].iloc[0]), "share_below_1": f"{r.loc['floor', 'share_below_1']:.0%}",
           "exp_factor": f"{a.loc[EXP, 'factor_measured']:.4f}", "exp_theory": f"{a.loc[EXP, 'factor_theory']:.4f}",
           "crn_gain": f"{c['independent'] / c['common']:.0f}"}
    for cls in ("floor", "centre", "edge"):
        res[f"{cls}"] = f"{r.loc[cls, 'factor_mean']:.2f}"
        res[f"{cls}_theory"] = f"{r.loc[cls, 'factor_theory']:.2f}"
    return res


def main(out: str | Path = DEFAULT_OUT, full: bool = False) -> dict:
    """Run every experiment, write CSV + PNG into ``out``, return the key numbers."""
    out = output_dir(out)
    n, reps = (100_000, 200) if full else (20_000, 40)
    anti = antithetic_table(n, reps)
    anti.to_csv(out / "antithetic_crn_factors.csv", index=False)
    ns = [2**k for k in range(4, 17 if full else 13)]
    crn, crn_theory = crn_table(ns, 200 if full else 60)
    crn.to_csv(out / "antithetic_crn_difference.csv", index=False)
    pd.DataFrame([crn_theory]).to_csv(out / "antithetic_crn_theory.csv", index=False)
    plot_pairs(out / "antithetic_crn_pairs.png")
    plot_crn(crn, out / "antithetic_crn_rmse.png")
    reflection = reflection_table()
    reflection.to_csv(out / "antithetic_crn_reflection.csv", index=False)
    size, spp = ((320, 240), 512) if full else ((160, 120), 128)
    pixels, profile, maps = render_study.study(size, spp)
    pixels.to_csv(out / "antithetic_crn_render.csv", index=False)
    profile.to_csv(out / "antithetic_crn_render_profile.csv", index=False)
    render_study.plot(pixels, profile, maps, out / "antithetic_crn_render.png")
    a = anti.set_index("function")
    c = crn.groupby("numbers")["pair_var_measured"].mean()
    return {
        "antithetic": anti, "crn": crn, "crn_theory": crn_theory, "reflection": reflection,
        "render": pixels, "render_profile": profile,
        "exp_factor": float(a.loc[EXP, "factor_measured"]),
        "exp_factor_se": float(a.loc[EXP, "factor_se"]),
        "exp_factor_theory": float(catalogue.get("exp").theory["antithetic_factor"]),
        "sin_factor": float(a.loc["sin(pi x)", "factor_measured"]),
        "crn_ratio": float(c["independent"] / c["common"]),
        "files": sorted(p.name for p in out.iterdir()),
    }


if __name__ == "__main__":
    experiment_cli(main, DEFAULT_OUT, __doc__)
