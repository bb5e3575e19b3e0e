"""The figures of :mod:`vrlab.experiments.light_surfaces` (drawn from its computed data).

* ``area_samples_figure``: box points by face, ellipsoid points by A p_A, and observed /
  expected counts per chart cell for the Jacobian and the 'uniform' density;
* ``direction_pdfs_figure``: p_w of the first hit, the second hit and both, per light;
* ``renders_figure``: the renders at one shared exposure, relMSE per strategy and the
  per-pixel error maps.
"""
from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.ticker import MaxNLocator

from vrlab.metrics import rel_mse

from ._figures import EXPOSURE_NOTE, exposure_of, show_image, show_map

COLOURS = {"cosine": "C0", "light": "C1", "mixture": "C2", "mis-power": "C3"}     # render strategies


def _pvalue(gof: pd.DataFrame | None, light: str, text: str) -> str:
    if gof is None:
        return ""
    row = gof[(gof["light"] == light) & gof["density"].str.contains(text, regex=False)]
    if not len(row):
        return ""
    p = row["pvalue"].iloc[0]
    return f", χ² p = {p:.2g}" if p > 1e-300 else ", χ² p < 1e-300"


def _axes3d(ax, title: str) -> None:
    ax.set_xlabel("x (scene units)", fontsize=8)
    ax.set_ylabel("z (scene units)", fontsize=8)
    ax.set_zlabel("y, up (scene units)", fontsize=8)
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(3))
    ax.tick_params(labelsize=7)
    ax.set_title(title, fontsize=9)


def area_samples_figure(data: dict, gof: pd.DataFrame | None = None):
    """``data`` from ``light_surfaces.area_sample_data``; ``gof`` adds the chi-square p-values."""
    fig = plt.figure(figsize=(11, 9.5), layout="constrained")
    top, bottom = fig.subfigures(2, 1, height_ratios=[1.1, 1])
    ax = top.add_subplot(1, 2, 1, projection="3d")
    x, faces = data["box_points"], data["box_faces"]
    for k in range(6):
        f = x[faces == k]
        ax.scatter(f[:, 0], f[:, 2], f[:, 1], s=1.5, color=f"C{k}", label=f"face {k}: {len(f)} points")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=3, markerscale=4, frameon=False)
    _axes3d(ax, f"box light: {len(x)} points, face picked ∝ its area" + _pvalue(gof, "box", "faces by area"))
    ax = top.add_subplot(1, 2, 2, projection="3d")
    y = data["ell_points"]
    sc = ax.scatter(y[:, 0], y[:, 2], y[:, 1], s=1.5, c=data["ell_area_pdf"], cmap="coolwarm")
    bar = top.colorbar(sc, ax=ax, shrink=0.6, pad=0.1)
    bar.set_label("A · p_A (1 = uniform by area)", fontsize=8)
    _axes3d(ax, "ellipsoid light: mapped sphere points,\ndenser where A · p_A > 1 (ends of the long axis)")
    axes = bottom.subplots(1, 2)
    for ax, (key, label, text) in zip(axes, (("Jacobian", "Jacobian pdf", "Jacobian"),
                                             ("uniform", "'uniform' pdf 1/A", "claimed uniform"))):
        im = ax.imshow(data["ratio"][key], cmap="coolwarm", vmin=0.6, vmax=1.4, extent=(0, 1, 0, 1),
                       origin="lower", interpolation="nearest")
        ax.set_title(f"ellipsoid, per chart cell: {label}{_pvalue(gof, 'ellipsoid', text)}", fontsize=9)
        ax.set_xlabel("φ / 2π (sphere chart, dimensionless)", fontsize=8)
        ax.set_ylabel("(1 − z_s) / 2 (dimensionless)", fontsize=8)
    bar = bottom.colorbar(im, ax=list(axes), fraction=0.03, pad=0.02)
    bar.set_label("observed / expected count (dimensionless)", fontsize=8)
    return fig


def direction_pdfs_figure(maps: dict, norm: pd.DataFrame | None = None):
    """``maps`` from ``light_surfaces.direction_pdf_maps``; ``norm`` (``normalisation_table``)
    adds the integral of each density over the directions."""
    mass = {} if norm is None else norm.set_index("light")[["mass_first_hit_only", "mass_both_hits"]]
    fig, axes = plt.subplots(len(maps), 3, figsize=(12, 3.7 * len(maps)), squeeze=False, layout="constrained")
    for i, (name, (first, second, both, R)) in enumerate(maps.items()):
        vmax = np.quantile(both[both > 0], 0.98)
        titles = ["first hit only", "second hit (the far side)", "both hits: the sampling density"]
        if len(mass):
            titles[0] += f"\n∫ p_w dω = {mass.loc[name, 'mass_first_hit_only']:.3f}"
            titles[2] += f"\n∫ p_w dω = {mass.loc[name, 'mass_both_hits']:.4f}"
        for j, (title, z) in enumerate(zip(titles, (first, second, both))):
            show_map(axes[i, j], z.T, "p_w (1/sr)", title=f"{name}: {title}", cmap="magma", vmin=0, vmax=vmax,
                     origin="lower")
    fig.suptitle("solid-angle density of directions from a floor point, p_w = Σ_hits p_A d² / |cos θ_l| "
                 "(directions around the light's centre)", fontsize=10)
    return fig


def renders_figure(images: dict, reference: np.ndarray, table: pd.DataFrame):
    """Reference and strategies at one exposure (from the reference), relMSE per strategy,
    log10 per-pixel relative squared error maps."""
    t = table.set_index("strategy")
    exposure = exposure_of(reference)
    cols = len(images) + 1
    fig, axes = plt.subplots(2, cols, figsize=(3.3 * cols, 5.6), layout="constrained")
    ref_spp = int(t.loc[[s for s in t.index if s.startswith("reference")][0], "spp"])
    show_image(axes[0, 0], reference, exposure, f"reference, {ref_spp} spp (mis-power)")
    im = None
    for j, (s, img) in enumerate(images.items(), start=1):
        show_image(axes[0, j], img, exposure, f"{s}, {int(t.loc[s, 'spp'])} spp\nrelMSE = {t.loc[s, 'rel_mse']:.3g}")
        err = rel_mse(img, reference, axis=-1)                             # per-pixel relative MSE
        im = axes[1, j].imshow(np.log10(err + 1e-6), vmin=-4, vmax=0, cmap="viridis", interpolation="nearest")
        axes[1, j].set_title(f"{s}: per-pixel error", fontsize=9)
        axes[1, j].set_xticks([])
        axes[1, j].set_yticks([])
    bar = fig.colorbar(im, ax=axes[1, 1:], fraction=0.02, pad=0.01)
    bar.set_label("log₁₀ per-pixel relative squared error", fontsize=8)
    ax = axes[1, 0]
    names = list(images)
    ax.bar(range(len(names)), [t.loc[s, "rel_mse"] for s in names], color=[COLOURS[s] for s in names])
    ax.set_xticks(range(len(names)), names, rotation=30, fontsize=8)
    ax.set_yscale("log")
    ax.set_xlabel("strategy", fontsize=8)
    ax.set_ylabel("relMSE vs reference", fontsize=8)
    ax.set_title("relMSE at equal spp", fontsize=9)
    h, w = reference.shape[:2]
    fig.suptitle(f"box_ellipsoid, {w}×{h} pixels ({EXPOSURE_NOTE}, from the reference)", fontsize=10)
    return fig
