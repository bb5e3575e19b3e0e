"""Tables from a lab run: accuracy per sample count, convergence slopes, equal-time efficiency.

With R repetitions F_1..F_R of an estimator of I at cost n (integrand evaluations):

* bias = mean(F) - I;  RMSE = sqrt(mean((F - I)^2));  variance = sample variance of F (ddof 1);
* z_r = (F_r - I) / stderr_r should be about N(0, 1): ``z_std`` near 1 means the reported
  standard errors are calibrated, ``coverage`` is the share of 95% normal intervals
  F_r +- 1.96 stderr_r that contain I (0.95 if calibrated);
* efficiency = 1 / (variance x seconds) (Hammersley & Handscomb 1964, 5.2; Owen, *Monte
  Carlo theory, methods and examples*, 8.2: "relative efficiency" at equal cost).

Theoretical RMSE slopes in n (log-log), used beside the fitted ones:

* i.i.d. Monte Carlo and its unbiased reweightings (IS, MIS, antithetic, control variates,
  RIS, RQMC over a fixed number of strata...): -1/2 (central limit theorem);
* jittered (one point per cell of a grid in d dims) on smooth f: -1/2 - 1/d; with
  discontinuities along smooth boundaries: -1/2 - 1/(2d) (Mitchell 1996, "Consequences of
  stratified sampling in graphics"; Owen, ch. 10);
* Latin hypercube: -1/2 (only the additive part is removed; Stein 1987), -3/2 in 1D where it
  is jittered;
* randomized QMC on smooth f: scrambled Sobol' nets (SciPy's linear matrix scrambling with a
  digital shift), -3/2 up to log factors: Var = O(n^-3 (log n)^(d-1)) at n = 2^m points per
  replicate for f with continuous mixed partial derivatives (Owen 1997, "Scrambled net
  variance for integrals of smooth functions"; Owen 2003, "Variance with alternative
  scramblings of digital nets": linear scrambling has the same variance); scrambled Halton
  (not a net), about -1 (Koksma-Hlawka, discrepancy O(n^-1 log^d n)); on discontinuous f,
  either: -1/2 - 1/(4d - 2) (He & Wang 2015, "On the convergence rate of randomized
  quasi-Monte Carlo for discontinuous functions").

Tables are checked (errors name ``df``): a non-empty DataFrame with the needed columns,
numeric columns holding numbers, finite values and ``n > 0``, at least 2 repetitions per
(estimator, integrand, n) and no repeated (estimator, integrand, n, rep).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats

from .. import checks
from ._args import column_check, flag, frame

KEYS = ["estimator", "integrand", "n"]
_Z95 = float(stats.norm.ppf(0.975))
_CARRY = ["points", "class", "dim_u", "smooth", "strata"]


def _group(df: pd.DataFrame, keys: list[str]):
    return df.groupby(keys, sort=False, dropna=False)


def _check_run(df) -> pd.DataFrame:
    """A run table: finite values and times, n > 0, stderr >= 0 or NaN, exact finite or NaN."""
    num = ["n", "value", "stderr", "exact", "seconds"]
    df = frame(df, KEYS + ["value", "stderr", "exact", "seconds"], numeric=num)
    v = {c: df[c].to_numpy(float) for c in num}
    column_check(df, "n", np.isfinite(v["n"]) & (v["n"] > 0), "a positive sample count")
    column_check(df, "value", np.isfinite(v["value"]), "finite")
    column_check(df, "seconds", np.isfinite(v["seconds"]) & (v["seconds"] >= 0), "finite and >= 0")
    column_check(df, "stderr", np.isnan(v["stderr"]) | (v["stderr"] >= 0), ">= 0 (or NaN)")
    column_check(df, "exact", ~np.isinf(v["exact"]), "finite (or NaN if unknown)")
    keys = KEYS + (["rep"] if "rep" in df else [])
    dup = df.duplicated(keys)
    column_check(df, keys[-1], ~dup.to_numpy(), f"unique per {tuple(keys)} (two runs with the same labels?)")
    few = df.groupby(KEYS, sort=False, dropna=False)["value"].transform("size").to_numpy() < 2
    if few.any():
        key = tuple(df[KEYS].iloc[int(np.argmax(few))].tolist())
        raise ValueError(f"df: (estimator, integrand, n) = {key} has 1 repetition; a variance needs at least 2")
    return df


def summarize(df: pd.DataFrame) -> pd.DataFrame:
    """Per (estimator, integrand, n): ``reps, mean, exact, bias, rmse, rel_rmse, variance,
    mean_stderr, z_std, coverage, seconds, efficiency`` (formulas in the module docstring).

    ``df``: a ``run`` table (checked as in the module docstring)."""
    d = _check_run(df).copy()
    d["error"] = d["value"] - d["exact"]
    with np.errstate(divide="ignore", invalid="ignore"):
        z = d["error"] / d["stderr"]
    z = z.where(~((d["error"] == 0) & (d["stderr"] == 0)), 0.0)   # exact estimate, zero stderr
    d["_z"] = z.where(np.isfinite(z))
    d["_cover"] = (d["error"].abs() <= _Z95 * d["stderr"]).astype(float).where(d["exact"].notna())
    d["_sq"] = d["error"] ** 2
    g = _group(d, KEYS)
    out = pd.DataFrame({
        "reps": g["value"].size(),
        "mean": g["value"].mean(),
        "exact": g["exact"].first(),
        "rmse": np.sqrt(g["_sq"].mean()),
        "variance": g["value"].var(ddof=1),
        "mean_stderr": g["stderr"].mean(),
        "z_std": g["_z"].std(ddof=1),
        "coverage": g["_cover"].mean(),
        "seconds": g["seconds"].mean(),
    })
    out.insert(3, "bias", out["mean"] - out["exact"])
    with np.errstate(divide="ignore", invalid="ignore"):
        out.insert(out.columns.get_loc("rmse") + 1, "rel_rmse", out["rmse"] / out["exact"].abs())
        out["efficiency"] = 1.0 / (out["variance"] * out["seconds"])
    carry = [c for c in _CARRY if c in d]
    if carry:
        out = out.join(g[carry].first())
    return out.reset_index()


def theoretical_slope(cls: str, points: str, dim_u: int, smooth: bool = True,
                      fixed_strata: bool = False) -> tuple[float, str]:
    """Theoretical log-log slope of RMSE in n and its source (see the module docstring).

    ``cls``: estimator class name; ``points``: point-set name; ``dim_u``: uniforms per
    sample; ``smooth``: f without discontinuities; ``fixed_strata``: a ``Stratified``
    estimator with a fixed grid (otherwise its strata grow with n, like jittered).
    ``dim_u``: an integer (<= 0 or None: unknown); ``cls``, ``points``: strings.
    """
    if not isinstance(cls, str):
        raise TypeError(f"cls must be an estimator class name (a string), got {checks.describe(cls)}")
    if points is not None and not isinstance(points, str):
        raise TypeError(f"points must be a point-set name (a string) or None, got {checks.describe(points)}")
    dim_u = None if dim_u is None else checks.integer(dim_u, "dim_u")
    smooth, fixed_strata = flag(smooth, "smooth"), flag(fixed_strata, "fixed_strata")
    d = max(int(dim_u), 1) if dim_u is not None and dim_u > 0 else None
    pts = (points or "independent").lower()
    if cls == "Stratified" and not fixed_strata and d is not None:
        pts = "stratified"   # about n/2 strata: the jittered rate
    if cls == "RQMC":
        if smooth and pts == "sobol":
            return -1.5, ("RQMC, scrambled Sobol' net, smooth f: -3/2 up to logs, Var O(n^-3 (log n)^(d-1)) at "
                          "n = 2^m per replicate (Owen 1997)")
        if d is None or smooth:
            return -1.0, "RQMC, smooth f: ~ -1 up to logs (Koksma-Hlawka)"
        return -0.5 - 1.0 / (4 * d - 2), "RQMC, discontinuous f: -1/2 - 1/(4d-2) (He & Wang 2015)"
    if pts in ("stratified", "jittered") and d is not None:
        if smooth:
            return -0.5 - 1.0 / d, "jittered, smooth f: -1/2 - 1/d (Owen ch. 10)"
        return -0.5 - 0.5 / d, "jittered, discontinuous f: -1/2 - 1/(2d) (Mitchell 1996)"
    if pts in ("lhs", "latinhypercube") and d == 1:
        return (-1.5, "LHS in 1D = jittered, smooth f") if smooth else (-1.0, "LHS in 1D = jittered, discontinuous f")
    if pts in ("lhs", "latinhypercube"):
        return -0.5, "LHS: -1/2, smaller constant (Stein 1987)"
    if pts in ("halton", "hammersley", "sobol"):
        return -1.0, "QMC points, smooth f: ~ -1 (Koksma-Hlawka)"
    return -0.5, "Monte Carlo: -1/2 (CLT)"


#: sample counts a fitted slope needs (see :func:`fit_slopes`)
MIN_SLOPE_POINTS = 3


def fit_slopes(df: pd.DataFrame) -> pd.DataFrame:
    """Least-squares slope of log RMSE on log n per (estimator, integrand), with the theoretical slope.

    Accepts a run DataFrame (summarized first) or a ``summarize`` table.  Columns:
    ``estimator, integrand, slope, slope_se, intercept, theory, theory_note, n_min, n_max, points_used,
    slope_note``.  Rows with RMSE 0 or NaN are left out; a slope needs at least
    :data:`MIN_SLOPE_POINTS` = 3 sample counts (two points always fit a line exactly: no
    standard error, no check of the power law): with fewer it is NaN and ``slope_note`` says why.
    """
    s = _summary(df, ["rmse"], ("rmse",))
    rows = []
    for (est, integ), g in _group(s, ["estimator", "integrand"]):
        g = g[(g["rmse"] > 0) & np.isfinite(g["rmse"])].sort_values("n")
        x, y = np.log(g["n"].to_numpy(float)), np.log(g["rmse"].to_numpy(float))
        slope = intercept = se = np.nan
        why = ""
        if len(x) >= MIN_SLOPE_POINTS and np.ptp(x) > 0:
            res = stats.linregress(x, y)
            slope, intercept, se = float(res.slope), float(res.intercept), float(res.stderr)
        else:
            why = f"needs >= {MIN_SLOPE_POINTS} sample counts with RMSE > 0, has {len(x)}"
        first = g.iloc[0] if len(g) else s[(s["estimator"] == est) & (s["integrand"] == integ)].iloc[0]
        strata = first.get("strata", None)
        cls, pts, dim_u = first.get("class", ""), first.get("points", "independent"), first.get("dim_u", -1)
        theory, note = theoretical_slope(cls if isinstance(cls, str) else "",
                                         pts if isinstance(pts, str) else "independent",
                                         int(dim_u) if _known(dim_u) else -1, bool(first.get("smooth", True)),
                                         fixed_strata=strata is not None and not pd.isna(strata))
        rows.append({"estimator": est, "integrand": integ, "slope": slope, "slope_se": se,
                     "intercept": intercept, "theory": theory, "theory_note": note,
                     "n_min": int(g["n"].min()) if len(g) else np.nan,
                     "n_max": int(g["n"].max()) if len(g) else np.nan, "points_used": len(g),
                     "slope_note": why})
    return pd.DataFrame(rows)


def _known(v) -> bool:
    """A finite whole number (a dim_u read back from a table may be a float or NaN)."""
    try:
        return bool(np.isfinite(float(v)) and float(v) == int(float(v)))
    except (TypeError, ValueError):
        return False


def _summary(df, columns: list[str], finite: tuple[str, ...] = ()) -> pd.DataFrame:
    """``df`` itself if it is a ``summarize`` table (has ``rmse``) with ``columns`` (those in
    ``finite`` finite and >= 0, or NaN), else its summary."""
    if isinstance(df, pd.DataFrame) and "rmse" in df:
        s = frame(df, ["estimator", "integrand", "n"] + columns, numeric=["n"] + columns)
        n = s["n"].to_numpy(float)
        column_check(s, "n", np.isfinite(n) & (n > 0), "a positive sample count")
        for c in finite:
            v = s[c].to_numpy(float)
            column_check(s, c, np.isnan(v) | (np.isfinite(v) & (v >= 0)), "finite and >= 0 (or NaN)")
        dup = s.duplicated(["estimator", "integrand", "n"]).to_numpy()
        column_check(s, "n", ~dup, "unique per (estimator, integrand) in a summary")
        return s
    return summarize(df)


def equal_time(df: pd.DataFrame, reference: str | None = None) -> pd.DataFrame:
    """Compare estimators at equal time: ``var_x_time`` = variance x seconds per (integrand, n).

    ``efficiency_gain`` = var_x_time(reference) / var_x_time(estimator): how many times
    less time the estimator needs for the reference's variance (reference: ``"mc"`` if
    present, else the first estimator); ``variance_reduction`` = variance(reference) /
    variance(estimator), the same at equal n.  Both are bigger-is-better (> 1: better than
    the reference).
    ``df``: a run or summary table; ``reference``: None or an estimator label in it.
    """
    if reference is not None and not isinstance(reference, str):
        raise TypeError(f"reference must be an estimator label (a string) or None, got {checks.describe(reference)}")
    s = _summary(df, ["variance", "seconds", "efficiency"], ("variance", "seconds"))
    if reference is None:
        reference = "mc" if (s["estimator"] == "mc").any() else s["estimator"].iloc[0]
    elif not (s["estimator"] == reference).any():
        raise ValueError(f"reference: no estimator {reference!r}; have {', '.join(s['estimator'].unique())}")
    t = s[["integrand", "n", "estimator", "variance", "seconds", "efficiency"]].copy()
    t["var_x_time"] = t["variance"] * t["seconds"]
    ref = t[t["estimator"] == reference].set_index(["integrand", "n"])
    idx = pd.MultiIndex.from_frame(t[["integrand", "n"]])
    with np.errstate(divide="ignore", invalid="ignore"):
        t["variance_reduction"] = ref["variance"].reindex(idx).to_numpy() / t["variance"].to_numpy()
        t["efficiency_gain"] = ref["var_x_time"].reindex(idx).to_numpy() / t["var_x_time"].to_numpy()
    t["reference"] = reference
    order = {name: i for i, name in enumerate(dict.fromkeys(t["integrand"]))}   # keep the run's order
    t["_o"] = t["integrand"].map(order)
    t = t.sort_values(["_o", "n", "efficiency_gain"], ascending=[True, True, False], kind="stable")
    return t.drop(columns="_o").reset_index(drop=True)
