"""Cosine-weighted hemisphere sampling three ways, and what it buys in a diffuse scene.

Questions answered (tables in ``cosine_sampling_*.csv``, figures ``*.png``):

* three constructions of p(w) = cos(theta)/pi -- inversion of the marginal CDF, projecting
  a uniform disk point up (Malley), normalising normal + uniform sphere point -- give the
  same distribution: chi-square goodness-of-fit p-values (vrlab.testing) and scatter plots;
  and what each costs per sample;
* on the integrand cos(theta) over the hemisphere (integral pi) cosine sampling has zero
  variance while uniform hemisphere sampling has pi^2/3 (closed form);
* a diffuse scene (the built-in Cornell box, small) rendered with uniform hemisphere,
  cosine, light and MIS (power) sampling at equal spp (the renderer's presets, per-sample
  values from ``vrlab.render.PixelIntegrand``): per-pixel sample variance.

Run ``python -m vrlab.experiments.cosine_sampling [--full] [--out DIR]``.
"""
from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np
import pandas as pd


import matplotlib.pyplot as plt

from vrlab._rng import spawn
from vrlab.distributions import CosineHemisphere, UniformHemisphere
from vrlab.estimate import Moments
from vrlab.estimators import MonteCarlo
from vrlab.integrands import catalogue
from vrlab.render import PixelIntegrand, builtin_scene_path, load_scene
from vrlab.testing import HemisphereChart, chi2_gof, sidak_threshold
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure

DEFAULT_OUT = Path("vrlab-out") / "cosine_sampling"          # relative to the working folder
METHODS = ("inversion", "disk", "sphere-shift")
ALPHA = 0.01   # family-wise level of the three chi-square tests
RENDER_STRATEGIES = ("uniform", "cosine", "light", "mis-power")   # renderer presets
BLOCK_PIXELS = 4096   # pixels per block of render_samples (memory bound)


def gof_table(n: int, seed: int = 0) -> pd.DataFrame:
    """Chi-square GOF of each construction against cos/pi on a (theta, phi) grid, and speed."""
    level = sidak_threshold(ALPHA, len(METHODS))
    rows = []
    for k, m in enumerate(METHODS):
        dist = CosineHemisphere(method=m)
        r = chi2_gof(dist, HemisphereChart(), bins=[10, 20], n=n, rng=seed + k)
        u = np.random.default_rng(seed).random((200_000, 2))
        dist.sample(u[:1000])  # warm up
        t0 = time.perf_counter()
        reps = 3
        for _ in range(reps):
            dist.sample(u)
        ns_per = (time.perf_counter() - t0) / reps / len(u) * 1e9
        rows.append({"method": m, "chi2": r.statistic, "dof": r.dof, "pvalue": r.pvalue, "n": r.n,
                     "level": level, "passes": r.pvalue > level, "ns_per_sample": ns_per})
    return pd.DataFrame(rows)


def plot_scatter(path: Path, n: int = 1500, seed: int = 1) -> Path:
    """Top view (x, y) and side view (x, z) of the same uniforms pushed through each method."""
    u = np.random.default_rng(seed).random((n, 2))
    fig, axes = plt.subplots(2, 4, figsize=(13, 6.2))
    dists = {"uniform hemisphere": UniformHemisphere(), **{f"cosine: {m}": CosineHemisphere(method=m) for m in METHODS}}
    for j, (label, dist) in enumerate(dists.items()):
        w = dist.sample(u)
        ax = axes[0, j]
        ax.scatter(w[:, 0], w[:, 1], s=2, c=u[:, 0], cmap="viridis")
        ax.add_patch(plt.Circle((0, 0), 1, fill=False, color="k", lw=0.6))
        ax.set_aspect("equal"); ax.set_xlim(-1.05, 1.05); ax.set_ylim(-1.05, 1.05)
        ax.set_title(f"{label}\ntop view (x, y)", fontsize=9)
        ax = axes[1, j]
        ax.hist(w[:, 2], bins=30, range=(0, 1), density=True, alpha=0.7)
        z = np.linspace(0, 1, 50)
        ax.plot(z, 2 * z if label.startswith("cosine") else np.ones_like(z), "k--", lw=1)
        ax.set_title("density of cos θ (dashed: theory)", fontsize=9)
    fig.suptitle("colour = first uniform u₁: the methods map the same u differently, the distribution is the same")
    return save_figure(fig, path, dpi=110)


def cos_variance(n: int, reps: int, seed: int = 2) -> pd.DataFrame:
    """Per-sample variance of uniform vs cosine sampling of int_H cos(theta) dw = pi."""
    integrand = catalogue.get("cos-hemisphere")
    rows = []
    for k, (label, dist) in enumerate(integrand.techniques.items()):
        est = MonteCarlo(dist, probe=False)
        v = np.array([est.estimate(integrand, n, rng=g).variance for g in spawn(np.random.SeedSequence([seed, k]), reps)])
        rows.append({"technique": label, "n": n, "reps": reps, "var_measured": v.mean(),
                     "var_se": v.std(ddof=1) / np.sqrt(reps), "var_theory": integrand.theory[f"var:{label}"]})
    for m in METHODS[1:]:   # the other two cosine constructions are exact too
        e = MonteCarlo(CosineHemisphere(method=m), probe=False).estimate(integrand, n, rng=seed)
        rows.append({"technique": f"cosine ({m})", "n": n, "reps": 1, "var_measured": e.variance,
                     "var_se": 0.0, "var_theory": 0.0})
    return pd.DataFrame(rows)


def render_samples(scene, estimator, spp: int, rng) -> np.ndarray:
    """Per-pixel, per-sample radiance ``(H, W, spp, 3)`` of ``estimator`` (a preset name such
    as ``"uniform"``, ``"cosine"``, ``"mis-power"``, or an estimator object):
    ``PixelIntegrand(scene, estimator).values`` on i.i.d. uniforms ``(pixels, spp, integ.dim)``
    from ``rng``, block after block of pixels.  Each estimator needs its own number of
    uniforms per sample (``integ.dim``): with the same ``rng``, strategies of the same dim
    (``"uniform"`` and ``"cosine"``, 4) get the very same uniforms, as all strategies did
    with the old fixed layout, so their variance ratio has common random numbers; the
    others (``"light"`` 5, ``"mis-power"`` 7) now get uniforms of their own."""
    return PixelIntegrand(scene, estimator).image_values(spp, rng, block_pixels=BLOCK_PIXELS)


def render_study(size: tuple[int, int], spps: list[int], seed: int = 3):
    scene = load_scene(builtin_scene_path("cornell_box"))
    scene = dataclasses.replace(scene, sensor=dataclasses.replace(scene.sensor, width=size[0], height=size[1]))
    rows, images = [], {}
    for spp in spps:
        for strategy in RENDER_STRATEGIES:
            t0 = time.perf_counter()
            s = render_samples(scene, strategy, spp, [seed, spp])    # same uniforms where dims agree
            secs = time.perf_counter() - t0
            lum = s.mean(-1)                                  # (H, W, spp) grey value
            mom = Moments().add(lum)
            var = mom.variance                                # per-pixel sample variance
            images[(strategy, spp)] = s.mean(-2)
            rows.append({"strategy": strategy, "spp": spp, "mean_pixel_variance": float(np.mean(var)),
                         "mean_pixel_stderr": float(np.mean(np.sqrt(var / spp))),
                         "image_mean": float(lum.mean()), "seconds": secs})
    table = pd.DataFrame(rows)
    base = table[table.strategy == "uniform"].set_index("spp")["mean_pixel_variance"]
    table["variance_vs_uniform"] = table["mean_pixel_variance"] / table["spp"].map(base)
    return table, images


def plot_renders(images: dict, spps: list[int], path: Path) -> Path:
    strategies = RENDER_STRATEGIES
    fig, axes = plt.subplots(len(spps), 4, figsize=(12, 2.6 * len(spps)), squeeze=False)
    for i, spp in enumerate(spps):
        for j, s in enumerate(strategies):
            img = images[(s, spp)]
            axes[i, j].imshow(np.clip(img / (1 + img), 0, 1) ** (1 / 2.2), interpolation="nearest")
            axes[i, j].set_title(f"{s}, {spp} spp", fontsize=9)
            axes[i, j].axis("off")
    return save_figure(fig, path, dpi=110)


def main(out: str | Path = DEFAULT_OUT, full: bool = False) -> dict:
    """Run every experiment, write CSV + PNG into ``out``, return the key numbers."""
    out = output_dir(out)
    gof = gof_table(1_000_000 if full else 200_000)
    gof.to_csv(out / "cosine_sampling_gof.csv", index=False)
    plot_scatter(out / "cosine_sampling_scatter.png")
    var = cos_variance(100_000 if full else 20_000, 50 if full else 20)
    var.to_csv(out / "cosine_sampling_variance.csv", index=False)
    spps = [64, 256, 1024] if full else [16, 64]
    size = (64, 48) if full else (32, 24)
    renders, images = render_study(size, spps)
    renders.to_csv(out / "cosine_sampling_renders.csv", index=False)
    plot_renders(images, spps, out / "cosine_sampling_renders.png")
    v = var.set_index("technique")
    return {
        "gof": gof, "variance": var, "renders": renders,
        "var_uniform": float(v.loc["uniform", "var_measured"]),
        "var_uniform_se": float(v.loc["uniform", "var_se"]),
        "var_cosine": float(v.loc["cosine", "var_measured"]),
        "files": sorted(p.name for p in out.iterdir()),
    }


if __name__ == "__main__":
    experiment_cli(main, DEFAULT_OUT, __doc__)
