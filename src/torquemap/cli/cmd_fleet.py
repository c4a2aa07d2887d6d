"""CLI: ``fleet identify`` and ``fleet drift`` (torquemap.fleet, torquemap.drift), and
``simulate fleet`` (torquemap.sim.fleet)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

_IDENTIFY_EXAMPLE = """example:
  torquemap simulate fleet --robots 3 --days 5 --out fleet
  torquemap fleet identify fleet/FLEET.toml -o fleet-out --workers 2
  torquemap fleet drift fleet-out -o drift.csv
"""


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add the ``fleet`` group with ``identify`` and ``drift``."""
    group = subparsers.add_parser(
        "fleet",
        help="identify every robot and day of a fleet on Dask; friction and PDTV drift",
        description="Fleets: identify every robot-day listed in a fleet file in parallel, "
        "then follow each robot's friction and PDTV over time (docs/fleet.md).",
        epilog=_IDENTIFY_EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = group.add_subparsers(dest="fleet_command", metavar="STEP", help="identify, then drift")
    sub.required = True
    ident = sub.add_parser(
        "identify",
        help="one model per robot and day, in parallel on Dask",
        description="Identify every robot-day of FLEET.toml on a Dask cluster (local by "
        "default) and write OUT/<robot>/<date>.toml and OUT/fleet-run.toml. A robot-day that "
        "fails is reported with its reason; the others finish.",
        epilog=_IDENTIFY_EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ident.add_argument("fleet", metavar="FLEET.toml", help="the fleet file (docs/fleet.md)")
    ident.add_argument("-o", "--output", metavar="OUT", required=True, help="output folder")
    ident.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        default=None,
        help="address of a running Dask scheduler (default: a local cluster)",
    )
    ident.add_argument(
        "--workers", type=int, default=2, help="workers of the local cluster (default 2)"
    )
    ident.add_argument(
        "--window",
        type=float,
        default=None,
        metavar="S",
        help="differentiation window [s] (default: identification's)",
    )
    ident.set_defaults(handler=_identify)
    drift = sub.add_parser(
        "drift",
        help="each robot's friction and PDTV over time, trends and flags",
        description="Fit a trend to every friction parameter and PDTV line of every robot over "
        "the days of OUT (from `fleet identify`) and flag those that move beyond the "
        "identification's uncertainty (wear, lubrication, a loose belt).",
        epilog="example:\n  torquemap fleet drift fleet-out -o drift.csv\n",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    drift.add_argument("out_dir", metavar="OUT", help="output folder of `fleet identify`")
    drift.add_argument(
        "-o", "--output", metavar="TABLE", default=None, help="write the trends (.csv, .parquet)"
    )
    drift.add_argument(
        "--all", action="store_true", help="print every series, not only the flagged ones"
    )
    drift.set_defaults(handler=_drift)


def register_simulate(benches: argparse._SubParsersAction[Any]) -> None:
    """Add ``simulate fleet`` to the ``simulate`` group."""
    fleet = benches.add_parser(
        "fleet",
        help="a fleet of SCARA robots whose friction and PDTV drift with use",
        description="Simulate ROBOTS robots for DAYS days, one short no-load sweep per robot "
        "and day, with friction that grows with wear and PDTV lines that grow on some robots; "
        "writes FLEET.toml, the robots' files and logs, and truth.toml (docs/fleet.md).",
        epilog="example:\n  torquemap simulate fleet --robots 3 --days 5 --out fleet\n",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    fleet.add_argument("--robots", type=int, required=True, help="number of robots (>= 1)")
    fleet.add_argument("--days", type=int, required=True, help="days per robot (>= 1)")
    fleet.add_argument("--out", metavar="DIR", required=True, help="output folder (created)")
    fleet.add_argument("--seed", type=int, default=0, help="random seed, >= 0 (default 0)")
    fleet.add_argument(
        "--motors",
        action="store_true",
        help="a light fleet of single direct-drive motors (6 s closed-form sweeps) instead of "
        "SCARA robots: for trying the fleet commands on hundreds of robot-days",
    )
    fleet.set_defaults(handler=_simulate)


def _simulate(args: argparse.Namespace) -> int:
    from torquemap.cli.outputs import check_outputs
    from torquemap.sim.fleet import write_fleet, write_motor_fleet

    check_outputs([], folders=[(args.out, ())])  # one line, before any work
    if args.motors:
        path = write_motor_fleet(args.out, robots=args.robots, days=args.days, seed=args.seed)
        print(f"wrote {path}")
        return 0

    def tick(done: int, total: int) -> None:
        print(f"simulated {done}/{total} robot-days", file=sys.stderr, flush=True)

    path = write_fleet(args.out, robots=args.robots, days=args.days, seed=args.seed, progress=tick)
    print(f"wrote {path}")
    return 0


def _identify(args: argparse.Namespace) -> int:
    from torquemap.cli.outputs import check_outputs
    from torquemap.fleet import DayOutcome, identify_fleet, read_fleet, summary_lines

    check_outputs([], folders=[(args.output, ())])  # one line, before any work
    fleet = read_fleet(args.fleet)

    def tick(outcome: DayOutcome, done: int, total: int) -> None:
        state = "ok" if outcome.ok else "FAILED"
        print(
            f"[{done}/{total}] {outcome.robot} {outcome.date}: {state}", file=sys.stderr, flush=True
        )

    run = identify_fleet(
        fleet,
        args.output,
        scheduler=args.scheduler,
        workers=args.workers,
        window=args.window,
        progress=tick,
    )
    for line in summary_lines(run):
        print(line)
    print(f"wrote {args.output}/fleet-run.toml")
    return 0 if len(run.failed) < len(run.outcomes) else 1


def _drift(args: argparse.Namespace) -> int:
    from torquemap.cli.outputs import TABLE, check_outputs
    from torquemap.drift import drift_columns, fleet_drift

    check_outputs([(args.output, TABLE)])  # one line, before the trends are printed
    drift = fleet_drift(args.out_dir)
    if args.output is not None:
        from torquemap.io import write_table

        write_table(args.output, drift_columns(drift))
    for line in drift.skipped:
        print(f"skipped {line}")
    for line in drift.too_few:
        print(
            f"no trend for {line} (a trend needs two days whose models hold standard errors, "
            "else three)"
        )
    shown = drift.series if args.all else drift.flagged
    for s in shown:
        mark = "FLAG" if s.flag else "    "
        print(
            f"{mark} {s.robot} {s.joint} {s.parameter}: {s.values[0]:.4g} -> {s.values[-1]:.4g} "
            f"on {len(s.dates)} days, trend {s.slope:+.3g}/day +/- {s.slope_se:.2g} "
            f"({s.sigma_source}){': ' + s.note if s.note else ''}"
        )
    print(
        f"{len(drift.flagged)} of {len(drift.series)} series flagged "
        f"({len({s.robot for s in drift.flagged})} robots)"
    )
    if args.output is not None:
        print(f"wrote {args.output}")
    return 0
