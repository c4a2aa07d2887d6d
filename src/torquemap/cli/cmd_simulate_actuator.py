"""CLI: ``simulate actuator``, one motor on a test stand for the anti-cogging loop.

Registered into the ``simulate`` group by :mod:`torquemap.cli.cmd_simulate`.
"""

from __future__ import annotations

import argparse
from typing import Any


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``actuator`` to the ``simulate`` group's sub-parsers."""
    p = subparsers.add_parser(
        "actuator",
        help="one motor on a test stand: position holds (quasi-static calibration) and a sweep",
        description="Simulate one axis of the SCARA bench (motor, friction, PDTV of 1, 2, 3, 4, "
        "21 and 48 CPR, 8000-count encoder) on a test stand and write DIR/robot.toml, "
        "DIR/holds.csv (holds at --positions angles out and back, as on-device anti-cogging "
        "calibration), DIR/sweep.csv (a 3 rad/s sweep) and DIR/truth.toml. With --map, write "
        "only DIR/sweep_after.csv: the same sweep with that map applied as feed-forward.",
        epilog="examples:\n  torquemap simulate actuator --out stand\n"
        "  torquemap identify stand/robot.toml stand/holds.csv --quasi-static -o stand/model.toml\n"
        "  torquemap pdtv-map stand/model.toml --joint a --bins 1024 -o stand/cog.csv\n"
        "  torquemap simulate actuator --out stand --map stand/cog.csv\n"
        "  torquemap cogging verify stand/model.toml stand/sweep_after.csv stand/sweep.csv",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--out", metavar="DIR", required=True, help="output folder (created)")
    p.add_argument("--seed", type=int, default=0, help="noise seed, >= 0 (default 0)")
    p.add_argument(
        "--positions", type=int, default=128, help="hold positions per revolution (default 128)"
    )
    p.add_argument(
        "--map",
        metavar="MAP.csv",
        default=None,
        help="an anti-cogging map from `pdtv-map` (torque column): write sweep_after.csv",
    )
    p.set_defaults(handler=_actuator)


def _actuator(args: argparse.Namespace) -> int:
    from torquemap.errors import InputError
    from torquemap.sim.actuator import write_actuator_bench

    if args.positions < 8:
        raise InputError(f"--positions must be at least 8, got {args.positions}")
    from torquemap.cli.outputs import check_outputs

    check_outputs([], folders=[(args.out, ())])  # one line, before any work
    written = write_actuator_bench(
        args.out, seed=args.seed, compensation_path=args.map, positions=args.positions
    )
    print(f"wrote {', '.join(written)}")
    return 0
