"""CLI: ``simulate rig``, a full characterisation run on the simulated bench (motor.toml, data.csv).

Registered into the ``simulate`` group by :mod:`torquemap.cli.cmd_simulate`.
"""

from __future__ import annotations

import argparse
from typing import Any

from torquemap.cli.cmd_linearize_collect import add_settings_arguments, settings_from
from torquemap.cli.helptext import described
from torquemap.cli.outputs import check_outputs


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
    which = rig.add_mutually_exclusive_group(required=True)
    which.add_argument("--motor", choices=("vr", "bldc"), help="motor type")
    which.add_argument(
        "--random",
        type=int,
        metavar="SEED",
        help="a random motor, amplifier and bench of the family (VR or BLDC, 3 or 4 phases, "
        "dead zones, friction, ...), its ramp and collection settings drawn from SEED; "
        "collection flags given override the draw",
    )
    rig.add_argument("--out", metavar="DIR", required=True, help="output folder (created)")
    rig.add_argument("--seed", type=int, default=0, help="noise seed, >= 0 (default 0)")
    rig.add_argument(
        "--ramping",
        choices=("narrow", "wide"),
        default=None,
        help="ramping (default wide; with --random, drawn)",
    )
    add_settings_arguments(rig, level_flag="--pulse-step", level_help="pulse-width step")
    rig.set_defaults(handler=_rig)


def _rig(args: argparse.Namespace) -> int:
    import dataclasses

    from torquemap.sim.family import random_bench
    from torquemap.sim.rig import write_rig_data, write_rig_folder

    check_outputs([], folders=[(args.out, ("motor.toml", "data.csv"))])

    if args.random is None:
        settings = settings_from(args)
        result = write_rig_data(
            args.out,
            motor=args.motor,
            seed=args.seed,
            ramping=args.ramping or "wide",
            settings=settings,
        )
    else:
        bench = random_bench(args.random, noise_seed=args.seed)
        if args.ramping:  # the line below describes the bench as collected
            bench = dataclasses.replace(bench, ramping=args.ramping)
        settings = settings_from(args, bench.settings)
        result = write_rig_folder(
            args.out,
            bench.rig,
            ramping=args.ramping or bench.ramping,
            settings=settings,
        )
        print(bench.describe())
    print(
        f"wrote motor.toml and data.csv ({result.rows} rows, {result.targets.size} positions, "
        f"{result.saturated_targets} stopped at sensor saturation) to {args.out}"
    )
    from pathlib import Path

    from torquemap.cli.cmd_linearize_collect import warn_level_step, warn_position_step
    from torquemap.linearize.motor import load_motor

    spec = load_motor(Path(args.out) / "motor.toml")
    data = str(Path(args.out) / "data.csv")
    warn_level_step(data, settings.level_step, spec.actuation_max, "pulse width")
    warn_position_step(data, settings.position_step, spec)
    return 0
