"""Antithetic direct lighting for :mod:`vrlab.experiments.antithetic_crn`.

A diffuse floor under a 2 x 2 rectangular light facing down, seen from below the light's
height.  Two estimators at equal cost, two cosine-weighted directions per camera ray:
``Antithetic("cosine")`` (the pair u, 1 - u: with the concentric disk warp the second
direction is the first mirrored about the normal, (x, y, z) -> (-x, -y, z)) against
``MonteCarlo("cosine")`` with two independent samples (``units=2``).  Per pixel,

    1 + rho = Var[antithetic pair mean] / Var[mean of two independent samples]
            = stderr_antithetic^2 / stderr_independent^2      (same spp).

Where the light lies on one side of a floor point, a direction that hits it mirrors to one
that misses (rho < 0: a gain); right under the light's centre both directions hit or miss
together (rho > 0: up to twice the variance).

Closed form at a floor point: a cosine sample's value is albedo L_e 1[hit], a Bernoulli
variable with P(hit) = F, the form factor of the light; both directions of a pair hit with
probability F_both, the form factor of the light's overlap with its point reflection about
the point's vertical axis (a centred rectangle of half widths h - |dx|, h - |dz|).  So

    1 + rho = 1 + (F_both - F^2) / (F (1 - F)),

with F of an axis-parallel rectangle at height H from the corner formula (Howell's catalogue,
parallel rectangle, element below a corner): F(a, b) = [A/sqrt(1+A^2) atan(B/sqrt(1+A^2)) +
B/sqrt(1+B^2) atan(A/sqrt(1+B^2))] / (2 pi), A = a/H, B = b/H, odd in a and b.  The measured
factor also holds the pixel footprint's variance (common to both), which pulls it towards 1.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

import matplotlib.pyplot as plt
from matplotlib.colors import TwoSlopeNorm
from scipy.ndimage import uniform_filter

from vrlab.estimators import Antithetic, MonteCarlo
from vrlab.lab.experiment import save_figure
from vrlab.render import load_scene, render
from vrlab.render.direct import DirectLighting
from vrlab.render.image import auto_exposure, srgb_encode

#: one colour per method, in every figure of vrlab.experiments.antithetic_crn
COLORS = {"independent": "tab:blue", "antithetic": "tab:orange", "common": "tab:green"}
LIGHT_HALF, LIGHT_HEIGHT, RADIANCE, ALBEDO = 1.0, 0.5, 2.0, 0.5
#: factors are shown on a log2 colour scale between these powers of two
LOG2_RANGE = (-4.0, 1.5)


def floor_scene(size: tuple[int, int]):
    """The floor (reflectance ALBEDO) under a 2 LIGHT_HALF square light at LIGHT_HEIGHT (radiance
    RADIANCE, facing down), seen from below the light's height looking down (every pixel sees
    the floor), ``size`` = (width, height)."""
    w, h = size
    return load_scene(f"""<scene version="3.0.0">
  <integrator type="direct"/>
  <sensor type="perspective">
    <float name="fov" value="60"/>
    <transform name="to_world"><lookat origin="0, 0.45, 1.9" target="0, 0, 1.1" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="{w}"/><integer name="height" value="{h}"/>
      <rfilter type="box"/></film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><scale value="10"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="{ALBEDO}"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><scale x="{LIGHT_HALF}" y="{LIGHT_HALF}"/><rotate x="1" angle="90"/>
      <translate y="{LIGHT_HEIGHT}"/></transform>
    <emitter type="area"><rgb name="radiance" value="{RADIANCE}"/></emitter>
  </shape>
</scene>""")


#: floor pixel classes by the distance of the floor point from the light's axis, d = max(|x|, |z|)
CLASSES = {"centre": "under the light's centre (d < ½ h)", "edge": "around the light's edge (½ h ≤ d < 3⁄2 h)",
           "outside": "farther out (d ≥ 3⁄2 h)"}


def form_factor(x0, x1, z0, z1, height: float) -> np.ndarray:
    """Cosine-weighted fraction of the hemisphere of a floor point at the origin covered by
    the rectangle [x0, x1] x [z0, z1] at ``height`` (corner formula, see the module docstring)."""
    def corner(x, z):
        a, b = np.asarray(x, float) / height, np.asarray(z, float) / height
        sa, sb = np.sqrt(1 + a * a), np.sqrt(1 + b * b)
        return (a / sa * np.arctan(b / sa) + b / sb * np.arctan(a / sb)) / (2 * np.pi)
    return corner(x1, z1) - corner(x0, z1) - corner(x1, z0) + corner(x0, z0)


def factor_theory(x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(1 + rho, F (1 - F))`` at floor points ``(x, z)``: the closed-form antithetic factor
    and the variance of one cosine sample divided by (albedo L_e)^2 (the weight of a point in
    a mean over pixels)."""
    h = LIGHT_HALF
    F = form_factor(-h - x, h - x, -h - z, h - z, LIGHT_HEIGHT)
    ax, az = np.maximum(h - np.abs(x), 0.0), np.maximum(h - np.abs(z), 0.0)
    both = form_factor(-ax, ax, -az, az, LIGHT_HEIGHT)
    var = F * (1 - F)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(var > 0, 1 + (both - F * F) / np.where(var > 0, var, 1.0), 1.0), var


def floor_points(scene) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel (central ray): the class of its floor point (keys of ``CLASSES``, h =
    LIGHT_HALF the light's half width; ``""`` if the ray misses the floor) and its (x, z)."""
    lit = DirectLighting(scene)
    o, d = lit.camera.pixel_centers()
    hits = lit.geometry.intersect(o.reshape(-1, 3), d.reshape(-1, 3))
    dist = np.max(np.abs(hits.p[:, [0, 2]]), -1) / LIGHT_HALF
    out = np.select([dist < 0.5, dist < 1.5], ["centre", "edge"], "outside")
    out = np.where(hits.shape == 0, out, "")
    shape = (scene.sensor.height, scene.sensor.width)
    return out.reshape(shape), hits.p[:, [0, 2]].astype(float).reshape(shape + (2,))


def study(size: tuple[int, int], spp: int, seed: int = 7) -> tuple[pd.DataFrame, pd.DataFrame, dict]:
    """Render both estimators.  Returns the summary per pixel class (mean factor = ratio of
    the mean variances, its closed form, per-pixel median and quantiles, share of pixels with
    a factor below 1), the profile against d/h = max(|x|, |z|) / LIGHT_HALF of the floor point
    (measured and closed form), and the maps for :func:`plot`."""
    scene = floor_scene(size)
    ests = {"antithetic": render(scene, spp, Antithetic("cosine"), rng=seed),
            "independent": render(scene, spp, MonteCarlo("cosine"), rng=seed + 1, units=2)}
    var = {k: np.mean(e.stderr.astype(float) ** 2, -1) for k, e in ests.items()}
    evals = {k: e.n_evals // spp for k, e in ests.items()}
    classes, xz = floor_points(scene)
    theory, weight = factor_theory(xz[..., 0], xz[..., 1])
    ok = var["independent"] > 0
    factor = np.where(ok, var["antithetic"] / np.where(ok, var["independent"], 1.0), np.nan)
    smooth = {k: uniform_filter(np.where(ok, v, 0.0), 3) / np.maximum(uniform_filter(ok * 1.0, 3), 1e-12)
              for k, v in var.items()}
    rows = []
    for name, m in [("floor", classes != "")] + [(c, classes == c) for c in CLASSES]:
        m = m & ok
        rows.append({"pixels": name, "count": int(m.sum()), "spp": spp,
                     "evals_per_ray_antithetic": evals["antithetic"], "evals_per_ray_independent": evals["independent"],
                     "factor_mean": float(var["antithetic"][m].mean() / var["independent"][m].mean()),
                     "factor_theory": float(np.sum(theory[m] * weight[m]) / np.sum(weight[m])),
                     "factor_median": float(np.median(factor[m])),
                     "factor_p05": float(np.quantile(factor[m], 0.05)),
                     "factor_p95": float(np.quantile(factor[m], 0.95)),
                     "share_below_1": float(np.mean(factor[m] < 1))})
    d = np.max(np.abs(xz), -1) / LIGHT_HALF
    edges = np.linspace(0, np.quantile(d[ok & (classes != "")], 0.98), 25)
    which = np.digitize(d, edges) - 1
    prof = []
    for b in range(len(edges) - 1):
        m = ok & (classes != "") & (which == b)
        if m.sum() >= 20:
            prof.append({"d_over_h_lo": edges[b], "d_over_h_hi": edges[b + 1], "pixels": int(m.sum()),
                         "factor_measured": float(var["antithetic"][m].mean() / var["independent"][m].mean()),
                         "factor_theory": float(np.sum(theory[m] * weight[m]) / np.sum(weight[m]))})
    maps = {"images": {k: e.value.astype(float) for k, e in ests.items()}, "factor": factor,
            "factor_3x3": smooth["antithetic"] / np.where(smooth["independent"] > 0, smooth["independent"], np.nan),
            "theory": np.where(classes != "", theory, np.nan), "classes": classes, "spp": spp, "size": size}
    return pd.DataFrame(rows), pd.DataFrame(prof), maps


def _factor_map(fig, ax, z, title: str, classes) -> None:
    lo, hi = LOG2_RANGE
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.clip(np.log2(z), lo, hi)
    cmap = plt.get_cmap("RdBu_r").with_extremes(bad="0.75")
    im = ax.imshow(z, cmap=cmap, norm=TwoSlopeNorm(0.0, lo, hi), interpolation="nearest")
    ax.contour(classes == "centre", levels=[0.5], colors="0.2", linewidths=1.0)
    ax.contour(np.isin(classes, ("centre", "edge")), levels=[0.5], colors="0.2", linewidths=1.0, linestyles="--")
    ax.set_xlabel("image column (pixels)", fontsize=8), ax.set_ylabel("image row (pixels)", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.set_title(title, fontsize=9)
    ticks = np.arange(np.ceil(lo), np.floor(hi) + 1)
    cb = fig.colorbar(im, ax=ax, shrink=0.9, ticks=ticks)
    cb.ax.set_yticklabels([f"{2.0 ** t:g}" for t in ticks])
    cb.set_label("1 + ρ (dimensionless, log scale)", fontsize=8)


def plot(table: pd.DataFrame, profile: pd.DataFrame, maps: dict, path: Path) -> Path:
    """Both renders (one shared auto exposure), the measured and the closed-form factor maps
    (blue: antithetic helps, red: it hurts) and the factor against the distance from the axis."""
    spp, (w, h) = maps["spp"], maps["size"]
    imgs = maps["images"]
    exposure = auto_exposure(imgs["independent"])
    fig = plt.figure(figsize=(11.5, 12))
    grid = fig.add_gridspec(3, 2, height_ratios=[1, 1, 0.8])
    for k, (key, title) in enumerate((("independent", "independent: 2 cosine samples per ray"),
                                      ("antithetic", "antithetic: cosine pair (u, 1 − u) per ray"))):
        ax = fig.add_subplot(grid[0, k])
        ax.imshow(srgb_encode(imgs[key] * exposure), interpolation="nearest")
        ax.set_title(f"{title}, {spp} spp", fontsize=9, color=COLORS[key])
        ax.set_xticks([]), ax.set_yticks([])
        for side in ax.spines.values():
            side.set_edgecolor(COLORS[key]), side.set_linewidth(2)
    _factor_map(fig, fig.add_subplot(grid[1, 0]), maps["factor_3x3"],
                "measured 1 + ρ = Var antithetic / Var independent\n(variances averaged over 3×3 pixels)",
                maps["classes"])
    _factor_map(fig, fig.add_subplot(grid[1, 1]), maps["theory"],
                "closed form 1 + ρ at the pixel centres\n(solid: d < ½ h, dashed: d < 3⁄2 h)", maps["classes"])
    ax = fig.add_subplot(grid[2, :])
    mid = (profile["d_over_h_lo"] + profile["d_over_h_hi"]) / 2
    ax.plot(mid, profile["factor_measured"], "o", color=COLORS["antithetic"], label="measured (ratio of mean variances)")
    ax.plot(mid, profile["factor_theory"], "-", color="k", lw=1.2, label="closed form")
    ax.axhline(1.0, color="0.6", lw=0.8, ls=":")
    for x in (0.5, 1.5):
        ax.axvline(x, color="0.6", lw=0.8, ls="--")
    ax.set_xlabel("distance of the floor point from the light's axis, d = max(|x|, |z|) / h (h = light half width)")
    ax.set_ylabel("variance factor 1 + ρ\n(dimensionless)")
    f = table.set_index("pixels")
    ax.set_title(f"antithetic / independent at equal cost; whole floor: measured {f.loc['floor', 'factor_mean']:.2f}, "
                 f"closed form {f.loc['floor', 'factor_theory']:.2f}", fontsize=9)
    ax.legend(fontsize=8)
    fig.suptitle(f"Antithetic direct lighting on a floor under a square light: {w}×{h} pixels, {spp} spp, "
                 "2 evaluations per camera ray for both\n(images: exposure auto, shared)", fontsize=10)
    return save_figure(fig, path, dpi=90)
