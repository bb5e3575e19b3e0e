"""Time vrlab Halton/Hammersley against scipy.stats.qmc.Halton and print a table.

    python benchmarks/bench_qmc.py [--quick] [--csv out.csv]
"""
from __future__ import annotations

import argparse

import pandas as pd

from vrlab.bench.qmc import bench_qmc


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2^16 points instead of 2^20")
    parser.add_argument("--csv", help="also write the rows to this CSV file")
    args = parser.parse_args()
    df = pd.DataFrame(bench_qmc(quick=args.quick))
    with pd.option_context("display.width", 160, "display.max_columns", 20):
        print(df.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    if args.csv:
        df.to_csv(args.csv, index=False)


if __name__ == "__main__":
    main()
