"""CLI: the ``linearize`` group: ``build``, ``evaluate``, ``figures`` (and ``collect``).

``collect`` is added by :mod:`torquemap.cli.cmd_linearize_collect`. See docs/linearize.md.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import TYPE_CHECKING, Any, Literal

from torquemap.cli.argtypes import float_in, int_in
from torquemap.cli.helptext import described
from torquemap.cli.outputs import C_HEADER, JSON, NPZ, check_outputs, warn_cut_last_lines

if TYPE_CHECKING:
    from torquemap.linearize.motor import MotorSpec
    from torquemap.linearize.tables import DataKind, LinearizeData

#: ``linearize build --nyquist``: the choice and ``build_tables``' ``nyquist`` it selects
NYQUIST: dict[str, bool | Literal["tested"]] = {"tested": "tested", "on": True, "off": False}


def _weight(text: str) -> float:
    """argparse type: a number >= 0 (inf allowed)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text}")
    return value


def _bias_weight(given: float | None, data: str) -> float:
    """``--bias-weight`` as given, else the collection record's bias readings over its readings
    per row (the record ``DATA.csv.collect.json`` beside the data), else the collection's
    default ratio."""
    from torquemap.linearize.collect import BIAS_READINGS_FACTOR

    if given is not None:
        return given
    settings = _record_settings(data)
    try:
        weight = float(settings["bias_readings"]) / float(settings["readings"])
    except (KeyError, TypeError, ValueError, ZeroDivisionError):
        return float(BIAS_READINGS_FACTOR)
    return weight if math.isfinite(weight) and weight >= 0 else float(BIAS_READINGS_FACTOR)


def _record_settings(data: str) -> dict[str, Any]:
    """The settings of the collection record beside ``data`` (the grid's
    ``DATA.csv.collect.json`` or the adaptive ``DATA.csv.adaptive.json``), {} without one."""
    from torquemap.linearize.resume import record_beside

    return record_beside(data)[1]


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add the ``linearize`` group and its sub-commands."""
    from torquemap.cli import cmd_linearize_collect, cmd_linearize_more

    group = subparsers.add_parser(
        "linearize",
        help="torque-linearisation look-up tables (Adept II paper)",
        **described(
            "Build and evaluate per-phase torque-linearisation tables from motor "
            "characterisation data (docs/linearize.md): collect the data (collect), build the "
            "tables (build), measure linearity before and after (evaluate), draw it (figures).",
            [
                "torquemap linearize build rig/motor.toml rig/data.csv -o tables.npz",
                "torquemap linearize evaluate rig/motor.toml rig/data.csv",
            ],
        ),
    )
    sub = group.add_subparsers(
        dest="linearize_command", metavar="SUBCOMMAND", help="the step to run"
    )
    sub.required = True

    build = sub.add_parser(
        "build",
        help="build the phase tables from DATA.csv",
        **described(
            "Build TABLES.npz (and optionally raw EPROM images, Intel HEX, a C header) from "
            "characterisation data. Nothing is written unless everything could be built.",
            [
                "torquemap linearize build rig/motor.toml rig/data.csv -o tables.npz",
                "torquemap linearize build rig/motor.toml rig/data.csv -o tables.npz --bin eprom "
                "--hex hex --c-header tables.h",
            ],
        ),
    )
    build.add_argument("motor", metavar="MOTOR.toml", help="the motor file")
    build.add_argument("data", metavar="DATA.csv", help="characterisation data")
    build.add_argument(
        "-o", "--out", metavar="TABLES.npz", required=True, help="tables file to write (.npz)"
    )
    build.add_argument("--bin", metavar="DIR", help="write raw images phase_k.bin here")
    build.add_argument("--hex", metavar="DIR", help="write Intel HEX phase_k.hex here")
    build.add_argument("--c-header", metavar="FILE", help="write a C header")
    build.add_argument(
        "--command-scaling",
        choices=("linear", "log"),
        default="linear",
        help="command law: torque linear in the command (default) or the log law",
    )
    build.add_argument(
        "--log-curvature",
        type=float_in(0.0, 100.0, low_open=True),
        default=4.0,
        help="k of the log law tau = tmax expm1(k|c|/C)/expm1(k) (default 4)",
    )
    build.add_argument(
        "--method",
        choices=("interp", "paper"),
        default="interp",
        help="interp: invert the monotone torque curves; paper: medians of quantised cells",
    )
    build.add_argument(
        "--actuation-bits",
        type=int_in(1, 32),
        help="table entry width [bits], rescaled to the motor's full scale (default: motor units)",
    )
    build.add_argument(
        "--no-monotonic", action="store_true", help="skip the monotonic filter (paper 5.6)"
    )
    build.add_argument(
        "--no-denoise",
        action="store_true",
        help="interp: use the rows as measured, no low-rank denoising of the collection's blocks",
    )
    build.add_argument(
        "--bias-weight",
        type=_weight,
        default=None,
        metavar="W",
        help="interp: weight of each position's bias measurement in rows, the collection's "
        "bias readings over its readings per row (default: from the collection's record "
        "DATA.csv.collect.json beside the data, else 10, the collection's default)",
    )
    build.add_argument(
        "--nyquist",
        choices=tuple(NYQUIST),
        default="tested",
        help="interp, where the structured surface is used: fit the torque at rest between "
        "measured positions as their interpolation plus their Nyquist harmonic. tested "
        "(default): where the measured positions' torque at rest alternates (cogging sampled "
        "twice a period, warned) and where the rows between them read the harmonic beyond "
        "their noise (an F test at level 0.001, warned); on: only where the measured "
        "positions alternate (the default before stop 41); off: never",
    )
    build.add_argument(
        "--onset-form",
        choices=("power", "amplifier", "choose"),
        default="power",
        help="interp: the onset law below the smallest torque the rig reads. power (default): "
        "max(a - d, 0)^n; amplifier: the amplifier's curved current past its dead zone; "
        "choose: the amplifier's form where it predicts each measured position's lowest "
        "readable row, held out, better than the power law (docs/linearize.md, stop 43)",
    )
    build.add_argument(
        "--onset-window",
        choices=("default", "choose"),
        default="default",
        help="interp: the onset law's fitting window. default: up to 0.3 of the "
        "position-independent torque; choose: 0.3 or 0.15, the narrower only where its law "
        "predicts the lowest readable rows of measured positions left out of the structured "
        "surface significantly better (slower: 8 more surface fits; docs/linearize.md, stop 44)",
    )
    build.set_defaults(handler=_build)

    evaluate = sub.add_parser(
        "evaluate",
        help="APMD, CAPMD, PAPMD of characterisation or verification data",
        **described(
            "Linearity measures of the paper (Eqs 1-3, Table 2). Without --tables, DATA.csv is "
            "characterisation data (command = pulse width); with --tables it is a verification "
            "run (position, command, torque).",
            [
                "torquemap linearize evaluate rig/motor.toml rig/data.csv",
                "torquemap linearize evaluate rig/motor.toml after.csv --tables tables.npz "
                "-o after.json",
            ],
        ),
    )
    evaluate.add_argument("motor", metavar="MOTOR.toml", help="the motor file")
    evaluate.add_argument("data", metavar="DATA.csv", help="characterisation or verification data")
    evaluate.add_argument("--tables", metavar="TABLES.npz", help="tables of a verification run")
    evaluate.add_argument(
        "-o", "--out", metavar="REPORT.json", help="also write the measures as JSON (.json)"
    )
    evaluate.set_defaults(handler=_evaluate)

    figures = sub.add_parser(
        "figures",
        help="figures: torque surfaces, tables, ramps, PMD, CAPMD, PAPMD",
        **described(
            "Write PNG figures of characterisation data, tables and (with --verification) the "
            "compensated run: torque surfaces, table surfaces, ramps, PMD distributions.",
            [
                "torquemap linearize figures rig/motor.toml rig/data.csv -o figs",
                "torquemap linearize figures rig/motor.toml rig/data.csv --tables tables.npz "
                "--verification after.csv -o figs",
            ],
        ),
    )
    figures.add_argument("motor", metavar="MOTOR.toml", help="the motor file")
    figures.add_argument("data", metavar="DATA.csv", help="characterisation data")
    figures.add_argument("--tables", metavar="TABLES.npz", help="tables to draw")
    figures.add_argument("--verification", metavar="VERIFY.csv", help="verification data")
    figures.add_argument("-o", "--out", metavar="DIR", required=True, help="output folder")
    figures.set_defaults(handler=_figures)

    cmd_linearize_collect.register(sub)
    cmd_linearize_more.register(sub)


def _build(args: argparse.Namespace) -> int:
    from torquemap.linearize.export import write_outputs
    from torquemap.linearize.motor import load_motor
    from torquemap.linearize.tables import build_tables, read_data
    from torquemap.linearize.window import WINDOWS

    files = [(args.out, NPZ), (args.c_header, C_HEADER)]
    check_outputs(files, [args.motor, args.data])
    spec = load_motor(args.motor)  # the number of phases names the image files
    check_outputs(
        files,
        [args.motor, args.data],
        folders=[
            (args.bin, [f"phase_{k + 1}.bin" for k in range(spec.phases)]),
            (args.hex, [f"phase_{k + 1}.hex" for k in range(spec.phases)]),
        ],
    )
    data = args.progress.run(
        "read the data", lambda: read_data(args.data, spec, kind="characterisation")
    )
    bias_weight = _bias_weight(args.bias_weight, args.data)
    tables = args.progress.run(
        "build the phase tables",
        lambda: build_tables(
            spec,
            data.position,
            data.level,
            data.torque,
            command_scaling=args.command_scaling,
            method=args.method,
            monotonic=not args.no_monotonic,
            denoise=not args.no_denoise,
            bias_weight=bias_weight,
            log_curvature=args.log_curvature,
            actuation_bits=args.actuation_bits,
            bias=data.bias,
            bias_open=_record_settings(args.data).get("bias_open") is True,
            nyquist=NYQUIST[args.nyquist],
            onset_form=args.onset_form,
            onset_window="choose" if args.onset_window == "choose" else WINDOWS[0],
            path=args.data,
        ),
    )
    written = write_outputs(
        tables, npz=args.out, bin_dir=args.bin, hex_dir=args.hex, c_header_path=args.c_header
    )
    print(
        f"largest position-independent torque {tables.torque_max:.6g} N m; torque_per_count "
        f"{tables.torque_per_count:.6g} N m ({tables.command_scaling} scaling, {tables.method})"
    )
    print(
        f"cells filled by interpolation {tables.voids_filled}, cells with several rows "
        f"{tables.median_cells}, entries raised by the monotonic filter {tables.monotonic_fixes}"
    )
    if tables.denoise_rank:
        print(f"rows denoised: low-rank fit of the collection's blocks, rank {tables.denoise_rank}")
    if tables.bias_drift >= 0:
        print(
            "rows re-zeroed on the bias column's smooth drift over the cycle "
            f"({tables.bias_drift} harmonic{'s' if tables.bias_drift != 1 else ''})"
        )
    if tables.surface:
        print(
            "between measured positions: the structured torque surface (the ramp hands over there)"
        )
    print("wrote " + ", ".join(written))
    for warning in tables.warnings:
        print(f"torquemap: warning: {args.data}: {warning}", file=sys.stderr)
    from torquemap.linearize.pulse_step import pulse_step_advice_rows

    coarse = pulse_step_advice_rows(data.position, data.level, data.torque, tables.torque_per_count)
    if coarse:
        print(f"torquemap: warning: {args.data}: {coarse}", file=sys.stderr)
    bits = args.actuation_bits
    if bits is not None and (1 << bits) - 1 < spec.actuation_max:
        # entries coarser than the motor's own pulse widths: resolution thrown away
        print(
            f"torquemap: warning: {args.motor}: --actuation-bits {bits} gives entries 0 .. "
            f"{(1 << bits) - 1}, coarser than the motor's pulse widths 0 .. "
            f"{spec.actuation_max}: each entry step is {spec.actuation_max / ((1 << bits) - 1):.3g} "
            "pulse widths (the option is for drives with more bits than the motor file's)",
            file=sys.stderr,
        )
    warn_cut_last_lines([args.data])  # after the run: a refusal stays one line
    return 0


def _read_evaluated(args: argparse.Namespace, spec: MotorSpec, kind: DataKind) -> LinearizeData:
    """DATA.csv of ``kind``; a file of the other kind is named as such (was: a missing column)."""
    from torquemap.errors import InputError
    from torquemap.linearize.tables import read_data

    try:
        return read_data(args.data, spec, kind=kind)
    except InputError as exc:
        if kind == "verification" and exc.message.startswith("missing column 'command'"):
            if "pulse_width" in exc.message:
                raise InputError(
                    "characterisation data (pulse_width), but --tables evaluates a verification "
                    "run (position, command, torque: linearize collect --tables); drop --tables "
                    "to evaluate the characterisation",
                    path=exc.path,
                ) from None
        if kind == "characterisation" and exc.message.startswith("missing column 'pulse_width'"):
            if "command" in exc.message:
                raise InputError(
                    "verification data (command), evaluated as a characterisation: give the "
                    "tables it was collected with, --tables TABLES.npz",
                    path=exc.path,
                ) from None
        raise


def _evaluate(args: argparse.Namespace) -> int:
    from torquemap.io import atomic_output
    from torquemap.linearize.export import load_tables
    from torquemap.linearize.metrics import evaluate_linearity, format_report, report_to_dict
    from torquemap.linearize.motor import load_motor

    check_outputs([(args.out, JSON)], [args.motor, args.data, args.tables])
    spec = load_motor(args.motor)
    tables = None if args.tables is None else load_tables(args.tables)
    kind: DataKind = "characterisation" if tables is None else "verification"
    data = args.progress.run("read the data", lambda: _read_evaluated(args, spec, kind))
    from torquemap.linearize.outliers import check_rows_read

    what = "pulse width" if kind == "characterisation" else "command"
    check_rows_read(data.position, data.level, data.torque, what=what, path=args.data)
    report = args.progress.run(
        "evaluate linearity",
        lambda: evaluate_linearity(spec, data, tables=tables, tables_path=args.tables),
    )
    print(format_report(report, title=f"{kind} data {args.data}"))
    if kind == "characterisation":
        from torquemap.linearize.metrics import characterisation_coverage_advice

        advice = characterisation_coverage_advice(
            data.position, spec.positions_per_cycle, spec.phases
        )
        if advice:
            print(f"torquemap: warning: {args.data}: {advice}", file=sys.stderr)
    if kind == "verification":
        from torquemap.linearize.metrics import coverage_advice

        advice = coverage_advice(data.position, spec.positions_per_cycle)
        if advice:
            print(f"torquemap: warning: {args.data}: {advice}", file=sys.stderr)
        rest = _verification_bias_advice(data, spec.positions_per_cycle, args.data)
        if rest:
            print(f"torquemap: warning: {args.data}: {rest}", file=sys.stderr)
    if args.out:
        with atomic_output(args.out) as tmp:
            tmp.write_text(json.dumps(report_to_dict(report), indent=2) + "\n")
        print(f"wrote {args.out}")
    warn_cut_last_lines([args.data])
    return 0


def _verification_bias_advice(data: Any, positions_per_cycle: int, path: str) -> str:
    """One line when a verification's bias, read at rest, holds a load (cogging beyond
    friction): its rows are then the torque above the torque at rest, and its APMD is not the
    joint's (tables that restore the load score worse on it than they are); else ''."""
    from torquemap.linearize.bias import check_bias

    if data.bias is None or data.position.size < 2:
        return ""
    if _record_settings(path).get("bias_open") is True:
        return ""  # read on an open contact, which holds no load at rest
    check = check_bias(
        data.position,
        data.level,
        data.torque,
        data.bias,
        positions_per_cycle=positions_per_cycle,
        bias_weight=_bias_weight(None, path),
    )
    if not check.varies:
        return ""
    load = check.load()
    return (
        f"the verification's bias read at rest holds up to {float(load.max(initial=0.0)):.3g} "
        f"N m more at {int(check.loaded.sum())} of {check.loaded.size} positions (cogging "
        "loading the contact at rest): its rows, and this APMD, are the torque above the "
        "torque at rest, not the joint's; verify with the bias on an open contact "
        "(linearize collect --tables ... --bias-open)"
    )


def _figures(args: argparse.Namespace) -> int:
    from torquemap.plots.linearize import FIGURE_NAMES, write_linearize_figures

    check_outputs(
        [],
        [args.motor, args.data, args.tables, args.verification],
        folders=[(args.out, FIGURE_NAMES)],
    )

    written = args.progress.run(
        "draw the figures",
        lambda: write_linearize_figures(
            args.motor,
            args.data,
            args.out,
            tables_path=args.tables,
            verification_path=args.verification,
        ),
    )
    print(f"wrote {len(written)} figures to {args.out}")
    warn_cut_last_lines([p for p in (args.data, args.verification) if p is not None])
    return 0
