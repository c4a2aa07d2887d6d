"""CLI: ``identify``, ``spectrum`` and ``pdtv-map`` (docs/identification.md)."""

from __future__ import annotations

import argparse
import sys
from math import nan
from typing import Any

from torquemap.errors import InputError


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add ``identify``, ``spectrum`` and ``pdtv-map`` to subparsers."""
    p = subparsers.add_parser(
        "identify", help="identify friction, inertia and PDTV from no-load logs"
    )
    p.add_argument("robot", metavar="ROBOT.toml")
    p.add_argument("logs", metavar="LOG", nargs="+")
    p.add_argument("-o", "--output", metavar="MODEL.toml", required=True)
    p.add_argument("--max-order", type=float, default=None, help="highest PDTV order [CPR]")
    p.add_argument("--joint", action="append", default=None, help="joint to identify (repeat)")
    p.add_argument(
        "--friction",
        choices=("whole", "passes"),
        default="whole",
        help="whole (default): friction through zero, inertia, PDTV and delay fitted to every "
        "sample; passes: the paper's constant-speed pass means (Eq 5)",
    )
    p.add_argument(
        "--window",
        type=float,
        default=0.05,
        metavar="S",
        help="differentiator window [s] (default 0.05; stored in the model for later commands)",
    )
    p.set_defaults(handler=_identify)

    s = subparsers.add_parser("spectrum", help="PDTV spectrum in CPR with the model's lines")
    s.add_argument("model", metavar="MODEL.toml")
    s.add_argument("log", metavar="LOG")
    s.add_argument("--joint", required=True)
    s.add_argument("-o", "--output", metavar="FIG.png", default=None)
    s.add_argument("--top", type=int, default=10, help="lines printed without -o")
    s.add_argument(
        "--window",
        type=float,
        default=None,
        metavar="S",
        help="differentiator window [s]; default the model's",
    )
    s.set_defaults(handler=_spectrum)

    m = subparsers.add_parser("pdtv-map", help="PDTV table over one motor revolution")
    m.add_argument("model", metavar="MODEL.toml")
    m.add_argument("--joint", required=True)
    m.add_argument("--bins", type=int, required=True)
    m.add_argument("-o", "--output", metavar="MAP.csv", required=True)
    m.add_argument("--format", choices=("csv", "json", "c-header"), default="csv")
    m.add_argument("--int-type", choices=("int16", "int8"), default="int16")
    m.set_defaults(handler=_pdtv_map)


def _identify(args: argparse.Namespace) -> int:
    from torquemap.identify import identify_model
    from torquemap.io import read_log, write_toml
    from torquemap.model import load_model, model_to_dict

    model = load_model(args.robot)
    logs = [read_log(path, model.robot) for path in args.logs]
    result = identify_model(
        model,
        logs,
        joints=args.joint,
        max_order=args.max_order,
        window=args.window,
        friction=args.friction,
    )
    write_toml(args.output, model_to_dict(result.model))
    for w in result.warnings:
        print(f"torquemap: warning: {w}", file=sys.stderr)
    for name, jr in result.joints.items():
        jm = result.model.joints[name]
        f = jm.friction.to_dict()
        top = sorted(jm.pdtv, key=lambda ln: -ln.amplitude)[:3]
        lines = ", ".join(f"{ln.order:g} CPR {ln.amplitude:.3g} N m" for ln in top) or "none"
        print(
            f"{name}: {len(jr.passes)} passes, J={jm.inertia.constant:.4g} kg m^2, "
            f"coulomb +{f.get('coulomb_positive', nan):.4g}/-{f.get('coulomb_negative', nan):.4g}"
            f" N m, viscous {f.get('viscous', nan):.4g} N m s/rad, {len(jm.pdtv)} PDTV lines "
            f"(top: {lines})"
        )
    print(f"wrote {args.output}")
    return 0


def _spectrum(args: argparse.Namespace) -> int:
    from torquemap.identify import identify_model
    from torquemap.io import read_log
    from torquemap.model import load_model

    model = load_model(args.model)
    log = read_log(args.log, model.robot)
    model.robot.joint(args.joint)
    from torquemap.estimate import model_window

    window = model_window(model) if args.window is None else args.window
    result = identify_model(model, [log], joints=[args.joint], window=window, friction="passes")
    jr = result.joints[args.joint]
    if jr.spectrum is None:
        raise InputError(
            f"joint {args.joint} has no slow constant-speed pass for a PDTV spectrum",
            path=args.log,
        )
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
        return 0
    sp = jr.spectrum
    order = sorted(range(sp.order.size), key=lambda i: -sp.amplitude[i])[: args.top]
    print(f"joint {args.joint}: {sp.revolutions:.3g} revolutions, top lines")
    print("order_cpr,amplitude_nm,phase_rad,in_model")
    known = {round(ln.order, 6) for ln in lines}
    for i in order:
        mark = "yes" if round(float(sp.order[i]), 6) in known else "no"
        print(f"{sp.order[i]:.4g},{sp.amplitude[i]:.6g},{sp.phase[i]:.4f},{mark}")
    return 0


def _pdtv_map(args: argparse.Namespace) -> int:
    from torquemap.model import load_model
    from torquemap.pdtv_map import pdtv_map, write_pdtv_map

    model = load_model(args.model)
    table = pdtv_map(model, args.joint, bins=args.bins)
    write_pdtv_map(args.output, table, file_format=args.format, int_type=args.int_type)
    print(f"wrote {args.output}")
    return 0
