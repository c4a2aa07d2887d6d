"""CLI: ``excite`` an exciting trajectory for identifying an arm (docs/arm.md); and the arm's
``identify`` / ``estimate`` handlers, which those commands call for arms with rigid-body dynamics.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``excite`` to subparsers."""
    p = subparsers.add_parser(
        "excite",
        help="an exciting trajectory (Fourier series within the URDF's limits) for identification",
        description="Write an exciting trajectory for an arm with a URDF: a Fourier series per "
        "joint that starts and ends at rest at the middle of each joint's range, stays inside "
        "the URDF's position and velocity limits, spans the ranges (up to +-pi), and is chosen "
        "for a well-conditioned regressor (inertial parameters and friction); the path is "
        "played at full speed and again at a quarter (--speeds), so that friction at low speed "
        "is seen at the same poses. Run it on the robot (after moving to the first row), log "
        "t, q_<j> and i_<j> or tau_<j>, and give the log to `torquemap identify`. "
        "No collision checking: try it slowly first.",
        epilog="example:\n  torquemap excite robot.toml -o excite.csv --duration 60",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("robot", metavar="ROBOT.toml", help="robot file of kind urdf")
    p.add_argument(
        "-o",
        "--output",
        metavar="TRAJ.csv|TRAJ.parquet",
        required=True,
        help="trajectory to write (t, q_<j>, qd_<j>, qdd_<j>)",
    )
    p.add_argument(
        "--duration",
        type=float,
        default=None,
        metavar="S",
        help="length [s], whole traversals rounded up (default: one traversal at each speed, "
        "5 periods with the default speeds)",
    )
    p.add_argument(
        "--period",
        type=float,
        default=None,
        metavar="S",
        help="fundamental period [s] of the path at full speed (default: twice the slowest "
        "joint's swing over its range at --speed-fraction of its speed limit, at most "
        "--duration: Panda 19.2 s, UR5 18 s; docs/arm.md)",
    )
    p.add_argument(
        "--speeds",
        default="1,0.25",
        metavar="V1,V2,...",
        help="speed schedule: the path is played at each of these fractions of its speed in "
        "turn (0 < |v| <= 1, negative: backwards; default 1,0.25)",
    )
    p.add_argument("--harmonics", type=int, default=5, metavar="N", help="harmonics per joint (5)")
    p.add_argument("--rate", type=float, default=500.0, metavar="HZ", help="sample rate (500)")
    p.add_argument(
        "--speed-fraction",
        type=float,
        default=0.7,
        metavar="F",
        help="fraction of each joint's URDF velocity limit used at most (0.7)",
    )
    p.add_argument(
        "--centre",
        default=None,
        metavar="Q1,Q2,...",
        help="pose [rad] to swing about, one angle per joint in the robot file's order "
        "(default: the middle of each joint's range); excite about the poses the robot works at",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the random search (0)")
    p.set_defaults(handler=_excite)


def _floats(text: str, flag: str, what: str) -> list[float]:
    """Comma-separated numbers; InputError naming ``flag`` otherwise."""
    from torquemap.errors import InputError

    try:
        return [float(v) for v in text.split(",")]
    except ValueError:
        raise InputError(f"{flag} must be comma-separated {what}, got {text!r}") from None


def _excite(args: argparse.Namespace) -> int:
    import numpy as np

    from torquemap.cli.outputs import TABLE, check_outputs
    from torquemap.errors import InputError
    from torquemap.excite import exciting_trajectory, trajectory_columns
    from torquemap.io import write_table
    from torquemap.robot import load_robot

    check_outputs([(args.output, TABLE)], [args.robot])  # before the search (docs/safety.md)
    robot = load_robot(args.robot)
    arm: Any = robot.arm
    if not hasattr(arm, "position_limits"):
        raise InputError("excite needs an arm with a URDF (kinematics = 'urdf')", path=args.robot)
    if not 0 < args.speed_fraction <= 1:
        raise InputError(f"--speed-fraction must be in (0, 1], got {args.speed_fraction}")
    centre = None if args.centre is None else _floats(args.centre, "--centre", "angles [rad]")
    speeds = _floats(args.speeds, "--speeds", "fractions")
    traj = exciting_trajectory(
        arm,
        duration=args.duration,
        speeds=speeds,
        period=args.period,
        harmonics=args.harmonics,
        rate=args.rate,
        speed_fraction=args.speed_fraction,
        centre=centre,
        rng=args.seed,
    )
    write_table(args.output, trajectory_columns(traj))
    print(
        f"{len(traj.joint_names)} joints, {traj.t[-1]:.4g} s, speeds "
        + ", ".join(f"{v:g}" for v in traj.speeds)
        + f", condition number of the regressor {traj.condition_number:.4g}"
    )
    linear = ~np.isfinite(np.asarray(arm.angle_period, dtype=float))  # prismatic: metres
    unit = "[rad]" if not linear.any() else "[rad; m for a prismatic joint]"
    print(
        f"start pose {unit}: "
        + ", ".join(f"{n}={c:.4f}" for n, c in zip(traj.joint_names, traj.centre, strict=True))
    )
    print(f"wrote {args.output}")
    return 0


def identify_arm_command(
    model: Any,
    log_paths: Sequence[str],
    output: str,
    *,
    exclude_contact: bool = False,
    window: float = 0.05,
) -> int:
    """``torquemap identify`` for an arm with rigid-body dynamics: identify, write, print."""
    import os
    from pathlib import Path

    from torquemap.identify_arm import identify_arm
    from torquemap.io import read_log, write_toml
    from torquemap.model import model_to_dict

    logs = [read_log(path, model.robot) for path in log_paths]
    result = identify_arm(model, logs, exclude_contact=exclude_contact, window=window)
    doc = model_to_dict(result.model)
    # the URDF is found relative to the model file: rewrite its path for the output's folder
    arm: Any = result.model.robot.arm
    urdf = Path(arm.urdf_path).resolve()
    folder = Path(output).resolve().parent
    doc["robot"]["urdf"] = os.path.relpath(urdf, folder)
    write_toml(output, doc)
    for w in result.warnings:
        print(f"torquemap: warning: {w}", file=sys.stderr)
    print(
        f"arm: {len(result.parameter_names)} parameters from {result.samples} samples, "
        f"condition number {result.condition_number:.4g}, "
        f"{'physically consistent' if result.consistent else 'NOT physically consistent'}"
    )
    for m in result.masses:
        print(f"  body {m.body}: mass {m.identified:.4g} +- {m.sigma:.2g} kg (URDF {m.urdf:.4g})")
    for k, name in enumerate(result.model.robot.joint_names):
        jm = result.model.joints[name]
        levels = jm.friction.static_levels()
        print(
            f"  {name}: armature {jm.inertia.constant:.4g} kg m^2, friction at rest "
            f"{levels[0]:+.4g}/{-levels[1]:+.4g} N m, {len(jm.pdtv)} PDTV lines, residual "
            f"{result.residual_sigma[k]:.3g} N m (motor side)"
        )
    print(f"wrote {output}")
    return 0


def estimate_arm_command(
    model: Any,
    log_path: str,
    output: str,
    *,
    method: str,
    cutoff: float,
    window: float,
    zero_phase: bool = False,
) -> int:
    """``torquemap estimate`` for an arm with rigid-body dynamics."""
    import numpy as np

    from torquemap.errors import InputError
    from torquemap.estimate_arm import arm_forces_columns, estimate_arm
    from torquemap.io import read_log, write_table

    if method not in ("acceleration", "momentum"):
        raise InputError(
            f"--method {method} is for single joints; an arm takes acceleration or momentum"
        )
    log = read_log(log_path, model.robot)
    est = estimate_arm(
        model,
        log,
        method="momentum" if method == "momentum" else "acceleration",
        cutoff=cutoff,
        window=window,
        zero_phase=zero_phase,
    )
    write_table(output, arm_forces_columns(est))
    for w in est.warnings:
        print(f"torquemap: warning: {w}", file=sys.stderr)
    ok = est.flag == 0
    summary = ""
    if ok.any():
        force = est.wrench[ok, :3]
        summary = f", |F| median {np.median(np.linalg.norm(force, axis=1)):.4g} N"
    print(f"{method}: {int(ok.sum())}/{ok.size} samples sound{summary}")
    print(f"wrote {output}")
    return 0
