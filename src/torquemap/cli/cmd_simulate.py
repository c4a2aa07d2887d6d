"""CLI: the ``simulate`` command group; ``simulate scara`` writes the simulated SCARA bench.

``simulate rig`` is registered by :mod:`torquemap.cli.cmd_simulate_rig`.
"""

from __future__ import annotations

import argparse
from typing import Any

from torquemap.cli import cmd_simulate_rig

_FILES = ("robot.toml", "sweep.csv", "circle.csv", "truth.csv", "truth.toml")


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add the ``simulate`` group, its ``scara`` sub-command, and ``rig`` from its module."""
    group = subparsers.add_parser("simulate", help="write the files of a simulated bench")
    benches = group.add_subparsers(dest="bench", metavar="BENCH")
    benches.required = True
    scara = benches.add_parser(
        "scara",
        help="the paper's SCARA: no-load sweeps, a 130 mm circle about a 3.5 N spring, truth",
        description="Simulate the SCARA bench of Simpson, Cook & Li and write robot.toml, "
        "sweep.csv, circle.csv, truth.csv and truth.toml into DIR (docs/formats.md).",
    )
    scara.add_argument("--out", metavar="DIR", required=True, help="output folder (created)")
    scara.add_argument("--seed", type=int, default=0, help="noise seed, >= 0 (default 0)")
    scara.set_defaults(handler=_scara)
    cmd_simulate_rig.register(benches)


def _scara(args: argparse.Namespace) -> int:
    from torquemap.sim.bench import write_scara_bench

    write_scara_bench(args.out, seed=args.seed)
    print(f"wrote {', '.join(_FILES)} to {args.out}")
    return 0
