"""Sampling patterns: where the uniforms go, how uniform they are, and what that buys.

Questions answered (tables in ``sampling_patterns_*.csv``, figures ``*.png``):

* 64 points from independent, jittered (stratified), Latin hypercube, Halton, Hammersley
  and Sobol sets, side by side;
* why a Hammersley set needs its size n in advance: its first coordinate is i/n, so the
  first quarter of a 256-point set covers only x < 1/4 (a prefix is not a good set),
  while a Halton prefix is fine;
* centred L2 discrepancy against n for every pattern;
* convergence slopes on smooth integrands (``lab.fit_slopes``): Monte Carlo -1/2,
  jittered -1/2 - 1/d (-1.5 in 1D, -1 in 2D), LHS, scrambled Halton/Sobol;
* the student report's experiment -- 4 sub-pixel strata against random sub-pixel
  positions at 5 and 1000 samples per pixel -- first on a pixel-footprint integrand with
  an edge (exact answer known), then in a small Cornell-box render (the script draws the
  strata itself, so both variants use the very same uniforms, and feeds them to
  ``vrlab.render.PixelIntegrand(scene, "light").values``);
* the renderer's pixel point sets, ``render(..., points=...)`` with None (i.i.d.),
  ``"stratified"`` (padded jittered strata over all of a pixel sample's uniforms),
  ``"sobol"`` and ``"halton"`` (a shared scrambled set, Cranley-Patterson shifted per
  pixel): per-pixel variance over independent renders, on edge pixels and the rest;
* the report's importance-sampling experiments at 10 and 1000 spp (fast mode: 10 and
  100): cos-weighted against uniform hemisphere sampling on the diffuse Cornell box, and
  Phong-BRDF sampling against uniform on the Phong floor of ``box_ellipsoid``; the
  unbiasedness argument E[f/p] = int f is checked numerically by a pooled z-test of each
  image against an independent MIS reference.

Run ``python -m vrlab.experiments.sampling_patterns [--full] [--out DIR]``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from vrlab import lab
from vrlab import points as P
from vrlab._rng import spawn
from vrlab.estimators import MonteCarlo
from vrlab.render import PixelIntegrand, builtin_scene_path, load_scene, render
from vrlab.render.image import rel_mse
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure

from . import _sampling_patterns_figures as figs

DEFAULT_OUT = Path("vrlab-out") / "sampling_patterns"          # relative to the working folder


def patterns(seed: int = 0) -> dict:
    """Fresh 2D engines, by name."""
    return {
        "independent": lambda: P.Independent(2, rng=seed),
        "jittered": lambda: P.Stratified(2, rng=seed),
        "Latin hypercube": lambda: P.LatinHypercube(2, rng=seed),
        "Halton": lambda: P.Halton(2),
        "Hammersley": lambda: P.Hammersley(2),
        "Sobol (scrambled)": lambda: P.Sobol(2, scramble=True, rng=seed),
    }


def pattern_points(n: int = 64) -> dict:
    """Panel title -> (pattern, points): ``n`` points of every pattern, then the first ``n``
    of a 4n-point Hammersley set and of the Halton sequence."""
    out = {f"{name}, n = {n}": (name, make().random(n)) for name, make in patterns().items()}
    out[f"first {n} of a {4 * n}-point Hammersley set"] = ("Hammersley prefix (n of 4n)",
                                                          P.Hammersley(2, n=4 * n).random(n))
    out[f"first {n} of the Halton sequence"] = ("Halton", P.Halton(2).random(n))
    return out


def discrepancy_table(ns: list[int], reps: int = 4) -> pd.DataFrame:
    """Centred L2 discrepancy per pattern and n (randomised patterns: mean over ``reps`` seeds)."""
    randomised = ("independent", "jittered", "Latin hypercube", "Sobol (scrambled)")
    rows = []
    for name in patterns():
        for n in ns:
            seeds = range(reps) if name in randomised else [0]
            vals = [P.discrepancy(patterns(seed=r)[name]().random(n)) for r in seeds]
            rows.append({"pattern": name, "n": n, "discrepancy": float(np.mean(vals))})
    for n in ns:   # a prefix: the first n rows of a 4n-point Hammersley set
        rows.append({"pattern": "Hammersley prefix (n of 4n)", "n": n,
                     "discrepancy": P.discrepancy(P.Hammersley(2, n=4 * n).random(n))})
    return pd.DataFrame(rows)


def convergence(ns: list[int], reps: int):
    est = MonteCarlo(probe=False)
    df1 = lab.run([("MC", est, P.Independent), ("jittered", est, P.Stratified), ("LHS", est, P.LatinHypercube)],
                  ["exp", "smooth-2d"], ns, reps, rng=1)
    df2 = lab.run([("Halton (scrambled)", est, P.Halton(2, scramble=True)),
                   ("Sobol (scrambled)", est, P.Sobol(2, scramble=True))], ["smooth-2d"], ns, reps, rng=2)
    summary = lab.summarize(pd.concat([df1, df2], ignore_index=True))
    return summary, lab.fit_slopes(summary)


# --------------------------------------------------------------------------- pixel strata
def subpixel_uniforms(u: np.ndarray, stratified: bool) -> np.ndarray:
    """Sample k of a pixel goes to quadrant k mod 4 (2 x 2 strata), jittered inside it."""
    if not stratified:
        return u
    u = u.copy()
    s = np.arange(u.shape[-2]) % 4
    u[..., 0] = (s % 2 + u[..., 0]) / 2
    u[..., 1] = (s // 2 + u[..., 1]) / 2
    return u


def pixel_estimate(values: np.ndarray, stratified: bool) -> np.ndarray:
    """Per-pixel estimate from values ``(..., spp)``: the plain mean, or with strata the mean of
    the four stratum means (unbiased also when spp is not a multiple of 4, e.g. 5 = 2+1+1+1)."""
    if not stratified:
        return values.mean(-1)
    s = np.arange(values.shape[-1]) % 4
    return np.mean([values[..., s == k].mean(-1) for k in range(4)], axis=0)


def edge(x: np.ndarray) -> np.ndarray:
    """A pixel footprint half covered by a bright object: 1 below the line y = 0.3 + 0.55 x."""
    return (x[..., 1] < 0.3 + 0.55 * x[..., 0]).astype(float)


EDGE_EXACT = 0.3 + 0.55 / 2


def edge_theory(spp: int, stratified: bool) -> float:
    """Var of the pixel estimate: p(1-p)/n, or sum over quadrants (1/16) p_k(1 - p_k)/n_k."""
    if not stratified:
        return EDGE_EXACT * (1 - EDGE_EXACT) / spp
    g = (np.arange(2000) + 0.5) / 2000
    counts = np.bincount(np.arange(spp) % 4, minlength=4)
    var = 0.0
    for k in range(4):
        xx, yy = np.meshgrid((k % 2 + g) / 2, (k // 2 + g) / 2)
        pk = edge(np.stack([xx, yy], -1)).mean()
        var += pk * (1 - pk) / counts[k] / 16
    return var


def edge_table(spps: list[int], reps: int, seed: int = 4) -> pd.DataFrame:
    rows = []
    for spp in spps:
        for stratified in (False, True):
            gen = np.random.default_rng([seed, spp, stratified])
            u = subpixel_uniforms(gen.random((reps, spp, 2)), stratified)
            est = pixel_estimate(edge(u), stratified)
            rows.append({"spp": spp, "sub-pixel": "4 strata" if stratified else "random", "reps": reps,
                         "mean": est.mean(), "exact": EDGE_EXACT, "var_measured": est.var(ddof=1),
                         "var_se": est.var(ddof=1) * np.sqrt(2 / (reps - 1)),
                         "var_theory": edge_theory(spp, stratified)})
    t = pd.DataFrame(rows)
    base = t[t["sub-pixel"] == "random"].set_index("spp")["var_measured"]
    t["var_vs_random"] = t["var_measured"] / t["spp"].map(base)
    return t


def small_box(size):
    """The built-in Cornell box at ``size`` = (width, height) pixels."""
    scene = load_scene(builtin_scene_path("cornell_box"))
    return scene.with_size(size[0], size[1])


def edge_pixels(integ: PixelIntegrand) -> np.ndarray:
    """Flat (H*W,) mask: rays near the four corners of the pixel hit more than one shape."""
    cam, h, w = integ.lighting.camera, integ.lighting.camera.height, integ.lighting.camera.width
    pix = np.stack(np.divmod(np.arange(h * w), w), -1)
    corners = np.array([[0.02, 0.02], [0.98, 0.02], [0.02, 0.98], [0.98, 0.98]])
    o, d = cam.pixel_rays(pix[:, None, :], np.broadcast_to(corners, (h * w, 4, 2)))
    ids = integ.lighting.geometry.intersect(o.reshape(-1, 3), d.reshape(-1, 3)).shape.reshape(h * w, 4)
    return (ids != ids[:, :1]).any(-1)


def render_strata(size, spps: list[int], reps: int, strategy: str = "light", seed: int = 5):
    """Per-pixel variance across ``reps`` independent renders, random vs 4 sub-pixel strata,
    split into edge pixels (the pixel footprint sees more than one surface) and the rest.
    Both variants evaluate ``PixelIntegrand(scene, strategy).values`` on the same uniforms
    ``(pixels, spp, integ.dim)``; only the map of the first two (the position in the pixel)
    differs, so the comparison uses common random numbers."""
    scene = small_box(size)
    integ = PixelIntegrand(scene, strategy)
    h, w = size[1], size[0]
    pix = np.stack(np.divmod(np.arange(h * w), w), -1)
    is_edge = edge_pixels(integ)
    rows, images, pixvar = [], {}, {}
    for spp in spps:
        ests = {False: [], True: []}
        for r, g in enumerate(spawn(np.random.SeedSequence([seed, spp]), reps)):
            u0 = g.random((h * w, spp, integ.dim))
            for stratified in (False, True):   # same uniforms, only the sub-pixel map differs
                lum = integ.values(pix, subpixel_uniforms(u0, stratified)).mean(-1)    # (pixels, spp)
                ests[stratified].append(pixel_estimate(lum, stratified))
        for stratified, e in ests.items():
            e = np.array(e)                   # (reps, pixels)
            var = e.var(0, ddof=1)
            images[(spp, stratified)] = e[0].reshape(h, w)
            pixvar[(spp, stratified)] = var
            rows.append({"spp": spp, "sub-pixel": "4 strata" if stratified else "random", "reps": reps,
                         "var_edge_pixels": float(var[is_edge].mean()),
                         "var_other_pixels": float(var[~is_edge].mean()),
                         "edge_pixels": int(is_edge.sum()), "other_pixels": int((~is_edge).sum())})
    t = pd.DataFrame(rows)
    for col in ("var_edge_pixels", "var_other_pixels"):
        base = t[t["sub-pixel"] == "random"].set_index("spp")[col]
        t[col.replace("var_", "ratio_")] = t[col] / t["spp"].map(base)
    # robust to the few pixels near the light that dominate the means: per-pixel ratios, median
    for col, m in (("median_ratio_edge", is_edge), ("median_ratio_other", ~is_edge)):
        t[col] = [float(np.median(pixvar[(r.spp, r["sub-pixel"] == "4 strata")][m]
                                  / np.maximum(pixvar[(r.spp, False)][m], 1e-30))) for _, r in t.iterrows()]
    return t, images, is_edge.reshape(h, w)


POINTS = {"independent": None, "stratified": "stratified", "sobol": "sobol", "halton": "halton"}


def render_points(size, spp: int, reps: int, strategy: str = "light", seed: int = 8) -> pd.DataFrame:
    """The renderer's pixel point sets: ``render(scene, spp, strategy, points=p)`` for p in
    ``POINTS``, ``reps`` independent renders each (their own seeds; for Sobol and Halton a
    new scramble and new shifts each time, i.e. randomised QMC).  The per-pixel variance of
    the grey value across the renders, split into edge pixels and the rest, and the median
    over pixels of its ratio to the i.i.d. variance.  Unlike the 4 sub-pixel strata above,
    these sets spread all ``integ.dim`` uniforms of a pixel's samples, the light sample's too.
    (``render``'s own ``stderr`` assumes i.i.d. samples, so it is not used for them.)"""
    scene = small_box(size)
    is_edge = edge_pixels(PixelIntegrand(scene, strategy))
    pixvar = {}
    for k, (name, points) in enumerate(POINTS.items()):
        imgs = np.array([render(scene, spp, strategy, points=points, rng=np.random.SeedSequence([seed, k, r]),
                                workers=1).value.mean(-1).ravel() for r in range(reps)])
        pixvar[name] = imgs.var(0, ddof=1)
    rows = []
    for name, var in pixvar.items():
        ratio = var / np.maximum(pixvar["independent"], 1e-30)
        rows.append({"points": name, "spp": spp, "reps": reps, "strategy": strategy,
                     "var_edge_pixels": float(var[is_edge].mean()), "var_other_pixels": float(var[~is_edge].mean()),
                     "median_ratio_edge": float(np.median(ratio[is_edge])),
                     "median_ratio_other": float(np.median(ratio[~is_edge]))})
    return pd.DataFrame(rows)


REPORT_IS = {"cornell_box": ("uniform", "cosine"), "box_ellipsoid": ("uniform", "bsdf")}


def report_importance(size, spps: list[int], ref_spp: int, seed: int = 6):
    """The report's cos- and BRDF-weighted importance sampling against uniform hemisphere
    sampling (returns the table, the images and the references): relMSE against an independent ``mis-power`` reference, the per-sample pixel
    variance (green channel, from the standard errors) and the pooled z of the image mean,
    z = (mean(img) - mean(ref)) / sqrt(sum se^2 + sum se_ref^2) / npix (unbiasedness)."""
    rows, images, refs = [], {}, {}
    for name, strategies in REPORT_IS.items():
        scene = load_scene(builtin_scene_path(name))
        scene = scene.with_size(size[0], size[1])
        ref = render(scene, ref_spp, "mis-power", rng=np.random.SeedSequence([seed, 0]), workers=1)
        ref, ref_se = ref.value, ref.stderr
        refs[name] = ref
        for spp in spps:
            for k, strategy in enumerate(strategies):
                est = render(scene, spp, strategy, rng=np.random.SeedSequence([seed, 1 + k, spp]), workers=1)
                img, se = est.value, est.stderr
                g, gs, rg, rs = (np.asarray(a[..., 1], float) for a in (img, se, ref, ref_se))
                z = (g.mean() - rg.mean()) / (np.sqrt(np.sum(gs ** 2) + np.sum(rs ** 2)) / g.size)
                images[(name, strategy, spp)] = img
                rows.append({"scene": name, "strategy": strategy, "spp": spp, "rel_mse": rel_mse(img, ref),
                             "pixel_variance": float(np.mean(gs ** 2) * spp), "pooled_z": float(z)})
    t = pd.DataFrame(rows)
    base = t[t.strategy == "uniform"].set_index(["scene", "spp"])["pixel_variance"]
    t["variance_vs_uniform"] = t.pixel_variance / [base[(r.scene, r.spp)] for r in t.itertuples()]
    return t, images, refs


def gallery_numbers(out: str | Path) -> dict:
    """The gallery caption's numbers, from ``sampling_patterns_slopes.csv``."""
    s = pd.read_csv(Path(out) / "sampling_patterns_slopes.csv").set_index(["estimator", "integrand"])["slope"]
    return {"mc_1d": f"{s[('MC', 'exp')]:.2f}", "jittered_1d": f"{s[('jittered', 'exp')]:.2f}",
            "jittered_2d": f"{s[('jittered', 'smooth-2d')]:.2f}", "sobol_2d": f"{s[('Sobol (scrambled)', 'smooth-2d')]:.2f}",
            "halton_2d": f"{s[('Halton (scrambled)', 'smooth-2d')]:.2f}", "lhs_2d": f"{s[('LHS', 'smooth-2d')]:.2f}"}


def main(out: str | Path = DEFAULT_OUT, full: bool = False) -> dict:
    """Run every experiment, write CSV + PNG into ``out``, return the key numbers."""
    out = output_dir(out)
    save_figure(figs.patterns_figure(pattern_points()), out / "sampling_patterns_points.png")
    disc = discrepancy_table([2**k for k in range(4, 13 if full else 11)])
    disc.to_csv(out / "sampling_patterns_discrepancy.csv", index=False)
    save_figure(figs.discrepancy_figure(disc), out / "sampling_patterns_discrepancy.png")
    summary, slopes = convergence([2**k for k in range(4, 16 if full else 13)], 100 if full else 40)
    summary.to_csv(out / "sampling_patterns_convergence.csv", index=False)
    slopes.to_csv(out / "sampling_patterns_slopes.csv", index=False)
    save_figure(figs.convergence_figure(summary, slopes), out / "sampling_patterns_convergence.png")
    edge_t = edge_table([4, 5, 8, 100, 1000], 20_000 if full else 4000)
    edge_t.to_csv(out / "sampling_patterns_pixel_edge.csv", index=False)
    spps = [5, 1000] if full else [5, 20]
    render_t, images, is_edge = render_strata((32, 24) if full else (24, 18), spps, 16)
    render_t.to_csv(out / "sampling_patterns_pixel_render.csv", index=False)
    save_figure(figs.strata_figure(images, spps, is_edge, render_t), out / "sampling_patterns_pixel_render.png")
    points_t = render_points((32, 24) if full else (24, 18), 64 if full else 16, 16)
    points_t.to_csv(out / "sampling_patterns_pixel_points.csv", index=False)
    report_t, report_images, report_refs = report_importance((48, 36) if full else (24, 18), [10, 1000] if full else [10, 100],
                                                4000 if full else 400)
    report_t.to_csv(out / "sampling_patterns_report_is.csv", index=False)
    save_figure(figs.report_figure(report_images, report_refs, report_t), out / "sampling_patterns_report_is.png")
    s = slopes.set_index(["estimator", "integrand"])
    return {
        "discrepancy": disc, "summary": summary, "slopes": slopes, "edge": edge_t, "render": render_t,
        "points": points_t, "report_is": report_t,
        "slope_mc_1d": float(s.loc[("MC", "exp"), "slope"]),
        "slope_jittered_1d": float(s.loc[("jittered", "exp"), "slope"]),
        "slope_jittered_2d": float(s.loc[("jittered", "smooth-2d"), "slope"]),
        "files": sorted(p.name for p in out.iterdir()),
    }


if __name__ == "__main__":
    experiment_cli(main, DEFAULT_OUT, __doc__)
