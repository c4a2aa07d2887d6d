"""CLI: ``report``, a self-contained HTML report of a model and the user's own logs."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from torquemap.cli.argtypes import add_window_argument
from torquemap.cli.helptext import described
from torquemap.cli.outputs import output_suffix, warn_cut_last_lines


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``report`` to subparsers."""
    p = subparsers.add_parser(
        "report",
        help="HTML report: friction, PDTV, spectra, estimated forces, thin-data warnings",
        **described(
            "Write one self-contained HTML file (figures embedded, no network needed) "
            "describing MODEL.toml and each LOG: the identified friction and PDTV, the spectrum "
            "of each log with constant-speed passes, the forces the model method estimates, and "
            "warnings where the data is thin.",
            ["torquemap report bench/model.toml bench/sweep.csv bench/circle.csv -o report.html"],
        ),
    )
    p.add_argument("model", metavar="MODEL.toml", help="model file (from identify)")
    p.add_argument("logs", metavar="LOG", nargs="+", help="logs to describe, .csv or .parquet")
    p.add_argument(
        "-o", "--output", metavar="REPORT.html", required=True, help="the report to write (.html)"
    )
    add_window_argument(p)
    p.set_defaults(handler=_report)


def _report(args: argparse.Namespace) -> int:
    from torquemap.cli.outputs import HTML, check_outputs
    from torquemap.user_report import write_user_report

    output_suffix(args.output, (".html", ".htm"), "report")
    check_outputs([(args.output, HTML)], [args.model, *args.logs])
    report = args.progress.run(
        "write the report",
        lambda: write_user_report(args.model, args.logs, args.output, window=args.window),
    )
    warnings = sum(len(s.warnings) for s in report.sections)
    figures = sum(len(s.figures) + len(s.charts) for s in report.sections)
    print(
        f"wrote {args.output} ({len(report.sections)} sections, {figures} figures, "
        f"{warnings} warning{'' if warnings == 1 else 's'})"
    )
    for section in report.sections:
        for w in section.warnings:
            print(f"torquemap: warning: {section.heading}: {w}", file=sys.stderr)
    warn_cut_last_lines(args.logs)  # after the run: a refusal stays one line
    return 0
