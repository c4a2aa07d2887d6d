"""CLI: ``estimate`` external joint torques and end-effector forces (docs/estimation.md)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from torquemap.estimate import METHODS


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``estimate`` to subparsers."""
    p = subparsers.add_parser(
        "estimate", help="estimate external torques and forces from a log (no force sensor)"
    )
    p.add_argument("model", metavar="MODEL.toml")
    p.add_argument("log", metavar="LOG")
    p.add_argument("-o", "--output", metavar="FORCES.csv|FORCES.parquet", required=True)
    p.add_argument(
        "--method",
        choices=METHODS,
        default="model",
        help="model (default): subtract the PDTV model; paper: notch in the position domain "
        "per monotonic pass; lowpass; raw (Eq 7 only)",
    )
    p.add_argument(
        "--cutoff",
        type=float,
        default=2.0,
        metavar="HZ",
        help="time-domain low-pass cut-off [Hz], the force bandwidth kept (default 2)",
    )
    p.add_argument(
        "--window",
        type=float,
        default=None,
        metavar="S",
        help="differentiator window [s] for velocity and acceleration (default: the window "
        "the model was identified with, else 0.05)",
    )
    p.add_argument(
        "--notch-width",
        type=float,
        default=0.5,
        metavar="CPR",
        help="-3 dB width of each position-domain notch [CPR] (paper method, default 0.5)",
    )
    p.add_argument(
        "--reversal-band",
        type=float,
        default=None,
        metavar="RAD_S",
        help="motor speed [rad/s] below which friction counts as undetermined (bridged, "
        "flagged); default per joint: the slowest speed identification measured friction at, "
        "or the model's zero_velocity if larger",
    )
    p.add_argument(
        "--figure",
        metavar="FIG.png",
        default=None,
        help="also plot the estimated torques (and forces) against time",
    )
    p.set_defaults(handler=_estimate)


def _estimate(args: argparse.Namespace) -> int:
    import numpy as np

    from torquemap.estimate import estimate_forces, forces_columns
    from torquemap.io import read_log, write_table
    from torquemap.model import load_model

    model = load_model(args.model)
    log = read_log(args.log, model.robot)
    est = estimate_forces(
        model,
        log,
        method=args.method,
        cutoff=args.cutoff,
        window=args.window,
        notch_width=args.notch_width,
        reversal_band=args.reversal_band,
    )
    write_table(args.output, forces_columns(est))
    if args.figure:
        from torquemap.plots.force import estimate_figure, save_figure

        save_figure(estimate_figure(est), args.figure)
    for w in est.warnings:
        print(f"torquemap: warning: {w}", file=sys.stderr)
    ok = est.flag == 0
    parts = [f"{int(ok.sum())}/{ok.size} samples sound"]
    for k, name in enumerate(est.joint_names):
        tau = est.tau_ext[ok, k]
        if tau.size:
            parts.append(f"tau_ext_{name} mean {np.mean(tau):+.4g} N m")
    if est.force is not None and ok.any():
        mag = np.hypot(est.force[ok, 0], est.force[ok, 1])
        parts.append(f"|F| median {np.median(mag):.4g} N")
    print(f"{args.method}: " + ", ".join(parts))
    print(f"wrote {args.output}")
    return 0
