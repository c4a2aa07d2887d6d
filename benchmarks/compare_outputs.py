"""Compare every column of two ``torquemap estimate`` outputs (Parquet or CSV).

For each column: how many values differ bit for bit (NaN equal to NaN), and the largest
absolute and relative difference among the finite ones. Exit status 1 when a column is
missing, the row counts differ, or a column listed with ``--exact`` (every column when it is
given alone) is not bit for bit.

    python benchmarks/compare_outputs.py A.parquet B.parquet --exact tau_ext_a tau_ext_b fx fy flag
    python benchmarks/compare_outputs.py A.parquet B.parquet --exact   # every column
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
import pyarrow.csv
import pyarrow.parquet


def _read(path: str) -> dict[str, np.ndarray]:
    table = pyarrow.parquet.read_table(path) if path.endswith(".parquet") else None
    if table is None:
        table = pyarrow.csv.read_csv(path)
    return {name: table.column(name).to_numpy() for name in table.column_names}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("first")
    parser.add_argument("second")
    parser.add_argument(
        "--exact", nargs="*", default=None, help="columns that must match bit for bit"
    )
    args = parser.parse_args(argv)
    a, b = _read(args.first), _read(args.second)
    exact = [] if args.exact is None else (args.exact or list(a))
    ok = True
    if set(a) != set(b):
        print(f"columns differ: {sorted(set(a) ^ set(b))}")
        ok = False
    for name in a:
        if name not in b:
            continue
        x, y = a[name], b[name]
        if x.shape != y.shape:
            print(f"{name}: {x.shape[0]} rows against {y.shape[0]}")
            ok = False
            continue
        if x.dtype.kind == "f":
            same = (x.view(np.int64) == y.view(np.int64)) | (np.isnan(x) & np.isnan(y))
            both = np.isfinite(x) & np.isfinite(y)
            diff = np.abs(x[both] - y[both])
            scale = np.maximum(np.abs(x[both]), np.abs(y[both]))
            rel = diff / np.where(scale > 0, scale, 1.0)
            worst = (float(diff.max(initial=0.0)), float(rel.max(initial=0.0)))
            nan_mismatch = int(np.sum(np.isnan(x) != np.isnan(y)))
        else:
            same = x == y
            worst, nan_mismatch = (float(np.max(np.abs(x - y), initial=0)), 0.0), 0
        differ = int(x.size - np.sum(same))
        print(
            f"{name:>16}: {differ:>9} of {x.size} differ, max abs {worst[0]:.3g}, "
            f"max rel {worst[1]:.3g}, NaN mismatches {nan_mismatch}"
        )
        if name in exact and differ:
            ok = False
    print("OK" if ok else "MISMATCH")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
