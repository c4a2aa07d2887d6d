"""CLI: ``estimate`` external joint torques and end-effector forces (docs/estimation.md)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from torquemap.cli.argtypes import add_window_argument, float_in, int_in
from torquemap.cli.helptext import described
from torquemap.cli.outputs import (
    FIGURE,
    TABLE_SUFFIXES,
    check_figure,
    check_outputs,
    check_table,
    columns_writer,
    warn_cut_last_lines,
)
from torquemap.estimate import METHODS

#: Logs of more samples than this (Parquet: its row count; CSV: judged by its size, STREAM_BYTES)
#: are read, estimated and written in blocks, in bounded memory; smaller ones in one piece (the
#: same numbers, to rounding: docs/performance.md).
STREAM_ROWS = 1 << 19
STREAM_BYTES = 32 << 20


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``estimate`` to subparsers."""
    p = subparsers.add_parser(
        "estimate",
        help="estimate external torques and forces from a log (no force sensor)",
        **described(
            "Estimate the torques the environment exerts on each joint, and for a planar arm "
            "the end-effector force, from motor currents (or torques) and encoders alone: the "
            "model's inertia, friction and PDTV are subtracted from the motor torque "
            "(docs/estimation.md). Writes t, tau_ext_<j> [N m], fx, fy [N] (an arm: fx, fy, "
            "fz [N], mx, my, mz [N m]), one standard deviation of each (<column>_sigma, NaN "
            "where the model records no uncertainty) and flag (0 = sound) to -o, its format "
            "chosen by the suffix (.csv, .parquet, .json; docs/formats.md); prints a one-line "
            "summary; warnings go to stderr.",
            [
                "torquemap estimate bench/model.toml bench/circle.csv -o forces.csv "
                "--figure forces.png",
                "torquemap estimate bench/model.toml bench/circle.csv -o forces_paper.parquet "
                "--method paper",
            ],
        ),
    )
    p.add_argument("model", metavar="MODEL.toml", help="model file (from identify)")
    p.add_argument("log", metavar="LOG", help="the log to estimate on, .csv or .parquet")
    p.add_argument(
        "-o",
        "--output",
        metavar="FORCES.csv",
        required=True,
        help="forces table: .csv, .parquet or .json (the suffix chooses the format)",
    )
    p.add_argument(
        "--method",
        choices=(*METHODS, "acceleration", "momentum"),
        default="model",
        help="model (default): subtract the PDTV model; paper: notch in the position domain "
        "per monotonic pass; lowpass; raw (Eq 7 only); for an arm with a URDF (docs/arm.md): acceleration (default there) "
        "or momentum (generalised-momentum observer)",
    )
    p.add_argument(
        "--cutoff",
        type=float,
        default=2.0,
        metavar="HZ",
        help="time-domain low-pass cut-off [Hz], the force bandwidth kept (default 2)",
    )
    add_window_argument(p)
    p.add_argument(
        "--notch-width",
        type=float_in(0.0, low_open=True),
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
        "--zero-phase",
        action="store_true",
        help="momentum method: run the observer forwards and backwards (no lag, offline)",
    )
    p.add_argument(
        "--figure",
        metavar="FIG.png",
        default=None,
        help="also plot the estimated torques (and forces) against time (.png, .svg or .pdf)",
    )
    p.add_argument(
        "--follow",
        action="store_true",
        help="LOG is a CSV still being written: read it as it grows and write each row once "
        "its filters have settled (the latency is printed); stop after --follow-timeout "
        "seconds without growth or on Ctrl-C (model, lowpass or raw method; .csv or .parquet "
        "output, renamed into place when reading stops)",
    )
    p.add_argument(
        "--follow-timeout",
        type=float_in(0.0, low_open=True),
        default=10.0,
        metavar="S",
        help="with --follow: stop when the log has not grown for S seconds (default 10)",
    )
    p.add_argument(
        "--threads",
        type=int_in(1, 64),
        default=None,
        metavar="N",
        help="a log estimated in blocks (more than 2^19 samples): estimate N blocks at once, "
        "in threads, while the log is read and the table written (the same table, byte for "
        "byte; each thread holds a block: ~300 MB more for two joints); default: the machine's "
        "cores, at most 2; "
        "1 = one block after the other. A followed log (--follow) is estimated in one thread",
    )
    p.set_defaults(handler=_estimate)


def _estimate(args: argparse.Namespace) -> int:
    status = _estimate_log(args)
    warn_cut_last_lines([args.log])  # after the run: a refusal stays one line
    return status


def _estimate_log(args: argparse.Namespace) -> int:
    import numpy as np

    from torquemap.estimate import check_answered, estimate_forces, forces_columns
    from torquemap.io import Writer, figure_writer, read_log, write_all
    from torquemap.model import load_model

    check_table(args.output)
    if args.figure:
        check_figure(args.figure)
    check_outputs([(args.output, TABLE_SUFFIXES), (args.figure, FIGURE)], [args.model, args.log])
    model = load_model(args.model)
    from torquemap.identify_arm import is_rigid_body_arm

    if is_rigid_body_arm(model.robot.arm):  # an arm with a URDF: docs/arm.md
        from torquemap.cli.cmd_excite import estimate_arm_command
        from torquemap.estimate import model_window

        method = "acceleration" if args.method == "model" else args.method
        window = model_window(model) if args.window is None else args.window
        return estimate_arm_command(
            model, args.log, args.output, method=method, cutoff=args.cutoff,
            window=window, zero_phase=args.zero_phase,
        )  # fmt: skip
    if args.method in ("acceleration", "momentum"):
        from torquemap.errors import InputError

        raise InputError(
            f"--method {args.method} needs an arm with a URDF (kinematics = 'urdf')",
            path=args.model,
        )
    if args.follow or _large(args.log):
        streamed = _estimate_in_blocks(args, model)
        if streamed is not None:
            return streamed
    log = args.progress.run("read the log", lambda: read_log(args.log, model.robot))
    est = args.progress.run(
        f"estimate ({args.method} method)",
        lambda: estimate_forces(
            model,
            log,
            method=args.method,
            cutoff=args.cutoff,
            window=args.window,
            notch_width=args.notch_width,
            reversal_band=args.reversal_band,
        ),
    )
    check_answered(est, model, reversal_band=args.reversal_band, path=args.log)
    writers: dict[str, Writer] = {args.output: columns_writer(args.output, forces_columns(est))}
    if args.figure:
        from torquemap.plots.force import estimate_figure

        fig = args.progress.run("draw the figure", lambda: estimate_figure(est))
        kind = Path(args.figure).suffix.lower().lstrip(".")
        writers[args.figure] = figure_writer(fig, kind=kind, dpi=120)
    write_all(writers)  # the forces and the figure, both or neither
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


def _large(path: str) -> bool:
    p = Path(path)
    try:
        if p.suffix.lower() == ".parquet":
            import pyarrow.parquet as pq

            return bool(pq.ParquetFile(p).metadata.num_rows > STREAM_ROWS)
        return p.stat().st_size > STREAM_BYTES
    except Exception:  # unreadable: read_log says why, in one line
        return False


def _estimate_in_blocks(args: argparse.Namespace, model: Any) -> int | None:
    """Estimate a large or growing log in blocks (None: this run needs the whole log)."""
    from torquemap.errors import InputError

    blockwise = (
        args.method in ("model", "lowpass", "raw")
        and not args.figure
        and Path(args.output).suffix.lower() in (".csv", ".parquet")
    )
    if not blockwise:
        if args.follow:
            raise InputError(
                "--follow estimates with the model, lowpass or raw method into a .csv or "
                ".parquet table, without --figure",
                path=args.log,
            )
        return None
    import numpy as np

    from torquemap.io import follow_log_chunks, iter_log_chunks
    from torquemap.stream import default_threads, estimate_to_file

    # a followed log answers a quarter-second block at a time: no gain, only latency
    threads = 1 if args.follow else args.threads or default_threads()

    if args.follow:
        chunks = follow_log_chunks(args.log, model.robot, timeout=args.follow_timeout)
    else:
        chunks = iter_log_chunks(args.log, model.robot)
    if args.follow and not getattr(args, "quiet", False):
        from torquemap.stream import ForceEstimator

        latency = ForceEstimator(
            model, method=args.method, cutoff=args.cutoff, window=args.window
        ).latency
        print(
            f"following {args.log}: rows written {latency:.3g} s of log time after they arrive",
            file=sys.stderr,
        )
    summary = args.progress.run(
        f"estimate in blocks ({args.method} method)",
        lambda: estimate_to_file(
            model,
            chunks,
            args.output,
            method=args.method,
            cutoff=args.cutoff,
            window=args.window,
            reversal_band=args.reversal_band,
            follow=args.follow,
            path=str(args.log),
            threads=threads,
        ),
    )
    for w in summary.warnings:
        print(f"torquemap: warning: {w}", file=sys.stderr)
    parts = [f"{summary.sound}/{summary.samples} samples sound"]
    if summary.sound:
        for k, name in enumerate(summary.joint_names):
            parts.append(f"tau_ext_{name} mean {summary.tau_ext_mean[k]:+.4g} N m")
    if summary.force_median is not None and np.isfinite(summary.force_median):
        approx = "" if summary.stride == 1 else "~"
        parts.append(f"|F| median {approx}{summary.force_median:.4g} N")
    print(f"{args.method}: " + ", ".join(parts))
    print(f"wrote {args.output}")
    return 0
