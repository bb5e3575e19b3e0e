"""Figures of a lab run: RMSE vs n (log-log, with fitted and theoretical slopes) and efficiency.

Drawn with matplotlib's object API on an Agg canvas (``matplotlib.figure.Figure``), so
no display is needed and the global pyplot state/backend is left alone.
``convergence_figure`` / ``efficiency_figure`` return the figure; ``convergence_plot`` /
``efficiency_plot`` draw it into a file.  Checked before drawing: the table (see
:mod:`vrlab.lab.summary`), ``path`` (a suffix matplotlib writes, in an existing folder),
``title`` and ``n``.

Figure rules: each estimator keeps one colour and marker in every panel and in both
figures (:func:`estimator_styles`: the reference estimator, ``mc`` if present, is black);
a convergence panel holds at most ``MAX_LINES`` lines (the reference plus up to
``MAX_LINES - 1`` others: estimators are split into small multiples); tick labels that
would overlap at the final size are dropped (:func:`tidy_tick_labels`).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd

from .. import checks
from ._args import optional_text, out_path
from .summary import _summary, equal_time, fit_slopes

#: lines per convergence panel, the reference estimator included
MAX_LINES = 6
#: colours of the estimators other than the reference, in order: tab10 without its grey, then
#: the darkest of each tab20b hue (14 colours: the full demo's 15 estimators all differ)
PALETTE = (tuple(c for k, c in enumerate(matplotlib.colormaps["tab10"].colors) if k != 7)
           + tuple(matplotlib.colormaps["tab20b"].colors[0::4]))
MARKERS = "osD^vP<>X"
REFERENCE_COLOUR = "black"
DPI = 110


def reference_estimator(names) -> str:
    """The baseline shown in every panel: ``"mc"`` if present, else the first estimator
    (the same rule as :func:`vrlab.lab.equal_time`)."""
    names = list(dict.fromkeys(names))
    return "mc" if "mc" in names else names[0]


def estimator_styles(names) -> dict[str, tuple[str | tuple, str]]:
    """estimator -> (colour, marker), in order of first appearance: the reference is black
    with circles, the i-th other gets PALETTE[i % 14] and MARKERS[1 + i % 8] (distinct pairs
    for up to 56 estimators)."""
    names = list(dict.fromkeys(names))
    ref = reference_estimator(names)
    styles = {ref: (REFERENCE_COLOUR, "o")}
    others = [e for e in names if e != ref]
    for i, e in enumerate(others):
        styles[e] = (PALETTE[i % len(PALETTE)], MARKERS[1 + i % (len(MARKERS) - 1)])
    return styles


def _labels_in_view(axis) -> list:
    """(position, Text) of the visible, non-empty tick labels of ``axis`` inside its view."""
    axis.get_ticklabels(which="both")          # places the ticks of the current limits
    lo, hi = sorted(axis.get_view_interval())
    span = (hi - lo) * 1e-9
    out = []
    for tick in axis.get_major_ticks() + axis.get_minor_ticks():
        loc = tick.get_loc()
        text = tick.label1
        if text.get_visible() and text.get_text() and loc is not None and lo - span <= loc <= hi + span:
            out.append((float(loc), text))
    return sorted(out, key=lambda p: p[0])


def overlapping_tick_labels(fig) -> list[tuple[str, str]]:
    """Pairs of tick labels of one axis whose boxes overlap on the drawn figure (draws it)."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    bad = []
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            labels = [t for _, t in _labels_in_view(axis)]
            boxes = [t.get_window_extent(renderer) for t in labels]
            for i in range(len(boxes)):
                for j in range(i + 1, len(boxes)):
                    if boxes[i].overlaps(boxes[j]):
                        bad.append((labels[i].get_text(), labels[j].get_text()))
    return bad


def tidy_tick_labels(fig, pad: float = 3.0) -> None:
    """On every axis of ``fig`` (laid out at its final size) whose tick labels collide, keep
    a label only if it clears the last kept one by ``pad`` pixels (the others become
    unlabelled ticks)."""
    from matplotlib.ticker import FixedFormatter, FixedLocator, NullFormatter

    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        for axis, k in ((ax.xaxis, 0), (ax.yaxis, 1)):
            labels = _labels_in_view(axis)
            kept, last = [], None
            for loc, text in labels:
                box = text.get_window_extent(renderer).padded(pad / 2)
                lo, hi = (box.x0, box.x1) if k == 0 else (box.y0, box.y1)
                if last is None or lo >= last[1] or hi <= last[0]:
                    kept.append((loc, text.get_text()))
                    last = (lo, hi)
            if len(kept) < len(labels):
                axis.set_major_locator(FixedLocator([loc for loc, _ in kept]))
                axis.set_major_formatter(FixedFormatter([s for _, s in kept]))
                axis.set_minor_formatter(NullFormatter())


def _n_label(v: float, _pos=None) -> str:
    """A sample count: ``16384``; from 10^5 on ``2²⁰`` (a power of two) or ``1.5×10⁵``."""
    if v < 1e5:
        return f"{v:.0f}"
    k = int(round(np.log2(v)))
    if v == 2.0**k:
        return "2" + str(k).translate(_SUPERSCRIPT)
    e = int(np.floor(np.log10(v)))
    return f"{v / 10.0**e:.3g}\u00d710" + str(e).translate(_SUPERSCRIPT)


def _n_ticks(ax, ns) -> None:
    """x ticks at the sampled n (as integers), no minor labels."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

    ns = sorted({int(v) for v in ns})
    step = max(1, -(-len(ns) // 6))
    ax.xaxis.set_major_locator(FixedLocator(ns[::step]))
    ax.xaxis.set_major_formatter(FuncFormatter(_n_label))
    ax.xaxis.set_minor_formatter(NullFormatter())


_SUPERSCRIPT = str.maketrans("-0123456789", "\u207b\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079")


def _power_label(v: float, _pos=None) -> str:
    """``2×10⁻³``: plain text with superscripts (mathtext costs a parser run per label)."""
    if not v > 0:
        return ""
    e = int(np.floor(np.log10(v) + 1e-9))
    m = v / 10.0**e
    power = "10" + str(e).translate(_SUPERSCRIPT)
    return power if abs(m - 1) < 1e-6 else f"{m:.2g}\u00d7{power}"


def _log_ticks(axis, lo: float, hi: float) -> None:
    """Labels of a log axis over [lo, hi]: decades, or 1-2-5 steps if fewer than two decades
    fall inside."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    few = not (lo > 0 and np.floor(np.log10(hi)) - np.ceil(np.log10(lo)) >= 1)
    axis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0) if few else (1.0,), numticks=8))
    axis.set_major_formatter(FuncFormatter(_power_label))
    axis.set_minor_formatter(NullFormatter())


def _groups(s: pd.DataFrame, ref: str) -> list[tuple[str, list[str]]]:
    """(integrand, estimators of one panel): every integrand split into the same number of
    panels, each with the reference and at most MAX_LINES - 1 others."""
    integrands = list(dict.fromkeys(s["integrand"]))
    names = {i: [e for e in dict.fromkeys(s.loc[s["integrand"] == i, "estimator"]) if e != ref] for i in integrands}
    k = max(1, max(-(-len(v) // (MAX_LINES - 1)) for v in names.values()))
    out = []
    for i in integrands:
        has_ref = (s.loc[s["integrand"] == i, "estimator"] == ref).any()
        for part in np.array_split(np.array(names[i], dtype=object), k) if names[i] else [[]]:
            if len(part) or has_ref:
                out.append((i, ([ref] if has_ref else []) + list(part)))
    return out


def _figure(panels: int, cols: int, box: dict, title: str):
    """A figure of ``panels`` axes in rows of ``cols``, laid out in inches (no layout engine:
    tight_layout measured every tick label and cost as much as drawing): each cell is
    ``box["left"] + box["width"] + box["right"]`` wide and ``box["top"] + box["height"] +
    box["bottom"]`` high, under ``title`` wrapped to the figure's width.  No empty cells."""
    import textwrap

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    rows = -(-panels // cols)
    cell_w = box["left"] + box["width"] + box["right"]
    cell_h = box["top"] + box["height"] + box["bottom"]
    text = textwrap.fill(title, max(30, int(10 * cell_w * cols)))   # about 10 characters of 11 pt per inch
    head = 0.2 + 0.24 * (text.count("\n") + 1)
    fw, fh = cell_w * cols, cell_h * rows + head
    fig = Figure(figsize=(fw, fh), dpi=DPI)
    FigureCanvasAgg(fig)
    fig.suptitle(text, fontsize=11, y=1 - 0.1 / fh, va="top")
    axes = []
    for k in range(panels):
        r, c = divmod(k, cols)
        x0 = c * cell_w + box["left"]
        y0 = fh - head - r * cell_h - box["top"] - box["height"]
        axes.append(fig.add_axes((x0 / fw, y0 / fh, box["width"] / fw, box["height"] / fh)))
    return fig, axes


def _columns(panels: int, per_integrand: int) -> int:
    if per_integrand > 1:
        return per_integrand
    return next((c for c in (3, 2) if panels % c == 0), min(panels, 3))


def convergence_figure(df: pd.DataFrame, *, title: str | None = None):
    """The figure of :func:`convergence_plot` (a ``matplotlib.figure.Figure``)."""
    title = optional_text(title, "title")
    s = _summary(df, ["rmse"], ("rmse",))
    if not np.isfinite(s["rmse"].to_numpy(float)).any():
        raise ValueError("df: no finite RMSE to draw (are the exact values of the integrands unknown?)")
    slopes = fit_slopes(s).set_index(["estimator", "integrand"])
    styles = estimator_styles(s["estimator"])
    ref = reference_estimator(s["estimator"])
    groups = _groups(s, ref)
    per = max(sum(1 for i, _ in groups if i == name) for name, _ in groups)
    ncol = 2 if max(len(str(e)) for e in styles) <= 14 else 1
    legend_h = 0.25 + 0.16 * -(-max(len(g) for _, g in groups) // ncol)
    box = {"left": 0.85, "width": 3.3, "right": 0.15, "top": 0.4, "height": 2.75, "bottom": 0.6 + legend_h}
    fig, axes = _figure(len(groups), _columns(len(groups), per), box, title or
                        f"Convergence: RMSE vs n, log-log; {ref} (black) in every panel for reference")
    count = {}
    for ax, (name, group) in zip(axes, groups):
        count[name] = count.get(name, 0) + 1
        part = s[s["integrand"] == name]
        for est in group:
            g = part[part["estimator"] == est].sort_values("n")
            colour, marker = styles[est]
            ok = (g["rmse"] > 0) & np.isfinite(g["rmse"])
            sl = slopes.loc[(est, name)]
            theory = f"{sl['theory']:+.2f}" if np.isfinite(sl["theory"]) else "n/a"
            if not ok.any():
                ax.plot([], [], marker=marker, color=colour, label=f"{est}, RMSE = 0 (theory {theory})")
                continue
            fitted = f"{sl['slope']:+.2f}" if np.isfinite(sl["slope"]) else "n/a"
            ax.plot(g["n"][ok].to_numpy(float), g["rmse"][ok].to_numpy(float), "-", marker=marker, color=colour,
                    ms=4.5, lw=1.5, label=f"{est}, {fitted} ({theory})")
        ax.set_xscale("log")
        ax.set_yscale("log")
        _n_ticks(ax, part["n"])
        _log_ticks(ax.yaxis, *ax.get_ylim())
        ax.set_xlabel("n (integrand evaluations)")
        ax.set_ylabel("RMSE (units of the integral)")
        of = sum(1 for i, _ in groups if i == name)
        ax.set_title(f"{name}: {len(group) - 1} estimators vs {ref}" + (f" ({count[name]}/{of})" if of > 1 else "")
                     if group and group[0] == ref else name, fontsize=10)
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(fontsize=7.5, title="estimator, fitted slope (theory)", title_fontsize=7.5,
                  loc="upper center", bbox_to_anchor=(0.5, -0.52 / box["height"]), ncol=ncol, frameon=False)
    tidy_tick_labels(fig)
    return fig


def convergence_plot(df: pd.DataFrame, path: str | Path, *, title: str | None = None) -> Path:
    """RMSE vs n per estimator, log-log, small multiples: one row of panels per integrand,
    each panel the reference estimator (``mc`` if present) and up to ``MAX_LINES - 1`` others.

    Legend: ``estimator, fitted slope (theoretical slope)`` (:func:`vrlab.lab.fit_slopes`).
    Zero RMSE (an exact estimator) cannot be drawn on a log axis and is noted in the legend.
    """
    path = out_path(path)
    convergence_figure(df, title=title).savefig(path, dpi=DPI)
    return path


def efficiency_figure(df: pd.DataFrame, *, n: int | None = None, reference: str | None = None):
    """The figure of :func:`efficiency_plot` (a ``matplotlib.figure.Figure``)."""
    t = equal_time(df, reference)
    if n is not None:
        n = checks.integer(n, "n", low=1)
        have = sorted(int(k) for k in t["n"].unique())
        if n not in have:
            raise ValueError(f"n: the table has no sample count {n}; it has {have}")
    styles = estimator_styles(_summary(df, ["variance"])["estimator"])
    ref = t["reference"].iloc[0]
    integrands = list(dict.fromkeys(t["integrand"]))
    names = t["estimator"].astype(str)
    box = {"left": 0.55 + 0.075 * names.str.len().max(), "width": 3.4, "right": 0.25, "top": 0.4,
           "height": 0.3 + 0.32 * names.nunique(), "bottom": 0.65}
    fig, axes = _figure(len(integrands), min(len(integrands), 3), box,
                        f"Equal-time efficiency 1 / (variance x seconds), relative to {ref}")
    for ax, name in zip(axes, integrands):
        part = t[t["integrand"] == name]
        at = part["n"].max() if n is None else n
        part = part[(part["n"] == at) & np.isfinite(part["efficiency_gain"])
                    & (part["efficiency_gain"] > 0)].iloc[::-1]
        ax.barh(part["estimator"], part["efficiency_gain"], color=[styles[e][0] for e in part["estimator"]])
        ax.axvline(1.0, color="0.4", lw=0.8, ls=":")
        ax.set_xscale("log")
        _log_ticks(ax.xaxis, *ax.get_xlim())
        ax.set_xlabel(f"efficiency relative to {ref} (dimensionless)")
        ax.set_ylabel("estimator")
        ax.set_title(f"{name}, n = {at}: > 1 beats {ref}", fontsize=10)
        ax.tick_params(axis="y", labelsize=8)
    tidy_tick_labels(fig)
    return fig


def efficiency_plot(df: pd.DataFrame, path: str | Path, *, n: int | None = None,
                    reference: str | None = None) -> Path:
    """Relative efficiency (equal time, see ``equal_time``) at sample count ``n``
    (default: the largest), one horizontal bar chart per integrand, log scale, each
    estimator in its colour of :func:`estimator_styles`.  ``n`` must be one of the table's
    sample counts."""
    path = out_path(path)
    efficiency_figure(df, n=n, reference=reference).savefig(path, dpi=DPI)
    return path
