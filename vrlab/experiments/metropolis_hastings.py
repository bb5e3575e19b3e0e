"""Metropolis--Hastings sampling of an image (lecture 001, "Sampling an image").

The target is a synthetic 64 x 64 image of blobs whose supports are *disconnected*
(zero density between them).  A chain starts inside one blob and proposes

* small steps: a Gaussian jitter (sd = ``step`` x width), accepted with prob min(1, f(y)/f(x));
* large steps: a uniform point of the square, with probability ``large_step_prob``.

Without large steps a chain can never cross the zero-density gap, so the other blobs are
never visited; the histogram's total-variation distance to the image stays at least the
mass outside the starting blob.  With large steps the histogram converges (TV -> 0, at
about the i.i.d. rate divided by the chain's inefficiency).

Run ``python -m vrlab.experiments.metropolis_hastings [--full] [--out DIR]``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import matplotlib.pyplot as plt
import pandas as pd

from vrlab.distributions.tabulated import PiecewiseConstant2D
from vrlab.estimators import MetropolisHastings
from vrlab.estimators.metropolis import sample_histogram
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure


DEFAULT_OUT = Path("vrlab-out") / "metropolis_hastings"          # relative to the working folder
# (centre x, centre y, radius, brightness); blob 0 is where the chains start
BLOBS = ((0.28, 0.30, 0.14, 1.0), (0.72, 0.68, 0.16, 0.6), (0.75, 0.22, 0.08, 1.5))
START = (0.28, 0.30)
LARGE_STEP_PROBS = (0.0, 0.1, 0.5)
IID = "i.i.d. (inversion)"


def config_name(large_step_prob: float) -> str:
    return "small steps only" if large_step_prob == 0 else f"small + {large_step_prob:.0%} large"


COLOURS = {**{config_name(p): f"C{k}" for k, p in enumerate(LARGE_STEP_PROBS)}, IID: "black"}


def blob_image(size: int = 64, blobs=BLOBS) -> np.ndarray:
    """image[iy, ix]: smooth bumps (1 - (r/R)^2)^2 inside disks, exactly 0 outside them."""
    c = (np.arange(size) + 0.5) / size
    x, y = np.meshgrid(c, c)
    img = np.zeros((size, size))
    for cx, cy, r, b in blobs:
        d2 = ((x - cx) ** 2 + (y - cy) ** 2) / (r * r)
        img += b * np.clip(1 - d2, 0, None) ** 2
    return img


def blob_labels(size: int = 64, blobs=BLOBS) -> np.ndarray:
    """Per pixel, the index of the blob it belongs to (-1: empty)."""
    c = (np.arange(size) + 0.5) / size
    x, y = np.meshgrid(c, c)
    lab = np.full((size, size), -1)
    for k, (cx, cy, r, _) in enumerate(blobs):
        lab[((x - cx) ** 2 + (y - cy) ** 2) < r * r] = k
    return lab


def _coarse(a: np.ndarray, f: int) -> np.ndarray:
    return a.reshape(a.shape[0] // f, f, a.shape[1] // f, f).sum(axis=(1, 3))


def tv_curve(samples: np.ndarray, probs: np.ndarray, checkpoints) -> np.ndarray:
    """TV distance between the pooled histogram of ``samples[:t]`` (T, C, 2) and the cell
    probabilities ``probs[iy, ix]`` for each t in ``checkpoints``."""
    bins = probs.shape[0]
    tv = []
    for t in checkpoints:
        dens, _ = sample_histogram(samples[:t], bins=bins)
        hist = dens.T / (bins * bins)          # histogramdd order is [ix, iy]; cell area 1/bins^2
        tv.append(0.5 * np.abs(hist - probs).sum())
    return np.array(tv)


def run_configs(n_steps: int, n_chains: int, seed: int, step: float = 0.03, size: int = 64, bins: int = 16):
    img = blob_image(size)
    dist = PiecewiseConstant2D(img)
    probs = _coarse(img, size // bins) / img.sum()
    labels = blob_labels(size)
    blob_mass = np.array([img[labels == k].sum() for k in range(len(BLOBS))]) / img.sum()
    checkpoints = np.unique(np.geomspace(16, n_steps, 14).astype(int))
    configs = {config_name(p): p for p in LARGE_STEP_PROBS}
    curves, runs, rows = {}, {}, []
    for k, (name, pl) in enumerate(configs.items()):
        mh = MetropolisHastings(dist.pdf, step=step, large_step_prob=pl, n_chains=n_chains, burn_in=0,
                                normalization=1.0)
        res = mh.run(n_steps, rng=np.random.SeedSequence([seed, k]), x0=START)
        runs[name] = res
        curves[name] = tv_curve(res.samples, probs, checkpoints)
        ix = np.minimum((res.samples * size).astype(int), size - 1)
        lab = labels[ix[..., 1], ix[..., 0]]
        frac = [float(np.mean(lab == j)) for j in range(len(BLOBS))]
        rows.append({"config": name, "large_step_prob": pl, "acceptance": res.acceptance,
                     "acceptance_small": res.acceptance_small, "acceptance_large": res.acceptance_large,
                     "tv_final": float(curves[name][-1]),
                     **{f"blob{j}_fraction": frac[j] for j in range(len(BLOBS))},
                     **{f"blob{j}_mass": float(blob_mass[j]) for j in range(len(BLOBS))}})
    # reference: i.i.d. samples of the image (inversion sampling) at the same sample counts
    g = np.random.default_rng([seed, 99])
    iid = dist.sample(g.random((n_steps * n_chains, 2))).reshape(n_steps, n_chains, 2)
    curves[IID] = tv_curve(iid, probs, checkpoints)
    tv = pd.DataFrame({"steps": checkpoints, "samples": checkpoints * n_chains,
                       **{k: v for k, v in curves.items()}})
    return {"image": img, "probs": probs, "blob_mass": blob_mass, "tv": tv, "summary": pd.DataFrame(rows),
            "runs": runs}


def histograms_figure(res: dict):
    """The target density and each chain's sample histogram, on one colour scale."""
    names = list(res["runs"])
    img = res["image"] / res["image"].mean()            # density per unit area (the square has area 1)
    bins = res["probs"].shape[0] * 2
    dens = {name: sample_histogram(res["runs"][name].samples, bins=bins)[0].T for name in names}
    vmax = max(img.max(), *(d.max() for d in dens.values()))
    fig, axes = plt.subplots(1, 1 + len(names), figsize=(3.4 * (1 + len(names)), 3.9), layout="constrained")
    im = axes[0].imshow(img, origin="lower", extent=(0, 1, 0, 1), cmap="magma", vmin=0, vmax=vmax)
    axes[0].plot(*START, "c+", ms=10, label="start of every chain")
    axes[0].legend(fontsize=7, loc="upper left")
    axes[0].set_title("target image", fontsize=10)
    summary = res["summary"].set_index("config")
    for ax, name in zip(axes[1:], names):
        ax.imshow(dens[name], origin="lower", extent=(0, 1, 0, 1), cmap="magma", vmin=0, vmax=vmax)
        t, c = res["runs"][name].samples.shape[:2]
        ax.set_title(f"MH: {name}\n{t} steps × {c} chains, TV = {summary.loc[name, 'tv_final']:.3f}", fontsize=9)
    for ax in axes:
        ax.set_xlabel("x (image width = 1)", fontsize=8)
        ax.set_ylabel("y (image height = 1)", fontsize=8)
        ax.set_xticks([0, 0.5, 1])
        ax.set_yticks([0, 0.5, 1])
    bar = fig.colorbar(im, ax=list(axes), fraction=0.02, pad=0.01)
    bar.set_label("density (per unit area)", fontsize=8)
    return fig


def tv_figure(res: dict):
    tv = res["tv"]
    cells = "×".join(map(str, res["probs"].shape))
    fig, ax = plt.subplots(figsize=(6.5, 4.3))
    for col in tv.columns[2:]:
        ax.loglog(tv["steps"], tv[col], "o-", ms=3, color=COLOURS[col], label=col)
    outside = 1 - res["blob_mass"][0]
    ax.axhline(outside, color="0.5", ls=":", lw=1, label=f"mass outside the start blob: {outside:.3f}")
    chains = next(iter(res["runs"].values())).samples.shape[1]
    ax.set_xlabel(f"steps per chain ({chains} chains pooled)")
    ax.set_ylabel(f"total variation to the image, {cells} cells (dimensionless)", fontsize=9)
    ax.set_title("convergence of the MH histogram", fontsize=10)
    ax.legend(fontsize=8)
    return fig


def gallery_numbers(out: str | Path) -> dict:
    """The gallery caption's numbers, from ``metropolis_hastings_summary.csv`` and ``_tv.csv``."""
    s = pd.read_csv(Path(out) / "metropolis_hastings_summary.csv").set_index("large_step_prob")
    tv = pd.read_csv(Path(out) / "metropolis_hastings_tv.csv")
    lo, hi = LARGE_STEP_PROBS[1:]
    return {"tv_trapped": f"{s.loc[0.0, 'tv_final']:.2f}", "outside": f"{1 - s.loc[0.0, 'blob0_mass']:.2f}",
            "p_lo": f"{lo:.0%}", "p_hi": f"{hi:.0%}", "tv_lo": f"{s.loc[lo, 'tv_final']:.3f}",
            "tv_hi": f"{s.loc[hi, 'tv_final']:.3f}", "tv_iid": f"{tv[IID].iloc[-1]:.3f}",
            "steps": int(tv["steps"].iloc[-1])}


def main(out: str | Path = DEFAULT_OUT, full: bool = False) -> dict:
    """Run the chains, write CSV + PNG into ``out``, return the key numbers."""
    out = output_dir(out)
    n_steps, n_chains = (100_000, 64) if full else (8_000, 32)
    res = run_configs(n_steps, n_chains, seed=5)
    res["tv"].to_csv(out / "metropolis_hastings_tv.csv", index=False)
    res["summary"].to_csv(out / "metropolis_hastings_summary.csv", index=False)
    save_figure(histograms_figure(res), out / "metropolis_hastings_histograms.png")
    save_figure(tv_figure(res), out / "metropolis_hastings_tv.png")
    return {"tv": res["tv"], "summary": res["summary"], "blob_mass": res["blob_mass"],
            "n_steps": n_steps, "n_chains": n_chains, "files": sorted(p.name for p in out.iterdir())}


if __name__ == "__main__":
    experiment_cli(main, DEFAULT_OUT, __doc__)
