"""Discrete sampling (lecture 001, "efficiently sample from a large distribution").

* CDF table + binary search: O(n) build (a prefix sum), O(log n) per draw.
* Alias table ("rob from the rich, give to the poor"): O(n) build, O(1) per draw: pick a
  column uniformly, then a biased coin chooses between the column's own index and its alias.

Timings (build and per-draw) against NumPy ``Generator.choice(p=...)`` and SciPy's
``DiscreteAliasUrn`` for n = 2^4 .. 2^20, and a check that each alias table encodes the
weights exactly: its implied pmf (q_i + sum over columns aliased to i of (1 - q_j)) / n
equals w / sum(w).

Run ``python -m vrlab.experiments.discrete_sampling [--full] [--out DIR]``.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import matplotlib.pyplot as plt
import pandas as pd
from scipy import stats
from scipy.stats.sampling import DiscreteAliasUrn

from vrlab import AliasTable, CDFTable
from vrlab.bench.timing import race
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure


DEFAULT_OUT = Path("vrlab-out") / "discrete_sampling"          # relative to the working folder
EXAMPLE = np.array([1.0, 6.0, 2.0, 0.5, 3.0, 0.0, 1.5, 2.0])   # the small worked example


def _urn(w, seed):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # UNU.RAN reports round-off for large tables
        return DiscreteAliasUrn(w, random_state=np.random.default_rng(seed))


def timings(exponents, draws: int, repeat: int, seed: int) -> pd.DataFrame:
    """Best-of-``repeat`` build and sampling times per method and n (sampling includes the uniforms)."""
    rng = np.random.default_rng(seed)
    rows = []
    for e in exponents:
        n = 2**e
        w = rng.random(n) ** 2
        p = w / w.sum()
        build = race({"vrlab AliasTable": lambda: AliasTable(w), "vrlab CDFTable": lambda: CDFTable(w),
                      "scipy DiscreteAliasUrn": lambda: _urn(w, seed), "numpy cumsum": lambda: np.cumsum(w)},
                     repeat)
        alias, cdf, urn = AliasTable(w), CDFTable(w), _urn(w, seed)
        gen = np.random.default_rng(seed + e)
        sample = race({"vrlab AliasTable": lambda: alias.sample(gen.random(draws)),
                       "vrlab CDFTable": lambda: cdf.sample(gen.random(draws)),
                       "scipy DiscreteAliasUrn": lambda: urn.rvs(draws),
                       "numpy Generator.choice": lambda: gen.choice(n, size=draws, p=p)}, repeat)
        for m, s in build.items():
            rows.append({"task": "build", "n": n, "method": m, "seconds": s, "ns_per_item": 1e9 * s / n})
        for m, s in sample.items():
            rows.append({"task": "sample", "n": n, "method": m, "seconds": s, "ns_per_item": 1e9 * s / draws})
    return pd.DataFrame(rows)


def pmf_check(exponents, seed: int) -> pd.DataFrame:
    """Max relative error of the alias table's implied pmf (and the CDF table's) against w / sum(w)."""
    rng = np.random.default_rng(seed)
    rows = []
    for e in exponents:
        w = rng.random(2**e) ** 2
        target = w / w.sum()
        for name, table in (("alias", AliasTable(w)), ("cdf", CDFTable(w))):
            err = np.abs(table.table_pmf() - target) / target
            rows.append({"n": 2**e, "table": name, "max_rel_error": float(err.max())})
    return pd.DataFrame(rows)


def example_table(weights=EXAMPLE) -> pd.DataFrame:
    """The alias table of the worked example: per column its keep probability and alias."""
    t = AliasTable(weights)
    q = np.asarray(t.q)
    alias = np.where(q < 1, t.alias, np.arange(t.n))
    return pd.DataFrame({"column": np.arange(t.n), "weight": weights, "p": t.probabilities,
                         "n_p": t.n * t.probabilities, "keep_q": q, "alias": alias,
                         "table_pmf": t.table_pmf()})


def example_chisquare(draws: int, seed: int, weights=EXAMPLE) -> dict:
    """Frequencies of ``draws`` alias-table samples against the pmf (chi-square, zero cells dropped)."""
    t = AliasTable(weights)
    counts = np.bincount(t.sample(np.random.default_rng(seed).random(draws)), minlength=t.n)
    p = t.probabilities
    keep = p > 0
    chi = stats.chisquare(counts[keep], draws * p[keep])
    return {"draws": draws, "counts": counts.tolist(), "chi2": float(chi.statistic), "p_value": float(chi.pvalue),
            "hits_on_zero_weight": int(counts[~keep].sum())}


COLOURS = {"vrlab AliasTable": "C0", "vrlab CDFTable": "C1", "scipy DiscreteAliasUrn": "C2",
           "numpy Generator.choice": "C3", "numpy cumsum": "C4"}
SUPERSCRIPT = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")


def example_figure(table: pd.DataFrame):
    """Columns of height 1 after robbing: the lower part keeps the column's own index, the upper
    part (1 - q) belongs to the alias (each index in its own colour, a palette apart from the
    method colours of the timings)."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    n = len(table)
    colors = plt.get_cmap("Set2")(np.arange(n) % 8)
    axes[0].bar(table["column"], table["n_p"], color=colors)
    axes[0].axhline(1, color="k", ls="--", lw=1)
    axes[0].set_title("n · p_i: the rich (> 1) and the poor (< 1)", fontsize=10)
    axes[0].set_ylabel("n · p_i (dimensionless)")
    axes[1].bar(table["column"], table["keep_q"], color=colors)
    axes[1].bar(table["column"], 1 - table["keep_q"], bottom=table["keep_q"],
                color=[colors[a] for a in table["alias"]], hatch="//", edgecolor="w")
    for c, (q, a) in enumerate(zip(table["keep_q"], table["alias"])):
        if q < 1:
            axes[1].text(c, q + (1 - q) / 2, f"→ {a}", ha="center", va="center", fontsize=8)
    axes[1].set_title("alias table: keep q_j (solid), alias (hatched, → index)", fontsize=10)
    axes[1].set_ylabel("share of column j (dimensionless)")
    for ax, label in zip(axes, ("index i", "column j")):
        ax.set_xlabel(label)
        ax.set_xticks(table["column"])
    return fig


def timings_figure(df: pd.DataFrame):
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, task, ylabel in ((axes[0], "sample", "time per draw (ns), uniforms included"),
                             (axes[1], "build", "build time per weight (ns)")):
        part = df[df["task"] == task]
        for m, g in part.groupby("method", sort=False):
            ax.loglog(g["n"], g["ns_per_item"], "o-", ms=3, color=COLOURS[m], label=m)
        ax.set_xscale("log", base=2)
        ax.set_xlabel("n (table size)")
        ax.set_ylabel(ylabel)
        ax.legend(fontsize=7)
    axes[0].set_title("draw cost: alias O(1), CDF search O(log n)", fontsize=10)
    axes[1].set_title("build cost (best of the repeats)", fontsize=10)
    fig.suptitle("discrete sampling: timings on this machine", fontsize=11)
    return fig


def gallery_numbers(out: str | Path) -> dict:
    """The gallery caption's numbers, from ``discrete_sampling_timings.csv``."""
    t = pd.read_csv(Path(out) / "discrete_sampling_timings.csv")
    s = t[t["task"] == "sample"].pivot(index="n", columns="method", values="ns_per_item")
    top = s.index.max()
    exp = lambda n: "2" + str(int(np.log2(n))).translate(SUPERSCRIPT)    # noqa: E731
    alias = s.loc[top, "vrlab AliasTable"]
    return {"n_lo": exp(s.index.min()), "n_hi": exp(top),
            "cdf_factor": f"{s.loc[top, 'vrlab CDFTable'] / alias:.0f}",
            "choice_factor": f"{s.loc[top, 'numpy Generator.choice'] / alias:.0f}",
            "alias_growth": f"{alias / s.loc[s.index.min(), 'vrlab AliasTable']:.1f}"}


def main(out: str | Path = DEFAULT_OUT, full: bool = False) -> dict:
    """Time, check and plot; write CSV + PNG into ``out``; return the key numbers."""
    out = output_dir(out)
    exponents = list(range(4, 21)) if full else list(range(4, 21, 4))
    draws, repeat = (10**6, 5) if full else (2**17, 2)
    t = timings(exponents, draws, repeat, 2026)
    t.to_csv(out / "discrete_sampling_timings.csv", index=False)
    save_figure(timings_figure(t), out / "discrete_sampling_timings.png")
    pmf = pmf_check(exponents, 7)
    pmf.to_csv(out / "discrete_sampling_pmf_check.csv", index=False)
    ex = example_table()
    ex.to_csv(out / "discrete_sampling_example.csv", index=False)
    save_figure(example_figure(ex), out / "discrete_sampling_example.png")
    chi = example_chisquare(10**6 if full else 10**5, 8)
    pd.DataFrame([{k: v for k, v in chi.items() if k != "counts"}]).to_csv(
        out / "discrete_sampling_chisquare.csv", index=False)
    s = t[t["task"] == "sample"].pivot(index="n", columns="method", values="ns_per_item")
    return {"timings": t, "pmf_check": pmf, "example": ex, "chisquare": chi,
            "max_rel_pmf_error": float(pmf[pmf["table"] == "alias"]["max_rel_error"].max()),
            "ns_per_draw": s, "files": sorted(p.name for p in out.iterdir())}


if __name__ == "__main__":
    experiment_cli(main, DEFAULT_OUT, __doc__)
