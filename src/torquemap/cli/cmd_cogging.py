"""CLI: ``cogging verify``, the anti-cogging map checked on a sweep taken with it applied."""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from torquemap.cli.argtypes import float_in


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add the ``cogging`` group and its ``verify`` sub-command."""
    group = subparsers.add_parser(
        "cogging",
        help="anti-cogging maps: verify a map on a sweep taken with it applied",
        description="Anti-cogging (PDTV) maps: calibrate with `identify` (or "
        "`identify --quasi-static` from position holds), export with `pdtv-map`, load into the "
        "drive (docs/odrive.md, docs/moteus.md), then `cogging verify`.",
        epilog="example:\n  torquemap cogging verify model.toml sweep_after.csv sweep.csv",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = group.add_subparsers(
        dest="cogging_command", metavar="COMMAND", help="verify: ripple before and after"
    )
    sub.required = True
    v = sub.add_parser(
        "verify",
        help="ripple per CPR line before and after the map, and the percentage removed",
        description="Compare, at every PDTV line of MODEL.toml, the torque ripple the position "
        "loop supplied and the speed ripple in LOG_AFTER (a constant-speed sweep with the map "
        "applied) against LOG_BEFORE (the same sweep without it) or, without LOG_BEFORE, "
        "against the model's line amplitudes (docs/odrive.md).",
        epilog="example:\n  torquemap cogging verify model.toml sweep_after.csv sweep.csv "
        "--require 80",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    v.add_argument("model", metavar="MODEL.toml", help="the model the map was exported from")
    v.add_argument("after", metavar="LOG_AFTER", help="sweep with the map applied (.csv/.parquet)")
    v.add_argument(
        "before", metavar="LOG_BEFORE", nargs="?", default=None, help="the same sweep without it"
    )
    v.add_argument("--joint", default=None, help="joint to verify (default: the one with lines)")
    v.add_argument(
        "--current",
        choices=("total", "feedback"),
        default="total",
        help="the log's current includes the map's feed-forward (total, as drives report it) "
        "or is the position loop's output only (feedback); default total",
    )
    v.add_argument(
        "--require",
        type=float_in(0.0, 100.0),
        default=None,
        metavar="PERCENT",
        help="exit with status 1 unless this much of the ripple is removed (speed ripple with "
        "LOG_BEFORE, torque ripple without)",
    )
    v.set_defaults(handler=_verify)


def _pct(x: float) -> str:
    return "n/a" if not math.isfinite(x) else f"{100 * x:.1f}"


def _verify(args: argparse.Namespace) -> int:
    from torquemap.cli.outputs import warn_cut_last_lines
    from torquemap.cogging import verify_cogging
    from torquemap.io import read_log
    from torquemap.model import load_model

    model = load_model(args.model)
    after = read_log(args.after, model.robot)
    before = None if args.before is None else read_log(args.before, model.robot)
    res = verify_cogging(
        model, after, before, joint=args.joint, current=args.current, path=args.model
    )
    for w in res.warnings:  # stderr, as every command's: stdout holds the CSV lines
        print(f"torquemap: warning: {w}", file=sys.stderr)
    src = "sweep without the map" if res.before_source == "log" else "model lines"
    print(f"joint {res.joint}: before = {src}; after = {args.after}")
    print(
        "order_cpr,torque_before_nm,torque_after_nm,torque_removed_pct,"
        "speed_before_rad_s,speed_after_rad_s,speed_removed_pct"
    )
    for ln in res.lines:
        print(
            f"{ln.order:g},{ln.torque_before:.4g},{ln.torque_after:.4g},"
            f"{_pct(ln.torque_removed)},{ln.speed_before:.4g},{ln.speed_after:.4g},"
            f"{_pct(ln.speed_removed)}"
        )
    print(
        f"all,{res.torque_before:.4g},{res.torque_after:.4g},{_pct(res.torque_removed)},"
        f"{res.speed_before:.4g},{res.speed_after:.4g},{_pct(res.speed_removed)}"
    )
    warn_cut_last_lines([args.after] + ([] if args.before is None else [args.before]))
    if args.require is not None:
        removed = res.speed_removed if res.before_source == "log" else res.torque_removed
        if not removed * 100 >= args.require:
            print(
                f"torquemap: check failed: {_pct(removed)} % removed, {args.require:g} % required"
            )
            return 1
    return 0


def identify_holds(model: Any, logs: Any, args: argparse.Namespace) -> int:
    """``identify --quasi-static``: PDTV lines from position holds; writes the model."""

    from torquemap.model import pdtv_summary, save_model
    from torquemap.quasistatic import identify_quasi_static

    result = identify_quasi_static(model, logs, joints=args.joint, max_order=args.max_order)
    save_model(args.output, result.model)
    for w in result.warnings:
        print(f"torquemap: warning: {w}", file=sys.stderr)
    for name, jr in result.joints.items():
        lines = result.model.joints[name].pdtv
        top = pdtv_summary(lines)
        print(
            f"{name}: {jr.holds.torque.size} holds at {jr.positions} positions per revolution, "
            f"orders searched up to {jr.max_order} CPR, {len(lines)} PDTV lines (top: {top}), "
            f"scatter {jr.residual_rms:.2g} N m"
        )
    print(f"wrote {args.output}")
    return 0
