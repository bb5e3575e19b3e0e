"""``vrlab demo``: the sampling layer at a glance, on built-in defaults.

Writes into one folder:
* ``warps.png`` – each warp's samples against its pdf (chi-square p-value in the title);
* ``warps_gof.csv`` – the chi-square goodness-of-fit table behind it;
* ``point_sets.png`` – 256 points of every point set in the unit square;
* ``discrepancy.csv`` – centred L2 discrepancy of each point set vs n;
* ``sampler_speed.csv`` – vrlab vs NumPy/SciPy timings (quick sizes), as ratios;
* ``lab_summary.csv``, ``lab_slopes.csv``, ``lab_runs.csv``, ``convergence.png``, ``efficiency.png``
  – estimators compared on ``exp``, ``sin``, ``glossy-light`` (:func:`lab_section`).
"""
from __future__ import annotations

import time
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


def _panel(ax, name, dist, x, gof):
    import matplotlib.pyplot as plt  # noqa: F401  (backend chosen by caller)

    if dist.dim_x == 1:
        ax.hist(x[:, 0], bins=60, density=True, alpha=0.6, label="samples")
        lo, hi = np.quantile(x[:, 0], [0.0, 0.999])
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
        ax.hist(x[:, 2], bins=60, density=True, alpha=0.6, label="samples")
        z = np.linspace(x[:, 2].min(), 1, 400)
        w = np.stack([np.sqrt(1 - z**2), np.zeros_like(z), z], -1)
        ax.plot(z, 2 * np.pi * dist.pdf(w), "k", lw=1.5, label="2 pi p(w)")
        ax.set_xlabel("cos theta")
    ax.set_title(f"{name}\nchi2 p = {gof.pvalue:.3f}", fontsize=8)
    ax.tick_params(labelsize=6)


def warp_figure(out: Path, seed: int, n: int) -> pd.DataFrame:
    import matplotlib.pyplot as plt

    cases = showcase()
    rngs = spawn(seed, len(cases))
    cols = 5
    rows = -(-len(cases) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.0 * cols, 2.7 * rows))
    table = []
    for ax, (name, dist, chart, bins), rng in zip(axes.ravel(), cases, rngs):
        gof = T.chi2_gof(dist, chart, bins, n=n, rng=rng, name=name)
        x = dist.sample(rng.random((min(n, 50_000), dist.dim_u)))
        table.append({"warp": name, "measure": dist.measure, "n": n, "chi2": gof.statistic, "dof": gof.dof,
                      "p_value": gof.pvalue,
                      "pdf_integral": T.integrate(dist.pdf, chart, tuple(2 * b for b in bins))})
        _panel(ax, name, dist, x, gof)
    for ax in axes.ravel()[len(cases):]:
        ax.axis("off")
    level = T.sidak_threshold(0.01, len(cases))
    fig.suptitle("vrlab warps: samples (histogram / scatter) against the pdf; "
                 f"reject a warp if p < {level:.1e} (1% family-wise over {len(cases)} tests)", fontsize=11)
    fig.tight_layout()
    fig.savefig(out / "warps.png", dpi=110)
    plt.close(fig)
    df = pd.DataFrame(table)
    df.to_csv(out / "warps_gof.csv", index=False)
    return df


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


def point_set_figure(out: Path, seed: int) -> None:
    import matplotlib.pyplot as plt

    engines = point_set_engines(2, seed)
    fig, axes = plt.subplots(2, 4, figsize=(12, 6.4))
    for ax, (name, eng) in zip(axes.ravel(), engines.items()):
        u = eng.random(256)
        ax.scatter(u[:, 0], u[:, 1], s=4)
        ax.set_xlim(0, 1), ax.set_ylim(0, 1), ax.set_aspect("equal")
        ax.set_xticks(np.linspace(0, 1, 5)), ax.set_yticks(np.linspace(0, 1, 5))
        ax.grid(alpha=0.3)
        ax.set_title(f"{name}\nCD = {P.discrepancy(u):.2e}", fontsize=9)
        ax.tick_params(labelsize=6)
    fig.suptitle("256 points of each point set (CD = centred L2 discrepancy)")
    fig.tight_layout()
    fig.savefig(out / "point_sets.png", dpi=110)
    plt.close(fig)


def discrepancy_table(out: Path, seed: int, ns=(64, 256, 1024, 4096), d: int = 2) -> pd.DataFrame:
    rows = []
    for n in ns:
        for name, eng in point_set_engines(d, seed).items():
            rows.append({"point set": name, "n": n, "d": d, "CD discrepancy": P.discrepancy(eng.random(n))})
    df = pd.DataFrame(rows).pivot(index="point set", columns="n", values="CD discrepancy")
    df.to_csv(out / "discrepancy.csv")
    return df


#: estimators of the demo's lab section (recipes that do not apply to an integrand, or whose
#: estimator module is not installed, are left out of that integrand's rows)
LAB_ESTIMATORS = ("mc", "is:linear", "is:brdf", "is:light", "mis-balance", "mis-power", "onesample",
                  "defensive", "antithetic", "cv", "stratified", "jittered", "lhs", "rqmc-sobol", "ris:8")
LAB_INTEGRANDS = ("exp", "sin", "glossy-light")


def lab_section(out: Path, seed: int, quick: bool) -> dict:
    """Estimators on ``exp``, ``sin`` and ``glossy-light``: a comparison table at the largest n
    (``lab_summary.csv``, ``lab_slopes.csv``, per-repetition ``lab_runs.csv``) and the
    convergence plot ``convergence.png`` (RMSE vs n with fitted slopes) plus ``efficiency.png``."""
    import os

    from . import lab

    out = Path(out)
    ns = (64, 256, 1024) if quick else (64, 256, 1024, 4096, 16384)
    reps = 12 if quick else 40
    workers = 1 if quick else max(1, min(2, os.cpu_count() or 1))
    t0 = time.perf_counter()
    df = lab.run(LAB_ESTIMATORS, LAB_INTEGRANDS, ns, reps, rng=seed, skip=True, workers=workers)
    summary = lab.summarize(df)
    slopes = lab.fit_slopes(summary)
    eq = lab.equal_time(summary)
    df.to_csv(out / "lab_runs.csv", index=False)
    summary.to_csv(out / "lab_summary.csv", index=False)
    slopes.to_csv(out / "lab_slopes.csv", index=False)
    lab.convergence_plot(summary, out / "convergence.png", title="vrlab lab: RMSE vs n (dashed: theoretical slope)")
    lab.efficiency_plot(summary, out / "efficiency.png")
    top = summary[summary["n"] == max(ns)].merge(eq[["integrand", "n", "estimator", "relative_efficiency"]],
                                                  on=["integrand", "n", "estimator"])
    table = top.merge(slopes[["estimator", "integrand", "slope", "theory"]], on=["estimator", "integrand"])
    table = table[["integrand", "estimator", "rmse", "bias", "z_std", "coverage", "relative_efficiency",
                   "slope", "theory"]]
    print(f"\nLab: estimators at n = {max(ns)} over {reps} repetitions (efficiency relative to mc at equal "
          "time; slope of RMSE vs n; convergence.png, efficiency.png)")
    with pd.option_context("display.width", 160, "display.max_columns", 20, "display.max_rows", 200):
        print(table.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    skipped = df.attrs.get("skipped", [])
    missing = sorted({s["estimator"] for s in skipped if "not available" in s["reason"]})
    if missing:
        print("not run (estimator module not installed): " + ", ".join(missing))
    return {"lab_seconds": time.perf_counter() - t0, "lab_rows": len(df), "lab_skipped": len(skipped)}


def render_section(out: Path, seed: int, quick: bool) -> pd.DataFrame:
    """The Veach figure: BSDF sampling | light sampling | MIS on the glossy plates scene."""
    import dataclasses

    from .render import builtin_scene_path, load_scene
    from .render.compare import compare, compare_figure

    scene = load_scene(builtin_scene_path("veach_mis"))
    w, h = (64, 48) if quick else (128, 96)
    scene.sensor = dataclasses.replace(scene.sensor, width=w, height=h)
    res = compare(scene, spp=8 if quick else 16, rng=seed, ref_spp=32 if quick else 128)
    compare_figure(res, out / "veach_mis.png",
                   title=f"Veach's glossy plates, {res['spp']} spp: BSDF sampling | light sampling | MIS (power)")
    df = pd.DataFrame({"strategy": list(res["rel_mse"]), "rel_mse": list(res["rel_mse"].values()),
                       "seconds": list(res["seconds"].values())})
    df.to_csv(out / "veach_mis.csv", index=False)
    return df


def run_demo(out: str | Path = "vrlab-demo", seed: int = 2026, quick: bool = False) -> dict:
    """Run the showcase and write its figures and tables into ``out``; returns a summary."""
    import matplotlib

    matplotlib.use("Agg")
    from . import checks
    from .bench import run as run_bench

    if not isinstance(out, (str, Path)) or not str(out):
        raise TypeError(f"out must be a folder path, got {out!r}")
    seed, quick = checks.integer(seed, "seed", low=0), checks.flag(quick, "quick")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"out: {out} exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    print(f"vrlab demo: writing into {out.resolve()}")
    gof = warp_figure(out, seed, 20_000 if quick else 200_000)
    print("\nWarps: chi-square goodness of fit of samples against the pdf (warps.png)")
    print(gof.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    point_set_figure(out, seed)
    disc = discrepancy_table(out, seed)
    print("\nPoint sets: centred L2 discrepancy in d = 2 (lower is more uniform; point_sets.png)")
    print(disc.to_string(float_format=lambda v: f"{v:.2e}"))
    speed = pd.DataFrame(run_bench("sampling", quick=True))
    speed.to_csv(out / "sampler_speed.csv", index=False)
    print("\nSamplers: vrlab vs peers, quick sizes (run `vrlab bench sampling` for full sizes)")
    with pd.option_context("display.width", 160, "display.max_columns", 20):
        print(speed.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    lab_info = lab_section(out, seed, quick)
    veach = render_section(out, seed, quick)
    print("\nRenderer: Veach's glossy plates at equal spp, relMSE against a high-spp MIS render (veach_mis.png)")
    print(veach.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    files = sorted(p.name for p in out.iterdir())
    seconds = time.perf_counter() - t0
    print(f"\nwrote {', '.join(files)} in {seconds:.1f} s")
    return {"out": str(out.resolve()), "files": files, "seconds": seconds, **lab_info}
