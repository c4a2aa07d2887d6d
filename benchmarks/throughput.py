"""Throughput of ``torquemap estimate`` and ``identify`` against the read-plus-one-pass floor.

The simulated SCARA bench (``simulate scara``, seed 0) is identified once; its 31 s circle
(62 k samples at 2 kHz) is tiled, forwards (a position jump at each seam, cut there), into
Parquet logs of 0.25, 1, 4 and 16 M samples, and its sweep likewise for ``identify``. Each
command runs in its own process with one BLAS thread; the process reports the CPU time (user +
sys) of the command alone (after its imports) and its peak resident memory (``VmHWM``, the
imports' own share given apart). The floor, measured in the same run on the same file (median of three runs): read
the Parquet log (pyarrow) and make one numpy pass over every column. The ratio is CPU time over
floor: the issue asks for estimate within 5x and identify within 10x at 4 M samples, and both
linear in the length (seconds per million samples flat).

    python benchmarks/throughput.py                      # estimate 0.25-16 M, identify 0.25-4 M
    python benchmarks/throughput.py --sizes 0.25 1       # quicker
    python benchmarks/throughput.py --identify-sizes     # estimate only
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

CHILD = r"""
import json, os, resource, sys, time
import numpy, scipy.signal, scipy.ndimage, pyarrow.parquet
from torquemap.cli.main import main
kind, args = sys.argv[1], sys.argv[2:]
def peak_kb():
    # VmHWM: this process's own peak (ru_maxrss keeps the forking parent's across exec)
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1])
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
base = peak_kb()
t0 = time.process_time()
if kind == "floor":
    table = pyarrow.parquet.read_table(args[0])
    total = 0.0
    for name in table.column_names:
        total += float(numpy.sum(numpy.diff(table.column(name).to_numpy())))
else:
    import contextlib, io
    with contextlib.redirect_stdout(io.StringIO()):
        code = main([kind, *args, "--quiet"])
    assert code == 0, code
cpu = time.process_time() - t0
peak = peak_kb()
print(json.dumps({"cpu": cpu, "peak_kb": peak, "base_kb": base}))
"""


def _run(kind: str, *args: str) -> dict[str, float]:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    out = subprocess.run(
        [sys.executable, "-c", CHILD, kind, *args],
        check=True,
        capture_output=True,
        text=True,
        env=env,
    )
    result: dict[str, float] = json.loads(out.stdout.strip().splitlines()[-1])
    return result


def tile(columns: dict[str, np.ndarray], n: int) -> dict[str, np.ndarray]:
    """``n`` samples of a log repeated forwards, at its own step from t = 0.

    Each repeat starts where the log starts (a position jump at the seam, which sanitising cuts
    there); a log played backwards would not do: friction would aid the motion, and identify
    refuses such a log as holding torque it cannot explain.
    """
    t = columns["t"]
    m = t.size
    h = float(np.median(np.diff(t)))
    reps = -(-n // m)
    idx = np.concatenate([np.arange(m) for _ in range(reps)])
    out = {"t": h * np.arange(n)}
    for name, values in columns.items():
        if name != "t":
            out[name] = values[idx[:n]]
    return out


def _write_parquet(path: Path, columns: dict[str, np.ndarray]) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    pq.write_table(pa.table(columns), path, row_group_size=1 << 20)


def _read_csv(path: Path) -> dict[str, np.ndarray]:
    import pyarrow.csv as pacsv

    table = pacsv.read_csv(path)
    return {name: table.column(name).to_numpy() for name in table.column_names}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=float, nargs="*", default=[0.25, 1, 4, 16])
    parser.add_argument("--identify-sizes", type=float, nargs="*", default=[0.25, 1, 4])
    args = parser.parse_args()
    from torquemap.cli.main import main as cli

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        bench = root / "bench"
        cli(["simulate", "scara", "--out", str(bench), "--quiet"])
        model = bench / "model.toml"
        cli(["identify", str(bench / "robot.toml"), str(bench / "sweep.csv"), "-o", str(model)])
        circle = _read_csv(bench / "circle.csv")
        sweep = _read_csv(bench / "sweep.csv")
        rows = []
        for kind, sizes, source in (
            ("estimate", args.sizes, circle),
            ("identify", args.identify_sizes, sweep),
        ):
            for size in sizes:
                n = round(size * 1e6)
                log = root / f"{kind}_{n}.parquet"
                _write_parquet(log, tile(source, n))
                # the floor is a fraction of a second: the median of three runs
                floors = sorted((_run("floor", str(log)) for _ in range(3)), key=lambda r: r["cpu"])
                floor = floors[1]
                if kind == "estimate":
                    run = _run("estimate", str(model), str(log), "-o", str(root / "forces.parquet"))
                else:
                    run = _run(
                        "identify", str(bench / "robot.toml"), str(log), "-o", str(root / "m.toml")
                    )
                rows.append((kind, n, run, floor))
                log.unlink()
                print(f"  {kind} {n / 1e6:g} M done", file=sys.stderr, flush=True)
    print(
        "| command | samples | CPU [s] | samples/s | s per M | peak RSS [MB] (imports) "
        "| floor [s] | ratio to floor |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for kind, n, run, floor in rows:
        cpu = run["cpu"]
        print(
            f"| {kind} | {n / 1e6:g} M | {cpu:.2f} | {n / cpu:.3g} | {cpu / (n / 1e6):.2f} | "
            f"{run['peak_kb'] / 1024:.0f} ({run['base_kb'] / 1024:.0f}) | {floor['cpu']:.2f} | "
            f"{cpu / floor['cpu']:.1f}x |"
        )


if __name__ == "__main__":
    main()
