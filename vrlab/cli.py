"""The ``vrlab`` command line: ``vrlab demo``, ``vrlab lab`` and ``vrlab bench``."""
from __future__ import annotations

import argparse
import json
import sys
from typing import Sequence


def _cmd_demo(args: argparse.Namespace) -> int:
    from .demo import run_demo

    summary = run_demo(args.out, seed=args.seed, quick=args.quick)
    if args.json:
        print(json.dumps(summary, indent=2, default=float))
    return 0


def _cmd_bench(args: argparse.Namespace) -> int:
    import pandas as pd

    from .bench import run

    rows = run(args.suite, quick=args.quick)
    if args.json:
        print(json.dumps(rows, indent=2, default=float))
    else:
        with pd.option_context("display.width", 160, "display.max_columns", 20):
            print(pd.DataFrame(rows).to_string(index=False))
    return 0


def _csv_list(text: str, what: str, parser: argparse.ArgumentParser) -> list[str]:
    items = [t.strip() for t in (text or "").split(",") if t.strip()]
    if not items:
        parser.error(f"{what}: give at least one name")
    return items


def _int_list(text: str, what: str, parser: argparse.ArgumentParser) -> list[int]:
    try:
        out = [int(t) for t in _csv_list(text, what, parser)]
    except ValueError:
        parser.error(f"{what}: expected comma-separated integers, got {text!r}")
    if min(out) < 1:
        parser.error(f"{what}: sample counts must be >= 1, got {text!r}")
    return out


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


def _cmd_lab(args: argparse.Namespace) -> int:
    import pandas as pd

    from .integrands import get, names
    from .lab import (
        build,
        convergence_plot,
        equal_time,
        fit_slopes,
        get_recipe,
        run,
        summarize,
    )

    parser = args.parser
    if args.list:
        return _lab_list(args)
    if not args.integrand or not args.estimators:
        parser.error("give --integrand and --estimators (or --list to see the choices)")
    integrands = _csv_list(args.integrand, "--integrand", parser)
    unknown = [i for i in integrands if i not in names()]
    if unknown:
        parser.error(f"--integrand: unknown {', '.join(map(repr, unknown))}; choose from {', '.join(names())}")
    estimators = _csv_list(args.estimators, "--estimators", parser)
    ns = _int_list(args.n, "--n", parser)
    if args.reps < 2:
        parser.error(f"--reps: need at least 2 repetitions for an RMSE and a variance, got {args.reps}")
    if args.workers < 1:
        parser.error(f"--workers must be >= 1, got {args.workers}")
    for e in estimators:
        try:
            get_recipe(e)
            for i in integrands:
                build(e, get(i))
        except ValueError as exc:
            parser.error(f"--estimators: {exc}")
    progress = args.progress if args.progress is not None else sys.stderr.isatty()
    try:
        df = run(estimators, integrands, ns, args.reps, rng=args.seed, progress=progress, workers=args.workers)
    except ValueError as exc:
        parser.error(str(exc))
    summary = summarize(df)
    slopes = fit_slopes(summary)
    eq = equal_time(summary)
    if args.csv:
        df.to_csv(args.csv, index=False)
    if args.plot:
        convergence_plot(summary, args.plot)
    if args.json:
        print(json.dumps({"seed": args.seed, "integrands": integrands, "estimators": estimators, "n": ns,
                          "reps": args.reps, "summary": _records(summary),
                          "slopes": _records(slopes), "equal_time": _records(eq),
                          "csv": args.csv, "plot": args.plot}, indent=2, default=_json_default))
        return 0
    cols = ["estimator", "integrand", "n", "mean", "bias", "rmse", "variance", "mean_stderr", "z_std",
            "coverage", "seconds", "efficiency"]
    with pd.option_context("display.width", 200, "display.max_columns", 30, "display.max_rows", 500):
        print(f"vrlab lab: {args.reps} repetitions, seed {args.seed}")
        print(summary[cols].to_string(index=False, float_format=lambda v: f"{v:.4g}"))
        print("\nRMSE slopes in log-log (fitted vs theory):")
        print(slopes[["estimator", "integrand", "slope", "slope_se", "theory", "theory_note"]]
              .to_string(index=False, float_format=lambda v: f"{v:.3f}"))
        at = eq[eq["n"] == eq.groupby("integrand")["n"].transform("max")]
        print(f"\nEqual time at the largest n: efficiency relative to {eq['reference'].iloc[0]} "
              "(variance x seconds ratio; > 1 is better):")
        print(at[["integrand", "n", "estimator", "relative_variance", "relative_efficiency"]]
              .to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    if args.csv or args.plot:
        print("\nwrote " + ", ".join(p for p in (args.csv, args.plot) if p))
    return 0


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


def _cmd_render(args: argparse.Namespace) -> int:
    import dataclasses
    import os
    import time

    import numpy as np

    from .render import builtin_scene_path, list_builtin_scenes, load_scene, render
    from .render.image import rel_mse, save_image

    if args.list:
        print("\n".join(list_builtin_scenes()))
        return 0
    if not args.scene:
        raise SystemExit("vrlab render: give a scene (an XML path or a built-in name; --list shows them)")
    path = args.scene if os.path.exists(args.scene) else builtin_scene_path(args.scene)
    scene = load_scene(path)
    if args.width or args.height:
        scene.sensor = dataclasses.replace(scene.sensor, width=args.width or scene.sensor.width,
                                           height=args.height or scene.sensor.height)
    if args.compare:
        from .render.compare import compare, compare_figure

        res = compare(scene, args.compare.split(","), args.spp or scene.sensor.spp, rng=args.seed,
                      reference=np.load(args.reference) if args.reference else None,
                      equal_time=args.equal_time)
        out = {"scene": str(path), "spp": res["spp"], "rel_mse": res["rel_mse"], "seconds": res["seconds"]}
        if args.output:
            out["figure"] = str(compare_figure(res, args.output, exposure=args.exposure))
        print(json.dumps(out, indent=2) if args.json else
              "\n".join(f"{k:12s} relMSE {v:.4g}  {res['seconds'][k]:.2f} s" for k, v in res["rel_mse"].items()))
        return 0
    t0 = time.perf_counter()
    if args.workers is None:
        from .render.film import default_workers
        args.workers = default_workers()
    show = args.progress if args.progress is not None else sys.stderr.isatty()
    bar = None
    if show:
        from .lab.runner import ProgressBar
        bar = ProgressBar(scene.sensor.width * scene.sensor.height, label="render")

    def progress(done, total):
        bar.update(done - bar.done)

    img, err = render(scene, args.spp, args.strategy, rng=args.seed, pixel_sampler=args.pixel_sampler,
                      light_selection=args.light_selection, emitter_samples=args.emitter_samples,
                      bsdf_samples=args.bsdf_samples, ris_candidates=args.ris_candidates,
                      workers=args.workers, progress=progress if bar else None)
    seconds = time.perf_counter() - t0
    spp = args.spp or scene.sensor.spp
    out = {"scene": str(path), "strategy": args.strategy, "spp": spp, "workers": args.workers,
           "width": scene.sensor.width,
           "height": scene.sensor.height, "seconds": seconds,
           "samples_per_second": scene.sensor.width * scene.sensor.height * spp / seconds,
           "mean_stderr": float(np.nanmean(err))}
    if args.output:
        out["output"] = str(save_image(args.output, img, args.exposure))
    if args.stderr_out:
        out["stderr_output"] = str(save_image(args.stderr_out, err))
    if args.reference:
        out["rel_mse"] = rel_mse(img, np.load(args.reference))
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        print("  ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in out.items()))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="vrlab",
        description="Monte Carlo estimators and variance reduction for rendering: samplers, warps, the integral lab, benchmarks.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    demo = sub.add_parser("demo", help="run the showcase on built-in defaults and write figures and tables",
                          description="Draw every warp's samples against its pdf, compare point sets "
                                      "(discrepancy) and samplers (speed); writes PNG and CSV files.")
    demo.add_argument("--out", default="vrlab-demo", help="output folder (default: %(default)s)")
    demo.add_argument("--seed", type=int, default=2026, help="root seed (default: %(default)s)")
    demo.add_argument("--quick", action="store_true", help="smaller sample counts (a few seconds)")
    demo.add_argument("--json", action="store_true", help="print a JSON summary of what was written")
    demo.set_defaults(func=_cmd_demo)

    lab = sub.add_parser("lab", help="compare estimators on lab integrands: RMSE, slopes, efficiency",
                         description="Run estimator recipes on catalogue integrands at several sample counts, "
                                     "repeated with spawned seeds; print a summary (bias, RMSE, variance, "
                                     "calibration of the standard errors, efficiency) and log-log RMSE slopes.",
                         epilog="examples: vrlab lab --list;  vrlab lab --integrand exp --estimators "
                                "mc,antithetic,cv,jittered --n 64,256,1024 --reps 50 --plot conv.png")
    lab.add_argument("--list", action="store_true", help="list integrands and recipes (and which apply where)")
    lab.add_argument("--integrand", metavar="NAME[,NAME]", help="catalogue integrand(s), see --list")
    lab.add_argument("--estimators", metavar="A,B,C", help="estimator recipes, e.g. mc,is:linear,mis-balance")
    lab.add_argument("--n", default="64,256,1024", metavar="N1,N2,...",
                     help="sample counts = integrand evaluations (default: %(default)s)")
    lab.add_argument("--reps", type=int, default=50, help="repetitions per setting (default: %(default)s)")
    lab.add_argument("--seed", type=int, default=0, help="root seed (default: %(default)s)")
    lab.add_argument("--workers", type=int, default=1, help="worker processes (same numbers for any count)")
    lab.add_argument("--csv", metavar="FILE", help="write the per-repetition rows as CSV")
    lab.add_argument("--plot", metavar="FILE.png", help="write the convergence plot (RMSE vs n)")
    lab.add_argument("--json", action="store_true", help="print summary, slopes and equal-time tables as JSON")
    lab.add_argument("--progress", dest="progress", action="store_true", default=None,
                     help="progress bar on stderr (default: when stderr is a terminal)")
    lab.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    lab.set_defaults(func=_cmd_lab, parser=lab)

    bench = sub.add_parser("bench", help="time vrlab side by side with its peers (NumPy, SciPy)",
                           description="Benchmarks reported as ratios against the peers, in one run.")
    bench.add_argument("suite", choices=["sampling", "qmc", "discrete", "estimators"],
                       help="sampling = qmc + discrete; estimators = estimator overhead and memory")
    bench.add_argument("--quick", action="store_true", help="smaller sizes (seconds, for a smoke run)")
    bench.add_argument("--json", action="store_true", help="print the rows as JSON")
    bench.set_defaults(func=_cmd_bench)
    from .render.direct import PIXEL_SAMPLERS, STRATEGIES

    rend = sub.add_parser("render", help="render a Mitsuba 3 XML scene (or a built-in one) with direct lighting",
                          description="Direct lighting with a choice of sampling strategy; writes .npy (linear), "
                                      ".png (tonemapped sRGB) or .exr.")
    rend.add_argument("scene", nargs="?", help="XML path or built-in scene name (see --list)")
    rend.add_argument("--list", action="store_true", help="list the built-in scenes")
    rend.add_argument("--spp", type=int, default=None, help="samples per pixel (default: the scene's)")
    rend.add_argument("--strategy", choices=list(STRATEGIES), default="mis-power")
    rend.add_argument("--pixel-sampler", choices=list(PIXEL_SAMPLERS), default="independent")
    rend.add_argument("--light-selection", choices=["uniform", "power"], default="uniform")
    rend.add_argument("--seed", type=int, default=0)
    rend.add_argument("--emitter-samples", type=int, default=None,
                      help="light samples per shading point (default: the scene integrator's)")
    rend.add_argument("--bsdf-samples", type=int, default=None,
                      help="BSDF samples per shading point (default: the scene integrator's)")
    rend.add_argument("--ris-candidates", type=int, default=8, help="light candidates per RIS sample (ris)")
    rend.add_argument("--workers", type=int, default=None,
                      help="worker processes (default: the CPUs available; tiles are seeded per tile, so "
                           "the image is the same for any count)")
    rend.add_argument("--progress", dest="progress", action="store_true", default=None,
                      help="progress bar on stderr (default: when stderr is a terminal)")
    rend.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    rend.add_argument("--width", type=int, default=None, help="override the film width")
    rend.add_argument("--height", type=int, default=None, help="override the film height")
    rend.add_argument("-o", "--output", help="image file: .npy, .png or .exr")
    rend.add_argument("--stderr-out", help="per-pixel standard error image (.npy, .png or .exr)")
    rend.add_argument("--reference", help="reference .npy: print relMSE = mean((img-ref)^2/(ref^2+0.01))")
    rend.add_argument("--exposure", type=float, default=1.0, help="exposure scale for .png")
    rend.add_argument("--compare", metavar="S1,S2,...", nargs="?", const="bsdf,light,mis-power",
                      help="render a grid of strategies at equal spp with relMSE under each panel "
                           "(default: the Veach figure bsdf,light,mis-power); -o names the figure (.png)")
    rend.add_argument("--equal-time", action="store_true",
                      help="with --compare: give each strategy the time the last one needs for --spp")
    rend.add_argument("--json", action="store_true", help="print time, samples/s and errors as JSON")
    rend.set_defaults(func=_cmd_render)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    return args.func(args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
