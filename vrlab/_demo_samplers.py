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
    warp, (name, distribution, chart, up to 50,000 samples, test result) for
    :func:`draw_warps`.  ``progress()`` is called after each warp."""
    cases = showcase()
    table, panels = [], []
    for (name, dist, chart, bins), rng in zip(cases, spawn(seed, len(cases))):
        gof = T.chi2_gof(dist, chart, bins, n=n, rng=rng, name=name)
        x = dist.sample(rng.random((min(n, 50_000), dist.dim_u)))
        table.append({"warp": name, "measure": dist.measure, "n": n, "chi2": gof.statistic, "dof": gof.dof,
                      "p_value": gof.pvalue,
                      "pdf_integral": T.integrate(dist.pdf, chart, tuple(2 * b for b in bins))})
        panels.append((name, dist, chart, x, gof))
        if progress is not None:
            progress()
    return pd.DataFrame(table), panels


#: the two "methods" of every warp panel, one colour each
SAMPLES, EXPECTED = "tab:blue", "black"


def _histogram(ax, values, lo, hi, bins=40):
    """Histogram of ``values`` on [lo, hi] as a density (count / (N x width)), one artist."""
    counts, edges = np.histogram(values, bins=bins, range=(lo, hi))
    ax.stairs(counts / (len(values) * np.diff(edges)), edges, fill=True, color=SAMPLES, alpha=0.55)


def _chart_marginal(dist, chart, axis: int, m: int = 400):
    """Expected density of chart coordinate ``axis`` at m midpoints u: the mean over the other
    coordinate's midpoints of pdf(x(s)) * jacobian(s) (midpoint rule)."""
    u = (np.arange(m) + 0.5) / m
    a, b = np.meshgrid(u, u, indexing="ij")
    s = np.stack([a, b] if axis == 0 else [b, a], -1)
    return u, np.mean(dist.pdf(chart.from_param(s)) * chart.jacobian(s), axis=1)


def _marginal_panel(ax, dist, chart, x, axis, to_v, xlabel, ylabel):
    """Samples' v = to_v(chart coordinate ``axis``) against its expected density from the pdf,
    f(u) / |dv/du| (the chart marginal of :func:`_chart_marginal`)."""
    u, f = _chart_marginal(dist, chart, axis)
    v = to_v(u)
    density = f / np.abs(np.gradient(v, u))
    _histogram(ax, to_v(chart.to_param(x)[:, axis]), v.min(), v.max())
    order = np.argsort(v)
    ax.plot(v[order], density[order], color=EXPECTED, lw=1.4)
    ax.set_xlabel(xlabel), ax.set_ylabel(ylabel)


def _specs(panels: list) -> list:
    """(title, draw(ax)) per grid cell: 1D warps, the disk (radius, angle), the triangle, the
    image (samples, pdf), directions, light surfaces."""
    specs = []
    for name, dist, chart, x, gof in panels:
        p = f"chi2 p = {gof.pvalue:.3f}"
        if dist.dim_x == 1:
            def one(ax, dist=dist, x=x):
                lo, hi = np.quantile(x[:, 0], [0.0, 0.999])
                _histogram(ax, x[:, 0], lo, hi, 60)
                grid = np.linspace(lo, hi, 400)[:, None]
                ax.plot(grid[:, 0], dist.pdf(grid), color=EXPECTED, lw=1.4)
                ax.set_xlabel("x (dimensionless)"), ax.set_ylabel("pdf p(x) (per unit x)")
            specs.append((f"{name}\n{p}", one))
        elif isinstance(dist, D.Disk):
            r = float(np.ravel(dist.radius)[0])
            specs.append((f"{name}: radius\n{p}", lambda ax, d=dist, c=chart, x=x, r=r: _marginal_panel(
                ax, d, c, x, 0, lambda u: r * np.sqrt(u), f"radius r (disk radius {r:g})", "density (per unit r)")))
            specs.append((f"{name}: angle\n{p} (same test)", lambda ax, d=dist, c=chart, x=x: _marginal_panel(
                ax, d, c, x, 1, lambda u: 2 * np.pi * u, "angle phi (radians)", "density (per radian)")))
        elif isinstance(dist, D.Triangle):
            vertex = ", ".join(f"{v:g}" for v in chart.v[0])
            specs.append((f"{name}: barycentric\n{p}", lambda ax, d=dist, c=chart, x=x, vx=vertex: _marginal_panel(
                ax, d, c, x, 0, lambda u: u, f"weight of vertex ({vx}) (dimensionless)",
                "density (per unit weight)")))
        elif isinstance(dist, D.PiecewiseConstant2D):
            specs.extend(_image_specs(name, p, dist, x))
        elif dist.measure == "area" and isinstance(chart, T.AtlasChart):
            k = len(chart.charts)
            centres = np.array([f.corner + f.e.sum(0) / 2 for f in chart.charts])
            off = centres - centres.mean(0)           # each face's side of the box: its largest offset
            faces = ["-+"[int(o[np.argmax(np.abs(o))] > 0)] + "xyz"[int(np.argmax(np.abs(o)))] for o in off]
            def box(ax, d=dist, c=chart, x=x, k=k, faces=faces):
                _marginal_panel(ax, d, c, x, 0, lambda u: u, f"box face (chart coordinate, 1/{k} each)", "density (per unit coordinate)")
                ax.set_xticks((np.arange(k) + 0.5) / k, faces)
            specs.append((f"{name}\n{p}", box))
        elif dist.measure == "area":
            def height(u, c=chart):
                return c.from_param(np.stack([u, np.zeros_like(u)], -1))[:, 2]
            specs.append((f"{name}: height\n{p}", lambda ax, d=dist, c=chart, x=x, h=height: _marginal_panel(
                ax, d, c, x, 0, h, "height z of the point (scene units)", "density (per unit z)")))
        else:
            # azimuthally symmetric about +z: the density of z = cos(theta) is 2 pi p(w(z))
            def direction(ax, dist=dist, x=x):
                lo = x[:, 2].min()
                _histogram(ax, x[:, 2], lo, 1.0, 60)
                z = np.linspace(lo, 1, 400)
                w = np.stack([np.sqrt(1 - z**2), np.zeros_like(z), z], -1)
                ax.plot(z, 2 * np.pi * dist.pdf(w), color=EXPECTED, lw=1.4)
                ax.set_xlabel("cos theta (dimensionless)"), ax.set_ylabel("density (per unit cos theta)")
            specs.append((f"{name}\n{p}", direction))
    return specs


def _image_specs(name, p, dist, x) -> list:
    """Two cells: a 2D histogram of the samples on the pdf's own cells, and the pdf, on one
    colour scale (colour bar on the second)."""
    counts, _, _ = np.histogram2d(x[:, 0], x[:, 1], bins=(dist.xedges, dist.yedges))
    hist = counts.T / (len(x) * np.prod(dist.cell))
    top = max(hist.max(), dist.density.max())
    extent = (dist.xedges[0], dist.xedges[-1], dist.yedges[0], dist.yedges[-1])

    def show(ax, img, bar):
        im = ax.imshow(img, origin="lower", extent=extent, cmap="magma", vmin=0, vmax=top, aspect="auto")
        ax.set_xlabel("x (dimensionless)"), ax.set_ylabel("y (dimensionless)")
        if bar:
            bar = ax.figure.colorbar(im, ax=ax, fraction=0.08, pad=0.03)
            bar.set_label("density (per unit area)", fontsize=7)
            bar.ax.tick_params(labelsize=6)
    return [(f"{name}: samples\n{p}", lambda ax: show(ax, hist, False)),
            (f"{name}: pdf\n(same colour scale)", lambda ax: show(ax, dist.density, True))]


def warps_figure(panels: list, cols: int = 6):
    """The ``warps.png`` figure (a ``matplotlib.figure.Figure``): one cell per entry of
    :func:`_specs`, ``cols`` per row, no empty cells when their count divides."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    specs = _specs(panels)
    rows = -(-len(specs) // cols)
    fig = Figure(figsize=(3.0 * cols, 2.9 * rows + 0.9), dpi=110)
    FigureCanvasAgg(fig)
    for k, (title, draw) in enumerate(specs):
        ax = fig.add_subplot(rows, cols, k + 1)
        ax.locator_params(axis="x", nbins=5)
        draw(ax)
        ax.set_title(title, fontsize=8)
        ax.tick_params(labelsize=6)
        ax.xaxis.label.set_size(7), ax.yaxis.label.set_size(7)
    level = T.sidak_threshold(0.01, len(panels))
    fig.suptitle(f"vrlab warps: samples against their pdf, {len(panels)} warps; reject a warp if "
                 f"p < {level:.1e} (1% family-wise)", fontsize=11)
    fig.legend(handles=[Patch(color=SAMPLES, alpha=0.55, label="samples (histogram, density)"),
                        Line2D([], [], color=EXPECTED, label="expected density, from the pdf")],
               loc="upper center", bbox_to_anchor=(0.5, 1 - 0.4 / fig.get_figheight()), ncol=2, fontsize=9,
               frameon=False)
    # fixed margins: tight_layout measures every tick label and costs seconds on many panels
    fig.subplots_adjust(left=0.04, right=0.985, bottom=0.06, top=1 - 1.25 / fig.get_figheight(), wspace=0.42,
                        hspace=0.7)
    return fig


def draw_warps(path: Path, panels: list) -> None:
    """``warps.png``: :func:`warps_figure`."""
    warps_figure(panels).savefig(path, dpi=110)


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


def point_sets_figure(seed: int):
    """The ``point_sets.png`` figure: 256 points of each point set in the unit square, CD in
    the title (a ``matplotlib.figure.Figure``)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    engines = point_set_engines(2, seed)
    fig = Figure(figsize=(12, 6.8), dpi=110)
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 4)
    n = 256
    for ax, (name, eng) in zip(axes.ravel(), engines.items()):
        u = eng.random(n)
        ax.scatter(u[:, 0], u[:, 1], s=4, color=SAMPLES)
        ax.set_xlim(0, 1), ax.set_ylim(0, 1), ax.set_aspect("equal")
        ax.set_xticks(np.linspace(0, 1, 5)), ax.set_yticks(np.linspace(0, 1, 5))
        ax.grid(alpha=0.3)
        ax.set_title(f"{name}\nCD = {centred_discrepancy(u):.2e}", fontsize=9)
        ax.set_xlabel("u1 (dimensionless)", fontsize=7), ax.set_ylabel("u2 (dimensionless)", fontsize=7)
        ax.tick_params(labelsize=6)
    fig.suptitle(f"{n} points of each point set in [0, 1)^2 (CD = centred L2 discrepancy, Hickernell 1998, "
                 "lower is more uniform; SciPy's qmc.discrepancy returns CD^2)", fontsize=10)
    fig.subplots_adjust(left=0.05, right=0.98, bottom=0.07, top=0.86, wspace=0.3, hspace=0.42)
    return fig


def draw_point_sets(path: Path, seed: int) -> None:
    """``point_sets.png``: :func:`point_sets_figure`."""
    point_sets_figure(seed).savefig(path, dpi=110)


def discrepancy_table(seed: int, ns=(64, 256, 1024, 4096), d: int = 2) -> pd.DataFrame:
    """CD (not CD^2) of each point set at each n: one row per point set, one column per n."""
    rows = []
    for n in ns:
        for name, eng in point_set_engines(d, seed).items():
            rows.append({"point set": name, "n": n, "d": d, "CD": centred_discrepancy(eng.random(n))})
    return pd.DataFrame(rows).pivot(index="point set", columns="n", values="CD")
