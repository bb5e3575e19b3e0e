"""``vrlab lab``: estimator recipes on catalogue integrands (see :mod:`vrlab.lab`).

Checked before any work starts (usage errors, exit status 2, unless noted): the
integrand and estimator lists (non-empty, no blank or repeated entries, known names,
each recipe applicable to each integrand), ``--n`` (integers 1 .. 2**30, no repeats;
one trial estimate per pair at the smallest n, if <= 2**16, catches counts too small
for a recipe),
``--reps`` (2 .. 10**6), ``--seed`` (0 .. 2**128-1), ``--workers`` (1 .. 256),
``--csv`` (``.csv``), ``--plot`` (``.png``, ``.pdf``, ``.svg``) and ``--store``
(``.sqlite``): suffix, and a folder that exists and is writable (else exit status 1);
``--scheduler`` (a Dask scheduler address, ``tcp://HOST:PORT`` or ``HOST:PORT``; not with
``--workers`` > 1; needs ``dask.distributed``).

Then, before the sweep starts: an address that does not answer as a Dask scheduler within
``SCHEDULER_TIMEOUT`` = 10 seconds (a closed port, an HTTP server such as its dashboard,
an unroutable address) is a failure, one line, exit status 1; a scheduler without workers
is said so on stderr and waited for at most ``WORKER_WAIT`` = 60 seconds (then exit 1)
(:func:`vrlab.cli_args.connect_scheduler`); a ``--store`` file of another
sweep is a usage error (exit 2: give another file), one that is not a lab store a failure
(exit 1).  With ``--store`` a rerun of the same command, after an interruption of any kind,
runs only the missing units (:mod:`vrlab.lab.store`).
"""
from __future__ import annotations

import argparse
import contextlib
import json
import sys
import warnings

from . import cli_args as A
from . import limits
from .cli_args import SCHEDULER_TIMEOUT, connect_scheduler, scheduler_address  # noqa: F401

N_MAX = limits.MAX_N
REPS_MAX = 10**6
FIGURE_SUFFIXES = (".png", ".pdf", ".svg")
PREFLIGHT_MAX = 2**16        # the trial estimate is skipped above this n (it would cost real time)


def add_parser(sub, **kw) -> argparse.ArgumentParser:
    lab = sub.add_parser("lab", help="compare estimators on lab integrands: RMSE, slopes, efficiency",
                         description="Run estimator recipes on catalogue integrands at several sample counts,\n"
                                     "repeated with spawned seeds; print a summary (bias, RMSE, variance,\n"
                                     "calibration of the standard errors, efficiency) and log-log RMSE slopes.",
                         **kw)
    lab.epilog = ("examples: vrlab lab --list\n          vrlab lab --integrand exp --estimators "
                  "mc,antithetic,cv,jittered --n 64,256,1024 --reps 50 --plot conv.png\n\n" + (lab.epilog or ""))
    lab.add_argument("--list", action="store_true", help="list integrands and recipes (and which apply where)")
    lab.add_argument("--integrand", metavar="NAME[,NAME]", help="catalogue integrand(s) with closed-form "
                                                               "integrals, e.g. exp,sin (--list shows them)")
    lab.add_argument("--estimators", metavar="A,B,C", help="estimator recipes, e.g. mc,is:linear,mis-balance "
                                                           "(--list shows them and where they apply)")
    lab.add_argument("--n", default="64,256,1024", metavar="N1,N2,...",
                     help="sample counts = integrand evaluations, 1 .. 2**30 (default: %(default)s)")
    lab.add_argument("--reps", default="50", help=f"repetitions per setting, 2 .. {REPS_MAX} (default: %(default)s)")
    lab.add_argument("--seed", default="0", help="root seed of every random number, 0 .. 2**128-1: each "
                                                 "repetition gets its own spawned seed (default: %(default)s)")
    lab.add_argument("--workers", default="1",
                     help=f"worker processes, 1 .. {A.WORKERS_MAX} (same numbers for any count; default: %(default)s)")
    lab.add_argument("--scheduler", metavar="ADDRESS",
                     help="run the units on a running Dask scheduler, e.g. tcp://127.0.0.1:8786 (needs "
                          "vrlab[distributed]; same numbers as local runs; an address that does not answer as a "
                          f"scheduler within {A.SCHEDULER_TIMEOUT:g} s: exit 1; no workers: waits up to "
                          f"{A.WORKER_WAIT:g} s)")
    lab.add_argument("--store", metavar="FILE.sqlite",
                     help="keep each finished unit in this SQLite file; rerunning the same command resumes "
                          "an interrupted sweep (a store of another sweep is refused)")
    lab.add_argument("--csv", metavar="FILE.csv", help="write the per-repetition rows as CSV")
    lab.add_argument("--plot", metavar="FILE.png", help="write the convergence plot (RMSE vs n): .png, .pdf or .svg")
    lab.add_argument("--json", action="store_true", help="print summary, slopes and equal-time tables as JSON")
    lab.add_argument("--progress", dest="progress", action="store_true", default=None,
                     help="progress bar on stderr (default: when stderr is a terminal)")
    lab.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    lab.set_defaults(parser=lab, func=run_lab)
    return lab


def _lab_list(args: argparse.Namespace) -> int:
    from .integrands import get, names
    from .lab import explain, list_recipes

    recipes = list_recipes()
    table = {}
    for name in names():
        integrand = get(name)
        why = explain(integrand)
        table[name] = {"dim": integrand.dim, "domain": integrand.domain if isinstance(integrand.domain, str)
                       else "box", "exact": integrand.exact, "techniques": list(integrand.techniques),
                       "applicable": [k for k, v in why.items() if v is None],
                       "not_applicable": {k: v for k, v in why.items() if v is not None}}
    if args.json:
        print(json.dumps({"recipes": recipes, "integrands": table}, indent=2, default=float))
        return 0
    print("Estimator recipes (--estimators A,B,...; '<a+b>' picks techniques, e.g. mis-balance:brdf+light):")
    width = max(len(r["recipe"]) for r in recipes)
    for r in recipes:
        missing = "" if r["available"] else f"   [not installed: {r['module']}]"
        print(f"  {r['recipe']:<{width}}  {r['summary']}{missing}")
    print("\nIntegrands (--integrand NAME) and the recipes that apply:")
    width = max(map(len, table))
    for name, t in table.items():
        print(f"  {name:<{width}}  {t['dim']}D {t['domain']}, exact {t['exact']:.6g}, "
              f"techniques: {', '.join(t['techniques']) or '-'}")
        print(f"  {'':<{width}}    {', '.join(t['applicable'])}")
    return 0


def check_lab(args: argparse.Namespace) -> dict:
    """Every flag of ``vrlab lab`` as a value (see the module docstring); raises
    :class:`~vrlab.cli_args.UsageError` or :class:`~vrlab.cli_args.Failure`."""
    from .integrands import get, names
    from .lab import build

    if args.integrand is None or args.estimators is None:
        raise A.UsageError("give --integrand and --estimators (or --list to see the choices)")
    integrands = A.names(args.integrand, "--integrand", names())
    estimators = A.names(args.estimators, "--estimators")
    ns = A.integers(args.n, "--n", low=1, high=N_MAX)
    plan = dict(integrands=integrands, estimators=estimators, ns=ns,
                reps=A.integer(args.reps, "--reps", low=2, high=REPS_MAX),
                seed=A.seed(args.seed), workers=A.workers(args.workers))
    plan["csv"] = A.output_file(args.csv, "--csv", (".csv",))
    plan["plot"] = A.output_file(args.plot, "--plot", FIGURE_SUFFIXES)
    plan["store"] = A.output_file(args.store, "--store", (".sqlite",))
    A.distinct({"--csv": plan["csv"], "--plot": plan["plot"], "--store": plan["store"]})
    plan["scheduler"] = scheduler_address(args.scheduler)
    if plan["scheduler"] is not None and plan["workers"] > 1:
        raise A.UsageError("--scheduler and --workers > 1 do not go together: the scheduler's workers run the "
                           "units (leave out --workers)")
    # each recipe on each integrand, once at the smallest n: names, applicability and counts
    # too small for a recipe (antithetic pairs, RQMC replicates ...) fail here, not mid-run
    n0 = min(ns)
    for e in estimators:
        for i in integrands:
            integrand = get(i)
            try:
                estimator, points = build(e, integrand)
            except (TypeError, ValueError) as exc:
                raise A.UsageError(f"--estimators: {exc}") from exc
            if n0 > PREFLIGHT_MAX:
                continue
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    estimator.estimate(integrand, n0, rng=0, points=points)
            except (TypeError, ValueError) as exc:
                raise A.UsageError(f"--n {n0}: recipe {e!r} on {i!r}: {exc}") from exc
    return plan


def run_lab(args: argparse.Namespace) -> int:
    if args.list:
        return _lab_list(args)
    plan = check_lab(args)
    from ._alloc import keep_freed_memory

    keep_freed_memory()     # this process is vrlab's own: reuse freed NumPy temporaries (vrlab._alloc)
    import pandas as pd

    from .lab import convergence_plot, equal_time, fit_slopes, run, summarize
    from .lab.store import StoreError, StoreMismatch

    with contextlib.ExitStack() as stack:
        client = None
        if plan["scheduler"] is not None:
            client = stack.enter_context(connect_scheduler(plan["scheduler"]))
        try:
            df = run(plan["estimators"], plan["integrands"], plan["ns"], plan["reps"], rng=plan["seed"],
                     progress=_progress(args.progress), workers=plan["workers"], executor=client,
                     store=plan["store"], resumed=_resumed(plan["store"]))
        except StoreError as exc:            # raised before any unit runs
            text = "--store" + str(exc).removeprefix("store")
            raise (A.UsageError if isinstance(exc, StoreMismatch) else A.Failure)(text) from None
    from .lab.summary import MIN_SLOPE_POINTS
    from .lab.trust import flag_notes, stderr_flags, trust_thresholds

    summary = summarize(df)
    summary["flag"] = stderr_flags(summary)          # as the demo: are the error bars to be trusted?
    slopes = fit_slopes(summary)
    eq = equal_time(summary)
    csv, plot = args.csv, args.plot
    if csv:
        df.to_csv(csv, index=False)
    if plot:
        convergence_plot(summary, plot)
    if args.json:
        print(json.dumps({"seed": plan["seed"], "integrands": plan["integrands"], "estimators": plan["estimators"],
                          "n": plan["ns"], "reps": plan["reps"], "summary": _records(summary),
                          "slopes": _records(slopes), "equal_time": _records(eq),
                          "csv": csv, "plot": plot}, indent=2, default=_json_default))
        return 0
    cols = ["estimator", "integrand", "n", "flag", "mean", "bias", "rmse", "variance", "mean_stderr", "z_std",
            "coverage", "seconds", "efficiency"]
    with pd.option_context("display.width", 200, "display.max_columns", 30, "display.max_rows", 500):
        print(f"vrlab lab: {plan['reps']} repetitions, seed {plan['seed']}")
        print(summary[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}"))
        th = trust_thresholds(plan["reps"], 2 * len(summary))
        for line in flag_notes(summary[summary["flag"] != ""], th, plan["reps"]):
            print(line)
        if len(plan["ns"]) < MIN_SLOPE_POINTS:
            print(f"\nRMSE slopes: not fitted, they need at least {MIN_SLOPE_POINTS} sample counts (--n has "
                  f"{len(plan['ns'])}: give e.g. --n 64,256,1024)")
        else:
            print("\nRMSE slopes in log-log (fitted vs theory):")
            print(slopes[["estimator", "integrand", "slope", "slope_se", "theory", "theory_note", "slope_note"]]
                  .to_string(index=False, float_format=lambda v: f"{v:.3f}"))
        at = eq[eq["n"] == eq.groupby("integrand")["n"].transform("max")]
        print(f"\nAt the largest n, against {eq['reference'].iloc[0]} (bigger is better; > 1: better than it): "
              "variance_reduction = its variance / this variance (equal n), efficiency_gain = its variance x "
              "seconds / this variance x seconds (equal time):")
        print(at[["integrand", "n", "estimator", "variance_reduction", "efficiency_gain"]]
              .to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    if csv or plot:
        print("\nwrote " + ", ".join(p for p in (csv, plot) if p))
    return 0


def _resumed(store):
    """The line a resumed --store sweep prints on stderr before it runs the missing units."""
    def say(stored, total):
        print(f"vrlab lab: resuming: {stored} of {total} units already stored in {store}; running the "
              f"other {total - stored}", file=sys.stderr, flush=True)
    return say


def _progress(flag):
    """--progress: a bar even off a terminal; default: a bar when stderr is a terminal;
    --no-progress: none."""
    if flag is None or flag is False:
        return flag is None
    from .lab.progress import ProgressBar

    bar = []

    def show(done, total):
        if not bar:
            bar.append(ProgressBar(total))
        bar[0].update(done - bar[0].done)
    return show


def _records(df) -> list[dict]:
    """Rows as dicts with NaN and infinities as None (strict JSON)."""
    import numpy as np

    clean = df.replace([np.inf, -np.inf], np.nan).astype(object)
    return clean.where(clean.notna(), None).to_dict("records")


def _json_default(v):
    import numpy as np

    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (np.floating,)):
        return float(v)
    if isinstance(v, np.bool_):
        return bool(v)
    return str(v)
