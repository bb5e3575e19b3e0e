"""The figures of :mod:`vrlab.experiments.gradient_domain` (drawn from its computed data).

One colour per method in every figure (``COLOURS``); renders compared side by side share
one exposure, from their reference (``_figures.exposure_of``).
"""
from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from ._figures import EXPOSURE_NOTE, exposure_of, show_image, show_map

COLOURS = {"common": "C0", "independent": "C1", "primal": "C7", "plain_equal_time": "C4", "l2": "C2",
           "l1": "C3", "reference": "black"}


def variance_figure(maps: dict):
    """Per-pixel Var[a - b]: measured against the formula, and the CRN gain map."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), layout="constrained")
    ax = axes[0]
    for common in (False, True):
        f, m = maps["formula"][common], maps["measured"][common]
        ok = (f > 0) & (m > 0)
        ax.loglog(f[ok], m[ok], ".", ms=3, color=COLOURS["common" if common else "independent"], alpha=0.6,
                  label=("common u: Var a + Var b − 2 Cov" if common else "independent u: Var a + Var b"))
    lo = min(v[v > 0].min() for d in (maps["formula"], maps["measured"]) for v in d.values())
    hi = max(v.max() for d in (maps["formula"], maps["measured"]) for v in d.values())
    ax.loglog([lo, hi], [lo, hi], "k:", lw=0.8, label="measured = formula")
    ax.set_xlabel("formula from PixelIntegrand samples (radiance², per sample)")
    ax.set_ylabel("measured: dx.stderr² · spp (radiance², per sample)")
    ax.set_title("per-pixel Var[I(x+1;u) − I(x;u)], Cornell box, summed over RGB", fontsize=9)
    ax.legend(fontsize=7)
    f_ind, f_crn = maps["formula"][False], maps["formula"][True]
    with np.errstate(divide="ignore", invalid="ignore"):     # no variance at all (black pixels): grey
        gain = np.where(f_ind > 1e-9, np.log10(f_ind / np.maximum(f_crn, 1e-9 * f_ind)), np.nan)
    axes[1].set_facecolor("0.8")
    show_map(axes[1], gain.reshape(maps["shape"]), "log₁₀ variance gain (dimensionless)", vmin=-1, vmax=3,
             title="log₁₀ variance gain of CRN: (Var a + Var b) / Var[a − b]\n"
                   f"(grey: no variance; the largest gain, inside the light, is $10^{{{np.nanmax(gain):.0f}}}$)")
    return fig


def crn_figure(images: dict, spp: int):
    """Shared against independent uniforms: renders, luminance errors, one row of pixels."""
    ref = images["reference"]
    h = ref.shape[0]
    exposure = exposure_of(ref)
    errors = {k: (images[k] - ref).mean(-1) for k in ("shared", "independent")}
    lim = float(np.quantile(np.abs(np.concatenate([e.ravel() for e in errors.values()])), 0.99))
    fig, axes = plt.subplots(2, 3, figsize=(11.5, 6.2), layout="constrained")
    titles = {"shared": "ONE set of uniforms for all pixels", "independent": "own uniforms per pixel"}
    for j, label in enumerate(("shared", "independent")):
        show_image(axes[0, j], images[label], exposure, f"{spp} spp, {titles[label]}", 9)
        im = axes[1, j].imshow(errors[label], cmap="RdBu_r", vmin=-lim, vmax=lim, interpolation="nearest")
        axes[1, j].set_title(f"{label}: error of the luminance", fontsize=9)
        axes[1, j].set_xticks([]); axes[1, j].set_yticks([])
    bar = fig.colorbar(im, ax=list(axes[1, :2]), fraction=0.03, pad=0.01)
    bar.set_label("image − reference, luminance (radiance)", fontsize=8)
    show_image(axes[0, 2], ref, exposure, f"reference (Mitsuba 3), {EXPOSURE_NOTE}", 9)
    ax = axes[1, 2]
    for label in ("shared", "independent"):
        ax.plot(images[label][h // 2, :, 0], color=COLOURS["common" if label == "shared" else "independent"],
                lw=1, label=label)
    ax.plot(ref[h // 2, :, 0], ":", color=COLOURS["reference"], lw=1, label="reference")
    ax.set_xlabel("pixel column")
    ax.set_ylabel("red radiance (linear)")
    ax.set_title(f"red channel along row {h // 2}", fontsize=9)
    ax.legend(fontsize=7)
    return fig


def relmse_figure(summary: pd.DataFrame, methods: dict, size: tuple[int, int]):
    """relMSE per scene and method at the highest spp (mean over seeds, ± one standard error)."""
    top = summary[summary["spp"] == summary["spp"].max()]
    fig, ax = plt.subplots(figsize=(9.5, 4.3))
    x = np.arange(len(top))
    width = 0.8 / len(methods)
    for j, (k, label) in enumerate(methods.items()):
        ax.bar(x + (j - (len(methods) - 1) / 2) * width, top[f"relmse_{k}"], width, yerr=top[f"relmse_{k}_se"],
               label=label, color=COLOURS[k], capsize=2)
    ax.set_yscale("log")
    ax.set_xticks(x, [f"{s}\n(equal time: {e} spp)" for s, e in zip(top["scene"], top["spp_equal_time"])], fontsize=8)
    ax.set_xlabel("scene")
    ax.set_ylabel("relMSE vs reference (mean over seeds)")
    ax.set_title(f"gradient-domain rendering, {size[0]}×{size[1]}, {int(top['spp'].iloc[0])} spp, "
                 f"{int(top['reps'].iloc[0])} seeds (bars: ± 1 se)", fontsize=10)
    ax.legend(fontsize=7, ncol=2)
    return fig


def gradients_figure(kept: dict, names, alpha: float):
    """Per scene: primal, sqrt |dx|, sqrt |dy| and the L1 reconstruction (one exposure per
    scene, from its reference; one colour scale for |dx| and |dy|)."""
    fig, axes = plt.subplots(len(names), 4, figsize=(13.5, 2.9 * len(names)), squeeze=False, layout="constrained")
    for row, name in zip(axes, names):
        k = kept[name][0]
        exposure = exposure_of(k["ref"])
        show_image(row[0], k["images"]["primal"], exposure, f"{name}: primal ({EXPOSURE_NOTE})", 8)
        grads = {key: np.sqrt(np.abs(k[key]).mean(-1)) for key in ("dx", "dy")}
        vmax = float(np.quantile(np.concatenate([g.ravel() for g in grads.values()]), 0.99))
        for ax, key, title in ((row[1], "dx", "|dx| = |I(x+1,y) − I(x,y)|"), (row[2], "dy", "|dy| = |I(x,y+1) − I(x,y)|")):
            show_map(ax, grads[key], "√|difference| (√radiance)", title=f"{title}, square root", cmap="magma",
                     vmin=0, vmax=vmax, fontsize=8)
        show_image(row[3], k["images"]["l1"], exposure, f"L1 reconstruction (α = {alpha:g})", 8)
    return fig


def alpha_figure(sweep: pd.DataFrame):
    names = list(dict.fromkeys(sweep["scene"]))
    fig, axes = plt.subplots(1, len(names), figsize=(4.4 * len(names), 3.9), squeeze=False)
    for ax, name in zip(axes[0], names):
        s = sweep[sweep["scene"] == name]
        ax.loglog(s["alpha"], s["relmse_l2"], "o-", color=COLOURS["l2"], label="L2")
        ax.loglog(s["alpha"], s["relmse_l1"], "s-", color=COLOURS["l1"], label="L1")
        ax.axhline(s["relmse_primal"].iloc[0], color=COLOURS["primal"], ls=":", lw=1.2, label="primal (equal spp)")
        ax.axhline(s["relmse_plain_equal_time"].iloc[0], color=COLOURS["plain_equal_time"], ls="--", lw=1.2,
                   label="plain (equal time)")
        ax.set_xlabel("α (screening weight, dimensionless)")
        ax.set_ylabel("relMSE vs reference")
        ax.set_title(f"{name}: relMSE against α", fontsize=10)
        ax.legend(fontsize=7)
    return fig


def losses_figure(kept: dict, names):
    """Reference, equal-time plain, L2, L1 (one exposure per scene, from the reference) and
    log10 of L1's per-pixel error over the plain one."""
    fig, axes = plt.subplots(len(names), 5, figsize=(16, 2.9 * len(names)), squeeze=False, layout="constrained")
    for row, name in zip(axes, names):
        k, maps = kept[name][0], kept[name + "/maps"]
        exposure = exposure_of(k["ref"])
        for ax, img, title in ((row[0], k["ref"], f"{name}: reference ({EXPOSURE_NOTE})"),
                               (row[1], k["images"]["plain_equal_time"], "plain, equal time"),
                               (row[2], k["images"]["l2"], "L2"), (row[3], k["images"]["l1"], "L1")):
            show_image(ax, img, exposure, title, 8)
        ratio = np.log10((maps["l1"] + 1e-4) / (maps["plain_equal_time"] + 1e-4))   # both tiny: 0
        show_map(row[4], ratio, "log₁₀ error ratio (dimensionless)", cmap="RdBu_r", vmin=-2, vmax=2, fontsize=8,
                 title="log₁₀ relMSE(L1) / relMSE(plain, equal time)\nred: gradient-domain loses")
    return fig
