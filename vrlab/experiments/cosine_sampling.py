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

import time
from pathlib import Path

import numpy as np
import matplotlib.pyplot as plt
import pandas as pd

from vrlab._rng import spawn
from vrlab.distributions import CosineHemisphere, UniformHemisphere
from vrlab.estimate import Moments
from vrlab.estimators import MonteCarlo
from vrlab.integrands import catalogue
from vrlab.render import PixelIntegrand, builtin_scene_path, load_scene
from vrlab.testing import HemisphereChart, chi2_gof, sidak_threshold
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure

from ._figures import EXPOSURE_NOTE, exposure_of, show_image

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


COLOURS = {"uniform hemisphere": "C7", "inversion": "C0", "disk": "C1", "sphere-shift": "C2"}


def scatter_figure(gof: pd.DataFrame | None = None, n: int = 1500, seed: int = 1):
    """Top view (x, y) of the same uniforms pushed through each method, coloured by u1, and
    the density of cos(theta) against theory; with ``gof`` the chi-square p-values."""
    u = np.random.default_rng(seed).random((n, 2))
    fig, axes = plt.subplots(2, 4, figsize=(13, 6.6), layout="constrained")
    dists = {"uniform hemisphere": UniformHemisphere(), **{m: CosineHemisphere(method=m) for m in METHODS}}
    pvals = {} if gof is None else gof.set_index("method")["pvalue"].to_dict()
    for j, (label, dist) in enumerate(dists.items()):
        w = dist.sample(u)
        ax = axes[0, j]
        sc = ax.scatter(w[:, 0], w[:, 1], s=2, c=u[:, 0], cmap="viridis", vmin=0, vmax=1)
        ax.add_patch(plt.Circle((0, 0), 1, fill=False, color="k", lw=0.6))
        ax.set_aspect("equal"); ax.set_xlim(-1.05, 1.05); ax.set_ylim(-1.05, 1.05)
        name = label if label.startswith("uniform") else f"cosine: {label}"
        ax.set_title(f"{name}\ntop view of {n} directions", fontsize=9)
        ax.set_xlabel("x = sin θ cos φ (dimensionless)", fontsize=8)
        ax.set_ylabel("y = sin θ sin φ (dimensionless)", fontsize=8)
        ax = axes[1, j]
        ax.hist(w[:, 2], bins=30, range=(0, 1), density=True, color=COLOURS[label], alpha=0.8)
        z = np.linspace(0, 1, 50)
        ax.plot(z, np.ones_like(z) if label.startswith("uniform") else 2 * z, "k--", lw=1)
        p = pvals.get(label)
        ax.set_title("density of cos θ (dashed: theory)" + ("" if p is None else f"\nχ² test on the hemisphere: p = {p:.2g}"),
                     fontsize=9)
        ax.set_xlabel("cos θ (dimensionless)", fontsize=8)
        ax.set_ylabel("probability density of cos θ", fontsize=8)
    bar = fig.colorbar(sc, ax=axes[0, :], fraction=0.02, pad=0.01)
    bar.set_label("first uniform u₁ (dimensionless)", fontsize=8)
    fig.suptitle("the same uniforms (colour = u₁) through each map: different places, the same cosine distribution")
    return fig


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
    scene = scene.with_size(size[0], size[1])
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


def renders_figure(images: dict, spps: list[int], table: pd.DataFrame):
    """The renders at every spp; one exposure for all, from MIS at the highest spp."""
    strategies = RENDER_STRATEGIES
    t = table.set_index(["strategy", "spp"])
    exposure = exposure_of(images[(strategies[-1], max(spps))])
    fig, axes = plt.subplots(len(spps), len(strategies), figsize=(3.2 * len(strategies), 2.75 * len(spps)),
                             squeeze=False, layout="constrained")
    for i, spp in enumerate(spps):
        for j, s in enumerate(strategies):
            var = t.loc[(s, spp), "mean_pixel_variance"]
            show_image(axes[i, j], images[(s, spp)], exposure,
                       f"{s}, {spp} spp\nmean per-sample pixel variance {var:.3g}")
    h, w = images[(strategies[0], spps[0])].shape[:2]
    fig.suptitle(f"Cornell box, {w}×{h} pixels, equal spp ({EXPOSURE_NOTE}, from {strategies[-1]} at {max(spps)} spp)",
                 fontsize=10)
    return fig


def gallery_numbers(out: str | Path) -> dict:
    """The gallery caption's numbers, from ``cosine_sampling_renders.csv`` and ``_variance.csv``."""
    r = pd.read_csv(Path(out) / "cosine_sampling_renders.csv")
    v = pd.read_csv(Path(out) / "cosine_sampling_variance.csv").set_index("technique")
    spps = sorted(int(k) for k in r["spp"].unique())
    return {"spps": " and ".join(map(str, spps)), "var_uniform": f"{v.loc['uniform', 'var_measured']:.3g}",
            "var_uniform_theory": f"{v.loc['uniform', 'var_theory']:.3g}"}


def main(out: str | Path = DEFAULT_OUT, full: bool = False) -> dict:
    """Run every experiment, write CSV + PNG into ``out``, return the key numbers."""
    out = output_dir(out)
    gof = gof_table(1_000_000 if full else 200_000)
    gof.to_csv(out / "cosine_sampling_gof.csv", index=False)
    save_figure(scatter_figure(gof), out / "cosine_sampling_scatter.png")
    var = cos_variance(100_000 if full else 20_000, 50 if full else 20)
    var.to_csv(out / "cosine_sampling_variance.csv", index=False)
    spps = [64, 256, 1024] if full else [16, 64]
    size = (64, 48) if full else (32, 24)
    renders, images = render_study(size, spps)
    renders.to_csv(out / "cosine_sampling_renders.csv", index=False)
    save_figure(renders_figure(images, spps, renders), out / "cosine_sampling_renders.png")
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
