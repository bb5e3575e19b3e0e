"""Resampled importance sampling (RIS): variance and efficiency against the number of candidates M.

RIS (Talbot, Cline & Egbert 2005; the RIS section of the CT5202 notes) draws M candidates
x_1..x_M from an easy source density p, weights them w_j = p̂(x_j) / p(x_j) with an
unnormalised target p̂, keeps one, Y, with probability proportional to its weight and returns

    F = f(Y) / p̂(Y) * (1/M) sum_j w_j .

Questions answered (tables ``ris_*.csv``, figures ``ris_*.png``):

* 1D, ``gauss-bump`` (a Gaussian of width 0.05 on [0, 1]), uniform source, target p̂ = a
  Gaussian 1.5x wider (close to f, not proportional to it): the per-output-sample variance for
  M = 1, 2, ..., 64 against its two limits, Var_p[f/p] at M = 1 (plain MC) and, as M -> oo,
  the variance of IS with the normalised density p̂ / int p̂ (both by quadrature);
* the special case p̂ = f, where F = (1/M) sum_j f(x_j) / p(x_j) and Var = Var_p[f/p] / M exactly
  (checked against a standard-error band built from the fourth moment of f(U));
* efficiency 1 / (variance x cost per output sample) when every candidate costs time, with the
  measured NumPy time (f is as cheap as a candidate here) and with a cost model where f costs
  F_COST = 10 candidates (as a shadow ray does): an optimum M in between;
* the ``many_lights`` scene (128 sphere lights, powers over three decades): one light sample
  with the light chosen uniformly or by power, against RIS with M = 1, 4, 16, 32 uniformly drawn
  light candidates and M = 16 power-drawn ones (one shadow ray each; the renderer's presets
  ``"light"`` and ``"ris"``, i.e. ``MonteCarlo("light")`` and ``RIS("light",
  target="unshadowed", m=M)``, with ``light_selection=``): relMSE against a 16x-spp
  reference (over the pixels that see no light) and render time.

Run ``python -m vrlab.experiments.ris [--full] [--out DIR]``.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import matplotlib.pyplot as plt
import pandas as pd

from vrlab._rng import spawn
from vrlab.estimators import RIS
from vrlab.integrands import catalogue, mc_variance
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure
from vrlab.render import builtin_scene_path, load_scene, render
from vrlab.render.direct import DirectLighting
from vrlab.metrics import REL_MSE_EPS, rel_mse, relative_squared_error

from ._figures import EXPOSURE_NOTE, exposure_of, show_image

DEFAULT_OUT = Path("vrlab-out") / "ris"          # relative to the working folder
MS = (1, 2, 4, 8, 16, 32, 64)
EPS = REL_MSE_EPS               # relMSE = (x - ref)^2 / (ref^2 + EPS): vrlab.metrics
F_COST = 10.0                   # cost model: one f evaluation (a shadow ray) = 10 candidates
REF_M = 16                      # candidates of the many-lights reference (power-drawn)


# --------------------------------------------------------------------------- 1D toy
def toy():
    """The integrand, the uniform source p and the normalised 'close' target (a wider Gaussian)."""
    f = catalogue.get("gauss-bump")
    return f, f.techniques["uniform"], f.techniques["normal"]


def limits() -> dict:
    """Var of one sample at M = 1 (IS with p) and as M -> oo (IS with p̂ / int p̂), by quadrature."""
    f, source, target = toy()
    return {"var_m1": mc_variance(f, source), "var_inf": mc_variance(f, target),
            "exact": float(f.exact)}


def proportional_band(m: int, n: int, reps: int) -> float:
    """Standard error of the replicate-mean per-sample variance when F is the mean of ``m`` i.i.d.
    X = f(U) (p = uniform, p̂ = f, or M = 1): Var(s^2) = (mu4_F - sigma_F^4) / n with
    mu4_F = (mu4_X + 3 (m - 1) sigma_X^4) / m^3 (for Gaussian F this is the chi-square band
    2 sigma^4 / n).  The moments of X come from a fine midpoint rule."""
    f, _, _ = toy()
    x = (np.arange(400_000) + 0.5) / 400_000
    d = f(x[:, None]) - f.exact
    s2, mu4 = float(np.mean(d**2)), float(np.mean(d**4))
    mu4_f = (mu4 + 3 * (m - 1) * s2 * s2) / m**3
    return float(np.sqrt((mu4_f - (s2 / m) ** 2) / (n * reps)))


def _replicates(est, f, n: int, reps: int, seed) -> dict:
    es = [est.estimate(f, n, rng=g) for g in spawn(seed, reps)]
    v = np.array([e.variance for e in es])
    vals = np.array([e.value for e in es])
    secs = np.array([e.seconds for e in es])
    return {"var_measured": v.mean(), "var_se": v.std(ddof=1) / np.sqrt(reps),
            "mean_value": vals.mean(), "value_se": vals.std(ddof=1) / np.sqrt(reps),
            "sec_per_sample": float(np.min(secs)) / n}      # best of reps: least disturbed by load


def variance_sweep(ms, n: int, reps: int, seed: int = 1) -> pd.DataFrame:
    """Per M: measured per-sample variance (mean over ``reps`` runs of ``n`` output samples) and
    time per output sample, for the close target and for p̂ = f (theory Var_p[f/p] / M)."""
    f, source, target = toy()
    lim = limits()
    rows = []
    for k, m in enumerate(ms):
        for case, tgt in (("close", target.pdf), ("proportional", f)):
            ss = np.random.SeedSequence([seed, k, len(case)])
            r = _replicates(RIS(source, tgt, int(m), probe=False), f, n, reps, ss)
            r.update(case=case, M=int(m), n=n, reps=reps, exact=lim["exact"],
                     var_theory=lim["var_m1"] / m if case == "proportional" else
                     (lim["var_m1"] if m == 1 else np.nan))
            rows.append(r)
    t = pd.DataFrame(rows)
    t["var_interp"] = lim["var_inf"] + (lim["var_m1"] - lim["var_inf"]) / t["M"]   # not a theorem
    t["ratio"] = t["var_measured"] / t["var_theory"]
    t["ratio_se"] = t["var_se"] / t["var_theory"]
    t["ratio_band"] = [proportional_band(m, n, reps) / vt if (c == "proportional" or m == 1) else np.nan
                       for c, m, vt in zip(t["case"], t["M"], t["var_theory"])]   # theory SE of ratio
    # efficiency with the measured time per output sample; the two cases do the same work, so
    # each M uses the mean of their times
    sec = t.groupby("M")["sec_per_sample"].transform("mean")
    t["efficiency"] = 1.0 / (t["var_measured"] * sec)
    a, b = cost_fit(t)
    t["sec_fit"] = a + b * t["M"]
    # the same with a cost model where f is expensive, as a shadow ray is: cost F_COST + M
    t["cost_model"] = F_COST + t["M"]
    t["efficiency_model"] = 1.0 / (t["var_measured"] * t["cost_model"])
    return t


def cost_fit(table: pd.DataFrame) -> tuple[float, float]:
    """a, b of time per output sample = a + b M (a: f and bookkeeping, b: one candidate), fitted
    by least squares on relative errors (weights 1 / time), so the small M count as much as the large."""
    m, sec = table["M"].to_numpy(float), table["sec_per_sample"].to_numpy(float)
    b, a = np.polyfit(m, sec, 1, w=1.0 / sec)
    return float(max(a, 0.0)), float(b)


def selection_histograms(ms=(1, 4, 64), n: int = 50_000, seed: int = 3) -> dict:
    """Samples Y kept by the reservoir for several M (close target): their density tends to p̂ / int p̂."""
    f, source, target = toy()
    out = {}
    for k, m in enumerate(ms):
        ris = RIS(source, target.pdf, m)
        u = np.random.default_rng([seed, k]).random((n, ris.dim_u()))
        out[m] = ris.reservoirs(u).y[:, 0]
    return out


COLOURS = {"close": "C0", "proportional": "C1", "light, uniform": "C7", "light, power": "C5",
           "RIS, uniform candidates": "C2", "RIS, power candidates": "C3"}


def variance_figure(table: pd.DataFrame, lim: dict, hists: dict):
    """Variance against M with its limits, efficiency against M, and the kept sample's density."""
    f, source, target = toy()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.3))
    ax = axes[0]
    ms = np.array(sorted(table["M"].unique()), float)
    mm = np.geomspace(ms[0], ms[-1], 100)
    for case, label in (("close", "p̂ = wider Gaussian (close to f)"), ("proportional", "p̂ = f")):
        t = table[table["case"] == case]
        ax.errorbar(t["M"], t["var_measured"], 2 * t["var_se"], fmt="o", ms=4, color=COLOURS[case], label=label)
    ax.plot(mm, lim["var_m1"] / mm, color=COLOURS["proportional"], lw=1, ls="--", label="Var_p[f/p] / M")
    ax.plot(mm, lim["var_inf"] + (lim["var_m1"] - lim["var_inf"]) / mm, color="0.5", lw=0.8,
            label="V∞ + (V₁ − V∞)/M (interpolation)")
    ax.axhline(lim["var_m1"], color="k", lw=0.8, ls=":", label="M = 1: Var_p[f/p] (plain MC)")
    ax.axhline(lim["var_inf"], color=COLOURS["close"], lw=0.8, ls="-.", label="M → ∞: IS with p̂/∫p̂")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("candidates M")
    ax.set_ylabel("variance per output sample (dimensionless)")
    ax.set_title("RIS variance, gauss-bump, uniform source (± 2 se)", fontsize=10)
    ax.legend(fontsize=7)

    ax = axes[1]
    t = table[table["case"] == "close"]
    tp = table[table["case"] == "proportional"]
    c = COLOURS["close"]
    best = {col: int(t.loc[t[col].idxmax(), "M"]) for col in ("efficiency", "efficiency_model")}
    ax.plot(t["M"], t["efficiency"] / t["efficiency"].iloc[0], "o-", color=c,
            label=f"p̂ close, measured time (f cheap): best M = {best['efficiency']}")
    ax.plot(t["M"], t["efficiency_model"] / t["efficiency_model"].iloc[0], "o--", color=c,
            label=f"p̂ close, cost {F_COST:g} + M: best M = {best['efficiency_model']}")
    ax.plot(tp["M"], tp["efficiency_model"] / tp["efficiency_model"].iloc[0], "s:", color=COLOURS["proportional"],
            label=f"p̂ = f, cost {F_COST:g} + M")
    ax.set_xscale("log", base=2)
    ax.set_xlabel("candidates M")
    ax.set_ylabel("efficiency 1/(Var × cost), relative to M = 1")
    ax.set_title(f"candidates cost time (cost model: f = {F_COST:g} candidates)", fontsize=10)
    ax.legend(fontsize=7)

    ax = axes[2]
    x = np.linspace(0, 1, 400)[:, None]
    shades = plt.get_cmap("Purples")(np.linspace(0.55, 1.0, len(hists)))
    for (m, y), shade in zip(hists.items(), shades):
        ax.hist(y, bins=80, range=(0.2, 0.8), density=True, histtype="step", color=shade,
                label=f"kept Y, M = {m} ({len(y)} samples)")
    ax.plot(x[:, 0], target.pdf(x), "k", lw=1, label="p̂ / ∫p̂")
    ax.plot(x[:, 0], f(x) / f.exact, "k:", lw=1, label="f / ∫f")
    ax.set_xlim(0.2, 0.8)
    ax.set_xlabel("x (dimensionless)")
    ax.set_ylabel("probability density (dimensionless)")
    ax.set_title("the kept sample's density tends to p̂/∫p̂", fontsize=10)
    ax.legend(fontsize=7)
    return fig


# --------------------------------------------------------------------------- many lights
def methods(ms, power_candidates: bool = True) -> list[tuple[str, str, str, int]]:
    """(label, strategy, light_selection, M)."""
    rows = [("light, uniform", "light", "uniform", 1), ("light, power", "light", "power", 1)]
    rows += [(f"RIS M={m}", "ris", "uniform", m) for m in ms]
    if power_candidates:
        rows.append((f"RIS M={max(ms) // 2}, power cand.", "ris", "power", max(ms) // 2))
    return rows


def small_scene(size):
    """``many_lights`` at ``size`` = (width, height) pixels."""
    scene = load_scene(builtin_scene_path("many_lights"))
    return scene.with_size(size[0], size[1])


def light_free_mask(scene, sub: int = 6) -> np.ndarray:
    """(H, W) True where none of ``sub`` x ``sub`` camera rays through the pixel or its 8
    neighbours hits a light.

    A pixel that sees part of a light gets a camera-sampling error (radiance up to 1000 or the
    floor's ~1) that no light-selection strategy touches and that dominates a relMSE at a few
    spp; the comparison uses the other pixels."""
    hit = DirectLighting(scene).pixel_hits(sub)           # geometry and camera only
    h, w = scene.sensor.height, scene.sensor.width
    emitters = np.array([s.emitter is not None for s in scene.shapes] + [False])
    lit = emitters[np.where(hit >= 0, hit, len(scene.shapes))].any(-1)
    lit = np.pad(lit.reshape(h, w), 1)
    near = np.zeros((h, w), bool)
    for dy in range(3):          # and their neighbours: a light can show in a pixel between the rays
        for dx in range(3):
            near |= lit[dy:dy + h, dx:dx + w]
    return ~near


def relmse(img: np.ndarray, ref: np.ndarray, ref_err: np.ndarray | None = None, mask=None) -> float:
    """Mean over (masked) pixels and channels of (img - ref)^2 / (ref^2 + EPS); with ``ref_err``
    the reference's own variance (ref_err^2, independent noise) is subtracted."""
    return rel_mse(img, ref, ref_err=ref_err, mask=mask)


def many_lights(size, spp: int, ref_spp: int, ms, seed: int = 7, power_candidates: bool = True
                ) -> tuple[pd.DataFrame, dict, np.ndarray]:
    """Render ``many_lights`` with every method at ``spp`` and a reference (RIS, M = 16, power
    candidates, ``ref_spp``, its own seed); relMSE over the pixels that see no light."""
    scene = small_scene(size)
    mask = light_free_mask(scene)
    t0 = time.perf_counter()
    ref_est = render(scene, ref_spp, "ris", rng=[seed, 0], light_selection="power", ris_candidates=REF_M)
    ref_sec = time.perf_counter() - t0
    ref, ref_err = ref_est.value.astype(float), ref_est.stderr.astype(float)
    rows, images = [], {}
    for k, (label, strategy, sel, m) in enumerate(methods(ms, power_candidates), start=1):
        t0 = time.perf_counter()
        est = render(scene, spp, strategy, rng=[seed, k], light_selection=sel, ris_candidates=m)
        img, err = est.value, est.stderr
        sec = time.perf_counter() - t0
        images[label] = img
        rel = relmse(img, ref, ref_err, mask)
        pred = float(np.mean(relative_squared_error(err.astype(float) ** 2, ref)[mask]))   # unbiased: MSE = Var
        rows.append({"method": label, "strategy": strategy, "light_selection": sel,
                     "M": m if strategy == "ris" else np.nan, "spp": spp, "seconds": sec,
                     "relmse": rel, "relmse_from_stderr": pred, "relmse_x_seconds": rel * sec,
                     "mean": float(img.mean()), "ref_mean": float(ref.mean())})
    t = pd.DataFrame(rows)
    t["pixels"] = int(mask.sum())
    t["lights"] = sum(s.emitter is not None for s in scene.shapes)
    t.attrs.update(ref_spp=ref_spp, ref_seconds=ref_sec, ref_relmse_from_stderr=float(
        np.mean(relative_squared_error(ref_err ** 2, ref)[mask])))
    return t, images, ref


def images_figure(table: pd.DataFrame, images: dict, ref: np.ndarray):
    """Every method's render and the reference at one exposure (from the reference)."""
    n = len(images) + 1
    cols = 4
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.4 * cols, 3.0 * rows), layout="constrained")
    axes = axes.ravel()
    exposure = exposure_of(ref)
    t = table.set_index("method")
    show_image(axes[0], ref, exposure, f"reference ({table.attrs.get('ref_spp')} spp, RIS M={REF_M}, power)", 8)
    for ax, (label, img) in zip(axes[1:], images.items()):
        r = t.loc[label]
        show_image(ax, img, exposure, f"{label}, {int(r['spp'])} spp", 8)
        ax.set_xlabel(f"relMSE {r['relmse']:.3g}, {r['seconds']:.2f} s", fontsize=8)
    for ax in axes[n:]:
        fig.delaxes(ax)
    fig.suptitle(f"many_lights: {int(table['lights'].iloc[0])} sphere lights, one shadow ray per sample; relMSE over "
                 f"the {int(table['pixels'].iloc[0])} pixels that see no light ({EXPOSURE_NOTE})", fontsize=10)
    return fig


def efficiency_figure(table: pd.DataFrame):
    """relMSE and relMSE x time against M, with one-sample light selection as lines."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    t = table.set_index("method")
    ris = table[(table["strategy"] == "ris") & (table["light_selection"] == "uniform")]
    pw = table[(table["strategy"] == "ris") & (table["light_selection"] == "power")]
    for ax, col, ylabel in ((axes[0], "relmse", "relMSE (equal spp)"),
                            (axes[1], "relmse_x_seconds", "relMSE × render time (s), lower = better")):
        ax.plot(ris["M"], ris[col], "o-", color=COLOURS["RIS, uniform candidates"], label="RIS, uniform candidates")
        for label, ls in (("light, uniform", "--"), ("light, power", ":")):
            ax.axhline(float(t.loc[label, col]), color=COLOURS[label], ls=ls, label=label)
        ax.plot(pw["M"], pw[col], "s", color=COLOURS["RIS, power candidates"], label="RIS, power candidates")
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_xlabel("candidates M")
        ax.set_ylabel(ylabel)
        ax.legend(fontsize=7)
    spp = int(table["spp"].iloc[0])
    axes[0].set_title(f"many_lights: error at equal samples ({spp} spp)", fontsize=10)
    axes[1].set_title("many_lights: error × time", fontsize=10)
    return fig


def gallery_numbers(out: str | Path) -> dict:
    """The gallery caption's numbers, from ``ris_many_lights.csv``."""
    t = pd.read_csv(Path(out) / "ris_many_lights.csv")
    power = t[(t["strategy"] == "ris") & (t["light_selection"] == "power")].iloc[0]
    m = int(power["M"])
    by = t.set_index("method")["relmse"]
    return {"lights": int(t["lights"].iloc[0]), "spp": int(t["spp"].iloc[0]), "m": m,
            "uniform": f"{by['light, uniform']:.2g}", "power": f"{by['light, power']:.2g}",
            "ris": f"{by[f'RIS M={m}']:.2g}", "ris_power": f"{power['relmse']:.2g}"}


def main(out: str | Path = DEFAULT_OUT, full: bool = False) -> dict:
    """Run the 1D sweep and the many-lights renders, write CSV + PNG into ``out``, return key numbers."""
    out = output_dir(out)
    lim = limits()
    n, reps = (50_000, 40) if full else (10_000, 20)
    table = variance_sweep(MS, n, reps)
    table.to_csv(out / "ris_variance.csv", index=False)
    save_figure(variance_figure(table, lim, selection_histograms()), out / "ris_variance.png")

    size, spp, ref_spp = ((160, 120), 8, 512) if full else ((80, 60), 8, 128)
    lights, images, ref = many_lights(size, spp, ref_spp, (1, 4, 16, 32))
    lights.to_csv(out / "ris_many_lights.csv", index=False)
    save_figure(images_figure(lights, images, ref), out / "ris_many_lights.png")
    save_figure(efficiency_figure(lights), out / "ris_many_lights_efficiency.png")

    close = table[table["case"] == "close"].set_index("M")
    prop = table[table["case"] == "proportional"].set_index("M")
    ml = lights.set_index("method")
    return {
        "variance": table, "many_lights": lights, "limits": lim,
        "var_m1": float(close.loc[1, "var_measured"]), "var_m1_se": float(close.loc[1, "var_se"]),
        "var_m64": float(close.loc[64, "var_measured"]), "var_m64_se": float(close.loc[64, "var_se"]),
        "best_M": int(close["efficiency"].idxmax()), "best_M_model": int(close["efficiency_model"].idxmax()),
        "cost_fit_ns": tuple(1e9 * x for x in cost_fit(table)),
        "var_m1_band": float(close.loc[1, "ratio_band"] * close.loc[1, "var_theory"]),
        "proportional_ratio": prop["ratio"].to_dict(),
        "proportional_ratio_band": prop["ratio_band"].to_dict(),
        "relmse": ml["relmse"].to_dict(), "seconds": ml["seconds"].to_dict(),
        "ref_spp": ref_spp, "ref_seconds": lights.attrs["ref_seconds"],
        "files": sorted(p.name for p in out.iterdir()),
    }


if __name__ == "__main__":
    experiment_cli(main, DEFAULT_OUT, __doc__)
