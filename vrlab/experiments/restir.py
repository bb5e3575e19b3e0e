"""From RIS to ReSTIR: reservoirs that visit their neighbours, and what the MIS weights of the reuse must do.

ReSTIR (Bitterli et al. 2020, weighted as generalized RIS, Lin et al. 2022;
:class:`vrlab.estimators.ReSTIR`) runs RIS in every pixel, drops the kept sample where it is
occluded (visibility reuse) and lets each pixel resample once more among its own reservoir
and those of k neighbours, with the target re-evaluated (and a shadow ray traced) at the
receiving pixel.  Its unbiased contribution weight is

    W_c = sum_s m_s(y_s) q_c(y_s) W_s J_s / q_c(Y),

and the MIS weights m_s decide whether the result stays unbiased.

Questions answered (tables ``restir_*.csv``, figures ``restir_*.png``):

* one pixel, RIS on a closed form: f(x) = e^(a x) on [0, 1] blocked on [lo, hi), uniform
  source, target p̂ = e^(a x) (the unshadowed f): mean and variance per sample against M, the
  candidates, with both limits in closed form, Var_p[f/p] at M = 1 and, as M -> oo,
  Var = I (Z - I) (I = int f, Z = int p̂): the mass of p̂ behind the occluder is what RIS
  cannot learn;
* a row of B pixels with slopes a_b and an occluder moving along the row (the family of
  ``tests/test_restir.py``): per pixel the mean over passes against the exact integral (z)
  and the variance per pass, for RIS alone, RIS with (k + 1) times the candidates, and ReSTIR
  with pairwise, balance and 1/M weights; the 1/M bias against its prediction
  E = (I_c + k mean_o J_{c, c+o}) / (k + 1), J_{c,t} = int f_c over where pixel t is not
  occluded (closed form); the correlation of neighbouring pixels within a pass and the
  standard error of the row mean over passes against the one that treats pixels as
  independent;
* the renderer on ``many_lights`` (128 sphere lights) at a small size and few spp: one light
  sample, RIS and ReSTIR (preset ``"restir"``, pairwise; balance and 1/M as estimator objects)
  with ``light_selection`` uniform, power and bvh (pbrt-v4's light BVH): relMSE over the
  pixels that see no light against a ``mis-power`` / bvh reference with many more samples,
  the render time, and relMSE x time (the equal-time comparison: at equal time the relMSE
  scales as 1 / time); next to it the counted cost (``Estimate.extra["cost"]``,
  :mod:`vrlab.render.cost`: rays and evaluations, default weights) and relMSE x counted cost
  per pixel (the equal-cost comparison, the same on any machine).

Run ``python -m vrlab.experiments.restir [--full] [--out DIR]``.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from vrlab import distributions as D
from vrlab.estimators import RIS, ReSTIR
from vrlab.estimators.restir import grid_offsets
from vrlab.integrands import Integrand
from vrlab.lab.experiment import experiment_cli, output_dir, save_figure
from vrlab.metrics import rel_mse
from vrlab.render import preset, render
from vrlab.render.light_set import LIGHT_SELECTIONS

from ._restir_figures import efficiency_figure, images_figure, row_figure
from .ris import light_free_mask, small_scene

DEFAULT_OUT = Path("vrlab-out") / "restir"          # relative to the working folder

# one pixel: f(x) = exp(a x) 1[x not in [lo, hi)]
PIXEL = {"a": 3.0, "lo": 0.45, "hi": 0.7}
MS = (1, 2, 4, 8, 16, 32, 64)

# the row: B pixels, slopes from -2 to 2, an occluder [LO_b, LO_b + 0.25) moving along it
B = 16
A = np.linspace(-2.0, 2.0, B)
LO = 0.1 + 0.04 * np.arange(B)
HI = LO + 0.25
CANDIDATES, NEIGHBOURS, RADIUS = 8, 5, 3.0
ROW_METHODS = ("RIS", f"RIS, {CANDIDATES * (NEIGHBOURS + 1)} candidates", "ReSTIR pairwise",
               "ReSTIR balance", "ReSTIR 1/M")
COLOURS = {"RIS": "C7", ROW_METHODS[1]: "C5", "ReSTIR pairwise": "C0", "ReSTIR balance": "C2",
           "ReSTIR 1/M": "C3"}

SELECTIONS = LIGHT_SELECTIONS
REF = "mis-power, bvh"


# --------------------------------------------------------------------------- closed forms
def _int_exp(a, lo, hi):
    """int_lo^hi e^(a x) dx (0 where hi <= lo); a != 0, element-wise."""
    a, lo, hi = np.broadcast_arrays(*(np.asarray(v, float) for v in (a, lo, hi)))
    return np.where(hi > lo, (np.exp(a * hi) - np.exp(a * lo)) / a, 0.0)


def exact(a, lo, hi):
    """I = int_0^1 e^(a x) 1[x not in [lo, hi)] dx."""
    return _int_exp(a, 0.0, 1.0) - _int_exp(a, lo, hi)


def pixel_limits(a: float, lo: float, hi: float) -> dict:
    """Closed forms for one pixel with the uniform source and the target p̂ = e^(a x):
    the exact integral I, the target's mass Z, Var at M = 1 (Var_p[f/p] = int f^2 - I^2)
    and as M -> oo (IS with p̂ / Z: int f^2 Z / p̂ - I^2 = I Z - I^2, since f^2 / p̂ = f)."""
    i = float(exact(a, lo, hi))
    z = float(_int_exp(a, 0.0, 1.0))
    f2 = float(exact(2 * a, lo, hi))
    return {"exact": i, "Z": z, "var_m1": f2 - i * i, "var_inf": i * z - i * i,
            "occluded_share": float(_int_exp(a, lo, hi)) / z}


def _col(v, xx):
    return np.asarray(v).reshape(np.shape(v) + (1,) * xx.ndim)


def row_unshadowed(x):
    """The targets p̂_b(x) = e^(a_b x): (B, ...) for points x (..., 1)."""
    xx = x[..., 0]
    return np.exp(_col(A, xx) * xx)


def row_shadowed(x):
    """f_b(x) = e^(a_b x) 1[x not in [LO_b, HI_b)]: (B, ...)."""
    xx = x[..., 0]
    return row_unshadowed(x) * ~((xx >= _col(LO, xx)) & (xx < _col(HI, xx)))


def row_integrand() -> Integrand:
    return Integrand(row_shadowed, [(0, 1)], exact(A, LO, HI), "shadowed-row")


def one_over_m_expectation(k: int = NEIGHBOURS, radius: float = RADIUS) -> np.ndarray:
    """What ReSTIR with the 1/M weights converges to at each pixel (identity shift, one pass):
    each of the k + 1 contributors has weight 1/(k + 1) where it can bring y, and neighbour t
    can bring y only where t is not occluded, so E_c = (I_c + k mean_o J_{c, c+o}) / (k + 1),
    the mean over the offsets o a neighbour slot picks uniformly (the row wraps around), and
    J_{c,t} = int f_c 1[t not occluded] (closed form: the two occluders and their overlap)."""
    offs = grid_offsets((B,), radius)[:, 0]
    c = np.arange(B)[:, None]
    t = (c + offs[None, :]) % B
    a = A[:, None]
    both = _int_exp(a, LO[:, None], HI[:, None]) + _int_exp(a, LO[t], HI[t]) \
        - _int_exp(a, np.maximum(LO[:, None], LO[t]), np.minimum(HI[:, None], HI[t]))
    J = _int_exp(a, 0.0, 1.0) - both
    return (exact(A, LO, HI) + k * J.mean(-1)) / (k + 1)


# --------------------------------------------------------------------------- 1. one pixel
def one_pixel(ms=MS, n: int = 4000, reps: int = 10, seed: int = 1, pixel: dict = PIXEL) -> pd.DataFrame:
    """RIS on one pixel for each M: the mean over ``reps`` x ``n`` samples and its z against the
    exact integral, and the variance per sample (mean over ``reps`` runs, its standard error),
    with the closed-form limits at M = 1 and M -> oo."""
    a, lo, hi = pixel["a"], pixel["lo"], pixel["hi"]
    lim = pixel_limits(a, lo, hi)
    f = Integrand(lambda x: exact_free(x, a, lo, hi), [(0, 1)], lim["exact"], "shadowed-pixel")
    rows = []
    for m in ms:
        est = RIS(D.UniformInterval(0.0, 1.0), lambda x: np.exp(a * x[..., 0]), int(m), probe=False)
        es = [est.estimate(f, n, rng=g) for g in np.random.SeedSequence([seed, int(m)]).spawn(reps)]
        v = np.array([e.variance for e in es])
        vals = np.array([e.value for e in es])
        mean = vals.mean()
        se = vals.std(ddof=1) / np.sqrt(reps)
        rows.append({"M": int(m), "mean": mean, "exact": lim["exact"], "z": (mean - lim["exact"]) / se,
                     "var": v.mean(), "var_se": v.std(ddof=1) / np.sqrt(reps),
                     "var_m1_theory": lim["var_m1"], "var_inf_theory": lim["var_inf"],
                     "n": n * reps})
    t = pd.DataFrame(rows)
    t.attrs.update(lim, **pixel)
    return t


def exact_free(x, a, lo, hi):
    """One pixel's f(x) = e^(a x) 1[x not in [lo, hi)] at points x (..., 1)."""
    xx = x[..., 0]
    return np.exp(a * xx) * ~((xx >= lo) & (xx < hi))


# --------------------------------------------------------------------------- 2. the row
def row_estimators(candidates: int = CANDIDATES, k: int = NEIGHBOURS, radius: float = RADIUS) -> dict:
    """The row's methods: ReSTIR objects (neighbours = 0 is RIS in every pixel)."""
    return {"RIS": ReSTIR(candidates, 0, radius, 1, target=row_unshadowed),
            f"RIS, {candidates * (k + 1)} candidates": ReSTIR(candidates * (k + 1), 0, radius, 1,
                                                               target=row_unshadowed),
            "ReSTIR pairwise": ReSTIR(candidates, k, radius, 1, "pairwise", target=row_unshadowed),
            "ReSTIR balance": ReSTIR(candidates, k, radius, 1, "balance", target=row_unshadowed),
            "ReSTIR 1/M": ReSTIR(candidates, k, radius, 1, "1/M", target=row_unshadowed)}


def row_passes(passes: int = 2000, seed: int = 2) -> tuple[dict, dict]:
    """Unit values (B, passes) of every row method from independent uniforms, and the seconds each took."""
    f = row_integrand()
    values, seconds = {}, {}
    for i, (name, est) in enumerate(row_estimators().items()):
        u = np.random.default_rng([seed, i]).random((passes, est.dim_u(f)))
        t0 = time.perf_counter()
        values[name] = est.unit_values(f, u)
        seconds[name] = time.perf_counter() - t0
    return values, seconds


def row_pixels(values: dict) -> pd.DataFrame:
    """Per method and pixel: mean over passes, its standard error, z against the exact
    integral, relative bias, variance per pass, and the 1/M prediction."""
    ex, pred = exact(A, LO, HI), one_over_m_expectation()
    rows = []
    for name, v in values.items():
        n = v.shape[-1]
        mean, se = v.mean(-1), v.std(-1, ddof=1) / np.sqrt(n)
        expect = pred if name == "ReSTIR 1/M" else ex
        rows.append(pd.DataFrame({"method": name, "pixel": np.arange(B), "a": A, "lo": LO, "hi": HI,
                                  "exact": ex, "mean": mean, "se": se, "z": (mean - ex) / se,
                                  "rel_bias": mean / ex - 1, "expected": expect,
                                  "z_vs_expected": (mean - expect) / se, "var": v.var(-1, ddof=1)}))
    return pd.concat(rows, ignore_index=True)


def row_summary(values: dict, seconds: dict) -> pd.DataFrame:
    """Per method: the largest |z| over pixels, the pooled z of the row mean (its standard
    error over passes), the mean variance per pass and its ratio to RIS's, the shadow rays per
    pixel and pass, the correlation of neighbouring pixels' values within a pass, and the
    standard error of the row mean over passes against the one that treats pixels as independent."""
    ex = exact(A, LO, HI)
    ests = row_estimators()
    rows = []
    for name, v in values.items():
        n = v.shape[-1]
        z = (v.mean(-1) - ex) / (v.std(-1, ddof=1) / np.sqrt(n))
        per_pass = (v - ex[:, None]).mean(0)                  # row-mean error of each pass
        se_passes = per_pass.std(ddof=1) / np.sqrt(n)         # honest: passes are independent
        se_naive = np.sqrt(np.sum(v.var(-1, ddof=1) / n)) / B  # as if the pixels were independent
        d = v - v.mean(-1, keepdims=True)
        d = d / d.std(-1, keepdims=True)
        rows.append({"method": name, "candidates": ests[name].candidates, "neighbours": ests[name].neighbours,
                     "max_abs_z": float(np.max(np.abs(z))), "pooled_z": float(per_pass.mean() / se_passes),
                     "mean_rel_bias": float(np.mean(v.mean(-1) / ex - 1)),
                     "var": float(v.var(-1, ddof=1).mean()), "shadow_rays": ests[name].traced_per_unit(),
                     "neighbour_corr": float(np.mean(d * np.roll(d, -1, 0))),
                     "se_row_mean": se_passes, "se_row_mean_naive": se_naive, "seconds": seconds[name],
                     "passes": n})
    t = pd.DataFrame(rows)
    t["var_ratio"] = t["var"] / float(t.loc[t["method"] == "RIS", "var"].iloc[0])
    t["se_ratio"] = t["se_row_mean"] / t["se_row_mean_naive"]
    t["var_x_rays"] = t["var"] * t["shadow_rays"]          # variance at equal shadow rays (lab cost model)
    return t


# --------------------------------------------------------------------------- 3. the renderer
def render_methods(m: int) -> list[tuple[str, object, str]]:
    """(label, estimator (preset name or object), light_selection) of the renderer runs."""
    out = []
    for sel in SELECTIONS:
        out += [(f"light, {sel}", "light", sel), (f"RIS, {sel}", "ris", sel), (f"ReSTIR, {sel}", "restir", sel)]
    out += [("ReSTIR balance, bvh", ReSTIR(m, NEIGHBOURS, RADIUS, 1, "balance"), "bvh"),
            ("ReSTIR 1/M, bvh", ReSTIR(m, NEIGHBOURS, RADIUS, 1, "1/M"), "bvh")]
    return out


def many_lights(size=(48, 36), spp: int = 4, ref_spp: int = 256, m: int = 8, seeds: int = 3, seed: int = 11
                ) -> tuple[pd.DataFrame, dict, np.ndarray]:
    """Every method at ``spp`` on ``many_lights`` at ``size``, ``seeds`` renders each: relMSE
    (mean over the seeds) over the pixels that see no light, and over the others (next to or on
    a lamp), against a ``mis-power`` / bvh reference at ``ref_spp`` (its variance subtracted);
    seconds (the fastest render: least disturbed by load); relMSE x seconds; the image mean over
    the light-free pixels against the reference's; the counted rays and weighted cost per sample
    (mean over the seeds) and relMSE x counted cost per pixel.  The renders of one light selection and seed
    share their random numbers (``rng``), so the three ReSTIR weightings see the same candidates
    and neighbours: ``mean_vs_pairwise`` (their image mean over pairwise's, per seed, then
    averaged) isolates what the weights change."""
    scene = small_scene(size)
    mask = light_free_mask(scene)
    t0 = time.perf_counter()
    ref_est = render(scene, ref_spp, "mis-power", rng=[seed, 0], light_selection="bvh")
    ref_sec = time.perf_counter() - t0
    ref, ref_err = ref_est.value.astype(float), ref_est.stderr.astype(float)
    ref_mean = float(ref[mask].mean())
    rows, images, means = [], {}, {}
    for label, est, sel in render_methods(m):
        rel, near, secs, costs, rays, means[label] = [], [], [], [], [], []
        for s in range(seeds):
            t0 = time.perf_counter()
            out = render(scene, spp, est, rng=[seed, 1 + SELECTIONS.index(sel), s], light_selection=sel,
                         ris_candidates=m)
            secs.append(time.perf_counter() - t0)
            counted = out.extra["cost"]
            costs.append(counted["weighted_per_sample"])
            rays.append(sum(v for k, v in counted["per_sample"].items() if k.endswith("_rays")))
            img = out.value.astype(float)
            rel.append(rel_mse(img, ref, ref_err=ref_err, mask=mask))
            near.append(rel_mse(img, ref, ref_err=ref_err, mask=~mask))
            means[label].append(float(img[mask].mean()))
            if s == 0:
                images[label] = img
        kind = label.split(",")[0]
        obj = preset(est, ris_candidates=m)[0] if isinstance(est, str) else est
        rows.append({"method": label, "kind": kind, "light_selection": sel, "spp": spp,
                     "shadow_rays": int(obj.traced_per_unit()) if hasattr(obj, "traced_per_unit") else 1,
                     "candidates": m if kind != "light" else 1, "relmse": float(np.mean(rel)),
                     "seconds": float(np.min(secs)), "rays_per_sample": float(np.mean(rays)),
                     "cost_per_sample": float(np.mean(costs)), "relmse_near_lights": float(np.mean(near)),
                     "mean_ratio": float(np.mean(means[label])) / ref_mean})
    t = pd.DataFrame(rows)
    pair = np.array(means["ReSTIR, bvh"])
    t["mean_vs_pairwise"] = [float(np.mean(np.array(means[lab]) / pair)) if lab.startswith("ReSTIR") and
                             lab.endswith("bvh") else np.nan for lab in t["method"]]
    t["relmse_x_seconds"] = t["relmse"] * t["seconds"]
    t["relmse_x_cost"] = t["relmse"] * t["spp"] * t["cost_per_sample"]        # counted cost per pixel
    t["pixels"] = int(mask.sum())
    t["lights"] = sum(s.emitter is not None for s in scene.shapes)
    t["width"], t["height"], t["seeds"], t["ref_spp"] = size[0], size[1], seeds, ref_spp
    t.attrs.update(ref_spp=ref_spp, ref_seconds=ref_sec)
    return t, images, ref


# --------------------------------------------------------------------------- main
def gallery_numbers(out: str | Path) -> dict:
    """The gallery caption's numbers, from ``restir_many_lights.csv`` and ``restir_row_summary.csv``."""
    t = pd.read_csv(Path(out) / "restir_many_lights.csv").set_index("method")
    s = pd.read_csv(Path(out) / "restir_row_summary.csv").set_index("method")
    best = t["relmse_x_seconds"].idxmin()
    return {"lights": int(t["lights"].iloc[0]), "spp": int(t["spp"].iloc[0]), "m": int(t["candidates"].max()),
            "rays": int(t.loc["ReSTIR, bvh", "shadow_rays"]), "k": int(s.loc["ReSTIR pairwise", "neighbours"]),
            "row_pixels": B,
            "size": f"{int(t['width'].iloc[0])}×{int(t['height'].iloc[0])}",
            **{f"{k}_{sel}": f"{t.loc[f'{k}, {sel}', 'relmse']:.2g}" for k in ("RIS", "ReSTIR") for sel in SELECTIONS},
            **{f"{k}_{sel}_t": f"{t.loc[f'{k}, {sel}', 'relmse_x_seconds']:.2g}" for k in ("RIS", "ReSTIR")
               for sel in SELECTIONS},
            "best": best, "row_var_ratio": f"{s.loc['ReSTIR pairwise', 'var_ratio']:.2f}",
            "row_1m_bias": f"{-100 * s.loc['ReSTIR 1/M', 'mean_rel_bias']:.0f}%",
            "row_1m_z": f"{s.loc['ReSTIR 1/M', 'pooled_z']:.0f}",
            "row_pairwise_z": f"{s.loc['ReSTIR pairwise', 'max_abs_z']:.1f}"}


def main(out: str | Path = DEFAULT_OUT, full: bool = False) -> dict:
    """One pixel, the row and the renders; write CSV + PNG into ``out``, return the tables."""
    out = output_dir(out)
    one = one_pixel(n=20_000 if full else 4000, reps=20 if full else 10)
    one.to_csv(out / "restir_one_pixel.csv", index=False)

    values, seconds = row_passes(8000 if full else 2000)
    pixels, summary = row_pixels(values), row_summary(values, seconds)
    pixels.to_csv(out / "restir_row_pixels.csv", index=False)
    summary.to_csv(out / "restir_row_summary.csv", index=False)
    save_figure(row_figure(pixels, one, row_shadowed, ROW_METHODS, COLOURS,
                           f"c = {CANDIDATES}, k = {NEIGHBOURS}, r = {RADIUS:g}"), out / "restir_row.png")

    size, spp, ref_spp, seeds = ((96, 72), 4, 1024, 4) if full else ((48, 36), 4, 256, 3)
    ml, images, ref = many_lights(size, spp, ref_spp, seeds=seeds)
    ml.to_csv(out / "restir_many_lights.csv", index=False)
    save_figure(images_figure(ml, images, ref, SELECTIONS, REF), out / "restir_many_lights.png")
    save_figure(efficiency_figure(ml, SELECTIONS), out / "restir_many_lights_efficiency.png")
    return {"one_pixel": one, "row_pixels": pixels, "row": summary, "many_lights": ml,
            "limits": dict(one.attrs), "ref_seconds": ml.attrs["ref_seconds"],
            "files": sorted(p.name for p in out.iterdir())}


if __name__ == "__main__":
    experiment_cli(main, DEFAULT_OUT, __doc__)
