"""Drawing helpers of the experiment modules, for the figure rules of issue 15.

* ``show_image(ax, img, exposure, title)``: a linear render shown as sRGB, clamp(exposure
  * img) then the sRGB curve (:func:`vrlab.render.image.srgb_encode`; NaN shows black).
  Images compared side by side share ONE exposure, ``exposure_of(reference)`` =
  :func:`vrlab.render.image.auto_exposure` (key 0.18 on the log-average luminance, at most
  3% of the pixels clip) of the reference or the first image; such figures say so
  (``EXPOSURE_NOTE``).
* ``show_map(ax, values, label, ...)``: a false-colour map with a colour bar whose label
  names the quantity and its unit.
* ``convergence_panel(ax, summary, slopes, integrand, estimators, colours)``: RMSE against
  n, log-log, one line per estimator in its colour (a dict per module, the same in every
  panel and figure); the legend gives the fitted slope (the theoretical one in brackets),
  the dashed line of the same colour is the theoretical slope through the first point.
Figures are written by :func:`vrlab.lab.experiment.save_figure`.
"""
from __future__ import annotations


import numpy as np

EXPOSURE_NOTE = "exposure: auto, shared"


def exposure_of(reference: np.ndarray) -> float:
    """``auto_exposure`` of an (H, W, 3) or (H, W) linear image (NaN ignored)."""
    from vrlab.render.image import auto_exposure

    img = np.asarray(reference, float)
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, -1)
    return auto_exposure(img)


def display(img: np.ndarray, exposure: float) -> np.ndarray:
    """sRGB values in [0, 1] of ``exposure * img`` (grey (H, W) images become (H, W, 3))."""
    from vrlab.render.image import srgb_encode

    img = np.nan_to_num(np.asarray(img, float), nan=0.0, posinf=0.0, neginf=0.0)
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, -1)
    return srgb_encode(img * exposure)


def show_image(ax, img: np.ndarray, exposure: float, title: str, fontsize: float = 9) -> None:
    """A linear render at ``exposure`` on an axis-free panel titled ``title``."""
    ax.imshow(display(img, exposure), interpolation="nearest")
    ax.set_title(title, fontsize=fontsize)
    ax.set_xticks([])
    ax.set_yticks([])


def show_map(ax, values: np.ndarray, label: str, *, title: str | None = None, cmap: str = "viridis",
             vmin: float | None = None, vmax: float | None = None, fontsize: float = 9, extent=None,
             origin: str = "upper"):
    """A false-colour map of ``values`` with a colour bar labelled ``label`` (quantity and
    unit); axis-free unless ``extent`` is given.  Returns the image."""
    im = ax.imshow(values, cmap=cmap, vmin=vmin, vmax=vmax, interpolation="nearest", extent=extent,
                   origin=origin)
    if title:
        ax.set_title(title, fontsize=fontsize)
    if extent is None:
        ax.set_xticks([])
        ax.set_yticks([])
    bar = ax.figure.colorbar(im, ax=ax, fraction=0.046, pad=0.03)
    bar.set_label(label, fontsize=fontsize - 1)
    bar.ax.tick_params(labelsize=fontsize - 1)
    return im


def convergence_panel(ax, summary, slopes, integrand: str, estimators, colours: dict,
                      labels: dict | None = None) -> None:
    """RMSE vs n of ``estimators`` on ``integrand`` (rows of a ``lab.summarize`` table; slopes
    from ``lab.fit_slopes``), log-log, each in ``colours[name]`` (``labels[name]`` in the
    legend, default the name).  A zero RMSE cannot be drawn and is named in the legend."""
    s = slopes.set_index(["estimator", "integrand"])
    part = summary[summary["integrand"] == integrand]
    for name in estimators:
        g = part[part["estimator"] == name].sort_values("n")
        if g.empty:
            continue
        label = (labels or {}).get(name, name)
        sl = s.loc[(name, integrand)]
        ok = (g["rmse"] > 0) & np.isfinite(g["rmse"])
        if not ok.any():
            ax.plot([], [], "o", color=colours[name], label=f"{label}: RMSE = 0")
            continue
        n, r = g["n"][ok].to_numpy(float), g["rmse"][ok].to_numpy(float)
        fitted = f"{sl['slope']:+.2f}" if np.isfinite(sl["slope"]) else "n/a"
        ax.plot(n, r, "o-", ms=3.5, lw=1.4, color=colours[name],
                label=f"{label}: {fitted} ({sl['theory']:+.2f})")
        if np.isfinite(sl["theory"]):
            ax.plot(n, r[0] * (n / n[0]) ** sl["theory"], "--", color=colours[name], lw=0.9, alpha=0.7)
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("n (integrand evaluations)")
    ax.set_ylabel("RMSE (units of the integral)")
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=7, title="fitted slope (theory, dashed)", title_fontsize=7)
