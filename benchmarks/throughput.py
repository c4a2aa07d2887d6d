"""Throughput of ``torquemap estimate`` and ``identify`` against the read-plus-one-pass floor.

The simulated SCARA bench (``simulate scara``, seed 0) is identified once; its 31 s circle
(62 k samples at 2 kHz) is tiled, forwards (a position jump at each seam, cut there), into
Parquet logs of 0.25, 1, 4 and 16 M samples, and its sweep likewise for ``identify`` (the
pass method, ``--friction passes``, and the default whole-log fit, ``--friction whole``). A
tiled sweep repeats the same revolutions, so it does not show what a truly longer sweep does to the PDTV line search:
``--long`` also simulates the bench with every sweep pass ``F`` times as many revolutions
(``Sweep.revolutions``) and identifies that, reporting the PDTV lines found against the
simulator's truth. Each command runs in its own process with one BLAS thread; the process
reports the CPU time (user + sys) of the command alone (after its imports) and its peak
resident memory (``VmHWM``, the imports' own share given apart). The floor, measured in the
same run on the same file (median of three runs): read the Parquet log (pyarrow; by row
groups above 16 M samples, where the whole table would not fit a small machine) and make
one numpy pass over every column. The ratio is CPU time over floor: the issue asks for
estimate within 5x and identify within 10x at 4 M samples, and both linear in the length
(seconds per million samples flat). The wall time (the command's elapsed seconds, same
process) and its ratio to the floor's wall time are given beside it: ``estimate`` of a log
in blocks runs ``--threads`` blocks at once (its default: the machine's cores, at most 2), so
its wall time is what a user waits for on a machine with cores to spare; ``--threads 1 2``
runs every estimate size with each count, one after the other (the ``threads`` column; ``-``:
the command's default or a command without the option). On a machine shared with other
jobs the wall time measures the load as well: compare runs made back to back.

    python benchmarks/throughput.py                      # the defaults below
    python benchmarks/throughput.py --sizes 0.25 1 --identify-sizes --whole-sizes --long
    python benchmarks/throughput.py --sizes 64 --identify-sizes --whole-sizes --long  # once
    python benchmarks/throughput.py --sizes 1 4 --seamless-sizes 4 --identify-sizes \
        --whole-sizes --long                             # estimate only, with a seamless log
    python benchmarks/throughput.py --sizes 1 4 --identify-sizes --whole-sizes --long \
        --threads 1 2                                    # estimate in one thread and in two
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

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
w0 = time.perf_counter()
t0 = time.process_time()
if kind == "floor":
    total = 0.0
    if pyarrow.parquet.ParquetFile(args[0]).metadata.num_rows <= 16_000_000:
        table = pyarrow.parquet.read_table(args[0])
        for name in table.column_names:
            total += float(numpy.sum(numpy.diff(table.column(name).to_numpy())))
    else:
        for batch in pyarrow.parquet.ParquetFile(args[0]).iter_batches(batch_size=1 << 20):
            for column in batch.columns:
                total += float(numpy.sum(numpy.diff(column.to_numpy())))
else:
    import contextlib, io
    with contextlib.redirect_stdout(io.StringIO()):
        code = main([kind, *args, "--quiet"])
    assert code == 0, code
cpu = time.process_time() - t0
wall = time.perf_counter() - w0
peak = peak_kb()
print(json.dumps({"cpu": cpu, "wall": wall, "peak_kb": peak, "base_kb": base}))
"""


def _run(kind: str, *args: str) -> dict[str, Any]:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    out = subprocess.run(
        [sys.executable, "-c", CHILD, kind, *args],
        check=True,
        capture_output=True,
        text=True,
        env=env,
    )
    result: dict[str, Any] = json.loads(out.stdout.strip().splitlines()[-1])
    return result


def tile(
    columns: dict[str, np.ndarray], n: int, *, start: int = 0, seamless: bool = False
) -> dict[str, np.ndarray]:
    """Samples ``start:start + n`` of a log repeated forwards, at its own step from t = 0.

    Each repeat starts where the log starts (a position jump at the seam, which sanitising cuts
    there); a log played backwards would not do: friction would aid the motion, and identify
    refuses such a log as holding torque it cannot explain. ``seamless``: each repeat's angles
    (``q_*``) continue from where the last ended (the circle starts and ends at rest), so that
    the log has no seam and is estimated in pieces as long as the blocks, as a long recording
    is (the arm turns on from repeat to repeat: a timing case, not a physical one).
    """
    t = columns["t"]
    m = t.size
    h = float(np.median(np.diff(t)))
    at = np.arange(start, start + n)
    idx = at % m
    out = {"t": h * at}
    for name, values in columns.items():
        if name != "t":
            out[name] = values[idx]
            if seamless and name.startswith("q_"):
                out[name] = out[name] + (at // m) * (values[-1] - values[0])
    return out


def _tiles(
    columns: dict[str, np.ndarray], n: int, rows: int, *, seamless: bool = False
) -> Iterator[dict[str, np.ndarray]]:
    for start in range(0, n, rows):
        yield tile(columns, min(rows, n - start), start=start, seamless=seamless)


def _write_parquet(
    path: Path, columns: dict[str, np.ndarray], n: int, *, seamless: bool = False
) -> None:
    """``n`` tiled samples written by row groups of 2^20 (memory bounded for any ``n``)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    writer = None
    try:
        for part in _tiles(columns, n, 1 << 20, seamless=seamless):
            table = pa.table(part)
            if writer is None:
                writer = pq.ParquetWriter(path, table.schema)
            writer.write_table(table, row_group_size=1 << 20)
    finally:
        if writer is not None:
            writer.close()


def _read_csv(path: Path) -> dict[str, np.ndarray]:
    import pyarrow.csv as pacsv

    table = pacsv.read_csv(path)
    return {name: table.column(name).to_numpy() for name in table.column_names}


def _lines(path: Path) -> dict[str, list[float]]:
    """PDTV orders per joint of a model or truth file."""
    import tomllib

    doc = tomllib.loads(path.read_text())
    return {
        name: sorted({float(line["order"]) for line in joint.get("pdtv", [])})
        for name, joint in doc.get("joints", {}).items()
    }


def _long_bench(root: Path, factor: float) -> Path:
    """The seed-0 bench with every sweep pass ``factor`` times as many revolutions."""
    from torquemap.sim.bench import write_scara_bench
    from torquemap.sim.scara import default_bench

    bench = default_bench()
    sweep = dataclasses.replace(bench.sweep, revolutions=bench.sweep.revolutions * factor)
    out = root / f"long{factor:g}"
    write_scara_bench(out, bench=dataclasses.replace(bench, sweep=sweep))
    return out


def _floor(log: Path) -> dict[str, Any]:
    # the floor is a fraction of a second: the median of three runs
    return sorted((_run("floor", str(log)) for _ in range(3)), key=lambda r: r["cpu"])[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=float, nargs="*", default=[0.25, 1, 4, 16])
    parser.add_argument("--identify-sizes", type=float, nargs="*", default=[0.25, 1, 4])
    parser.add_argument("--whole-sizes", type=float, nargs="*", default=[0.25, 1])
    parser.add_argument(
        "--seamless-sizes",
        type=float,
        nargs="*",
        default=[],
        help="estimate also a circle tiled without seams (one piece per block) of these sizes",
    )
    parser.add_argument(
        "--long",
        type=float,
        nargs="*",
        default=[1, 4],
        help="sweeps simulated with this many times the revolutions per pass (identify)",
    )
    parser.add_argument(
        "--threads",
        type=int,
        nargs="*",
        default=[],
        help="run each estimate size with estimate --threads N for each N given, in turn "
        "(default: once, with the command's own default)",
    )
    args = parser.parse_args()
    from torquemap.cli.main import main as cli

    rows = []
    notes = []
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        bench = root / "bench"
        cli(["simulate", "scara", "--out", str(bench), "--quiet"])
        robot = str(bench / "robot.toml")
        model = bench / "model.toml"
        cli(["identify", robot, str(bench / "sweep.csv"), "-o", str(model), "--quiet"])
        circle = _read_csv(bench / "circle.csv")
        sweep = _read_csv(bench / "sweep.csv")
        for kind, sizes, source in (
            ("estimate", args.sizes, circle),
            ("estimate (seamless)", args.seamless_sizes, circle),
            ("identify --friction passes", args.identify_sizes, sweep),
            ("identify --friction whole", args.whole_sizes, sweep),
        ):
            for size in sizes:
                n = round(size * 1e6)
                log = root / f"log_{n}.parquet"
                _write_parquet(log, source, n, seamless=kind.endswith("(seamless)"))
                floor = _floor(log)
                if kind.startswith("estimate"):
                    for threads in args.threads or [None]:
                        extra = [] if threads is None else ["--threads", str(threads)]
                        out = str(root / "f.parquet")
                        run = _run("estimate", str(model), str(log), "-o", out, *extra)
                        run["threads"] = threads
                        rows.append((kind, f"{n / 1e6:g} M", n, run, floor))
                else:
                    extra = kind.split()[1:]
                    run = _run("identify", robot, str(log), "-o", str(root / "m.toml"), *extra)
                    rows.append((kind, f"{n / 1e6:g} M", n, run, floor))
                log.unlink()
                print(f"  {kind} {n / 1e6:g} M done", file=sys.stderr, flush=True)
        for factor in args.long:
            folder = _long_bench(root, factor)
            columns = _read_csv(folder / "sweep.csv")
            n = columns["t"].size
            log = root / "long.parquet"
            _write_parquet(log, columns, n)
            floor = _floor(log)
            run = _run(
                "identify",
                str(folder / "robot.toml"),
                str(log),
                "-o",
                str(root / "m.toml"),
                "--friction",
                "passes",
            )
            found, truth = _lines(root / "m.toml"), _lines(folder / "truth.toml")
            label = "identify --friction passes"
            rows.append((label, f"sweep x{factor:g} ({n / 1e6:.2f} M)", n, run, floor))
            notes.append(
                f"sweep x{factor:g}: PDTV orders found "
                + "; ".join(f"{j} {found.get(j)} (truth {truth[j]})" for j in truth)
            )
            log.unlink()
            print(f"  long sweep x{factor:g} done", file=sys.stderr, flush=True)
    print(
        "| command | samples | CPU [s] | samples/s | s per M | peak RSS [MB] (imports) "
        "| floor [s] | ratio to floor | threads | wall [s] | floor wall [s] "
        "| wall ratio to floor |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for kind, label, n, run, floor in rows:
        cpu = run["cpu"]
        threads = run.get("threads")
        print(
            f"| {kind} | {label} | {cpu:.2f} | {n / cpu:.3g} | {cpu / (n / 1e6):.2f} | "
            f"{run['peak_kb'] / 1024:.0f} ({run['base_kb'] / 1024:.0f}) | {floor['cpu']:.2f} | "
            f"{cpu / floor['cpu']:.1f}x | {'-' if threads is None else threads} | "
            f"{run['wall']:.2f} | {floor['wall']:.2f} | {run['wall'] / floor['wall']:.1f}x |"
        )
    for line in notes:
        print(line)


if __name__ == "__main__":
    main()
