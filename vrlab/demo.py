"""``vrlab demo``: the sampling layer at a glance, on built-in defaults.

Five sections, in this order.  Each prints its header *before* its work starts; the long
steps (the warps, the lab sweep, the speed races of the full demo, the reference render)
show a tqdm progress bar on stderr when stderr is a terminal, and stay quiet otherwise.

1. Warps: ``warps.png`` (each warp's samples against the density its pdf predicts,
   chi-square p-value in the title) and ``warps_gof.csv`` (the goodness-of-fit table and each pdf's integral).
2. Point sets: ``point_sets.png`` (256 points of every point set) and ``discrepancy.csv``,
   the centred L2 discrepancy CD of each set vs n (Hickernell 1998).  SciPy's
   ``scipy.stats.qmc.discrepancy(method="CD")`` (:func:`vrlab.points.discrepancy`) returns
   the *squared* CD; the demo reports CD, its square root, which falls like the
   integration error (~ n^-1/2 for independent points, ~ n^-1 up to logs for QMC).
3. Speed, two separate tables: ``speed_qmc.csv`` (Halton / Hammersley against
   ``scipy.stats.qmc.Halton``) and, in the full demo only, ``speed_discrete.csv`` (alias and
   CDF tables against NumPy and SciPy); ``vrlab bench sampling`` runs both at full sizes.
4. Lab: estimators on ``exp``, ``sin`` and ``glossy-light`` (:func:`lab_section`):
   ``lab_runs.csv``, ``lab_summary.csv``, ``lab_slopes.csv``, ``lab_table.csv`` (the
   printed table with its trust flags), ``convergence.png`` and ``efficiency.png``.
5. Renderer: Veach's glossy plates, BSDF sampling | light sampling | MIS (``veach_mis.png``,
   ``veach_mis.csv``), relMSE against a higher-spp MIS reference that it renders first; the
   three panels share one exposure, ``auto_exposure`` of the reference
   (:mod:`vrlab.render.image`).

Figures follow the same rules: labelled axes with units, one colour per method in every
panel (estimators: :func:`vrlab.lab.plots.estimator_styles`), at most six lines per
convergence panel (small multiples, ``mc`` in each), every warp beside the density its
pdf predicts (1D: the pdf; disk, triangle and light surfaces: marginals of their chart
coordinates; the image pdf: a 2D histogram beside the pdf on one colour scale).

Sizes (``quick`` / full): warps 2e4 / 2e5 samples; discrepancy up to n = 1024 / 4096;
QMC races at d = 2, 8 / 2, 8, 32 (best of 2 / 3), discrete races in the full demo only;
lab: 10 of the 15 estimators on ``exp`` and ``glossy-light`` at n = 64 .. 1024 with 12
repetitions in this process / all 15 on all three integrands at n = 64 .. 16384 with 40
repetitions in 2 forked worker processes; render 64x48 at 8 spp with a 32-spp reference /
128x96 at 16 spp with a 128-spp reference.  The figures are drawn in a forked process while
the numbers go on (:class:`_Painter`).  ``benchmarks/bench_demo.py`` times both demos.

Stderr trust flags (:func:`vrlab.lab.trust.stderr_flags`; column ``flag`` of ``lab_summary.csv`` per
(estimator, integrand, n), and of the printed table, where an estimator carries its worst
flag over the sweep's n).  If an estimator's standard errors are honest, its R repetitions
give z_r = (F_r - I) / stderr_r about N(0, 1): (R - 1) z_std^2 ~ chi^2_{R-1}, and the count
K of 95 % intervals F_r +- 1.96 stderr_r that hold I is Binomial(R, 0.95).  Each
(estimator, integrand, n) row gets two tests at the Sidak level
alpha = 1 - 0.99^(1 / (2 rows)), so that with honest errors *any* flag in the sweep has a
chance of at most about 1 %:

* ``!`` stderr too small, the error bars cannot be trusted: z_std above the upper end of
  the chi-square band ``std_band(R, alpha)`` (:mod:`vrlab.significance`), or
  P(K <= k) < alpha for the observed count k (coverage below the smallest
  count that binomial chance allows).  Typical cause: a heavy tail that R samples of n
  rarely reach (``is:brdf`` on ``glossy-light`` misses the small bright light), so the
  sample variance underestimates the variance.
* ``~`` stderr far too large: z_std below the band's lower end.  The intervals are safe but
  say little (jittered and Latin hypercube errors, reported as if i.i.d.).

The thresholds are computed from R and the number of rows, and printed under the table
with the n at which each flag was raised.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from ._demo_samplers import discrepancy_table, draw_point_sets, draw_warps, showcase, warp_table

from .lab.trust import (FLAG_FAMILY_ALPHA, _worst, stderr_flags, trust_thresholds,  # noqa: F401  (public here too)
                        flag_notes as _flag_notes)


def _bar(total: int, label: str):
    """A tqdm bar on stderr, quiet when stderr is not a terminal."""
    from .lab.progress import ProgressBar

    return ProgressBar(total, label=label, disable=None)


class _Painter:
    """Draws figures in forked child processes, one at a time, while the demo computes on
    (its figures cost about as much as its numbers, and the machine has 2 cores).  Without
    ``fork`` or with a single core it draws in this process.  ``wait`` joins the children
    and raises ``RuntimeError`` naming any figure that failed."""

    def __init__(self):
        import multiprocessing as mp
        import os

        fork = "fork" in mp.get_all_start_methods() and (os.cpu_count() or 1) > 1
        self._ctx = mp.get_context("fork") if fork else None
        self._lock = self._ctx.Lock() if fork else None
        self._jobs: list = []

    @staticmethod
    def _locked(lock, fn, args):
        with lock:
            fn(*args)

    def draw(self, name: str, fn, *args) -> None:
        if self._ctx is None:
            fn(*args)
            return
        p = self._ctx.Process(target=self._locked, args=(self._lock, fn, args), name=f"vrlab demo: {name}",
                              daemon=True)
        p.start()
        self._jobs.append((name, p))

    def wait(self) -> None:
        failed = []
        for name, p in self._jobs:
            p.join()
            if p.exitcode != 0:
                failed.append(f"{name} (exit code {p.exitcode})")
        self._jobs = []
        if failed:
            raise RuntimeError("vrlab demo: drawing failed: " + ", ".join(failed))


def speed_tables(out: Path, quick: bool) -> dict[str, pd.DataFrame]:
    """QMC generation races (and, in the full demo, discrete sampling races) as two tables,
    each with its own columns (``speed_qmc.csv``, ``speed_discrete.csv``)."""
    from .bench.discrete import bench_discrete
    from .bench.qmc import bench_qmc

    steps = {"qmc": lambda: bench_qmc(True, dims=(2, 8) if quick else (2, 8, 32), repeat=2 if quick else 3)}
    if not quick:
        steps["discrete"] = lambda: bench_discrete(True)
    bar = _bar(len(steps), "speed") if len(steps) > 1 else None
    tables = {}
    for name, step in steps.items():
        tables[name] = pd.DataFrame(step()).drop(columns="suite", errors="ignore")
        tables[name].to_csv(out / f"speed_{name}.csv", index=False)
        if bar is not None:
            bar.update()
    return tables


#: estimators of the demo's lab section (recipes that do not apply to an integrand, or whose
#: estimator module is not installed, are left out of that integrand's rows)
LAB_ESTIMATORS = ("mc", "is:linear", "is:brdf", "is:light", "mis-balance", "mis-power", "onesample",
                  "defensive", "antithetic", "cv", "stratified", "jittered", "lhs", "rqmc-sobol", "ris:8")
#: the quick demo's subset, one or two of each family (scrambled Halton for RQMC: building
#: scrambled Sobol' engines costs more than all the other estimators of the quick sweep together)
QUICK_ESTIMATORS = ("mc", "is:linear", "is:brdf", "is:light", "mis-balance", "defensive", "antithetic", "cv",
                    "jittered", "rqmc-halton")
LAB_INTEGRANDS = ("exp", "sin", "glossy-light")
#: the quick demo's integrands: a smooth 1D one and the 2D MIS toy
QUICK_INTEGRANDS = ("exp", "glossy-light")


def lab_sizes(quick: bool) -> tuple[tuple[int, ...], int]:
    """(sample counts, repetitions) of the lab section."""
    return ((64, 256, 1024), 12) if quick else ((64, 256, 1024, 4096, 16384), 40)


def lab_section(out: Path, seed: int, quick: bool, painter: _Painter | None = None) -> dict:
    """Estimators on ``exp``, ``sin`` (full demo) and ``glossy-light``: a comparison table at
    the largest n with stderr trust flags (printed and ``lab_table.csv``), ``lab_summary.csv``,
    ``lab_slopes.csv``, per-repetition ``lab_runs.csv``, the convergence plot
    ``convergence.png`` (RMSE vs n with fitted slopes; drawn by ``painter`` if given) and
    ``efficiency.png``."""
    import os

    from . import lab

    out = Path(out)
    ns, reps = lab_sizes(quick)
    # the full sweep in 2 forked workers (the same numbers as 1 process); the quick one in this
    # process, while the painter draws the earlier figures on the other core
    workers = 1 if quick else max(1, min(2, os.cpu_count() or 1))
    t0 = time.perf_counter()
    estimators, integrands = (QUICK_ESTIMATORS, QUICK_INTEGRANDS) if quick else (LAB_ESTIMATORS, LAB_INTEGRANDS)
    df = lab.run(estimators, integrands, ns, reps, rng=seed, skip=True, workers=workers, progress=True)
    summary = lab.summarize(df)
    slopes = lab.fit_slopes(summary)
    eq = lab.equal_time(summary)
    flagged = summary.assign(flag=stderr_flags(summary))        # every (estimator, integrand, n)
    df.to_csv(out / "lab_runs.csv", index=False)
    flagged.to_csv(out / "lab_summary.csv", index=False)
    slopes.to_csv(out / "lab_slopes.csv", index=False)

    def convergence():
        ref = lab.plots.reference_estimator(summary["estimator"])
        lab.convergence_plot(summary, out / "convergence.png",
                             title=f"vrlab lab: RMSE vs n over {reps} repetitions, log-log; {ref} (black) in "
                                   "every panel; legend: estimator, fitted slope (theory)")

    if painter is not None:
        painter.draw("convergence.png", convergence)     # meanwhile: the table, efficiency.png, the render
    else:
        convergence()
    top = summary[summary["n"] == max(ns)].merge(eq[["integrand", "n", "estimator", "efficiency_gain"]],
                                                  on=["integrand", "n", "estimator"])
    table = top.merge(slopes[["estimator", "integrand", "slope", "theory"]], on=["estimator", "integrand"])
    worst = flagged.groupby(["estimator", "integrand"], sort=False)["flag"].agg(_worst).reset_index()
    table = table.merge(worst, on=["estimator", "integrand"])      # flagged at any n of the sweep
    table = table[["integrand", "estimator", "flag", "rmse", "bias", "z_std", "coverage", "efficiency_gain",
                   "slope", "theory", "reps"]]
    table.to_csv(out / "lab_table.csv", index=False)
    with pd.option_context("display.width", 160, "display.max_columns", 20, "display.max_rows", 200):
        print(table.drop(columns="reps").to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    for line in _flag_notes(flagged[flagged["flag"] != ""], trust_thresholds(reps, 2 * len(flagged)), reps):
        print(line)
    for line in theory_notes(slopes):
        print(line)
    skipped = df.attrs.get("skipped", [])
    missing = sorted({s["estimator"] for s in skipped if "not available" in s["reason"]})
    if missing:
        print("not run (estimator module not installed): " + ", ".join(missing))
    lab.efficiency_plot(summary, out / "efficiency.png")
    return {"lab_seconds": time.perf_counter() - t0, "lab_rows": len(df), "lab_skipped": len(skipped),
            "lab_flagged": {m: int((table["flag"] == m).sum()) for m in ("!", "~")}}


def theory_notes(slopes: pd.DataFrame) -> list[str]:
    """One line per theoretical slope of ``slopes`` (:func:`vrlab.lab.fit_slopes`): the rate,
    its source (``theory_note``) and the estimator x integrand rows it applies to."""
    lines = ["theory: the slope theory gives, by estimator and integrand (vrlab.lab.theoretical_slope)"]
    for (theory, note), g in slopes.groupby(["theory", "theory_note"], sort=False):
        rows = [f"{est} on {', '.join(gi['integrand'])}" for est, gi in g.groupby("estimator", sort=False)]
        lines.append(f"  {theory:+.3g}: {note}: {'; '.join(rows)}")
    return lines


def render_section(out: Path, seed: int, quick: bool) -> pd.DataFrame:
    """The Veach figure: BSDF sampling | light sampling | MIS on the glossy plates scene.
    The reference (an MIS render at more spp, its own seed) is rendered first, with progress."""
    
    from .render import builtin_scene_path, load_scene, render
    from .render.compare import compare, compare_figure

    scene = load_scene(builtin_scene_path("veach_mis"))
    w, h = (64, 48) if quick else (128, 96)
    scene = scene.with_size(w, h)
    ref_spp = 32 if quick else 128
    bar = _bar(w * h, f"reference, {ref_spp} spp")
    reference = render(scene, ref_spp, "mis-power", rng=np.random.SeedSequence([seed, 1]),
                       progress=lambda done, total: bar.update(max(0, done - bar.done))).value
    bar.close()
    res = compare(scene, spp=8 if quick else 16, rng=seed, reference=reference)
    # one exposure for the three panels, auto from the reference; compare_figure's title states it once
    compare_figure(res, out / "veach_mis.png", exposure="auto",
                   title=f"Veach's glossy plates, {res['spp']} spp per pixel: BSDF sampling | light sampling | "
                         f"MIS (power)\nrelMSE against a {ref_spp}-spp reference, which sets the exposure")
    df = pd.DataFrame({"strategy": list(res["rel_mse"]), "rel_mse": list(res["rel_mse"].values()),
                       "seconds": list(res["seconds"].values())})
    df.to_csv(out / "veach_mis.csv", index=False)
    return df


def _header(text: str) -> None:
    print("\n" + text, flush=True)


def _table(df: pd.DataFrame, digits: int = 4, index: bool = False) -> str:
    with pd.option_context("display.width", 160, "display.max_columns", 20):
        return df.to_string(index=index, float_format=lambda v: f"{v:.{digits}g}")


def run_demo(out: str | Path = "vrlab-demo", seed: int = 2026, quick: bool = False) -> dict:
    """Run the showcase and write its figures and tables into ``out``; returns a summary with
    the seconds of each section (``sections``, figures drawn in the background counted in
    ``"figures (waiting)"``) and in all (``seconds``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401  (imported once here, inherited by the forked painters)

    from . import checks

    if not isinstance(out, (str, Path)) or not str(out):
        raise TypeError(f"out must be a folder path, got {out!r}")
    seed, quick = checks.integer(seed, "seed", low=0), checks.flag(quick, "quick")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"out: {out} exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    sections: dict[str, float] = {}
    painter = _Painter()
    print(f"vrlab demo{' --quick' if quick else ''}: writing into {out.resolve()}", flush=True)

    t = time.perf_counter()
    _header("Warps: chi-square goodness of fit of samples against the pdf (warps.png)")
    bar = _bar(len(showcase()), "warps")
    gof, panels = warp_table(seed, 20_000 if quick else 200_000, progress=bar.update)
    gof.to_csv(out / "warps_gof.csv", index=False)
    painter.draw("warps.png", draw_warps, out / "warps.png", panels)
    print(_table(gof))
    sections["warps"] = time.perf_counter() - t

    t = time.perf_counter()
    _header("Point sets: CD = centred L2 discrepancy in d = 2, lower is more uniform (point_sets.png); "
            "CD is the square root of SciPy's qmc.discrepancy(method='CD'), which is CD^2")
    painter.draw("point_sets.png", draw_point_sets, out / "point_sets.png", seed)
    disc = discrepancy_table(seed, (64, 256, 1024) if quick else (64, 256, 1024, 4096))
    disc.to_csv(out / "discrepancy.csv")
    print(_table(disc, 3, index=True))
    sections["point sets"] = time.perf_counter() - t

    t = time.perf_counter()
    _header("Speed: vrlab vs NumPy/SciPy at quick sizes, best of a few runs (`vrlab bench sampling`: full sizes)")
    speed = speed_tables(out, quick)
    print("QMC point generation (speedup = peer seconds / vrlab seconds):\n" + _table(speed["qmc"]))
    if "discrete" in speed:
        print("\nDiscrete sampling (ratio_vs_vrlab = seconds / vrlab AliasTable seconds):\n"
              + _table(speed["discrete"]))
    else:
        print("(discrete sampling races: in the full demo, or `vrlab bench discrete`)")
    sections["speed"] = time.perf_counter() - t

    t = time.perf_counter()
    ns, reps = lab_sizes(quick)
    _header(f"Lab: estimators at n = {max(ns)} over {reps} repetitions (efficiency relative to mc at equal "
            "time; slope of RMSE vs n; flag: stderr not to be trusted at some n, see below; "
            "convergence.png, efficiency.png)")
    lab_info = lab_section(out, seed, quick, painter)
    sections["lab"] = time.perf_counter() - t

    t = time.perf_counter()
    _header("Renderer: Veach's glossy plates at equal spp, relMSE against a higher-spp MIS render "
            "(veach_mis.png)")
    print(_table(render_section(out, seed, quick)))
    sections["render"] = time.perf_counter() - t

    t = time.perf_counter()
    painter.wait()
    sections["figures (waiting)"] = time.perf_counter() - t
    files = sorted(p.name for p in out.iterdir())
    seconds = time.perf_counter() - t0
    print(f"\nwrote {', '.join(files)} in {seconds:.1f} s")
    return {"out": str(out.resolve()), "files": files, "seconds": seconds, "sections": sections, **lab_info}
