"""CLI: ``simulate rig``, a full characterisation run on the simulated bench (motor.toml, data.csv).

Registered into the ``simulate`` group by :mod:`torquemap.cli.cmd_simulate`.
"""

from __future__ import annotations

import argparse
from typing import Any

from torquemap.cli.helptext import described
from torquemap.cli.outputs import check_outputs
from torquemap.progress import NULL


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``rig`` to the ``simulate`` group's sub-parsers."""
    rig = subparsers.add_parser(
        "rig",
        help="a motor characterisation bench (Adept II paper): motor.toml and data.csv",
        **described(
            "Simulate the torque-linearisation data collection of the Adept II paper (Fig 12) "
            "on a variable reluctance or brushless DC motor and write DIR/motor.toml and "
            "DIR/data.csv (docs/linearize-collect.md). The defaults subsample the cycle: every "
            "4th table position and every 4th pulse width, 10 readings per row.",
            [
                "torquemap simulate rig --motor vr --out rig",
                "torquemap simulate rig --motor bldc --out rig_bldc --ramping narrow --transitions",
            ],
        ),
    )
    rig.add_argument("--motor", choices=("vr", "bldc"), required=True, help="motor type")
    rig.add_argument("--out", metavar="DIR", required=True, help="output folder (created)")
    rig.add_argument("--seed", type=int, default=0, help="noise seed, >= 0 (default 0)")
    rig.add_argument(
        "--ramping", choices=("narrow", "wide"), default="wide", help="ramping (default wide)"
    )
    rig.add_argument("--readings", type=int, default=10, help="readings per row (default 10)")
    rig.add_argument(
        "--bias-readings",
        type=int,
        default=None,
        help="readings averaged for the sensor bias at each position (default 10x --readings)",
    )
    rig.add_argument(
        "--bias-open",
        action="store_true",
        help="read the bias with the contact open, not at rest (where cogging alone loads the "
        "contact, the rows then hold the torque at rest)",
    )
    rig.add_argument("--pulse-step", type=int, default=4, help="pulse-width step (default 4)")
    rig.add_argument(
        "--position-step", type=int, default=4, help="table positions between targets (default 4)"
    )
    rig.add_argument(
        "--transitions",
        action="store_true",
        help="also target every position where the ramp changes (the phases' hand-over)",
    )
    rig.add_argument("--no-progress", action="store_true", help="no progress bar (as --quiet)")
    rig.set_defaults(handler=_rig)


def _rig(args: argparse.Namespace) -> int:
    from torquemap.sim.rig import write_rig_data

    check_outputs([], folders=[(args.out, ("motor.toml", "data.csv"))])

    result = write_rig_data(
        args.out,
        motor=args.motor,
        seed=args.seed,
        ramping=args.ramping,
        readings=args.readings,
        bias_readings=args.bias_readings,
        bias_open=args.bias_open,
        transitions=args.transitions,
        pulse_step=args.pulse_step,
        position_step=args.position_step,
        progress=NULL if args.no_progress else args.progress,
    )
    print(
        f"wrote motor.toml and data.csv ({result.rows} rows, {result.targets.size} positions, "
        f"{result.saturated_targets} stopped at sensor saturation) to {args.out}"
    )
    return 0
