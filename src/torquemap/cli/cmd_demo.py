"""CLI: ``demo``, everything torquemap does on the built-in simulated benches (what ``make demo`` runs)."""

from __future__ import annotations

import argparse
from typing import Any


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``demo`` to subparsers."""
    p = subparsers.add_parser(
        "demo",
        help="simulate the benches, identify, estimate, build tables, write a report",
        description="Run torquemap end to end on the built-in simulated benches (the SCARA of "
        "Simpson, Cook & Li, a Panda arm in MuJoCo and the Adept II linearisation rig) and "
        "write DIR/report.html. "
        "Each step is reported on stderr (--quiet: none); the summary goes to stdout.",
        epilog="example:\n  torquemap demo --out demo-out\n  torquemap demo --out demo-out "
        "--seed 3 --quiet > summary.txt",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--out", metavar="DIR", default="demo-out", help="output folder (demo-out)")
    p.add_argument("--seed", type=int, default=0, help="noise seed, >= 0 (default 0)")
    p.set_defaults(handler=_demo)


def _demo(args: argparse.Namespace) -> int:
    from torquemap.cli.outputs import check_outputs
    from torquemap.demo import format_summary, run_demo

    check_outputs([], folders=[(args.out, ("report.html",))])

    summary = run_demo(args.out, seed=args.seed, progress=args.progress)
    print(format_summary(summary))
    return 0
