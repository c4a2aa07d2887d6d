"""CLI: ``linearize home`` and ``linearize transfer`` (Adept II paper, Table 1 and §6.2).

Registered into the ``linearize`` group by :mod:`torquemap.cli.cmd_linearize`. See
docs/linearize-homing.md and docs/linearize-transfer.md.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from torquemap.cli.argtypes import float_in
from torquemap.cli.outputs import warn_cut_last_lines


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``home`` and ``transfer`` to the ``linearize`` group's sub-parsers."""
    from torquemap.cli.cmd_linearize_collect import add_rig_choice

    home = subparsers.add_parser(
        "home",
        help="locate the table positions on the position counter from the phases' equilibria",
        description="Home a simulated free motor from its phases' torque equilibria (each phase "
        "energised alone, reached from below and from above), repeatedly, with the motor "
        "displaced by hand in between, and report the counter offset and its repeatability "
        "(Adept II paper, Table 1). See docs/linearize-homing.md.",
        epilog="examples:\n  torquemap linearize home rig/motor.toml --sim vr --repeats 20\n"
        "  torquemap linearize home rig/motor.toml --random 7 --tables tables.npz",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    home.add_argument("motor", metavar="MOTOR.toml", help="the motor file (equilibria)")
    add_rig_choice(home)
    home.add_argument(
        "--tables",
        metavar="TABLES.npz",
        help="take the equilibria from the tables (checked against the motor file)",
    )
    home.add_argument("--seed", type=int, default=0, help="power-up and friction seed (default 0)")
    home.add_argument("--repeats", type=int, default=10, help="homings (default 10)")
    home.add_argument(
        "--pulse-width", type=int, default=None, help="energised phase's pulse width (default max)"
    )
    home.add_argument(
        "--friction",
        type=float,
        default=0.01,
        help="bearing friction, fraction of a phase's peak torque (default 0.01)",
    )
    home.add_argument("--json", action="store_true", help="print JSON instead of text")
    home.set_defaults(handler=_home)

    transfer = subparsers.add_parser(
        "transfer",
        help="characterisation data for a second joint from a handful of its measurements",
        description="Scale the first joint's full characterisation to a second joint of the same "
        "motor type from a handful of its rows (a few positions and pulse widths, e.g. "
        "'linearize collect --position-step 86 --step 64' for 512 positions per cycle) and "
        "write the second joint's DATA.csv, to be built with 'linearize build' (Adept II "
        "paper, section 6.2). See docs/linearize-transfer.md.",
        epilog="example:\n  torquemap linearize transfer j1/motor.toml j1/data.csv j2/motor.toml "
        "j2/few.csv -o j2/data.csv",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    transfer.add_argument("first_motor", metavar="FIRST.toml", help="the first joint's motor file")
    transfer.add_argument("first_data", metavar="FIRST.csv", help="its full characterisation")
    transfer.add_argument("second_motor", metavar="SECOND.toml", help="the second joint's")
    transfer.add_argument("few", metavar="FEW.csv", help="the second joint's handful of rows")
    transfer.add_argument("-o", "--out", metavar="DATA.csv", required=True, help="output data")
    transfer.set_defaults(handler=_transfer)


def _home(args: argparse.Namespace) -> int:
    import dataclasses

    import numpy as np

    from torquemap.linearize.export import load_tables
    from torquemap.linearize.homing import circular_difference, circular_mean
    from torquemap.linearize.metrics import check_tables_fit
    from torquemap.linearize.motor import load_motor
    from torquemap.sim.free_motor import home_on_sim

    spec = load_motor(args.motor)
    source = args.motor
    if args.tables:
        tables = load_tables(args.tables)
        # phases, positions, bits, full scale and equilibria (only the phases and positions
        # before: a sibling's tables homed to their own equilibria without a word)
        check_tables_fit(spec, tables, path=args.tables)
        spec = dataclasses.replace(spec, equilibrium_positions=tables.equilibrium_positions)
        source = args.tables
    results, _truth = home_on_sim(
        spec,
        sim=args.sim or "vr",
        random=args.random,
        seed=args.seed,
        repeats=args.repeats,
        pulse_width=args.pulse_width,
        friction_fraction=args.friction,
        path=source,
    )
    n = spec.positions_per_cycle
    offsets = np.array([r.offset for r in results])
    centre = circular_mean(offsets, n)
    deviation = circular_difference(offsets, centre, n)
    # one homing measures no repeatability (was: std 0.000, range 0.000): None in JSON
    std = float(np.std(deviation, ddof=1)) if offsets.size > 1 else None
    spread = float(np.ptp(deviation)) if offsets.size > 1 else None
    summary = {
        "offset": centre,
        "repeatability_std": std,
        "range": spread,
        "homings": [
            {
                "offset": r.offset,
                "spread": r.spread,
                "hysteresis": r.hysteresis.tolist(),
            }
            for r in results
        ],
    }
    if args.json:
        print(json.dumps(summary, indent=2))
        return 0
    for i, r in enumerate(results, start=1):
        print(
            f"homing {i:>3}: offset {r.offset:8.3f}  spread {r.spread:.3f}  "
            f"hysteresis {' '.join(f'{h:+.0f}' for h in r.hysteresis)}"
        )
    if std is None or spread is None:
        repeat = "repeatability: not measured by one homing (--repeats 2 or more)"
    else:
        repeat = (
            f"repeatability: std {std:.3f}, range {spread:.3f} table positions over "
            f"{len(results)} homings"
        )
    print(
        f"offset {centre:.3f} table positions (table position = counter - {round(centre)} mod "
        f"{n}); {repeat}"
    )
    return 0


def _transfer(args: argparse.Namespace) -> int:
    from torquemap.cli.outputs import CSV, check_outputs
    from torquemap.io import atomic_output
    from torquemap.linearize.motor import load_motor
    from torquemap.linearize.tables import read_data
    from torquemap.linearize.transfer import transfer_characterisation

    # before any work, as every command does (docs/safety.md): the rows are written as CSV,
    # and an output that is an input would replace it
    check_outputs(
        [(args.out, CSV)], [args.first_motor, args.first_data, args.second_motor, args.few]
    )
    first_spec = load_motor(args.first_motor)
    second_spec = load_motor(args.second_motor)
    first = read_data(args.first_data, first_spec, kind="characterisation")
    few = read_data(args.few, second_spec, kind="characterisation")
    result = transfer_characterisation(first_spec, first, second_spec, few)
    with atomic_output(args.out) as tmp:
        with open(tmp, "w") as handle:
            handle.write("position,pulse_width,torque\n")
            for p, w, t in zip(result.position, result.pulse_width, result.torque, strict=True):
                handle.write(f"{p},{w},{t:.10g}\n")
    gains = " ".join(f"{g:.3f}" for g in result.gain)
    print(
        f"wrote {result.position.size} rows to {args.out} from {result.measurements} "
        f"measurements: phase gains {gains}, pulse width {result.pulse_offset:+.1f} + "
        f"{result.pulse_scale:.3f} w (curve {result.pulse_curve:+.3f}); misfit "
        f"{100 * result.residual:.1f} % (unchanged {100 * result.residual_unchanged:.1f} %)"
    )
    scores = ", ".join(
        f"{k} {100 * v:.1f} %" if v < float("inf") else f"{k}: amplifier law on a bound"
        for k, v in result.held_out.items()
    )
    print(
        f"scaling {result.model}: chosen by the handful's held-out error (each position "
        f"predicted from the others: {scores})"
    )
    for warning in result.warnings:
        print(f"torquemap: warning: {args.second_motor}: {warning}", file=sys.stderr)
    warn_cut_last_lines([args.first_data, args.few])  # after the run: a refusal stays one line
    return 0


def add_adaptive_arguments(parser: argparse.ArgumentParser) -> None:
    """``--adaptive`` and ``--budget`` for ``linearize collect``."""
    parser.add_argument(
        "--adaptive",
        action="store_true",
        help="choose where to measure (where the torque surface bends) within --budget of the "
        "grid's readings; resumable (docs/linearize-adaptive.md)",
    )
    parser.add_argument(
        "--budget",
        type=float_in(0.0, 1.0, low_open=True),  # names the flag (was a bare "budget fraction")
        default=None,
        help="adaptive: fraction of the settings' grid's readings to spend (default 1/3)",
    )


def collect_adaptive_command(args: argparse.Namespace, spec: Any, settings: Any) -> int:
    """``linearize collect --adaptive``: on the simulated or random rig, resumable."""
    from torquemap.errors import InputError
    from torquemap.linearize.adaptive import collect_adaptive
    from torquemap.sim.rig import check_rig_fits, sim_rig

    if args.tables:
        raise InputError("--adaptive collects characterisation data; it takes no --tables")
    if args.seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {args.seed}")
    if args.random is not None:
        from torquemap.sim.family import random_bench

        rig = random_bench(args.random, noise_seed=args.seed).rig
        what = f"random motor {args.random}"
    else:
        rig = sim_rig(args.sim, rng=args.seed)
        what = f"simulated {args.sim} motor"
    check_rig_fits(rig, spec, what)
    fraction = 1.0 / 3.0 if args.budget is None else args.budget
    result = collect_adaptive(rig, spec, args.out, settings, fraction=fraction)
    resumed = f", resumed after {result.resumed_blocks} blocks" if result.resumed_blocks else ""
    print(
        f"wrote {result.rows} rows ({result.blocks} blocks at {result.positions} positions, "
        f"{result.levels.size} pulse widths, {result.row_readings} readings a row{resumed}) to "
        f"{args.out}: {result.readings} readings "
        f"of a budget of {result.budget} ({100 * result.readings / result.grid_readings:.0f} % "
        "of the grid's)"
    )
    if not result.bias_column:
        from torquemap.cli.cmd_linearize_collect import note_without_bias

        note_without_bias(args.out)
    return 0
