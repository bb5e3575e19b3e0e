"""Multiple importance sampling (MIS): heuristics, one-sample mixtures, and Veach's plates.

Questions answered (tables in ``mis_*.csv``, figures ``*.png``):

* on the 2D toy ``glossy-light`` (a narrow glossy lobe meets two lights, one small and
  bright, one large and dim), the per-sample variance of BRDF sampling, light sampling
  and their MIS combinations with the balance, power, maximum, cutoff and optimal
  heuristics, next to quadrature predictions (``vrlab.integrands.mc_variance``);
* the one-sample mixture (pick a technique at random) against the multi-sample estimator;
* Veach's bound: the balance heuristic is never worse than any other weighting by more
  than (1/min n_i - 1/sum n_i) I^2;
* the Veach MIS figure (four glossy plates x four spherical lights) rendered with BSDF,
  light and MIS (power) sampling, with the per-pixel variance in each (plate, light) region
  (per-sample pixel values from ``vrlab.render.PixelIntegrand(scene, preset).values``).

Run ``python -m vrlab.experiments.mis [--full] [--out DIR]``.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd


import matplotlib.pyplot as plt

from vrlab._rng import spawn
from vrlab.distributions import Mixture
from vrlab.estimate import Moments
from vrlab.estimators import HEURISTICS, MIS, MonteCarlo, OneSampleMIS
from vrlab.integrands import Integrand, catalogue, mc_variance
from vrlab.render import PixelIntegrand, builtin_scene_path, load_scene
from vrlab.render.direct import DirectLighting
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure

DEFAULT_OUT = Path("vrlab-out") / "mis"          # relative to the working folder
STRATEGIES = ("bsdf", "light", "mis-power")      # renderer presets (vrlab.render.PRESETS)
BLOCK_PIXELS = 4096                                # pixels per block of render_samples (memory bound)


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
    estimators = {"brdf only": MonteCarlo(b, probe=False), "light only": MonteCarlo(l, probe=False)}
    estimators.update({f"MIS {h}": MIS([b, l], heuristic=h, probe=False) for h in HEURISTICS})
    estimators["one-sample balance"] = OneSampleMIS([b, l], heuristic="balance", probe=False)
    estimators["one-sample power"] = OneSampleMIS([b, l], heuristic="power", probe=False)
    theory = {"brdf only": mc_variance(integrand, b), "light only": mc_variance(integrand, l),
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


def plot_toy(path: Path) -> Path:
    integrand = catalogue.get("glossy-light")
    b, l = integrand.techniques["brdf"], integrand.techniques["light"]
    g = np.linspace(0, 1, 240)
    x = np.stack(np.meshgrid(g, g, indexing="xy"), -1).reshape(-1, 2)
    panels = {"f (glossy lobe x lights)": integrand.f(x), "p_brdf": b.pdf(x), "p_light": l.pdf(x)}
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.4))
    for ax, (title, z) in zip(axes, panels.items()):
        im = ax.imshow(np.log10(z.reshape(240, 240) + 1e-3), origin="lower", extent=(0, 1, 0, 1))
        ax.set_title(f"log10({title})", fontsize=9)
        fig.colorbar(im, ax=ax, shrink=0.8)
    return save_figure(fig, path, dpi=110)


# --------------------------------------------------------------------------- Veach plates
def _scene(size):
    scene = load_scene(builtin_scene_path("veach_mis"))
    return dataclasses.replace(scene, sensor=dataclasses.replace(scene.sensor, width=size[0], height=size[1]))


def regions(scene) -> tuple[np.ndarray, np.ndarray, list, list]:
    """Per pixel: plate index (0-3, -1 elsewhere) and the light (0-3) closest in angle to the
    mirror reflection of the central camera ray.  Approximate highlight regions: every plate
    pixel is assigned to the light its mirror direction points nearest to."""
    integ = DirectLighting(scene)
    h, w = scene.sensor.height, scene.sensor.width
    rows, cols = np.divmod(np.arange(h * w), w)
    pix = np.stack([rows, cols], -1)
    o, d = integ.camera.pixel_rays(pix[:, None, :], np.full((h * w, 1, 2), 0.5))
    o, d = o.reshape(-1, 3), d.reshape(-1, 3)
    hits = integ.geometry.intersect(o, d)
    plates = [k for k, s in enumerate(scene.shapes) if s.bsdf.type == "roughconductor"]
    plate = np.full(h * w, -1)
    for i, k in enumerate(plates):
        plate[hits.shape == k] = i
    r = d - 2 * np.sum(d * hits.n, -1, keepdims=True) * hits.n
    cos = []
    for light in integ.lights:
        to = light.sphere[0] - hits.p
        cos.append(np.sum(r * to, -1) / np.linalg.norm(to, axis=-1))
    light = np.argmax(np.stack(cos, -1), -1)
    light = np.where(plate >= 0, light, -1)
    alphas = [scene.shapes[k].bsdf.params["alpha"] for k in plates]
    radii = [l.sphere[1] for l in integ.lights]
    return plate.reshape(h, w), light.reshape(h, w), alphas, radii


def render_samples(scene, estimator, spp: int, rng) -> np.ndarray:
    """Per-pixel, per-sample radiance ``(H, W, spp, 3)`` of ``estimator`` (a preset name or
    an estimator object): ``PixelIntegrand(scene, estimator).values`` on i.i.d. uniforms
    ``(pixels, spp, integ.dim)`` drawn from ``rng``, block after block of pixels.

    Each estimator needs its own number of uniforms per sample (``integ.dim``), so the
    strategies no longer share their uniforms bit for bit; nothing below relies on common
    random numbers (each strategy's per-pixel variance is measured on its own samples)."""
    return PixelIntegrand(scene, estimator).image_values(spp, rng, block_pixels=BLOCK_PIXELS)


def veach_study(size, spp: int, seed: int = 5):
    scene = _scene(size)
    plate, light, alphas, radii = regions(scene)
    images, var, mean = {}, {}, {}
    for k, s in enumerate(STRATEGIES):
        samples = render_samples(scene, s, spp, np.random.SeedSequence([seed, k]))
        images[s] = samples.mean(-2)
        mom = Moments().add(samples.mean(-1))
        var[s] = mom.variance          # per-pixel sample variance of the grey value
        mean[s] = mom.mean
    rows = []
    for i, a in enumerate(alphas):
        for j, r in enumerate(radii):
            m = (plate == i) & (light == j)
            if not m.any():
                continue
            row = {"plate": i, "alpha": a, "light": j, "radius": r, "pixels": int(m.sum())}
            for s in STRATEGIES:
                row[f"var_{s}"] = float(var[s][m].mean())
            for s in STRATEGIES:
                # a heavy-tailed technique that never hit the light shows a small sample
                # variance *and* a too-dark mean: keep the region means as a diagnostic
                row[f"mean_{s}"] = float(mean[s][m].mean())
            # a variance of exactly 0 means the technique never reached the light in the region
            # (e.g. BSDF sampling of the smallest light at low spp): unmeasured, not the best
            single = {s: row[f"var_{s}"] for s in ("bsdf", "light") if row[f"var_{s}"] > 0}
            row["best_single"] = min(single, key=single.get) if single else ""
            row["mis_over_best"] = row["var_mis-power"] / single[row["best_single"]] if single else np.nan
            rows.append(row)
    return pd.DataFrame(rows), images, (plate, light)


def plot_veach(images: dict, masks, spp: int, path: Path) -> Path:
    fig, axes = plt.subplots(1, 4, figsize=(15, 3.2))
    for ax, s in zip(axes, STRATEGIES):
        img = images[s]
        ax.imshow(np.clip(img / (1 + img), 0, 1) ** (1 / 2.2), interpolation="nearest")
        ax.set_title(f"{s}, {spp} spp", fontsize=9)
        ax.axis("off")
    plate, light = masks
    lab = np.where(plate >= 0, 4 * plate + light, np.nan)
    axes[3].imshow(lab, cmap="tab20", interpolation="nearest")
    axes[3].set_title("regions: colour = (plate, nearest light)", fontsize=9)
    axes[3].axis("off")
    return save_figure(fig, path, dpi=110)


def main(out: str | Path = DEFAULT_OUT, full: bool = False) -> dict:
    """Run every experiment, write CSV + PNG into ``out``, return the key numbers."""
    out = output_dir(out)
    n, reps = (100_000, 60) if full else (10_000, 30)
    table = heuristic_table(n, reps)
    table.to_csv(out / "mis_heuristics.csv", index=False)
    plot_toy(out / "mis_glossy_light.png")
    size, spp = ((200, 150), 64) if full else ((80, 60), 16)
    veach, images, masks = veach_study(size, spp)
    veach.to_csv(out / "mis_veach_regions.csv", index=False)
    plot_veach(images, masks, spp, out / "mis_veach.png")
    t = table.set_index("estimator")
    return {
        "heuristics": table, "veach": veach,
        "var_balance": float(t.loc["MIS balance", "var_measured"]),
        "var_balance_se": float(t.loc["MIS balance", "var_se"]),
        "var_balance_theory": float(t.loc["MIS balance", "var_theory"]),
        "var_optimal": float(t.loc["MIS optimal", "var_measured"]),
        "files": sorted(p.name for p in out.iterdir()),
    }


if __name__ == "__main__":
    experiment_cli(main, DEFAULT_OUT, __doc__)
