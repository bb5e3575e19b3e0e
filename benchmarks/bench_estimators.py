"""Estimator overhead vs bare NumPy (MonteCarlo, MIS balance) and a 10^8-sample run's peak memory.

    python benchmarks/bench_estimators.py [--quick] [--json]
"""
import argparse
import json
import sys
from pathlib import Path

import pandas as pd

try:
    from vrlab.bench.estimators import bench_estimators
except ImportError:  # run from a checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from vrlab.bench.estimators import bench_estimators

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="10^6 samples, 10^7 for memory (seconds)")
    parser.add_argument("--json", action="store_true", help="print the rows as JSON")
    args = parser.parse_args()
    rows = bench_estimators(quick=args.quick)
    if args.json:
        print(json.dumps(rows, indent=2, default=float))
    else:
        with pd.option_context("display.width", 200, "display.max_columns", 20):
            print(pd.DataFrame(rows).to_string(index=False, float_format=lambda v: f"{v:.4g}"))
