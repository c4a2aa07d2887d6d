"""``torquemap`` entry point: builds the parser from the command modules and maps errors to one line.

Each command module owns its sub-command(s) through ``register(subparsers)``; every handler
returns an exit status. Bad input raises :class:`torquemap.errors.InputError`, printed here as
one line with the file it concerns, exit status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from torquemap import __version__
from torquemap.cli import (
    cmd_demo,
    cmd_estimate,
    cmd_excite,
    cmd_identify,
    cmd_import,
    cmd_linearize,
    cmd_report,
    cmd_simulate,
)
from torquemap.errors import InputError

_MODULES = (
    cmd_simulate,
    cmd_identify,
    cmd_estimate,
    cmd_excite,
    cmd_linearize,
    cmd_demo,
    cmd_report,
    cmd_import,
)


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    """The full ``torquemap`` argument parser."""
    parser = _Parser(
        prog="torquemap",
        description="Sensorless force estimation, friction and PDTV identification, "
        "and torque-linearisation tables for electric actuators.",
    )
    parser.add_argument("--version", action="version", version=f"torquemap {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for module in _MODULES:
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status (0 ok, 1 failed check, 2 bad input)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        status: int = args.handler(args)
    except InputError as exc:
        print(f"torquemap: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("torquemap: interrupted", file=sys.stderr)
        return 130
    except OSError as exc:
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"torquemap: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2
    return status


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
