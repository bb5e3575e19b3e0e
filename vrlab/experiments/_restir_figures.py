"""Figures of :mod:`vrlab.experiments.restir` (one pixel and the row; the many-lights renders)."""
from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from ._figures import EXPOSURE_NOTE, exposure_of, show_image


def row_figure(pixels: pd.DataFrame, one: pd.DataFrame, family, methods, colours: dict, settings: str):
    """One pixel's variance against M; the row's family ``family(x)`` (B, ...); bias per pixel; variance
    per pixel, for ``methods`` in ``colours`` (``settings``: the reuse settings, for a title)."""
    fig, axes = plt.subplots(1, 4, figsize=(19, 4.2))
    ax = axes[0]
    lim = one.attrs
    ax.errorbar(one["M"], one["var"], 2 * one["var_se"], fmt="o-", ms=4, color="C0", label="RIS, measured (± 2 se)")
    ax.axhline(lim["var_m1"], color="k", ls=":", lw=0.9, label="M = 1: Var_p[f/p]")
    ax.axhline(lim["var_inf"], color="C0", ls="-.", lw=0.9, label="M → ∞: I (Z − I)")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("candidates M")
    ax.set_ylabel("variance per sample (dimensionless)")
    ax.set_title(f"one pixel: e^({lim['a']:g}x) blocked on [{lim['lo']:g}, {lim['hi']:g})", fontsize=10)
    ax.legend(fontsize=7)

    ax = axes[1]
    x = np.linspace(0, 1, 400)[:, None]
    img = family(x)
    ax.imshow(img, aspect="auto", origin="lower", extent=(0, 1, -0.5, len(img) - 0.5), cmap="magma")
    ax.set_xlabel("x (dimensionless)")
    ax.set_ylabel("pixel b")
    ax.set_title("the row: f_b = e^(a_b x), dark band: occluder", fontsize=10)

    ax = axes[2]
    for name in methods:
        p = pixels[pixels["method"] == name]
        ax.errorbar(p["pixel"] + 0.08 * (methods.index(name) - 2), p["mean"] / p["exact"] - 1,
                    2 * p["se"] / p["exact"], fmt="o", ms=3, color=colours[name], label=name)
    p = pixels[pixels["method"] == "ReSTIR 1/M"]
    ax.plot(p["pixel"], p["expected"] / p["exact"] - 1, "_", ms=12, color=colours["ReSTIR 1/M"],
            label="1/M, predicted bias")
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xlabel("pixel b")
    ax.set_ylabel("mean / exact − 1 (± 2 se)")
    ax.set_title("bias per pixel over passes", fontsize=10)
    ax.legend(fontsize=7)

    ax = axes[3]
    for name in methods:
        p = pixels[pixels["method"] == name]
        ax.plot(p["pixel"], p["var"] / p["exact"] ** 2, "o-", ms=3, color=colours[name], label=name)
    ax.set_yscale("log")
    ax.set_xlabel("pixel b")
    ax.set_ylabel("variance per pass / exact² (dimensionless)")
    ax.set_title(f"variance per pixel ({settings})", fontsize=10)
    ax.legend(fontsize=7)
    return fig


def images_figure(table: pd.DataFrame, images: dict, ref: np.ndarray, selections, ref_label: str):
    """RIS and ReSTIR with each light selection and the reference, at one exposure."""
    shown = [f"{kind}, {sel}" for kind in ("RIS", "ReSTIR") for sel in selections]
    fig, axes = plt.subplots(2, 4, figsize=(13.6, 5.6), layout="constrained")
    exposure = exposure_of(ref)
    t = table.set_index("method")
    show_image(axes[0, 0], ref, exposure, f"reference: {ref_label}, {table.attrs.get('ref_spp')} spp", 8)
    axes[1, 0].axis("off")
    for i, label in enumerate(shown):
        ax = axes[i // len(selections), 1 + i % len(selections)]
        r = t.loc[label]
        show_image(ax, images[label], exposure, f"{label}, {int(r['spp'])} spp", 8)
        ax.set_xlabel(f"relMSE {r['relmse']:.3g}, {r['seconds']:.2f} s", fontsize=8)
    fig.suptitle(f"many_lights, {int(table['lights'].iloc[0])} sphere lights, M = {int(table['candidates'].max())} "
                 f"candidates; relMSE over the {int(table['pixels'].iloc[0])} pixels that see no light "
                 f"({EXPOSURE_NOTE})", fontsize=10)
    return fig


def efficiency_figure(table: pd.DataFrame, selections):
    """relMSE at equal spp, relMSE x time (equal time) and relMSE x counted cost (equal cost) per
    method, grouped by light selection."""
    fig, axes = plt.subplots(1, 3, figsize=(17, 4))
    kinds = ("light", "RIS", "ReSTIR")
    colours = {"light": "C7", "RIS": "C1", "ReSTIR": "C0"}
    w = 0.26
    x = np.arange(len(selections))
    t = table.set_index("method")
    for ax, col, ylabel in ((axes[0], "relmse", "relMSE (equal spp)"),
                            (axes[1], "relmse_x_seconds", "relMSE × render time (s): equal-time, lower = better"),
                            (axes[2], "relmse_x_cost", "relMSE × counted cost per pixel: equal-cost, lower = better")):
        for i, kind in enumerate(kinds):
            vals = [t.loc[f"{kind}, {sel}", col] for sel in selections]
            ax.bar(x + (i - 1) * w, vals, w, color=colours[kind], label=kind)
        for j, (label, marker) in enumerate((("ReSTIR balance, bvh", "^"), ("ReSTIR 1/M, bvh", "v"))):
            ax.plot([2 + w + 0.08 * (j + 1)], [t.loc[label, col]], marker, color="k", label=label)
        ax.set_xticks(x, [f"selection: {s}" for s in selections])
        ax.set_yscale("log")
        ax.set_ylabel(ylabel)
        ax.legend(fontsize=7)
    spp = int(table["spp"].iloc[0])
    axes[0].set_title(f"many_lights at {spp} spp", fontsize=10)
    axes[1].set_title("the same work normalised by time", fontsize=10)
    axes[2].set_title("... and by counted rays and evaluations (vrlab.render.cost)", fontsize=10)
    return fig
