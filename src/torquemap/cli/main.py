"""``torquemap`` entry point: builds the parser from the command modules and maps errors to one line.

Each command module owns its sub-command(s) through ``register(subparsers)``; every handler
returns an exit status. Bad input raises :class:`torquemap.errors.InputError`, printed here as
one line with the file it concerns, exit status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from types import ModuleType

from torquemap import __version__
from torquemap.cli.helptext import described
from torquemap.errors import InputError, one_line

#: The command modules, in the order of ``torquemap --help``; imported by :func:`build_parser`
#: (numpy and the rest load there, inside :func:`main`'s Ctrl-C handler).
_MODULE_NAMES = (
    "cmd_simulate",
    "cmd_identify",
    "cmd_estimate",
    "cmd_excite",
    "cmd_linearize",
    "cmd_demo",
    "cmd_report",
    "cmd_import",
    "cmd_fleet",
    "cmd_cogging",
)


def _modules() -> list[ModuleType]:
    return [importlib.import_module(f"torquemap.cli.{name}") for name in _MODULE_NAMES]


_QUIET_HELP = "no progress output on stderr (results and warnings still print)"


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    """The full ``torquemap`` argument parser."""
    parser = _Parser(
        prog="torquemap",
        **described(
            "Sensorless force estimation, friction and PDTV identification, and "
            "torque-linearisation tables for electric actuators. Each command says what it "
            "does, with examples, under torquemap COMMAND --help; docs/tutorial.md walks "
            "through them. Progress goes to stderr (steps over 2 s), results to stdout.",
            [
                "torquemap demo --out demo-out",
                "torquemap identify robot.toml sweep.csv -o model.toml",
                "torquemap --quiet estimate model.toml run.parquet -o forces.csv",
            ],
        ),
    )
    parser.add_argument("--version", action="version", version=f"torquemap {__version__}")
    parser.add_argument("-q", "--quiet", action="store_true", help=_QUIET_HELP)
    sub = parser.add_subparsers(
        dest="command",
        metavar="COMMAND",
        parser_class=_Parser,
        help="the command to run; torquemap COMMAND --help describes it, with examples",
    )
    sub.required = True
    for module in _modules():
        module.register(sub)
    for command in commands(parser):
        _add_quiet(command)
    return parser


def subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The sub-commands of ``parser`` by name (aliases left out)."""
    out: dict[str, argparse.ArgumentParser] = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            seen: set[int] = set()
            for name, child in action.choices.items():
                if id(child) not in seen:
                    seen.add(id(child))
                    out[name] = child
    return out


def commands(parser: argparse.ArgumentParser) -> list[argparse.ArgumentParser]:
    """Every command that runs (the leaves of the sub-command tree), depth first."""
    children = subparsers(parser)
    if not children:
        return [parser]
    out: list[argparse.ArgumentParser] = []
    for child in children.values():
        out.extend(commands(child))
    return out


def _add_quiet(command: argparse.ArgumentParser) -> None:
    """``--quiet`` after the command too (``torquemap CMD --quiet``), where it has none yet."""
    taken = command._option_string_actions
    if "--quiet" in taken:
        return
    flags = ["--quiet"] if "-q" in taken else ["-q", "--quiet"]
    # SUPPRESS: absent, it must not reset the global --quiet given before the command
    command.add_argument(*flags, action="store_true", default=argparse.SUPPRESS, help=_QUIET_HELP)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status (0 ok, 1 failed check, 2 bad input)."""
    try:
        from torquemap._memory import retain_freed_memory
        from torquemap.progress import reporter

        # block after block the same large arrays: reuse their pages, do not fault in new ones
        retain_freed_memory()
        parser = build_parser()  # imports numpy and the commands: Ctrl-C there is handled too
        args = parser.parse_args(argv)
        args.progress = reporter(quiet=bool(getattr(args, "quiet", False)))
        status: int = args.handler(args)
    except InputError as exc:
        print(f"torquemap: error: {one_line(str(exc))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("torquemap: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader of stdout closed it (``torquemap ... | head``): stop quietly, as a pipeline
        # expects, and keep Python's flush at exit from failing on the same pipe again
        _silence_stdout()
        return 128 + 13  # SIGPIPE's status
    except OSError as exc:
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"torquemap: error: {one_line(f'{where}{exc.strerror or exc}')}", file=sys.stderr)
        return 2
    return status


def _silence_stdout() -> None:
    """Point stdout at the null device (its pipe is gone)."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass  # stdout replaced (tests) or without a descriptor


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
