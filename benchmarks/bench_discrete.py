"""Alias table vs NumPy choice vs SciPy DiscreteAliasUrn vs CDF table.

    python benchmarks/bench_discrete.py [--quick]
"""
import argparse
import sys
from pathlib import Path

import pandas as pd

try:
    from vrlab.bench.discrete import bench_discrete
except ImportError:  # run from a checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from vrlab.bench.discrete import bench_discrete

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="10^6 draws, smaller tables (a few seconds)")
    args = parser.parse_args()
    df = pd.DataFrame(bench_discrete(quick=args.quick))
    with pd.option_context("display.width", 160):
        print(df.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
