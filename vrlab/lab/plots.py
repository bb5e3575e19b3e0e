"""Figures of a lab run: RMSE vs n (log-log, fitted and theoretical slopes) and efficiency.

Drawn with matplotlib's object API on an Agg canvas (``matplotlib.figure.Figure``), so
no display is needed and the global pyplot state/backend is left alone.  Checked before
drawing: the table (see :mod:`vrlab.lab.summary`), ``path`` (a suffix matplotlib writes,
in an existing folder), ``title`` and ``n``.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd

from .. import checks
from ._args import optional_text, out_path
from .summary import _summary, equal_time, fit_slopes


def _figure(panels: int, width: float = 4.6, height: float = 3.8):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    cols = min(panels, 3)
    rows = -(-panels // cols)
    fig = Figure(figsize=(width * cols, height * rows))
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    for ax in axes[panels:]:
        ax.axis("off")
    return fig, axes[:panels]


def convergence_plot(df: pd.DataFrame, path: str | Path, *, title: str | None = None) -> Path:
    """RMSE vs n per estimator, one panel per integrand, log-log.

    Legend: ``estimator  fitted slope (theory)``; the dashed line of the same colour is
    the theoretical slope through the estimator's first point.  Zero RMSE (an exact
    estimator) cannot be drawn on a log axis and is noted in the legend.
    """
    path = out_path(path)
    title = optional_text(title, "title")
    s = _summary(df, ["rmse"], ("rmse",))
    if not np.isfinite(s["rmse"].to_numpy(float)).any():
        raise ValueError("df: no finite RMSE to draw (are the exact values of the integrands unknown?)")
    slopes = fit_slopes(s).set_index(["estimator", "integrand"])
    integrands = list(dict.fromkeys(s["integrand"]))
    rows = -(-s.groupby("integrand")["estimator"].nunique().max() // 2)
    fig, axes = _figure(len(integrands), 4.8, 3.6 + 0.17 * rows)
    for ax, name in zip(axes, integrands):
        part = s[s["integrand"] == name]
        for i, (est, g) in enumerate(part.groupby("estimator", sort=False)):
            g = g.sort_values("n")
            ok = (g["rmse"] > 0) & np.isfinite(g["rmse"])
            # 20 colours and 5 markers: no two of up to 20 estimators look alike
            color = matplotlib.colormaps["tab20"](i % 20)
            marker = "osD^v"[i % 5]
            sl = slopes.loc[(est, name)]
            if not ok.any():
                ax.plot([], [], marker=marker, color=color, label=f"{est}  (RMSE = 0)")
                continue
            n, r = g["n"][ok].to_numpy(float), g["rmse"][ok].to_numpy(float)
            fitted = f"{sl['slope']:+.2f}" if np.isfinite(sl["slope"]) else "n/a"
            ax.plot(n, r, "-", marker=marker, color=color, ms=4, lw=1.4,
                    label=f"{est}  {fitted} ({sl['theory']:+.2f})")
            ax.plot(n, r[0] * (n / n[0]) ** sl["theory"], "--", color=color, lw=0.9, alpha=0.6)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("n (integrand evaluations)")
        ax.set_ylabel("RMSE")
        ax.set_title(name)
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(fontsize=7, title="estimator  fitted slope (theory, dashed)", title_fontsize=7,
                  loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2, frameon=False)
    fig.suptitle(title or "Convergence: RMSE vs n", fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path


def efficiency_plot(df: pd.DataFrame, path: str | Path, *, n: int | None = None,
                    reference: str | None = None) -> Path:
    """Relative efficiency (equal time, see ``equal_time``) at sample count ``n``
    (default: the largest), one horizontal bar chart per integrand, log scale.  ``n`` must be
    one of the table's sample counts."""
    path = out_path(path)
    t = equal_time(df, reference)
    if n is not None:
        n = checks.integer(n, "n", low=1)
        have = sorted(int(k) for k in t["n"].unique())
        if n not in have:
            raise ValueError(f"n: the table has no sample count {n}; it has {have}")
    integrands = list(dict.fromkeys(t["integrand"]))
    fig, axes = _figure(len(integrands), 4.6, 0.6 + 0.32 * t["estimator"].nunique() + 1.0)
    for ax, name in zip(axes, integrands):
        part = t[t["integrand"] == name]
        at = part["n"].max() if n is None else n
        part = part[(part["n"] == at) & np.isfinite(part["relative_efficiency"])
                    & (part["relative_efficiency"] > 0)].iloc[::-1]
        ax.barh(part["estimator"], part["relative_efficiency"],
                color=["C3" if v < 1 else "C0" for v in part["relative_efficiency"]])
        ax.axvline(1.0, color="k", lw=0.8)
        ax.set_xscale("log")
        ax.set_xlabel(f"efficiency relative to {t['reference'].iloc[0]} (n = {at})")
        ax.set_title(name)
        ax.tick_params(labelsize=7)
    fig.suptitle("Equal-time efficiency 1 / (variance x time), relative", fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path
