"""The figures of :mod:`vrlab.experiments.sampling_patterns` (drawn from its computed data).

One colour per pattern (``COLOURS``) in every figure: the points, the discrepancy against
n, the convergence of the estimators that use the pattern.
"""
from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from ._figures import EXPOSURE_NOTE, convergence_panel, exposure_of, show_image

COLOURS = {"independent": "black", "jittered": "C0", "Latin hypercube": "C1", "Halton": "C2",
           "Hammersley": "C4", "Sobol (scrambled)": "C3", "Hammersley prefix (n of 4n)": "C5"}
ESTIMATORS = {"MC": "independent", "jittered": "jittered", "LHS": "Latin hypercube",
              "Halton (scrambled)": "Halton", "Sobol (scrambled)": "Sobol (scrambled)"}   # estimator -> pattern
RANDOMISED = ("independent", "jittered", "Latin hypercube", "Sobol (scrambled)")


def patterns_figure(points: dict):
    """``points``: title -> (pattern, (n, 2) array), at most 8 panels."""
    fig, axes = plt.subplots(2, 4, figsize=(13, 6.9), layout="constrained")
    for ax, (title, (pattern, x)) in zip(axes.ravel(), points.items()):
        ax.scatter(x[:, 0], x[:, 1], s=8, color=COLOURS[pattern])
        ax.set_title(title, fontsize=9)
        ax.set_xlim(0, 1); ax.set_ylim(0, 1); ax.set_aspect("equal")
        ax.set_xticks([0, 0.5, 1]); ax.set_yticks([0, 0.5, 1]); ax.grid(lw=0.3)
        ax.set_xlabel("u₁ (dimensionless)", fontsize=8)
        ax.set_ylabel("u₂ (dimensionless)", fontsize=8)
    for ax in axes.ravel()[len(points):]:
        fig.delaxes(ax)
    fig.suptitle("2D point sets in the unit square", fontsize=11)
    return fig


def discrepancy_figure(table: pd.DataFrame):
    """Centred L2 discrepancy against n: randomised patterns, then deterministic ones."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.3), sharey=True)
    n = np.array(sorted(table["n"].unique()), float)
    top = 0.5 * table["discrepancy"].max()
    names = list(dict.fromkeys(table["pattern"]))
    groups = (("randomised point sets", [p for p in names if p in RANDOMISED]),
              ("deterministic point sets", [p for p in names if p not in RANDOMISED]))
    for ax, (title, group) in zip(axes, groups):
        for name in group:
            g = table[table["pattern"] == name]
            ax.loglog(g["n"], g["discrepancy"], "o-", ms=3, color=COLOURS[name], label=name)
        ax.loglog(n, top * (n / n[0]) ** -0.5, ":", color="0.4", lw=0.8, label="∝ n^−1/2")
        ax.loglog(n, top * (n / n[0]) ** -1.0, "--", color="0.4", lw=0.8, label="∝ n^−1")
        ax.set_xlabel("n (points)")
        ax.set_ylabel("centred L2 discrepancy (dimensionless)")
        ax.set_title(title, fontsize=10)
        ax.legend(fontsize=7)
    fig.suptitle("how uniform are the point sets? (randomised: mean over seeds)", fontsize=11)
    return fig


def convergence_figure(summary: pd.DataFrame, slopes: pd.DataFrame):
    """RMSE vs n: per integrand the stratified patterns against MC, on the 2D integrand also
    the scrambled low-discrepancy sequences against MC (at most 3 estimators per panel)."""
    names = list(dict.fromkeys(summary["estimator"]))
    strata = [e for e in ("MC", "jittered", "LHS") if e in names]
    qmc = [e for e in ("MC", "Halton (scrambled)", "Sobol (scrambled)") if e in names]
    panels = [(i, strata, "stratified sets") for i in dict.fromkeys(summary["integrand"])]
    panels += [(i, qmc, "scrambled QMC") for i in
               dict.fromkeys(summary.loc[summary["estimator"].isin(qmc[1:]), "integrand"])]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.8 * len(panels), 4.4), squeeze=False)
    colours = {e: COLOURS[ESTIMATORS[e]] for e in names}
    for ax, (integrand, ests, kind) in zip(axes[0], panels):
        convergence_panel(ax, summary, slopes, integrand, ests, colours)
        ax.set_title(f"{integrand}: {kind} against MC", fontsize=10)
    fig.suptitle("RMSE against n, one colour per point set", fontsize=11)
    return fig


def strata_figure(images: dict, spps: list[int], is_edge: np.ndarray, table: pd.DataFrame | None = None):
    """Grey renders with random and 4-strata sub-pixel positions at one exposure (from the
    stratified render at the highest spp) and the edge-pixel mask; with ``table`` (rows of
    ``render_strata``) the median per-pixel variance ratio to random on edge pixels."""
    exposure = exposure_of(images[(max(spps), True)])
    ratio = {} if table is None else {(r.spp, r["sub-pixel"]): r.median_ratio_edge for _, r in table.iterrows()}
    fig, axes = plt.subplots(1, 2 * len(spps) + 1, figsize=(3.3 * (2 * len(spps) + 1), 3.2), layout="constrained")
    k = 0
    for spp in spps:
        for stratified in (False, True):
            name = "4 strata" if stratified else "random"
            title = f"{spp} spp, {name} sub-pixel"
            if stratified and (spp, name) in ratio:
                title += f"\nedge-pixel variance × {ratio[(spp, name)]:.2f} (median)"
            show_image(axes[k], images[(spp, stratified)], exposure, title, 9)
            k += 1
    axes[k].imshow(is_edge, cmap="gray", interpolation="nearest")
    axes[k].set_title(f"white: the {int(is_edge.sum())} edge pixels", fontsize=9)
    axes[k].set_xticks([])
    axes[k].set_yticks([])
    h, w = is_edge.shape
    fig.suptitle(f"Cornell box {w}×{h}, light sampling, grey value, same uniforms for both sub-pixel maps "
                 f"({EXPOSURE_NOTE})", fontsize=10)
    return fig


def report_figure(images: dict, refs: dict, table: pd.DataFrame):
    """Per scene (row) the report's strategies and spp, at the exposure of that scene's reference."""
    scenes = list(dict.fromkeys(k[0] for k in images))
    per = max(sum(1 for k in images if k[0] == s) for s in scenes)
    fig, axes = plt.subplots(len(scenes), per, figsize=(3.0 * per, 2.7 * len(scenes)), squeeze=False,
                             layout="constrained")
    t = table.set_index(["scene", "strategy", "spp"])
    for row, scene in zip(axes, scenes):
        exposure = exposure_of(refs[scene])
        for ax, key in zip(row, [k for k in images if k[0] == scene]):
            show_image(ax, images[key], exposure, f"{scene}: {key[1]}, {key[2]} spp\nrelMSE {t.loc[key, 'rel_mse']:.3g}", 8)
    fig.suptitle(f"uniform against importance sampling ({EXPOSURE_NOTE} per scene, from its MIS reference)",
                 fontsize=10)
    return fig
