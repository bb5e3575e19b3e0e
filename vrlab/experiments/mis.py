"""Multiple importance sampling (MIS): heuristics, one-sample mixtures, and Veach's plates.

Questions answered (tables in ``mis_*.csv``, figures ``*.png``):

* on the 2D toy ``glossy-light`` (a narrow glossy lobe meets two lights, one small and
  bright, one large and dim), the per-sample variance of BRDF sampling, light sampling
  and their MIS combinations with the balance, power, maximum, cutoff and optimal
  heuristics, next to quadrature predictions (``vrlab.integrands.mc_variance``);
* the one-sample mixture (pick a technique at random) against the multi-sample estimator;
* Veach's bound: the balance heuristic is never worse than any other weighting by more
  than (1/min n_i - 1/sum n_i) I^2;
* Veach's plates (four glossy plates x four spherical lights, built-in scene ``veach_mis``)
  rendered with BSDF sampling, light sampling and MIS with the balance and the power
  heuristic at two evaluations per camera ray, with the relMSE of every method in each
  (plate, light) region (:mod:`vrlab.experiments.mis_plates`).

Run ``python -m vrlab.experiments.mis [--full] [--out DIR]``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd


import matplotlib.pyplot as plt

from vrlab._rng import spawn
from vrlab.distributions import Mixture
from vrlab.estimators import HEURISTICS, MIS, MonteCarlo, OneSampleMIS
from vrlab.experiments import mis_plates
from vrlab.experiments.mis_plates import COLORS
from vrlab.integrands import Integrand, catalogue, mc_variance
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure

DEFAULT_OUT = Path("vrlab-out") / "mis"          # relative to the working folder


def balance_prediction(integrand, techniques) -> float:
    """N Var[F] of multi-sample MIS with the balance heuristic and n_i = N/K, by quadrature.

    With equal counts every technique contributes f / sum_k p_k, so
    N Var[F] = K sum_i Var_{p_i}[ f p_i / sum_k p_k / p_i ] -- one mc_variance call per technique.
    """
    dists = list(techniques)
    k = len(dists)

    def part(i):
        def g(x):
            ps = [d.pdf(x) for d in dists]
            s = sum(ps)
            return np.where(s > 0, integrand.f(x) * ps[i] / np.where(s > 0, s, 1.0), 0.0)
        return Integrand(g, integrand.domain)

    return k * sum(mc_variance(part(i), d, quad=4) for i, d in enumerate(dists))


def heuristic_table(n: int, reps: int, seed: int = 1) -> pd.DataFrame:
    integrand = catalogue.get("glossy-light")
    tech = integrand.techniques
    b, l = tech["brdf"], tech["light"]
    I = integrand.exact
    estimators = {"BSDF only": MonteCarlo(b, probe=False), "light only": MonteCarlo(l, probe=False)}
    estimators.update({f"MIS {h}": MIS([b, l], heuristic=h, probe=False) for h in HEURISTICS})
    estimators["one-sample balance"] = OneSampleMIS([b, l], heuristic="balance", probe=False)
    estimators["one-sample power"] = OneSampleMIS([b, l], heuristic="power", probe=False)
    theory = {"BSDF only": mc_variance(integrand, b), "light only": mc_variance(integrand, l),
              "MIS balance": balance_prediction(integrand, [b, l]),
              "one-sample balance": mc_variance(integrand, Mixture([b, l], [0.5, 0.5]))}
    rows = []
    for k, (label, est) in enumerate(estimators.items()):
        es = [est.estimate(integrand, n, rng=g) for g in spawn(np.random.SeedSequence([seed, k]), reps)]
        v = np.array([e.variance for e in es])
        vals = np.array([e.value for e in es])
        rows.append({"estimator": label, "n": n, "reps": reps, "mean_value": vals.mean(), "exact": I,
                     "var_measured": v.mean(), "var_se": v.std(ddof=1) / np.sqrt(reps),
                     "var_theory": theory.get(label, np.nan)})
    t = pd.DataFrame(rows)
    bal = t.set_index("estimator").loc["MIS balance", "var_measured"]
    # Veach 1997, Theorem 9.2 in per-sample units (N Var): with n_i = N/2, the slack is (2 - 1) I^2
    t["balance_minus_this"] = bal - t["var_measured"]
    t["veach_bound"] = np.where(t["estimator"].str.startswith("MIS"), I**2, np.nan)
    return t


def plot_toy(table: pd.DataFrame, path: Path) -> Path:
    """The toy's f and the two densities (log colour maps), and every estimator's per-sample
    variance (bars: measured, with 2 standard errors; black dots: quadrature)."""
    integrand = catalogue.get("glossy-light")
    b, l = integrand.techniques["brdf"], integrand.techniques["light"]
    g = np.linspace(0, 1, 240)
    x = np.stack(np.meshgrid(g, g, indexing="xy"), -1).reshape(-1, 2)
    panels = {"f (glossy lobe × lights)": ("log10 f (dimensionless)", integrand.f(x)),
              "p_BSDF (BSDF sampling)": ("log10 p (1 / unit area)", b.pdf(x)),
              "p_light (light sampling)": ("log10 p (1 / unit area)", l.pdf(x))}
    fig = plt.figure(figsize=(15, 7.2))
    grid = fig.add_gridspec(2, 3, height_ratios=[1, 1.05])
    for k, (title, (unit, z)) in enumerate(panels.items()):
        ax = fig.add_subplot(grid[0, k])
        im = ax.imshow(np.log10(z.reshape(240, 240) + 1e-3), origin="lower", extent=(0, 1, 0, 1))
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("x₁ (dimensionless)"), ax.set_ylabel("x₂ (dimensionless)")
        fig.colorbar(im, ax=ax, shrink=0.85, label=unit)
    ax = fig.add_subplot(grid[1, :])
    pos = np.arange(len(table))
    ax.bar(pos, table["var_measured"], yerr=2 * table["var_se"], capsize=3,
           color=[COLORS[e] for e in table["estimator"]])
    ax.plot(pos, table["var_theory"], "ko", ms=5, label="quadrature prediction")
    ax.set_yscale("log")
    ax.set_xticks(pos, table["estimator"], fontsize=8)
    ax.set_xlabel("estimator (N samples per run)")
    ax.set_ylabel("N Var[F] per sample (dimensionless)")
    ax.set_title(f"glossy-light toy: per-sample variance of each estimator ({table['reps'].iloc[0]} runs of "
                 f"N = {table['n'].iloc[0]})", fontsize=9)
    ax.legend(fontsize=8)
    return save_figure(fig, path, dpi=110)


def gallery_numbers(out: str | Path) -> dict:
    """The gallery caption's numbers, read from ``mis_veach_regions.csv``: for each MIS
    heuristic the largest relMSE ratio to the better single technique, its region, and in how
    many regions MIS beats both single techniques."""
    t = pd.read_csv(Path(out) / "mis_veach_regions.csv")
    res = {"regions": len(t), "spp": int(t["spp"].iloc[0])}
    for key in ("balance", "power"):
        ratio = t[f"{key} / best"]
        worst = t.loc[ratio.idxmax()]
        res.update({f"{key}_max": f"{ratio.max():.2f}", f"{key}_worst": f"plate {worst['plate']} × light {worst['light']}",
                    f"{key}_min": f"{ratio.min():.2f}", f"{key}_wins": int((ratio < 1).sum())})
    return res


def main(out: str | Path = DEFAULT_OUT, full: bool = False) -> dict:
    """Run every experiment, write CSV + PNG into ``out``, return the key numbers."""
    out = output_dir(out)
    n, reps = (100_000, 60) if full else (10_000, 30)
    table = heuristic_table(n, reps)
    table.to_csv(out / "mis_heuristics.csv", index=False)
    plot_toy(table, out / "mis_glossy_light.png")
    size, spp = ((400, 300), 128) if full else ((200, 150), 32)
    veach, plates = mis_plates.study(size, spp)
    veach.to_csv(out / "mis_veach_regions.csv", index=False)
    mis_plates.plot(veach, plates, out / "mis_veach.png")
    t = table.set_index("estimator")
    return {
        "heuristics": table, "veach": veach,
        "var_balance": float(t.loc["MIS balance", "var_measured"]),
        "var_balance_se": float(t.loc["MIS balance", "var_se"]),
        "var_balance_theory": float(t.loc["MIS balance", "var_theory"]),
        "var_optimal": float(t.loc["MIS optimal", "var_measured"]),
        "exact": float(table["exact"].iloc[0]),
        "alphas": plates["alphas"], "radii": plates["radii"], "spp": spp, "size": size,
        "files": sorted(p.name for p in out.iterdir()),
    }


if __name__ == "__main__":
    experiment_cli(main, DEFAULT_OUT, __doc__)
