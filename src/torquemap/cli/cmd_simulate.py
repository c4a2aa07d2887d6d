"""CLI: the ``simulate`` command group; ``simulate scara`` writes the simulated SCARA bench.

``simulate figures`` draws the paper's Figs 3-8 from a bench folder; ``simulate rig`` is
registered by :mod:`torquemap.cli.cmd_simulate_rig`.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from torquemap.cli import cmd_fleet, cmd_simulate_actuator, cmd_simulate_rig
from torquemap.cli.helptext import described
from torquemap.cli.outputs import check_outputs

_FILES = ("robot.toml", "sweep.csv", "circle.csv", "truth.csv", "truth.toml")


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add the ``simulate`` group, its ``scara`` sub-command, and ``rig`` from its module."""
    group = subparsers.add_parser(
        "simulate",
        help="write the files of a simulated bench",
        **described(
            "Simulated benches to try torquemap without hardware, and to check it against a "
            "known truth: scara (the SCARA of Simpson, Cook & Li), rig (the motor "
            "characterisation bench of the Adept II paper), figures (the first paper's Figs 3 "
            "to 8 from a scara folder).",
            [
                "torquemap simulate scara --out bench",
                "torquemap simulate rig --motor vr --out rig",
            ],
        ),
    )
    benches = group.add_subparsers(dest="bench", metavar="BENCH", help="the bench to simulate")
    benches.required = True
    scara = benches.add_parser(
        "scara",
        help="the paper's SCARA: no-load sweeps, a 130 mm circle about a 3.5 N spring, truth",
        **described(
            "Simulate the SCARA bench of Simpson, Cook & Li and write robot.toml, sweep.csv "
            "(no-load identification sweeps), circle.csv (a 130 mm circle about a 3.5 N "
            "spring), truth.csv and truth.toml (for checking only) into DIR (docs/formats.md). "
            "The files are a function of the seed alone.",
            ["torquemap simulate scara --out bench", "torquemap simulate scara --out b7 --seed 7"],
        ),
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
        "(torquemap.sim.scara_family) instead of the paper's bench; truth.toml says what was drawn",
    )
    scara.set_defaults(handler=_scara)
    figures = benches.add_parser(
        "figures",
        help="draw the paper's Figs 3-8 from a simulated SCARA bench folder",
        **described(
            "Identify the bench's sweeps, estimate on its circle with the paper method, and "
            "write fig3..fig8 PNG files (Simpson, Cook & Li) into --out.",
            [
                "torquemap simulate figures bench --out figs",
                "torquemap simulate figures bench --out figs --model bench/model.toml",
            ],
        ),
    )
    figures.add_argument("bench_dir", metavar="BENCH_DIR", help="folder of `simulate scara`")
    figures.add_argument("--out", metavar="DIR", required=True, help="output folder (created)")
    figures.add_argument(
        "--model", metavar="MODEL.toml", default=None, help="use this model, not a new one"
    )
    figures.set_defaults(handler=_figures)
    arm = benches.add_parser(
        "arm",
        help="a Panda (or UR5, xArm7, Z1, Jaco2, or a leg) in MuJoCo unlike its URDF: free.csv, task.csv (5-20 N on a surface), truth",
        description="Simulate a Panda, UR5, xArm7, Z1 or Jaco2 (example-robot-data) in MuJoCo whose true masses differ "
        "from its URDF by up to 15 % and which carries a 0.8 kg tool, and write robot.toml, "
        "panda.urdf (or <arm>.urdf), free.csv, task.csv, truth.csv, truth.toml and truth.urdf into DIR "
        "(docs/arm.md). --arm leg: a vertical two-link leg (gravity in its plane, a 0.3 kg mass "
        "its URDF lacks) whose foot steps on a compliant ground in task.csv; leg.urdf "
        "(docs/arm-bench.md).",
        epilog="examples:\n  torquemap simulate arm --out arm --random 1\n"
        "  torquemap simulate arm --arm leg --out leg\n"
        "  torquemap identify arm/robot.toml arm/free.csv -o arm/model.toml\n"
        "  torquemap estimate arm/model.toml arm/task.csv -o arm/forces.csv",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    arm.add_argument("--out", metavar="DIR", required=True, help="output folder (created)")
    arm.add_argument(
        "--random", metavar="SEED", type=int, default=0, help="seed of the true arm (default 0)"
    )
    arm.add_argument(
        "--arm",
        choices=("panda", "ur5", "xarm7", "z1", "jaco2", "leg"),
        default="panda",
        help="the example-robot-data arm (a 7-axis Panda or xArm7; a 6-axis UR5, Unitree Z1 "
        "or Kinova Jaco2), or the two-link leg (default panda)",
    )
    arm.add_argument(
        "--free-duration",
        type=float,
        default=100.0,
        metavar="S",
        help="[s] (default 100): whole traversals of torquemap excite's default path, at "
        "full speed and at a quarter, up to this length rounded up (Panda 115 s)",
    )
    arm.add_argument(
        "--task-duration", type=float, default=15.0, metavar="S", help="[s] (default 15)"
    )
    arm.set_defaults(handler=_arm)
    cmd_simulate_rig.register(benches)
    cmd_fleet.register_simulate(benches)
    cmd_simulate_actuator.register(benches)


def _scara(args: argparse.Namespace) -> int:
    from torquemap.sim.bench import write_scara_bench
    from torquemap.sim.scara_family import random_bench_or_error

    check_outputs([], folders=[(args.out, _FILES)])

    bench = None if args.random is None else random_bench_or_error(args.random)
    seed = args.seed if args.seed is not None else (args.random or 0)
    args.progress.run(
        "simulate the SCARA bench (sweeps and circle)",
        lambda: write_scara_bench(args.out, seed=seed, bench=bench),
    )
    print(f"wrote {', '.join(_FILES)} to {args.out}")
    return 0


def _arm(args: argparse.Namespace) -> int:
    from torquemap.errors import InputError
    from torquemap.sim.arm import write_arm_bench

    if args.random < 0:
        raise InputError(f"--random must be >= 0, got {args.random}")
    check_outputs([], folders=[(args.out, ())])  # one line, before any work
    for name in ("free_duration", "task_duration"):
        if not 2.0 <= getattr(args, name) <= 600.0:
            raise InputError(f"--{name.replace('_', '-')} must be in [2, 600] s")
    paths = write_arm_bench(
        args.out,
        seed=args.random,
        free_duration=args.free_duration,
        task_duration=args.task_duration,
        arm=args.arm,
    )
    print(f"wrote {', '.join(p.name for p in paths)} to {args.out}")
    return 0


def _figures(args: argparse.Namespace) -> int:
    from torquemap.sim.paper_figures import BENCH_FILES, write_paper_figures

    bench = Path(args.bench_dir)
    check_outputs(
        [], [args.model, *(bench / name for name in BENCH_FILES)], folders=[(args.out, ())]
    )

    paths = args.progress.run(
        "identify, estimate and draw Figs 3 to 8",
        lambda: write_paper_figures(args.bench_dir, args.out, model_path=args.model),
    )
    print(f"wrote {', '.join(p.name for p in paths)} to {args.out}")
    return 0
