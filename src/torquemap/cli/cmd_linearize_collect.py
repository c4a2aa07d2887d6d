"""CLI: ``linearize collect``, data collection against a simulated rig (resumable).

Registered into the ``linearize`` group by :mod:`torquemap.cli.cmd_linearize`.
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from torquemap.linearize.collect import CollectionSettings
    from torquemap.linearize.motor import MotorSpec

from torquemap.cli.helptext import described
from torquemap.cli.outputs import output_suffix


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``collect`` to the ``linearize`` group's sub-parsers."""
    collect = subparsers.add_parser(
        "collect",
        help="collect torque data (or verification data with --tables) on a simulated rig",
        **described(
            "Run the automated data collection of the Adept II paper (Fig 12) against a "
            "simulated rig and append the rows to DATA.csv; an existing DATA.csv is resumed. "
            "With --tables, a verification run through the phase tables (columns position, "
            "command, torque). See docs/linearize-collect.md.",
            [
                "torquemap linearize collect rig/motor.toml --sim vr -o data.csv",
                "torquemap linearize collect rig/motor.toml --sim vr --tables tables.npz "
                "-o after.csv",
            ],
        ),
    )
    collect.add_argument("motor", metavar="MOTOR.toml", help="the motor file")
    collect.add_argument("-o", "--out", metavar="DATA.csv", required=True, help="data file")
    add_rig_choice(collect)
    collect.add_argument("--seed", type=int, default=0, help="noise seed, >= 0 (default 0)")
    collect.add_argument(
        "--tables", metavar="TABLES.npz", help="phase tables: verification run instead"
    )
    add_settings_arguments(collect, level_flag="--step", level_help="pulse-width or command step")
    from torquemap.cli.cmd_linearize_more import add_adaptive_arguments

    add_adaptive_arguments(collect)
    collect.set_defaults(handler=_collect)


def add_rig_choice(parser: argparse.ArgumentParser) -> None:
    """``--sim vr|bldc`` or ``--random SEED``: which simulated motor (one of them, required)."""
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument("--sim", choices=("vr", "bldc"), help="simulated motor")
    which.add_argument(
        "--random",
        type=int,
        metavar="SEED",
        help="the random motor of `simulate rig --random SEED`",
    )


def add_settings_arguments(
    parser: argparse.ArgumentParser, *, level_flag: str, level_help: str
) -> None:
    """The collection's settings (:class:`CollectionSettings`), the same flags for every command.

    ``level_flag`` is the command's historical name for the level step (``--step`` or
    ``--pulse-step``); ``--level-step`` is accepted by both. A flag not given keeps the base
    settings' value (:func:`settings_from`): the paper's, or a random bench's.
    """
    parser.add_argument("--readings", type=int, default=None, help="readings per row (default 10)")
    parser.add_argument(
        "--bias-readings",
        type=int,
        default=None,
        help="readings averaged for the sensor bias at each position (default 10x --readings)",
    )
    parser.add_argument(
        "--bias-open",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="read the bias with the contact open, not at rest (where cogging alone loads the "
        "contact, the rows then hold the torque at rest); --no-bias-open: at rest",
    )
    parser.add_argument(
        level_flag,
        "--level-step",
        dest="level_step",
        type=int,
        default=None,
        help=f"{level_help} (default 4)",
    )
    parser.add_argument(
        "--position-step",
        type=int,
        default=None,
        help="table positions between targets (default 4)",
    )
    parser.add_argument(
        "--transitions",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="also target every position where the ramp changes (the phases' hand-over); "
        "--no-transitions: the evenly spaced targets alone (e.g. the paper's settings on a "
        "random bench whose draw targets them)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def settings_from(
    args: argparse.Namespace, base: CollectionSettings | None = None
) -> CollectionSettings:
    """The :class:`CollectionSettings` of parsed :func:`add_settings_arguments` flags; a flag
    not given keeps ``base``'s value (default: the paper's settings)."""
    import dataclasses

    from torquemap.linearize.collect import CollectionSettings

    changes = {
        name: getattr(args, name)
        for name in (
            "readings",
            "bias_readings",
            "bias_open",
            "position_step",
            "level_step",
            "transitions",
        )
        if getattr(args, name) is not None
    }
    start = CollectionSettings() if base is None else base
    from torquemap.progress import NULL

    hook = NULL if args.no_progress else getattr(args, "progress", True)
    return dataclasses.replace(start, progress=hook, **changes)


def _collect(args: argparse.Namespace) -> int:
    from torquemap.cli.outputs import CSV, check_outputs
    from torquemap.errors import InputError
    from torquemap.linearize.motor import load_motor

    check_outputs([(args.out, CSV)], [args.motor, args.tables])  # DATA.csv itself: resumed
    from torquemap.sim.rig import collect_on_sim

    output_suffix(args.out, (".csv",), "data")
    if args.budget is not None and not args.adaptive:
        # a grid collection spends no budget: it collected the whole grid without a word
        raise InputError("--budget is the adaptive collection's: add --adaptive, or drop it")
    spec = load_motor(args.motor)
    _warn_step_past_half_way(args, spec)
    _warn_position_step_past_build(args, spec)
    if args.adaptive:
        from torquemap.cli.cmd_linearize_more import collect_adaptive_command

        return collect_adaptive_command(args, spec, settings_from(args))
    if args.random is not None:
        from torquemap.sim.family import collect_on_random

        result = collect_on_random(
            spec,
            args.out,
            random=args.random,
            seed=args.seed,
            tables=args.tables,
            settings=settings_from(args),
        )
    else:
        result = collect_on_sim(
            spec,
            args.out,
            sim=args.sim,
            seed=args.seed,
            tables=args.tables,
            settings=settings_from(args),
        )
    resumed = f", resumed after {result.resumed_targets}" if result.resumed_targets else ""
    print(
        f"wrote {result.rows} rows ({result.new_rows} new{resumed}; "
        f"{result.targets.size} positions) to {args.out}"
    )
    if not result.bias_column:
        note_without_bias(args.out)
    return 0


def _warn_step_past_half_way(args: argparse.Namespace, spec: MotorSpec) -> None:
    """On stderr: a level step that leaves no level from 1 below half the range, where
    ``linearize evaluate`` reads the APMD's reference torque (it would refuse the data)."""
    step = getattr(args, "level_step", None)
    if step is None or getattr(args, "adaptive", False):
        return
    if args.tables is not None:
        from torquemap.linearize.collect import read_tables_npz

        # the reader the collection uses (tables without build's metadata are accepted)
        first = next(iter(read_tables_npz(args.tables, spec).values()))
        top, what = first.shape[1] // 2 - 1, "command"
    else:
        top, what = spec.actuation_max, "pulse width"
    warn_level_step(args.out, step, top, what)


def _warn_position_step_past_build(args: argparse.Namespace, spec: MotorSpec) -> None:
    """:func:`warn_position_step` for a characterisation run's flags (a verification run,
    through tables, is not built from)."""
    step = getattr(args, "position_step", None)
    if step is None or args.tables is not None or getattr(args, "adaptive", False):
        return
    warn_position_step(args.out, step, spec)


def warn_position_step(out: str, step: int, spec: MotorSpec) -> None:
    """On stderr: a position step whose gaps ``linearize build`` will not interpolate across
    (at most ``positions_per_cycle // (4 phases)`` positions): it would refuse the data after
    the whole collection (``--position-step 1000`` on 384 positions measured one)."""
    gap = max(1, spec.positions_per_cycle // (4 * spec.phases))
    if step - 1 > gap:
        print(
            f"torquemap: warning: {out}: a position step of {step} leaves gaps of up to "
            f"{min(step, spec.positions_per_cycle) - 1} positions between targets; linearize "
            f"build interpolates across at most {gap} and refuses wider ones; a step of at "
            f"most {gap + 1} keeps within it",
            file=sys.stderr,
        )


def warn_level_step(out: str, step: int, top: int, what: str) -> None:
    """On stderr, when ``step`` leaves no level in ``1 .. top / 2`` (module's collect)."""
    if step > top / 2:
        print(
            f"torquemap: warning: {out}: a step of {step} leaves no {what} from 1 below "
            f"half way ({top / 2:g}): linearize evaluate cannot read the APMD's reference "
            f"torque there; a step of at most {max(top // 2, 1)} can",
            file=sys.stderr,
        )


def note_without_bias(out: str) -> None:
    """On stderr: ``out`` is an older file without the bias column, resumed in its format."""
    print(
        f"torquemap: note: {out}: an older file without the bias column, resumed in its "
        "format: linearize build cannot check what the bias held",
        file=sys.stderr,
    )
