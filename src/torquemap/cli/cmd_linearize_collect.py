"""CLI: ``linearize collect``, data collection against a simulated rig (resumable).

Registered into the ``linearize`` group by :mod:`torquemap.cli.cmd_linearize`.
"""

from __future__ import annotations

import argparse
from typing import Any

from torquemap.cli.helptext import described
from torquemap.cli.outputs import output_suffix
from torquemap.progress import NULL


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``collect`` to the ``linearize`` group's sub-parsers."""
    collect = subparsers.add_parser(
        "collect",
        help="collect torque data (or verification data with --tables) on a simulated rig",
        **described(
            "Run the automated data collection of the Adept II paper (Fig 12) against a "
            "simulated rig and append the rows to DATA.csv; an existing DATA.csv is resumed. "
            "With --tables, a verification run through the phase tables (columns position, "
            "command, torque). See docs/linearize-collect.md.",
            [
                "torquemap linearize collect rig/motor.toml --sim vr -o data.csv",
                "torquemap linearize collect rig/motor.toml --sim vr --tables tables.npz "
                "-o after.csv",
            ],
        ),
    )
    collect.add_argument("motor", metavar="MOTOR.toml", help="the motor file")
    collect.add_argument("-o", "--out", metavar="DATA.csv", required=True, help="data file")
    collect.add_argument("--sim", choices=("vr", "bldc"), required=True, help="simulated motor")
    collect.add_argument("--seed", type=int, default=0, help="noise seed, >= 0 (default 0)")
    collect.add_argument(
        "--tables", metavar="TABLES.npz", help="phase tables: verification run instead"
    )
    collect.add_argument("--readings", type=int, default=10, help="readings per row (default 10)")
    collect.add_argument(
        "--bias-readings",
        type=int,
        default=None,
        help="readings averaged for the sensor bias at each position (default 10x --readings)",
    )
    collect.add_argument(
        "--bias-open",
        action="store_true",
        help="read the bias with the contact open, not at rest (where cogging alone loads the "
        "contact, the rows then hold the torque at rest)",
    )
    collect.add_argument(
        "--step", type=int, default=4, help="pulse-width or command step (default 4)"
    )
    collect.add_argument(
        "--position-step", type=int, default=4, help="table positions between targets (default 4)"
    )
    collect.add_argument(
        "--transitions",
        action="store_true",
        help="also target every position where the ramp changes (the phases' hand-over)",
    )
    collect.add_argument("--no-progress", action="store_true", help="no progress bar (as --quiet)")
    collect.set_defaults(handler=_collect)


def _collect(args: argparse.Namespace) -> int:
    from torquemap.cli.outputs import CSV, check_outputs
    from torquemap.linearize.motor import load_motor

    check_outputs([(args.out, CSV)], [args.motor, args.tables])  # DATA.csv itself: resumed
    from torquemap.sim.rig import collect_on_sim

    output_suffix(args.out, (".csv",), "data")
    spec = load_motor(args.motor)
    result = collect_on_sim(
        spec,
        args.out,
        sim=args.sim,
        seed=args.seed,
        tables=args.tables,
        readings=args.readings,
        bias_readings=args.bias_readings,
        bias_open=args.bias_open,
        transitions=args.transitions,
        step=args.step,
        position_step=args.position_step,
        progress=NULL if args.no_progress else args.progress,
    )
    resumed = f", resumed after {result.resumed_targets}" if result.resumed_targets else ""
    print(
        f"wrote {result.rows} rows ({result.new_rows} new{resumed}; "
        f"{result.targets.size} positions) to {args.out}"
    )
    return 0
