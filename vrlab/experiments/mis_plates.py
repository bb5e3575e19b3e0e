"""Veach's glossy plates (built-in scene ``veach_mis``) for :mod:`vrlab.experiments.mis`.

Four methods at equal cost, two evaluations per camera ray: BSDF sampling and light
sampling with two samples each, and MIS with one sample of each technique weighted by
the balance or the power heuristic (``MIS(["light", "bsdf"], heuristic=...)``).

Regions: plate i (1 roughest ... 4 sharpest, ordered by the GGX alpha of the plates'
BSDFs) x light X (A smallest ... D largest, by radius).  Each plate pixel goes to the light
whose centre is nearest in angle to the mirror reflection of its central camera ray (an
approximate highlight region).  Per region the table gives the mean over its pixels of

    relMSE = s^2 / spp / (ref^2 + 0.01),

s^2 the pixel's sample variance of one sample's grey value and ref the mean of the four
methods' pixel estimates (each unbiased): the expected relMSE of the spp-sample pixel
estimate (MSE = variance for an unbiased estimator).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

import matplotlib.pyplot as plt

from vrlab.estimators import MIS, MonteCarlo
from vrlab.lab.experiment import save_figure
from vrlab.render import PixelIntegrand, builtin_scene_path, load_scene
from vrlab.render.direct import DirectLighting
from vrlab.render.image import auto_exposure, srgb_encode
from vrlab.metrics import relative_squared_error

#: one colour per method, in every figure of vrlab.experiments.mis (toy and plates)
COLORS = {"BSDF only": "tab:blue", "light only": "tab:orange", "MIS balance": "tab:green",
          "MIS power": "tab:red", "MIS maximum": "tab:purple", "MIS cutoff": "tab:brown",
          "MIS optimal": "tab:pink", "one-sample balance": "tab:olive", "one-sample power": "tab:cyan"}
#: the plates' methods: (estimator, units per camera ray), two evaluations per ray each
METHODS = {"BSDF only": (lambda: MonteCarlo("bsdf"), 2), "light only": (lambda: MonteCarlo("light"), 2),
           "MIS balance": (lambda: MIS(["light", "bsdf"], heuristic="balance"), 1),
           "MIS power": (lambda: MIS(["light", "bsdf"], heuristic="power"), 1)}
SINGLE = ("BSDF only", "light only")
LETTERS = "ABCDEFGH"
BLOCK_PIXELS = 4096                                # pixels per block of image_values (memory bound)


def plates_scene(size: tuple[int, int]):
    """The built-in ``veach_mis`` scene with its sensor set to ``size`` = (width, height)."""
    scene = load_scene(builtin_scene_path("veach_mis"))
    return scene.with_size(size[0], size[1])


def region_name(plate: int, light: int, short: bool = False) -> str:
    """``"plate 2 × light A"`` (``"2A"`` if short) for 0-based ranks."""
    return f"{plate + 1}{LETTERS[light]}" if short else f"plate {plate + 1} × light {LETTERS[light]}"


def regions(scene) -> tuple[np.ndarray, np.ndarray, list, list]:
    """``(plate, light, alphas, radii)``: per pixel the plate rank (0 = roughest, -1 off the
    plates) and the light rank (0 = smallest) nearest in angle to the mirror reflection of the
    central camera ray; the plates' alpha (read from their BSDFs) by rank and the lights'
    radii by rank."""
    integ = DirectLighting(scene)
    h, w = scene.sensor.height, scene.sensor.width
    rows, cols = np.divmod(np.arange(h * w), w)
    o, d = integ.camera.pixel_rays(np.stack([rows, cols], -1)[:, None, :], np.full((h * w, 1, 2), 0.5))
    o, d = o.reshape(-1, 3), d.reshape(-1, 3)
    hits = integ.geometry.intersect(o, d)
    plates = [k for k, s in enumerate(scene.shapes) if s.bsdf.type == "roughconductor"]
    alphas = [float(scene.shapes[k].bsdf.alpha) for k in plates]
    plate = np.full(h * w, -1)
    for rank, i in enumerate(np.argsort(alphas)[::-1]):           # roughest first
        plate[hits.shape == plates[i]] = rank
    r = d - 2 * np.sum(d * hits.n, -1, keepdims=True) * hits.n
    radii = [float(light.sphere[1]) for light in integ.lights]
    order = np.argsort(radii)                                     # smallest first
    cos = [np.sum(r * (integ.lights[int(j)].sphere[0] - hits.p), -1)
           / np.linalg.norm(integ.lights[int(j)].sphere[0] - hits.p, axis=-1) for j in order]
    light = np.where(plate >= 0, np.argmax(np.stack(cos, -1), -1), -1)
    return (plate.reshape(h, w), light.reshape(h, w), sorted(alphas, reverse=True), sorted(radii))


def study(size: tuple[int, int], spp: int, seed: int = 5) -> tuple[pd.DataFrame, dict]:
    """Render the plates with every method of ``METHODS``; the per-region table (see the
    module docstring) and ``{"images": {method: (H, W, 3)}, "ref", "plate", "light",
    "alphas", "radii", "spp", "size"}`` for :func:`plot`."""
    scene = plates_scene(size)
    plate, light, alphas, radii = regions(scene)
    images, var, mean = {}, {}, {}
    for k, (name, (make, units)) in enumerate(METHODS.items()):
        samples = PixelIntegrand(scene, make(), units=units).image_values(
            spp, np.random.SeedSequence([seed, k]), block_pixels=BLOCK_PIXELS)
        images[name] = samples.mean(-2, dtype=np.float64)
        grey = samples.mean(-1, dtype=np.float64)               # (H, W, spp)
        var[name], mean[name] = grey.var(-1, ddof=1), grey.mean(-1)
    ref = np.mean([mean[m] for m in METHODS], 0)
    rows = []
    for i, a in enumerate(alphas):
        for j, r in enumerate(radii):
            m = (plate == i) & (light == j)
            if not m.any():
                continue
            row = {"region": region_name(i, j, short=True), "plate": i + 1, "alpha": a,
                   "light": LETTERS[j], "radius": r, "pixels": int(m.sum()), "spp": spp}
            for name in METHODS:
                row[f"relmse {name}"] = float(np.mean(relative_squared_error(var[name][m] / spp, ref[m])))
            # a relMSE of exactly 0: the technique never reached a light in the region (unmeasured)
            single = {s: row[f"relmse {s}"] for s in SINGLE if row[f"relmse {s}"] > 0}
            row["best single"] = min(single, key=single.get) if single else ""
            for name in ("MIS balance", "MIS power"):
                key = name.split()[1]
                row[f"{key} / best"] = row[f"relmse {name}"] / single[row["best single"]] if single else np.nan
            for name in METHODS:                 # a heavy-tailed technique that missed shows a too-dark mean
                row[f"mean {name}"] = float(mean[name][m].mean())
            row["mean ref"] = float(ref[m].mean())
            rows.append(row)
    return pd.DataFrame(rows), {"images": images, "ref": ref, "plate": plate, "light": light,
                                "alphas": alphas, "radii": radii, "spp": spp, "size": size}


def _region_key(ax, plate, light, alphas, radii) -> None:
    """The region map: a grey checkerboard of (plate, light) regions, each labelled, with the
    plates' alpha on the y ticks and the lights' radii on the x ticks."""
    lab = np.where(plate >= 0, 0.25 + 0.35 * ((plate + light) % 2), 1.0)
    ax.imshow(lab, cmap="gray", vmin=0, vmax=1, interpolation="nearest", aspect="auto")
    rows = np.nonzero((plate >= 0).any(1))[0]
    pad = max(2, (rows[-1] - rows[0]) // 12)
    ax.set_ylim(min(rows[-1] + pad, plate.shape[0] - 0.5), max(rows[0] - pad, -0.5))    # the plates only
    for i in range(len(alphas)):
        for j in range(len(radii)):
            rr, cc = np.nonzero((plate == i) & (light == j))
            if len(rr):
                ax.text(cc.mean(), rr.mean(), region_name(i, j, short=True), ha="center", va="center",
                        fontsize=8, color="white" if (i + j) % 2 == 0 else "black")
    ys = [np.nonzero(plate == i)[0].mean() for i in range(len(alphas))]
    xs = [np.nonzero(light == j)[1].mean() for j in range(len(radii))]
    ax.set_yticks(ys, [f"plate {i + 1}{' (roughest)' if i == 0 else ' (sharpest)' if i == len(alphas) - 1 else ''}"
                       f"\nα = {a:g}" for i, a in enumerate(alphas)], fontsize=7)
    ax.set_xticks(xs, [f"{LETTERS[j]}{' (smallest)' if j == 0 else ' (largest)' if j == len(radii) - 1 else ''}"
                       f"\nr = {r:g}" for j, r in enumerate(radii)], fontsize=7)
    ax.set_xlabel("light nearest the mirror direction (radius r, scene units)", fontsize=8)
    ax.set_title("region key: plate (GGX roughness α) × light (crop of the image)", fontsize=9)


def _relmse_panel(ax, table: pd.DataFrame, spp: int) -> None:
    x = np.arange(len(table))
    for k, name in enumerate(METHODS):
        ax.plot(x + (k - 1.5) * 0.15, table[f"relmse {name}"], "o", ms=4, color=COLORS[name], label=name)
    for b in range(4, len(table), 8):                 # shade every second plate's regions
        ax.axvspan(b - 0.5, min(b + 3.5, len(table) - 0.5), color="0.93", lw=0)
    ax.set_yscale("log")
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, hi * (hi / lo) ** 0.3)                        # room for the legend above the dots
    ax.set_xticks(x, table["region"], fontsize=7)
    ax.set_xlabel("region (plate 1–4 × light A–D, see the key)")
    ax.set_ylabel(f"relMSE at {spp} spp (dimensionless)")
    ax.set_title("relMSE per region (mean over its pixels)", fontsize=9)
    ax.legend(fontsize=7, ncol=2, loc="upper center")


def plot(table: pd.DataFrame, res: dict, path: Path) -> Path:
    """Four renders at one shared auto exposure, the region key and the per-region relMSE."""
    spp, (w, h) = res["spp"], res["size"]
    ref = res["ref"]
    exposure = auto_exposure(np.repeat(ref[..., None], 3, -1))
    fig, axes = plt.subplots(3, 2, figsize=(11, 12), height_ratios=[1, 1, 0.95])
    for ax, name in zip(axes[:2].ravel(), METHODS):
        ax.imshow(srgb_encode(res["images"][name] * exposure), interpolation="nearest")
        units = METHODS[name][1]
        how = "2 samples" if units == 2 else "1 light + 1 BSDF sample"
        ax.set_title(f"{name} ({how} per ray), {spp} spp", fontsize=9, color=COLORS[name])
        ax.set_xticks([]), ax.set_yticks([])
        for side in ax.spines.values():
            side.set_edgecolor(COLORS[name]), side.set_linewidth(2)
    _region_key(axes[2, 0], res["plate"], res["light"], res["alphas"], res["radii"])
    _relmse_panel(axes[2, 1], table, spp)
    fig.suptitle(f"Veach's plates, {w}×{h} pixels, {spp} spp, 2 evaluations per camera ray for every method\n"
                 f"(images: exposure auto, shared)", fontsize=10)
    return save_figure(fig, path, dpi=90)
