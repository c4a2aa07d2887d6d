"""CLI: ``report``, a self-contained HTML report of a model and the user's own logs."""

from __future__ import annotations

import argparse
from typing import Any


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``report`` to subparsers."""
    p = subparsers.add_parser(
        "report",
        help="HTML report: friction, PDTV, spectra, estimated forces, thin-data warnings",
        description="Write one self-contained HTML file (figures embedded, no network needed) "
        "describing MODEL.toml and each LOG: the identified friction and PDTV, the spectrum of "
        "each log with constant-speed passes, the forces the model method estimates, and "
        "warnings where the data is thin.",
    )
    p.add_argument("model", metavar="MODEL.toml")
    p.add_argument("logs", metavar="LOG", nargs="+")
    p.add_argument("-o", "--output", metavar="REPORT.html", required=True)
    p.add_argument(
        "--window",
        type=float,
        default=None,
        metavar="S",
        help="differentiator window [s]; default the model's",
    )
    p.set_defaults(handler=_report)


def _report(args: argparse.Namespace) -> int:
    from torquemap.user_report import write_user_report

    report = write_user_report(args.model, args.logs, args.output, window=args.window)
    warnings = sum(len(s.warnings) for s in report.sections)
    figures = sum(len(s.figures) for s in report.sections)
    print(
        f"wrote {args.output} ({len(report.sections)} sections, {figures} figures, "
        f"{warnings} warnings)"
    )
    return 0
