"""CLI: the ``simulate`` command group; ``simulate scara`` writes the simulated SCARA bench.

``simulate figures`` draws the paper's Figs 3-8 from a bench folder; ``simulate rig`` is
registered by :mod:`torquemap.cli.cmd_simulate_rig`.
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
    scara.add_argument(
        "--seed",
        type=int,
        default=None,
        help="noise seed, >= 0 (default 0, or SEED with --random)",
    )
    scara.add_argument(
        "--random",
        type=int,
        default=None,
        metavar="SEED",
        help="draw the robot, its friction laws, PDTV, logger and scenarios at random "
        "(torquemap.sim.family) instead of the paper's bench; truth.toml says what was drawn",
    )
    scara.set_defaults(handler=_scara)
    figures = benches.add_parser(
        "figures",
        help="draw the paper's Figs 3-8 from a simulated SCARA bench folder",
        description="Identify the bench's sweeps, estimate on its circle with the paper method, "
        "and write fig3..fig8 PNG files (Simpson, Cook & Li) into --out.",
    )
    figures.add_argument("bench_dir", metavar="BENCH_DIR", help="folder of `simulate scara`")
    figures.add_argument("--out", metavar="DIR", required=True, help="output folder (created)")
    figures.add_argument(
        "--model", metavar="MODEL.toml", default=None, help="use this model, not a new one"
    )
    figures.set_defaults(handler=_figures)
    cmd_simulate_rig.register(benches)


def _scara(args: argparse.Namespace) -> int:
    from torquemap.sim.bench import write_scara_bench
    from torquemap.sim.family import random_bench_or_error

    bench = None if args.random is None else random_bench_or_error(args.random)
    seed = args.seed if args.seed is not None else (args.random or 0)
    write_scara_bench(args.out, seed=seed, bench=bench)
    print(f"wrote {', '.join(_FILES)} to {args.out}")
    return 0


def _figures(args: argparse.Namespace) -> int:
    from torquemap.sim.paper_figures import write_paper_figures

    paths = write_paper_figures(args.bench_dir, args.out, model_path=args.model)
    print(f"wrote {', '.join(p.name for p in paths)} to {args.out}")
    return 0
