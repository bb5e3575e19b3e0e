"""Gradient-domain rendering: CRN differences of neighbouring pixels, then a screened Poisson solve.

Questions answered (tables in ``gradient_domain_*.csv``, figures ``*.png``):

* the lecture's formula Var[a - b] = Var a + Var b - 2 Cov(a, b) per pixel, for
  a = I(x + 1; u) and b = I(x; u) on a small diffuse Cornell box: the per-sample
  variance of the renderer's gradient (``render_gradient_domain(...).dx.stderr^2 * spp``)
  against the right-hand side computed from independent samples of
  ``PixelIntegrand.values``; with ``common=False`` (independent uniforms) against
  Var a + Var b (``gradient_domain_variance.csv``);
* "CRN numbers" in an image: all pixels share ONE set of uniforms, against independent
  uniforms per pixel.  Each pixel has the same distribution either way (the same expected
  error), but with shared numbers the errors of neighbours are strongly correlated, so
  the image looks smooth and its finite differences are accurate;
* the estimated gradients |dx|, |dy| next to the primal image;
* relMSE against a reference (Mitsuba 3 at 64x48 and 16384 spp where stored, a
  high-spp vrlab render for box_ellipsoid) of the primal image, the L2 and the L1
  reconstruction (alpha = 0.2) on every built-in scene, at equal spp and at equal render
  time: the plain render gets spp x (seconds of a gradient render / seconds of a plain
  render of the same spp, each the fastest of ``reps`` interleaved renders), mean over seeds (``gradient_domain_relmse.csv``); a
  render of m x spp is the average of m independent spp-renders (exactly the same
  estimator);
* an alpha sweep of L2 and L1 and the relMSE per region (bright pixels, edges and the
  pixels next to bright ones, smooth rest): where gradient-domain rendering loses;
* the solve time of ``screened_poisson`` at 1024 x 1024 x 3 (best of 3).

Run ``python -m vrlab.experiments.gradient_domain [--full] [--out DIR]``.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from vrlab.lab.experiment import experiment_cli, output_dir, save_figure
from vrlab.render import (PixelIntegrand, builtin_scene_path, list_builtin_scenes, list_mitsuba_references,
                          load_scene, mitsuba_reference, render, render_gradient_domain, screened_poisson)
from vrlab.metrics import rel_mse, relative_squared_error

from . import _gradient_domain_figures as figs

DEFAULT_OUT = Path("vrlab-out") / "gradient_domain"          # relative to the working folder
WIDTH, HEIGHT = 64, 48                      # the stored references' resolution
ALPHA = 0.2                                 # screened_poisson's default
ALPHAS = (0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0)
SWEEP_SCENES = ("cornell_box", "veach_mis", "many_lights")
METHODS = {"primal": "primal (= plain, equal spp)", "plain_equal_time": "plain, equal time",
           "l2": f"L2 (α = {ALPHA:g})", "l1": f"L1 (α = {ALPHA:g})"}


def sized(name: str, width: int = WIDTH, height: int = HEIGHT):
    """Built-in scene ``name`` with its sensor set to ``width`` x ``height``."""
    scene = load_scene(builtin_scene_path(name))
    return scene.with_size(width, height)


def reference(name: str, scene, spp: int, seed: int) -> tuple[np.ndarray, np.ndarray, str]:
    """(image, stderr, source): the stored Mitsuba 3 reference, else a vrlab render of ``spp``."""
    if name in list_mitsuba_references() and scene.sensor.width == 64 and scene.sensor.height == 48:
        mean, stderr = mitsuba_reference(name)
        return mean.astype(float), stderr.astype(float), "Mitsuba 3, 16384 spp"
    est = render(scene, spp, rng=[seed, 999], workers=2)
    return est.value.astype(float), est.stderr.astype(float), f"vrlab mis-power, {spp} spp"


def rel_se(img: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Per-pixel relative squared error (mean over RGB); its mean is ``rel_mse``."""
    return rel_mse(img, ref, axis=-1)


def all_pixels(h: int, w: int) -> np.ndarray:
    rows, cols = np.mgrid[0:h, 0:w]
    return np.stack([rows.ravel(), cols.ravel()], -1)


# --------------------------------------------------------------------------- 1. the variance formula
def variance_check(res: int, spp: int, seed: int = 11) -> tuple[pd.DataFrame, dict]:
    """Per pixel (summed over RGB): the renderer's Var[a - b] against the formula on other samples.

    The test statistic: d_i = measured_i - formula_i has mean 0 in every pixel and the pixels
    are independent, so z = sum d_i / sqrt(sum d_i^2) is about N(0, 1) (a self-normalised sum);
    the ratio sum measured / sum formula has standard error sqrt(sum d_i^2) / sum formula."""
    scene = load_scene(builtin_scene_path("cornell_box"), {"res": res})
    pix = PixelIntegrand(scene)
    pixels = all_pixels(res, res - 1)                    # every pixel with a right neighbour
    u = np.random.default_rng([seed, 2]).random((len(pixels), spp, pix.dim))
    a = pix.values(pixels + [0, 1], u).astype(float)      # a = I(x + 1; u), b = I(x; u): (P, S, 3)
    b = pix.values(pixels, u).astype(float)
    var_a, var_b = a.var(1, ddof=1), b.var(1, ddof=1)
    cov = ((a - a.mean(1, keepdims=True)) * (b - b.mean(1, keepdims=True))).sum(1) / (spp - 1)
    parts = {"var_a": var_a.sum(-1), "var_b": var_b.sum(-1), "cov": cov.sum(-1)}
    formula = {True: parts["var_a"] + parts["var_b"] - 2 * parts["cov"], False: parts["var_a"] + parts["var_b"]}
    rows, maps = [], {"formula": formula, "measured": {}, "shape": (res, res - 1), **parts}
    for common in (True, False):
        g = render_gradient_domain(scene, spp, rng=[seed, int(common)], common=common)
        m = (g.dx.stderr.astype(float) ** 2 * spp).sum(-1).ravel()
        maps["measured"][common] = m
        f, d = formula[common], m - formula[common]
        rows.append({"numbers": "common" if common else "independent", "pixels": len(m), "spp": spp,
                     "mean_var_a": parts["var_a"].mean(), "mean_var_b": parts["var_b"].mean(),
                     "mean_cov": parts["cov"].mean() if common else 0.0,
                     "formula": f.mean(), "measured": m.mean(), "ratio": m.sum() / f.sum(),
                     "ratio_se": np.sqrt(np.sum(d * d)) / f.sum(), "z": d.sum() / np.sqrt(np.sum(d * d))})
    table = pd.DataFrame(rows)
    table["gain_vs_independent"] = table["measured"].iloc[1] / table["measured"]
    return table, maps


# --------------------------------------------------------------------------- 2. CRN numbers in an image
def crn_images(spp: int, reps: int, seed: int = 21) -> tuple[pd.DataFrame, dict]:
    """Cornell box at 64x48: every pixel with the same uniforms, or each pixel its own."""
    scene = sized("cornell_box")
    ref = mitsuba_reference("cornell_box")[0].astype(float)
    pix = PixelIntegrand(scene)
    pixels = all_pixels(HEIGHT, WIDTH)
    lum_ref = ref.mean(-1)
    rows, first = [], {}
    for r in range(reps):
        gen = np.random.default_rng([seed, r])
        draws = {"shared": np.broadcast_to(gen.random((1, spp, pix.dim)), (len(pixels), spp, pix.dim)),
                 "independent": gen.random((len(pixels), spp, pix.dim))}
        for label, u in draws.items():
            img = pix.values(pixels, np.ascontiguousarray(u)).astype(float).mean(1).reshape(HEIGHT, WIDTH, 3)
            err = img.mean(-1) - lum_ref
            rows.append({"numbers": label, "spp": spp, "rep": r, "relmse": rel_mse(img, ref),
                         "neighbour_error_corr": np.corrcoef(err[:, :-1].ravel(), err[:, 1:].ravel())[0, 1],
                         "dx_rmse": np.sqrt(np.mean((np.diff(img, axis=1) - np.diff(ref, axis=1)) ** 2))})
            first.setdefault(label, img)
    table = pd.DataFrame(rows).groupby(["numbers", "spp"], as_index=False).agg(
        relmse=("relmse", "mean"), relmse_sd=("relmse", "std"), neighbour_error_corr=("neighbour_error_corr", "mean"),
        dx_rmse=("dx_rmse", "mean"), reps=("rep", "count"))
    return table, {**first, "reference": ref}


# --------------------------------------------------------------------------- 4. relMSE on every scene
def relmse_study(names: list[str], spp: int, reps: int, groups: tuple[int, ...], ref_spp: int,
                 seed: int = 31) -> tuple[pd.DataFrame, pd.DataFrame, dict]:
    """Per (scene, spp level, rep) relMSE; a level m x spp averages m of the ``reps`` renders."""
    rows, info, kept = [], [], {}
    for i, name in enumerate(names):
        scene = sized(name)
        ref, ref_se, source = reference(name, scene, ref_spp, seed)
        grads, t_plains = [], []
        for k in range(reps):            # interleaved, so that both see the same machine load
            grads.append(render_gradient_domain(scene, spp, rng=[seed, i, k]))
            t_plains.append(render(scene, spp, rng=[seed, i, 100 + k]).seconds)
        t_grad, t_plain = min(g.primal.seconds for g in grads), min(t_plains)
        spp_eq = max(1, int(round(spp * t_grad / t_plain)))
        plains = [render(scene, spp_eq, rng=[seed, i, 200 + k]) for k in range(reps)]
        info.append({"scene": name, "reference": source, "ref_noise_relmse": float(np.mean(relative_squared_error(ref_se**2, ref))),
                     "seconds_gradient": t_grad, "seconds_plain": t_plain, "time_ratio": t_grad / t_plain,
                     "seconds_plain_equal_time": min(p.seconds for p in plains)})
        for m in groups:
            maps = []
            for r in range(reps // m):
                part = slice(r * m, (r + 1) * m)
                p, dx, dy = (np.mean([getattr(g, k).value for g in grads[part]], 0).astype(float)
                             for k in ("primal", "dx", "dy"))
                imgs = {"primal": p, "plain_equal_time": np.mean([q.value for q in plains[part]], 0).astype(float)}
                row = {"scene": name, "spp": m * spp, "spp_equal_time": m * spp_eq, "rep": r}
                for norm in ("l2", "l1"):
                    t0 = time.perf_counter()
                    imgs[norm] = screened_poisson(p, dx, dy, alpha=ALPHA, norm=norm)
                    row[f"seconds_{norm}"] = time.perf_counter() - t0
                row.update({f"relmse_{k}": rel_mse(v, ref) for k, v in imgs.items()})
                rows.append(row)
                maps.append({k: rel_se(v, ref) for k, v in imgs.items()})
                if m == groups[-1]:
                    kept.setdefault(name, []).append({"images": imgs, "dx": dx, "dy": dy, "ref": ref})
            if m == groups[-1]:
                kept[name + "/maps"] = {k: np.mean([mp[k] for mp in maps], 0) for k in maps[0]}
    per_rep = pd.DataFrame(rows)
    cols = [f"relmse_{k}" for k in METHODS] + ["seconds_l2", "seconds_l1"]
    g = per_rep.groupby(["scene", "spp", "spp_equal_time"], sort=False)
    summary = g[cols].mean().join(g[[f"relmse_{k}" for k in METHODS]].sem().add_suffix("_se")).join(
        g.size().rename("reps")).reset_index()
    summary = summary.merge(pd.DataFrame(info), on="scene")
    for k in ("plain_equal_time", "l2", "l1"):
        summary[f"gain_{k}_vs_equal_time"] = summary["relmse_plain_equal_time"] / summary[f"relmse_{k}"]
    return summary, per_rep, kept


# --------------------------------------------------------------------------- 5. where it loses
def regions(ref: np.ndarray) -> dict[str, np.ndarray]:
    """Masks from the reference luminance L: bright (L > 1), edge (not bright, a neighbour
    differs by more than 30% of the larger value + 0.05, or within 2 pixels of a bright one),
    smooth (the rest)."""
    lum = ref.mean(-1)
    bright = lum > 1.0
    contrast = np.zeros_like(lum)
    for axis in (0, 1):
        d = np.abs(np.diff(lum, axis=axis)) / (np.maximum(lum[:-1] if axis == 0 else lum[:, :-1],
                                                         lum[1:] if axis == 0 else lum[:, 1:]) + 0.05)
        pad = [(0, 0), (0, 0)]
        for side in ((0, 1), (1, 0)):
            pad[axis] = side
            contrast = np.maximum(contrast, np.pad(d, pad))
    near = bright.copy()
    for _ in range(2):                            # dilate by one pixel (8-neighbourhood), twice
        p = np.pad(near, 1)
        near = np.any([p[1 + dy:1 + dy + lum.shape[0], 1 + dx:1 + dx + lum.shape[1]]
                       for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0)
    edge = ~bright & ((contrast > 0.3) | near)
    return {"bright": bright, "edge": edge, "smooth": ~bright & ~edge}


def region_table(kept: dict, names: list[str]) -> pd.DataFrame:
    rows = []
    for name in names:
        maps, masks = kept[name + "/maps"], regions(kept[name][0]["ref"])
        total = {k: v.sum() for k, v in maps.items()}
        for region, mask in masks.items():
            row = {"scene": name, "region": region, "pixels": int(mask.sum())}
            for k in METHODS:
                row[f"relmse_{k}"] = float(maps[k][mask].mean()) if mask.any() else np.nan
                row[f"share_{k}"] = float(maps[k][mask].sum() / total[k])
            rows.append(row)
    return pd.DataFrame(rows)


def alpha_sweep(kept: dict, names: tuple[str, ...], alphas: tuple[float, ...], reps: int) -> pd.DataFrame:
    rows = []
    for name in names:
        for r, k in enumerate(kept[name][:reps]):
            p, dx, dy, ref = k["images"]["primal"], k["dx"], k["dy"], k["ref"]
            for a in alphas:
                row = {"scene": name, "alpha": a, "rep": r, "relmse_primal": rel_mse(p, ref),
                       "relmse_plain_equal_time": rel_mse(k["images"]["plain_equal_time"], ref)}
                for norm in ("l2", "l1"):
                    row[f"relmse_{norm}"] = rel_mse(screened_poisson(p, dx, dy, alpha=a, norm=norm), ref)
                rows.append(row)
    return pd.DataFrame(rows).groupby(["scene", "alpha"], as_index=False, sort=False).mean().drop(columns="rep")


# --------------------------------------------------------------------------- 6. solve time
def tiled_input(primal: np.ndarray, dx: np.ndarray, dy: np.ndarray, n: int):
    """An n x n x 3 test input: the small render repeated; across the seams the differences
    are those of the tiled primal."""
    h, w = primal.shape[:2]
    ry, rx = -(-n // h), -(-n // w)
    p = np.tile(primal, (ry, rx, 1))
    gx = np.tile(np.concatenate([dx, primal[:, :1] - primal[:, -1:]], 1), (ry, rx, 1))
    gy = np.tile(np.concatenate([dy, primal[:1] - primal[-1:]], 0), (ry, rx, 1))
    return p[:n, :n], gx[:n, :n - 1], gy[:n - 1, :n]


def solve_times(k: dict, sizes: dict[str, tuple[int, ...]], repeats: int, per_rep: pd.DataFrame) -> pd.DataFrame:
    """Best of ``repeats`` calls on the tiled input of each size; first the 64x48 cornell_box
    solves that the relMSE study timed (best of all of them)."""
    cb = per_rep[per_rep["scene"] == "cornell_box"]
    rows = [{"norm": norm, "size": f"{WIDTH}x{HEIGHT}x3", "pixels": WIDTH * HEIGHT, "alpha": ALPHA,
             "repeats": len(cb), "seconds_best": cb[f"seconds_{norm}"].min(),
             "seconds_all": f"median {cb[f'seconds_{norm}'].median():.3g}"} for norm in ("l2", "l1")]
    for norm, ns in sizes.items():
        for n in ns:
            args = tiled_input(k["images"]["primal"], k["dx"], k["dy"], n)
            times = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                screened_poisson(*args, alpha=ALPHA, norm=norm)
                times.append(time.perf_counter() - t0)
            rows.append({"norm": norm, "size": f"{n}x{n}x3", "pixels": n * n, "alpha": ALPHA, "repeats": repeats,
                         "seconds_best": min(times), "seconds_all": " ".join(f"{t:.3g}" for t in times)})
    return pd.DataFrame(rows)


def gallery_numbers(out: str | Path) -> dict:
    """The gallery caption's numbers, read from ``gradient_domain_relmse.csv`` (lowest and
    highest spp level)."""
    s = pd.read_csv(Path(out) / "gradient_domain_relmse.csv")
    res = {"ratio_min": f"{s['time_ratio'].min():.1f}", "ratio_max": f"{s['time_ratio'].max():.1f}",
           "scenes": s["scene"].nunique(), "size": f"{WIDTH}×{HEIGHT}", "alpha": f"{ALPHA:g}"}
    for tag, spp in (("lo", s["spp"].min()), ("hi", s["spp"].max())):
        top = s[s["spp"] == spp].set_index("scene")
        res.update({f"spp_{tag}": int(spp), f"reps_{tag}": int(top["reps"].min())})
        for k in ("l1", "l2"):
            gain = top[f"gain_{k}_vs_equal_time"]
            res[f"{k}_wins_{tag}"] = ", ".join(gain.index[gain > 1]) or "no scene"
            res[f"{k}_loses_{tag}"] = ", ".join(gain.index[gain <= 1]) or "no scene"
            res[f"{k}_worst_{tag}"] = gain.idxmin()
            res[f"{k}_worst_factor_{tag}"] = f"{1 / gain.min():.0f}" if gain.min() < 0.1 else f"{1 / gain.min():.1f}"
    return res


def main(out: str | Path = DEFAULT_OUT, full: bool = False) -> dict:
    """Run every experiment, write CSV + PNG into ``out``, return the key numbers."""
    out = output_dir(out)
    var_t, var_maps = variance_check(32 if full else 24, 1024 if full else 128)
    var_t.to_csv(out / "gradient_domain_variance.csv", index=False)
    save_figure(figs.variance_figure(var_maps), out / "gradient_domain_variance.png")
    crn_spp = 4
    crn_t, crn_imgs = crn_images(crn_spp, 32 if full else 6)
    crn_t.to_csv(out / "gradient_domain_crn_image.csv", index=False)
    save_figure(figs.crn_figure(crn_imgs, crn_spp), out / "gradient_domain_crn_image.png")

    names = list_builtin_scenes()
    spp, reps, groups = (8, 48, (1, 4, 16)) if full else (4, 6, (1, 3))
    summary, per_rep, kept = relmse_study(names, spp, reps, groups, ref_spp=4096 if full else 256)
    summary.to_csv(out / "gradient_domain_relmse.csv", index=False)
    per_rep.to_csv(out / "gradient_domain_relmse_seeds.csv", index=False)
    save_figure(figs.relmse_figure(summary, METHODS, (WIDTH, HEIGHT)), out / "gradient_domain_relmse.png")
    save_figure(figs.gradients_figure(kept, ("cornell_box", "veach_mis"), ALPHA), out / "gradient_domain_gradients.png")

    sweep = alpha_sweep(kept, SWEEP_SCENES, ALPHAS, reps=4 if full else 1)
    sweep.to_csv(out / "gradient_domain_alpha.csv", index=False)
    save_figure(figs.alpha_figure(sweep), out / "gradient_domain_alpha.png")
    reg = region_table(kept, names)
    reg.to_csv(out / "gradient_domain_regions.csv", index=False)
    save_figure(figs.losses_figure(kept, SWEEP_SCENES), out / "gradient_domain_where_it_loses.png")

    # L1 at 1024^2 takes minutes per call (see BENCHMARKS.md), so only in the full run
    sizes = {"l2": (1024,), "l1": (1024,)} if full else {"l2": (1024,)}
    solve = solve_times(kept["cornell_box"][0], sizes, 3, per_rep)
    solve.to_csv(out / "gradient_domain_solve_times.csv", index=False)

    v = var_t.set_index("numbers")
    c = crn_t.set_index("numbers")
    lo, hi = summary["spp"].min(), summary["spp"].max()
    by_spp = summary.set_index(["scene", "spp"])
    return {
        "variance": var_t, "crn_image": crn_t, "relmse": summary, "alpha": sweep, "regions": reg, "solve": solve,
        "var_ratio_common": float(v.loc["common", "ratio"]), "var_ratio_common_se": float(v.loc["common", "ratio_se"]),
        "var_z_common": float(v.loc["common", "z"]), "var_z_independent": float(v.loc["independent", "z"]),
        "var_ratio_independent": float(v.loc["independent", "ratio"]),
        "crn_variance_gain": float(v.loc["common", "gain_vs_independent"]),
        "crn_neighbour_corr": float(c.loc["shared", "neighbour_error_corr"]),
        "independent_neighbour_corr": float(c.loc["independent", "neighbour_error_corr"]),
        # relMSE of L2 above the reference's own noise floor, highest spp over lowest (theory: lo / hi)
        "l2_decrease": {n: float((by_spp.loc[(n, hi), "relmse_l2"] - by_spp.loc[(n, hi), "ref_noise_relmse"])
                                 / (by_spp.loc[(n, lo), "relmse_l2"] - by_spp.loc[(n, lo), "ref_noise_relmse"]))
                        for n in names},
        "l1_gain_equal_time": {n: float(by_spp.loc[(n, hi), "gain_l1_vs_equal_time"]) for n in names},
        "l2_gain_equal_time": {n: float(by_spp.loc[(n, hi), "gain_l2_vs_equal_time"]) for n in names},
        "solve_l2_1024": float(solve.query("norm == 'l2' and pixels == 1024**2")["seconds_best"].iloc[0]),
        "files": sorted(p.name for p in out.iterdir()),
    }


if __name__ == "__main__":
    experiment_cli(main, DEFAULT_OUT, __doc__)
