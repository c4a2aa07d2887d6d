"""CLI: ``identify``, ``spectrum`` and ``pdtv-map`` (docs/identification.md)."""

from __future__ import annotations

import argparse
import sys
from math import nan
from pathlib import Path
from typing import Any, Literal

from torquemap.cli.argtypes import add_window_argument, float_in, int_in
from torquemap.cli.helptext import described
from torquemap.cli.outputs import (
    FIGURE,
    TOML,
    check_figure,
    check_outputs,
    output_suffix,
    warn_cut_last_lines,
)
from torquemap.errors import InputError

MapFormat = Literal["csv", "json", "c-header"]

#: Highest PDTV order --max-order accepts [CPR]: finer than any encoder resolves
#: (torquemap.model.MAX_PDTV_ORDER, the most a model file holds).
MAX_ORDER = 1e6
#: The friction methods of identify --friction (torquemap.identify.FRICTION_METHODS).
FRICTION_CHOICES = ("passes", "whole")
#: Most bins pdtv-map writes (torquemap.pdtv_map.MAX_BINS).
MAX_BINS = 1 << 20
_MAP_FORMATS: dict[str, MapFormat] = {
    ".csv": "csv",
    ".parquet": "csv",
    ".json": "json",
    ".h": "c-header",
}


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``identify``, ``spectrum`` and ``pdtv-map`` to subparsers."""
    p = subparsers.add_parser(
        "identify",
        help="identify friction, inertia and PDTV from no-load logs",
        **described(
            "Identify, per joint and on the motor side, Coulomb and viscous friction per "
            "direction (with Stribeck where the data shows it), inertia and the PDTV lines "
            "(cogging, poling, gear and belt teeth) from no-load logs: each joint moving back "
            "and forth at several constant speeds, one joint at a time, slowly for the PDTV "
            "(docs/identification.md). Writes the robot file plus the identified tables to "
            "MODEL.toml and prints one line per joint; warnings go to stderr.",
            [
                "torquemap identify bench/robot.toml bench/sweep.csv -o bench/model.toml",
                "torquemap identify robot.toml slow.parquet fast.parquet -o model.toml "
                "--joint b --max-order 50",
            ],
        ),
    )
    p.add_argument("robot", metavar="ROBOT.toml", help="robot file (or a model to re-identify)")
    p.add_argument("logs", metavar="LOG", nargs="+", help="no-load logs, .csv or .parquet")
    p.add_argument(
        "-o", "--output", metavar="MODEL.toml", required=True, help="model file to write (.toml)"
    )
    p.add_argument(
        "--max-order",
        type=float_in(0.0, MAX_ORDER, low_open=True),
        default=None,
        metavar="CPR",
        help="highest PDTV order [cycles per motor revolution] searched (default: what the "
        "slowest pass resolves)",
    )
    p.add_argument(
        "--joint",
        action="append",
        default=None,
        help="joint to identify (repeat; default: every joint that moves)",
    )
    p.add_argument(
        "--quasi-static",
        action="store_true",
        help="the logs hold position holds, not sweeps: PDTV from the mean holding torque "
        "(docs/odrive.md)",
    )
    p.add_argument(
        "--exclude-contact",
        action="store_true",
        help="arms with a URDF: the logs may hold contact (a leg's stance phases); find the "
        "contact samples as residual outliers and identify from the rest (docs/arm.md)",
    )
    p.add_argument(
        "--friction",
        choices=FRICTION_CHOICES,
        default="whole",
        help="whole (default): friction through zero speed, inertia, PDTV and delay fitted to "
        "every sample; passes: friction from the constant-speed pass means, the paper's Eq 5 "
        "(docs/identification.md)",
    )
    p.add_argument(
        "--low-speed-rows",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="--friction whole: fit friction also on the slow, steady rows below half the "
        "slowest pass (the default; record slow ramps to and from each pass, about 0.4 s to "
        "the slowest: friction is then measured below the slowest pass, not held by the "
        "prior); --no-low-speed-rows leaves them out, as before stop 38 "
        "(docs/identification.md)",
    )
    p.add_argument(
        "--stribeck-prior",
        action="store_true",
        help="--friction whole: centre the friction table's prior on a generalized Stribeck "
        "curve per direction (velocity and exponent searched), so that between and below the "
        "passes the table follows a Stribeck shape rather than a line in log speed "
        "(docs/identification.md)",
    )
    p.add_argument(
        "--choose-prior",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="--friction whole: per direction, take the friction table's prior centred on a "
        "Stribeck curve (--stribeck-prior) only where, with the slowest steady pass left out, "
        "its fit predicts that pass better than the smoothness prior's (the default since "
        "stop 39); --no-choose-prior keeps the smoothness prior everywhere, as before "
        "(docs/identification.md)",
    )
    add_window_argument(p, default=0.05)
    p.set_defaults(handler=_identify)

    s = subparsers.add_parser(
        "spectrum",
        help="PDTV spectrum in CPR with the model's lines",
        **described(
            "The position-domain spectrum of one joint's no-load log in cycles per motor "
            "revolution (CPR), the paper's Fig 4: printed as the strongest lines (CSV: "
            "order_cpr, amplitude_nm, phase_rad, in_model) or, with -o, drawn with the model's "
            "lines marked. The log needs a slow constant-speed pass of the joint.",
            [
                "torquemap spectrum bench/model.toml bench/sweep.csv --joint b --top 6",
                "torquemap spectrum bench/model.toml bench/sweep.csv --joint b -o spectrum_b.png",
            ],
        ),
    )
    s.add_argument("model", metavar="MODEL.toml", help="model file (from identify)")
    s.add_argument("log", metavar="LOG", help="no-load log, .csv or .parquet")
    s.add_argument("--joint", required=True, help="the joint whose spectrum is wanted")
    s.add_argument(
        "-o",
        "--output",
        metavar="FIG.png",
        default=None,
        help="draw the spectrum into FIG (.png, .svg or .pdf) instead of printing lines",
    )
    s.add_argument(
        "--top",
        type=int_in(1, 100000),
        default=10,
        metavar="N",
        help="lines printed without -o (default 10)",
    )
    add_window_argument(s)
    s.set_defaults(handler=_spectrum)

    m = subparsers.add_parser(
        "pdtv-map",
        help="PDTV (anti-cogging) table over one motor revolution",
        **described(
            "Tabulate a joint's identified PDTV over one motor revolution, BINS bins centred at "
            "(k + 0.5) 2 pi / BINS rad from the encoder zero: the torque [N m] and the current "
            "[A] that cancels it, for anti-cogging feed-forward in ODrive- or moteus-style "
            "firmware. The suffix of -o chooses the format: .csv or .parquet (columns "
            "motor_angle, torque, current), .json (metadata and the three arrays), .h (a C "
            "header of int16 or int8 counts and their scale).",
            [
                "torquemap pdtv-map bench/model.toml --joint b --bins 1024 -o cogging_b.csv",
                "torquemap pdtv-map bench/model.toml --joint b --bins 1024 -o cogging_b.json",
                "torquemap pdtv-map bench/model.toml --joint b --bins 1024 -o cogging_b.h "
                "--int-type int8",
            ],
        ),
    )
    m.add_argument("model", metavar="MODEL.toml", help="model file (from identify)")
    m.add_argument("--joint", required=True, help="the joint to tabulate")
    m.add_argument(
        "--bins",
        type=int_in(2, MAX_BINS),
        required=True,
        help=f"bins over one motor revolution (e.g. 1024), 2 .. {MAX_BINS}",
    )
    m.add_argument(
        "-o",
        "--output",
        metavar="MAP.csv",
        required=True,
        help="table to write: .csv, .parquet, .json or .h (the suffix chooses the format)",
    )
    m.add_argument(
        "--format",
        choices=("csv", "json", "c-header"),
        default=None,
        help="the format, where the suffix does not say it (default: from the suffix)",
    )
    m.add_argument(
        "--int-type",
        choices=("int16", "int8"),
        default="int16",
        help="C header: integer type of the table (default int16)",
    )
    m.set_defaults(handler=_pdtv_map)


def _identify(args: argparse.Namespace) -> int:
    status = _identify_logs(args)
    warn_cut_last_lines(args.logs)  # after the run: a refusal stays one line
    return status


def _identify_logs(args: argparse.Namespace) -> int:
    from torquemap.identify import identify_model
    from torquemap.io import read_log, write_toml
    from torquemap.model import load_model, model_to_dict, pdtv_summary

    output_suffix(args.output, (".toml",), "model")
    check_outputs([(args.output, TOML)], [args.robot, *args.logs])
    model = load_model(args.robot)
    from torquemap.identify_arm import is_rigid_body_arm

    if is_rigid_body_arm(model.robot.arm):  # an arm with a URDF: docs/arm.md
        from torquemap.cli.cmd_excite import identify_arm_command

        return identify_arm_command(
            model,
            args.logs,
            args.output,
            exclude_contact=args.exclude_contact,
            window=args.window,
        )
    progress = args.progress
    logs = progress.run(
        f"read {len(args.logs)} log{'s' if len(args.logs) > 1 else ''}",
        lambda: [read_log(path, model.robot) for path in args.logs],
    )
    if args.quasi_static:
        from torquemap.cli.cmd_cogging import identify_holds

        return identify_holds(model, logs, args)
    try:
        result = progress.run(
            "identify friction, inertia and PDTV",
            lambda: identify_model(
                model,
                logs,
                joints=args.joint,
                max_order=args.max_order,
                window=args.window,
                friction=args.friction,
                low_speed_rows=args.low_speed_rows,
                stribeck_prior=_prior_choice(args.stribeck_prior, args.choose_prior),
            ),
        )
    except InputError as exc:
        if exc.message.startswith("no joint moves at a steady speed") and _holds_only(model, logs):
            raise InputError(
                exc.message + "; these logs hold the motor still at many positions (an "
                "anti-cogging calibration?): identify --quasi-static reads them",
                path=exc.path,
            ) from None
        raise
    write_toml(args.output, model_to_dict(result.model))
    for w in result.warnings:
        print(f"torquemap: warning: {w}", file=sys.stderr)
    for name, jr in result.joints.items():
        jm = result.model.joints[name]
        f = jm.friction.to_dict()
        lines = pdtv_summary(jm.pdtv)
        if "speeds" in f:  # a friction table (identify --friction whole)
            up, down = jm.friction.static_levels()
            law = (
                f"friction at rest {up:+.4g}/{-down:+.4g} N m (table of {len(f['speeds'])} "
                f"speeds to {f['speeds'][-1]:.3g} rad/s)"
            )
        else:
            law = (
                f"coulomb {f.get('coulomb_positive', nan):+.4g}/"
                f"{-f.get('coulomb_negative', nan):+.4g} N m"
            )
        print(
            f"{name}: {len(jr.passes)} passes, J={jm.inertia.constant:.4g} kg m^2, {law}, "
            f"viscous {f.get('viscous', nan):.4g} N m s/rad, {len(jm.pdtv)} PDTV lines "
            f"(top: {lines})"
        )
    print(f"wrote {args.output}")
    return 0


def _prior_choice(curve: bool, choose: bool | None) -> bool | Literal["select"] | None:
    """The whole fit's ``stribeck_prior`` from ``--stribeck-prior`` and ``--[no-]choose-prior``.

    ``--stribeck-prior`` centres every direction's prior on the curve (True); otherwise
    ``--choose-prior`` chooses per direction (``"select"``), ``--no-choose-prior`` keeps the
    smoothness prior (False), and neither leaves the module's default (None).
    """
    if curve:
        return True
    if choose is None:
        return None
    return "select" if choose else False


def _holds_only(model: Any, logs: list[Any]) -> bool:
    """Whether ``identify --quasi-static`` finds position holds in ``logs`` (8 or more per
    revolution for some joint): a log of holds given to the sweep identification."""
    from torquemap.quasistatic import identify_quasi_static

    try:
        found = identify_quasi_static(model, logs)
    except InputError:
        return False
    return bool(found.joints)


def _spectrum(args: argparse.Namespace) -> int:
    from torquemap.arm_model import without_rigid_body
    from torquemap.estimate import model_window
    from torquemap.identify import identify_model
    from torquemap.identify_arm import is_rigid_body_arm
    from torquemap.io import read_log
    from torquemap.model import load_model

    if args.output:
        check_figure(args.output)
    check_outputs([(args.output, FIGURE)], [args.model, args.log])
    model = load_model(args.model)
    log = args.progress.run("read the log", lambda: read_log(args.log, model.robot))
    model.robot.joint(args.joint)
    window = model_window(model) if args.window is None else args.window
    if is_rigid_body_arm(model.robot.arm):
        # an arm's gravity and coupling vary along a pass: taken out first, or they read as
        # lines below a few CPR (the rigid bodies of the model's arm, identified or the URDF's)
        log = args.progress.run(
            "take out the rigid-body torque",
            lambda: without_rigid_body(log, model.robot, window=window),
        )
    excite = " (an exciting trajectory, torquemap excite's, has none)"
    no_pass = InputError(
        f"joint {args.joint} has no slow constant-speed pass for a PDTV spectrum"
        f"{excite if is_rigid_body_arm(model.robot.arm) else ''}; record each joint alone at "
        "several steady speeds, both directions, at least a quarter motor revolution per pass",
        path=args.log,
    )
    try:
        result = args.progress.run(
            f"identify joint {args.joint}",
            lambda: identify_model(
                model,
                [log],
                joints=[args.joint],
                window=window,
                friction="passes",
                # the spectrum is the log's, whatever the gravity check on this pass model says
                # (identify decides on the model; a pass model's misfit can look like gravity)
                vertical="warn",
            ),
        )
    except InputError as exc:
        # identify's "no joint moves at a steady speed ...; identification needs
        # constant-speed sweeps" read as if identify had been asked for
        if exc.message.startswith("no joint moves at a steady speed"):
            raise no_pass from None
        raise
    jr = result.joints[args.joint]
    if jr.spectrum is None:
        raise no_pass
    lines = model.joints[args.joint].pdtv
    if args.output:
        from torquemap.plots.pdtv import save_figure, spectrum_figure

        fig = spectrum_figure(
            jr.spectrum,
            lines,
            threshold=None if jr.picks is None else jr.picks.threshold,
            title=f"joint {args.joint}: PDTV position-frequency spectrum",
        )
        save_figure(fig, args.output)
        print(f"wrote {args.output}")
        warn_cut_last_lines([args.log])  # after the run: a refusal stays one line
        return 0
    sp = jr.spectrum
    order = sorted(range(sp.order.size), key=lambda i: -sp.amplitude[i])[: args.top]
    print(f"joint {args.joint}: {sp.revolutions:.3g} revolutions, top lines")
    print("order_cpr,amplitude_nm,phase_rad,in_model")
    # a pass shorter than a whole revolution puts the bins at k / revolutions, off the model's
    # integer orders: a line is the model's within half a bin (a real ODrive sweep of 0.996
    # revolutions showed 7.029 CPR; before, "no" for every line of the model)
    half_bin = 0.5 / sp.revolutions
    known = [ln.order for ln in lines]
    for i in order:
        near = any(abs(k - float(sp.order[i])) < half_bin - 1e-9 for k in known)
        mark = "yes" if near else "no"
        print(f"{sp.order[i]:.4g},{sp.amplitude[i]:.6g},{sp.phase[i]:.4f},{mark}")
    warn_cut_last_lines([args.log])  # after the run: a refusal stays one line
    return 0


def _pdtv_map(args: argparse.Namespace) -> int:
    from torquemap.model import load_model
    from torquemap.pdtv_map import aliased_orders, fractional_orders, pdtv_map, write_pdtv_map

    file_format = _map_format(args.output, args.format)
    suffixes = {"csv": (".csv", ".parquet"), "json": (".json",), "c-header": (".h",)}[file_format]
    if args.format is not None and Path(args.output).suffix.lower() not in _MAP_FORMATS:
        suffixes = (Path(args.output).suffix.lower(),)  # --format names what the suffix does not
    check_outputs([(args.output, suffixes)], [args.model])
    model = load_model(args.model)
    table = pdtv_map(model, args.joint, bins=args.bins)
    if not model.joints[args.joint].pdtv:  # a valid map of no ripple, but likely a robot file
        print(
            f"torquemap: warning: {args.model}: joint {args.joint!r} has no PDTV lines, the map "
            "is all zeros (a robot file, or identification found no line above the noise?)",
            file=sys.stderr,
        )
    fractional = fractional_orders(model, args.joint)
    if fractional:
        named = ", ".join(f"{n:g} CPR ({a:.3g} N m)" for n, a in fractional)
        print(
            f"torquemap: warning: {args.model}: joint {args.joint!r}: PDTV line(s) of "
            f"non-integer order left out of the table: {named}; a table over one motor "
            "revolution repeats every revolution and cannot hold them (joint-side or gearbox "
            "ripple?)",
            file=sys.stderr,
        )
    aliased = aliased_orders(model, args.joint, args.bins)
    if aliased:
        top = max(aliased)
        print(
            f"torquemap: warning: {args.model}: joint {args.joint!r}: {args.bins} bins cannot "
            f"hold its PDTV line(s) of order {', '.join(f'{n:g}' for n in aliased)} CPR (fewer "
            "than 2 bins a period: the staircase a firmware applies turns them into other "
            f"orders or amplitudes); use --bins "
            f"{int(2 * top) + 1} or more",
            file=sys.stderr,
        )
    write_pdtv_map(args.output, table, file_format=file_format, int_type=args.int_type)
    print(f"wrote {args.output}")
    return 0


def _map_format(path: str, given: MapFormat | None) -> MapFormat:
    """The map's format: the suffix's; ``--format`` where the suffix names none."""
    if given is None:
        return _MAP_FORMATS[output_suffix(path, tuple(_MAP_FORMATS), "map")]
    implied = _MAP_FORMATS.get(Path(path).suffix.lower())
    if implied is not None and implied != given:
        raise InputError(
            f"--format {given} contradicts the suffix (a {implied} file); drop --format or "
            "change the suffix",
            path=path,
        )
    return given
