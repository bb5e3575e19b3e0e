"""The sampler sections of ``vrlab demo`` (:mod:`vrlab.demo`): warps against their pdfs,
point sets and their centred discrepancy.  Numbers are computed by the ``*_table``
functions; the ``draw_*`` functions only draw them, so that the demo can draw in a
separate process while it computes on.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from . import distributions as D
from . import points as P
from . import testing as T
from ._rng import spawn


def showcase() -> list[tuple[str, object, object, tuple]]:
    """(name, distribution, chart, chi-square bins) for the warps shown in the demo."""
    img = np.outer(np.hanning(24) + 0.05, np.hanning(32) + 0.05)
    img[4:8, 20:28] += 2.0
    return [
        ("linear 8x/pi^2", D.LinearInterval(0, np.pi / 2, 0, 1), T.IntervalChart(0, np.pi / 2), (40,)),
        ("exponential rate 2", D.Exponential(2.0), T.HalfLineChart(0.5), (40,)),
        ("piecewise-constant 1D", D.PiecewiseConstant1D([1, 3, 0.5, 0, 2, 4]), T.IntervalChart(0, 1), (48,)),
        ("disk (concentric)", D.Disk(), T.DiskChart(), (16, 24)),
        ("triangle", D.Triangle((0, 0), (1, 0), (0.3, 0.9)), T.TriangleChart((0, 0), (1, 0), (0.3, 0.9)), (16, 16)),
        ("image luminance 2D", D.PiecewiseConstant2D(img), T.BoxChart([(0, 1), (0, 1)]), (32, 24)),
        ("uniform sphere", D.UniformSphere(), T.SphereChart(), (20, 30)),
        ("uniform hemisphere", D.UniformHemisphere(), T.HemisphereChart(), (20, 30)),
        ("cosine: inversion", D.CosineHemisphere("inversion"), T.HemisphereChart(), (20, 30)),
        ("cosine: disk", D.CosineHemisphere("disk"), T.HemisphereChart(), (20, 30)),
        ("cosine: sphere-shift", D.CosineHemisphere("sphere-shift"), T.HemisphereChart(), (20, 30)),
        ("Phong n=20", D.PhongLobe(20), T.HemisphereChart(power=2), (30, 24)),
        ("GGX alpha=0.3", D.GGX(0.3), T.HemisphereChart(power=2), (30, 24)),
        ("cone cos=0.8", D.UniformCone(0.8), T.CapChart(0.8), (20, 24)),
        ("box light (faces by area)", D.BoxSurface((0, 0, 0), (1.0, 0.5, 0.25)),
         T.box_surface_chart((0, 0, 0), (1.0, 0.5, 0.25)), (24, 8)),
        ("ellipsoid light (Jacobian pdf)", D.EllipsoidSurface.from_radii((0, 0, 0), (1.0, 0.5, 0.3)),
         T.EllipsoidChart((0, 0, 0), np.diag([1.0, 0.5, 0.3])), (20, 30)),
    ]




def warp_table(seed: int, n: int, progress=None) -> tuple[pd.DataFrame, list]:
    """Chi-square goodness of fit of each warp with ``n`` samples (``warps_gof.csv``) and, per
    warp, (name, distribution, up to 50,000 samples, test result) for :func:`draw_warps`.
    ``progress()`` is called after each warp."""
    cases = showcase()
    table, panels = [], []
    for (name, dist, chart, bins), rng in zip(cases, spawn(seed, len(cases))):
        gof = T.chi2_gof(dist, chart, bins, n=n, rng=rng, name=name)
        x = dist.sample(rng.random((min(n, 50_000), dist.dim_u)))
        table.append({"warp": name, "measure": dist.measure, "n": n, "chi2": gof.statistic, "dof": gof.dof,
                      "p_value": gof.pvalue,
                      "pdf_integral": T.integrate(dist.pdf, chart, tuple(2 * b for b in bins))})
        panels.append((name, dist, x, gof))
        if progress is not None:
            progress()
    return pd.DataFrame(table), panels


def _panel(ax, name, dist, x, gof):
    if dist.dim_x == 1:
        lo, hi = np.quantile(x[:, 0], [0.0, 0.999])
        counts, edges = np.histogram(x[:, 0], bins=60, range=(lo, hi), density=True)
        ax.stairs(counts, edges, fill=True, alpha=0.6, label="samples")    # one artist, not 60 bars
        grid = np.linspace(lo, hi, 400)[:, None]
        ax.plot(grid[:, 0], dist.pdf(grid), "k", lw=1.5, label="pdf")
        ax.set_xlabel("x")
    elif dist.dim_x == 2:
        if isinstance(dist, D.PiecewiseConstant2D):
            ax.imshow(dist.density, origin="lower", extent=(0, 1, 0, 1), cmap="magma")
        ax.scatter(x[:1500, 0], x[:1500, 1], s=1.5, c="tab:cyan" if isinstance(dist, D.PiecewiseConstant2D)
                   else "tab:blue")
        ax.set_aspect("equal")
    elif dist.measure == "area":
        # a light surface in 3D: points seen from above (x, y), coloured by their area density
        sc = ax.scatter(x[:3000, 0], x[:3000, 1], c=dist.pdf(x[:3000]), s=1.5, cmap="viridis")
        ax.figure.colorbar(sc, ax=ax, shrink=0.8).ax.tick_params(labelsize=6)
        ax.set_aspect("equal")
        ax.set_xlabel("x (colour: area pdf)")
    else:
        # azimuthally symmetric about +z: marginal density of z = cos(theta) is 2 pi p(w(z))
        lo = x[:, 2].min()
        counts, edges = np.histogram(x[:, 2], bins=60, range=(lo, 1.0), density=True)
        ax.stairs(counts, edges, fill=True, alpha=0.6, label="samples")
        z = np.linspace(lo, 1, 400)
        w = np.stack([np.sqrt(1 - z**2), np.zeros_like(z), z], -1)
        ax.plot(z, 2 * np.pi * dist.pdf(w), "k", lw=1.5, label="2 pi p(w)")
        ax.set_xlabel("cos theta")
    ax.set_title(f"{name}\nchi2 p = {gof.pvalue:.3f}", fontsize=8)
    ax.tick_params(labelsize=6)


def draw_warps(path: Path, panels: list) -> None:
    """``warps.png``: one panel per warp of :func:`warp_table`."""
    import matplotlib.pyplot as plt

    cols = 5
    rows = -(-len(panels) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.0 * cols, 2.7 * rows))
    for ax, panel in zip(axes.ravel(), panels):
        _panel(ax, *panel)
    for ax in axes.ravel()[len(panels):]:
        ax.axis("off")
    level = T.sidak_threshold(0.01, len(panels))
    fig.suptitle("vrlab warps: samples (histogram / scatter) against the pdf; "
                 f"reject a warp if p < {level:.1e} (1% family-wise over {len(panels)} tests)", fontsize=11)
    # fixed margins: tight_layout measures every tick label and costs seconds on 16 panels
    fig.subplots_adjust(left=0.04, right=0.98, bottom=0.05, top=0.9, wspace=0.35, hspace=0.75)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def point_set_engines(d: int, seed: int) -> dict:
    """Fresh engines for the point sets compared in the demo (each with its own child seed)."""
    rng = spawn(seed, 8)
    return {
        "independent": P.Independent(d, rng=rng[0]),
        "stratified (jittered)": P.Stratified(d, rng=rng[1]),
        "latin hypercube": P.LatinHypercube(d, rng=rng[2]),
        "halton": P.Halton(d),
        "halton scrambled": P.Halton(d, scramble=True, rng=rng[3]),
        "hammersley": P.Hammersley(d),
        "sobol (scrambled)": P.Sobol(d, rng=rng[4]),
        "hammersley + CP rotation": P.CranleyPatterson(P.Hammersley(d), rng=rng[5]),
    }


def centred_discrepancy(u) -> float:
    """CD, the centred L2 discrepancy (Hickernell 1998): the square root of SciPy's
    ``qmc.discrepancy(method="CD")``, which is CD^2."""
    return float(np.sqrt(P.discrepancy(u)))


def draw_point_sets(path: Path, seed: int) -> None:
    """``point_sets.png``: 256 points of each point set in the unit square, CD in the title."""
    import matplotlib.pyplot as plt

    engines = point_set_engines(2, seed)
    fig, axes = plt.subplots(2, 4, figsize=(12, 6.4))
    for ax, (name, eng) in zip(axes.ravel(), engines.items()):
        u = eng.random(256)
        ax.scatter(u[:, 0], u[:, 1], s=4)
        ax.set_xlim(0, 1), ax.set_ylim(0, 1), ax.set_aspect("equal")
        ax.set_xticks(np.linspace(0, 1, 5)), ax.set_yticks(np.linspace(0, 1, 5))
        ax.grid(alpha=0.3)
        ax.set_title(f"{name}\nCD = {centred_discrepancy(u):.2e}", fontsize=9)
        ax.tick_params(labelsize=6)
    fig.suptitle("256 points of each point set (CD = centred L2 discrepancy, Hickernell 1998; "
                 "SciPy's qmc.discrepancy returns CD^2)")
    fig.subplots_adjust(left=0.04, right=0.98, bottom=0.05, top=0.86, wspace=0.25, hspace=0.3)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def discrepancy_table(seed: int, ns=(64, 256, 1024, 4096), d: int = 2) -> pd.DataFrame:
    """CD (not CD^2) of each point set at each n: one row per point set, one column per n."""
    rows = []
    for n in ns:
        for name, eng in point_set_engines(d, seed).items():
            rows.append({"point set": name, "n": n, "d": d, "CD": centred_discrepancy(eng.random(n))})
    return pd.DataFrame(rows).pivot(index="point set", columns="n", values="CD")
