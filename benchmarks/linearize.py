"""Torque linearisation on four simulated joints beside the Adept II paper's Table 2, then on a
family of random motors at the paper's collection settings.

Run: ``.venv/bin/python benchmarks/linearize.py`` (the four joints, then 20 random motors);
``--no-joints`` for the random motors alone, ``--quick`` for them noise-free only (no
verification runs: for iterating), ``--motors N --first-seed S`` for other members of the family,
``--bias-rest`` to measure the CLI's default path beside them: the same collection with the bias
read at rest, its tables built with DATA.csv's ``bias`` column and without it;
``--onset-form`` / ``--onset-search`` / ``--onset-window`` to build the random motors' interp tables with another
onset law (``build_tables``' keywords; docs/linearize.md, "stop 40 (L44)"), ``--nyquist`` with
another use of the torque at rest's Nyquist wave (docs/linearize.md, "stop 41 (L45)").

Random motors (``torquemap.sim.family.paper_bench``): each collected at the paper's settings (10
readings a row, every 4th table position and pulse width) with the bias read on an open contact
(where cogging alone loads the contact, a bias read at rest would swallow it; the floor is the
absolute sensed torque); tables by both methods and the floor (the same exhaustive search as for
the joints); each evaluated noise-free over every cell of the sensed-torque surface, and measured
through one verification run per table set with the same sensor-noise seed on a rig with fresh
noise (every command at about 16 positions, every (P/16 + 1)-th: between the
characterisation's targets as often as on them; 40 readings a row). Reported: the APMD ratio to the floor,
its median and worst over the motors, the comparison with the paper's method on every motor, the
CAPMD at commands 1 to 3, and the motors on which ``build_tables`` warned (cogging the collection
sampled at most twice a period, :mod:`torquemap.linearize.sampling`).

The four joints:

For each joint: collect characterisation data on the simulated rig (every 2nd pulse width, every
2nd table position and every position where the ramp changes, a data density of about a quarter
like the paper's 28 to 32 % "in range"; ``READINGS`` readings a row, the bias of each position over ten times as many; wide
ramping) -> ``build_tables`` (both methods) -> collect a verification run through the tables on a
rig with fresh sensor noise (every command, every 4th position, ``READINGS`` readings a row) ->
evaluate (paper Eq 1). The paper averaged 10 readings a row; 40 cost a force sensor sampling at
1 kHz 30 ms more per row, little beside settling, and make the low commands (where the relative
PMD weighs most and a row's torque is a few times the noise of 10 readings) measurable.

The FLOOR is the best APMD any table of the same widths could reach on that rig. What the
force sensor sees, noise aside, when the motor sits at table position ``p`` with actuation
``a`` and the torque has risen from zero, is ``max(true_torque(p, a) - friction, 0)`` (the
rig's static friction band; compliance only moves which position the motor sits at, and every
table is looked up at the position the encoder reads). For every cell (p, c) the floor table
holds the base pulse width 0..actuation_max whose ramped actuation gives the sensed torque
closest to ``c * t_pi / 127`` (``t_pi`` the deepest valley of that surface). It is evaluated
three times, like the built tables: noise-free (Eq 1 over every cell of the sensed-torque
surface), measured through the same verification run with the same sensor-noise seed, and
through the same verification loop on a noise-free twin of the rig (friction, compliance and
bias kept; only the sensor noise removed), the like-for-like noise-free comparison. The "above
rest" rows measure both tables and floor against the sensed torque minus the sensed torque at
zero actuation: what the collection records when it zeroes the sensor at rest, which differs
from the contact torque where the cogging torque alone exceeds friction (J3). "Bias open"
(BLDC joints): the same collection with the bias read on an open contact
(``bias_open=True``), whose rows keep the torque at rest, against the absolute floor. Build time:
median of 7 calls of ``build_tables`` on joint 1's data (3 phases x 512 positions x 256
commands).
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from torquemap.linearize.collect import (
    CollectionSettings,
    collect_characterisation,
    collect_verification,
)
from torquemap.linearize.metrics import LinearityReport, apmd_report, evaluate_linearity
from torquemap.linearize.motor import MotorSpec, ramped_actuation
from torquemap.linearize.tables import LinearizeData, TableSet, build_tables, read_data
from torquemap.sim.family import paper_bench
from torquemap.sim.motors import BrushlessDcMotor, VariableReluctanceMotor
from torquemap.sim.rig import SimRig, brushless_dc_rig, variable_reluctance_rig

PAPER = {  # Table 2: uncompensated and compensated overall APMD [%], above 10 % command
    "J1 VR": (76.1, 4.2, 1.7),
    "J2 VR": (58.3, 2.4, 1.4),
    "J3 BLDC": (36.0, 13.1, 12.8),
    "J4 BLDC": (9.1, 4.6, 2.3),
}


READINGS = 40  # sensor readings averaged per row, characterisation and verification


def joints() -> dict[str, tuple[SimRig, SimRig]]:
    """Two rigs per joint (characterisation and verification noise), motors like Table 2's."""
    vr2 = VariableReluctanceMotor(
        peak_torque=55.0, second_harmonic=0.25, phase_gain=(1.0, 1.06, 0.97)
    )
    bldc4 = BrushlessDcMotor(harmonics=(0.08, 0.02), cogging=0.04)
    return {
        "J1 VR": (variable_reluctance_rig(rng=1), variable_reluctance_rig(rng=101)),
        "J2 VR": (
            variable_reluctance_rig(rng=2, motor=vr2),
            variable_reluctance_rig(rng=102, motor=vr2),
        ),
        "J3 BLDC": (brushless_dc_rig(rng=3), brushless_dc_rig(rng=103)),
        "J4 BLDC": (brushless_dc_rig(rng=4, motor=bldc4), brushless_dc_rig(rng=104, motor=bldc4)),
    }


def full_grid_report(torque: np.ndarray) -> LinearityReport:
    """Eq 1 over every cell of a (P, C + 1) torque grid, c = 0 .. C."""
    n, width = torque.shape
    p, c = np.meshgrid(np.arange(n), np.arange(width), indexing="ij")
    return apmd_report(
        p.ravel(), c.ravel(), torque.ravel(), command_max=width - 1, positions_per_cycle=n
    )


def sensed(
    rig: SimRig, position: np.ndarray, actuation: np.ndarray, *, above_rest: bool = False
) -> np.ndarray:
    """Noise-free sensed torque [N m] at the motor's table position: motor minus friction.

    ``above_rest``: minus the sensed torque at zero actuation (what a collection that zeroes
    the sensor at rest records; it differs where the cogging torque alone exceeds friction)."""
    out = np.maximum(rig.true_torque(position, actuation) - rig.settings.friction, 0.0)
    if above_rest:
        rest = rig.true_torque(position, np.zeros_like(actuation))
        out = out - np.maximum(rest - rig.settings.friction, 0.0)
    return out


def floor_tables(
    rig: SimRig, spec: MotorSpec, like: TableSet, *, above_rest: bool = False
) -> TableSet:
    """The best table of the same widths, searched exhaustively over every base pulse width."""
    n, top = spec.positions_per_cycle, spec.actuation_max
    p = np.arange(n)[:, None]
    act = ramped_actuation(np.arange(top + 1)[None, :], p, spec.ramp)
    surface = sensed(rig, p, act, above_rest=above_rest)
    cmax = like.command_max
    per_count = surface.max(axis=1).min() / cmax
    target = np.arange(cmax + 1) * per_count
    best = np.abs(surface[:, :, None] - target[None, None, :]).argmin(axis=1)  # (P, C + 1)
    phases = np.zeros_like(like.phases)
    phases[:, :, : cmax + 1] = np.moveaxis(ramped_actuation(best, p, spec.ramp), -1, 0)
    return dataclasses.replace(like, phases=phases, torque_per_count=float(per_count))


def noise_free(rig: SimRig, tables: TableSet, *, above_rest: bool = False) -> LinearityReport:
    """Eq 1 over every cell (p, c >= 0) of the sensed torque through the tables, no noise."""
    n, cmax = tables.positions_per_cycle, tables.command_max
    act = np.moveaxis(tables.phases[:, :, : cmax + 1], 0, -1)  # (P, C + 1, m)
    return full_grid_report(sensed(rig, np.arange(n)[:, None], act, above_rest=above_rest))


def characterise(
    rig: SimRig, spec: MotorSpec, out: Path, *, bias_open: bool = False
) -> LinearizeData:
    """Characterisation data: every 2nd pulse width and position plus the ramp's transitions."""
    settings = CollectionSettings(
        readings=READINGS,
        level_step=2,
        position_step=2,
        transitions=True,
        bias_open=bias_open,
        progress=False,
    )
    collect_characterisation(rig, spec, out, settings)
    return read_data(out, spec, kind="characterisation")


def measured(
    rig: SimRig, spec: MotorSpec, tables: TableSet, out: Path, seed: int
) -> LinearityReport:
    """APMD of a verification run through ``tables`` (every command, every 4th position)."""
    rig.rng = np.random.default_rng(seed)  # the same sensor noise for every table set
    settings = CollectionSettings(readings=READINGS, level_step=1, position_step=4, progress=False)
    collect_verification(rig, spec, tables.as_mapping(), out, settings)
    data = read_data(out, spec, kind="verification")
    return evaluate_linearity(spec, data, tables=tables)


# -- the family of random motors ---------------------------------------------------------------


def verification_settings(spec: MotorSpec) -> CollectionSettings:
    """Every command at 17 to 19 positions over the cycle, 40 readings a row (a reading costs
    little beside settling; more of them make the low commands measurable). The targets are
    ``floor(j P / n)`` with ``n = ceil(P / (P // 17))`` (:func:`collection_targets`): for every
    ``P`` of the family (128 to 512) ``P / n`` is not a whole number, so about a quarter of
    them fall on the characterisation's targets (every 4th position) and the rest between.
    (The step ``P // 16 + 1`` used before gave ``n = 16`` targets ``P / 16`` apart on 256, 384
    and 512 positions: all of them measured positions, so the verification never saw the
    tables between measured positions on those motors.)"""
    return CollectionSettings(
        readings=40, level_step=1, position_step=max(1, spec.positions_per_cycle // 17),
        bias_open=True, progress=False,
    )  # fmt: skip


def family_row(
    seed: int,
    tmp: Path,
    *,
    verify: bool,
    bias_rest: bool = False,
    onset: dict[str, object] | None = None,
) -> dict[str, float | str]:
    """One random motor at the paper's collection: interp, paper method and floor; with
    ``bias_rest``, also the CLI's default path: the same collection with the bias read at rest
    (the same sensor-noise seed, so the same readings), its tables built with DATA.csv's
    ``bias`` column (``rest``: the load it holds restored, :mod:`torquemap.linearize.bias`) and
    without it (``rest_plain``: the rows as measured, what an older file gives). ``onset``:
    ``build_tables``' keywords for the interp tables (``--onset-form``, ``--nyquist``,
    ``--onset-search``; default: its defaults)."""
    law = {} if onset is None else onset
    bench = paper_bench(seed)
    rig = bench.rig
    spec = rig.motor_spec(ramping=bench.ramping)
    out = tmp / f"family-{seed}.csv"
    # the paper's readings and steps; the bias read on an open contact (where cogging alone
    # loads the contact, a bias read at rest would swallow it)
    settings = dataclasses.replace(bench.settings, bias_open=True)
    collect_characterisation(rig, spec, out, settings)
    data = read_data(out, spec, kind="characterisation")
    row: dict[str, float | str] = {"motor": bench.describe()}
    # interp as ``linearize build`` makes it: the rows re-zeroed on the bias column's drift
    # (:mod:`torquemap.linearize.bias`); ``interp_rows`` the rows as measured (an older
    # three-column file, and this benchmark before the column)
    tables = {
        "interp": build_tables(
            spec,
            data.position,
            data.level,
            data.torque,
            bias=data.bias,
            **law,  # type: ignore[arg-type]
        ),
        "paper": build_tables(spec, data.position, data.level, data.torque, method="paper"),
        "interp_rows": build_tables(spec, data.position, data.level, data.torque, **law),  # type: ignore[arg-type]
    }
    tables["floor"] = floor_tables(rig, spec, tables["interp"])
    row["warnings"] = " | ".join(tables["interp"].warnings)
    if bias_rest:
        rest_out = tmp / f"family-{seed}-rest.csv"
        rest_settings = dataclasses.replace(bench.settings, bias_open=False)
        collect_characterisation(paper_bench(seed).rig, spec, rest_out, rest_settings)
        rest = read_data(rest_out, spec, kind="characterisation")
        tables["rest"] = build_tables(spec, rest.position, rest.level, rest.torque, bias=rest.bias)
        tables["rest_plain"] = build_tables(spec, rest.position, rest.level, rest.torque)
        row["rest_warned"] = float(any("bias read at rest" in w for w in tables["rest"].warnings))
    for name, t in tables.items():
        report = noise_free(rig, t)
        row[f"{name}_nf"] = report.apmd
        for c in (1, 2, 3):
            row[f"{name}_c{c}"] = float(report.capmd[c])
    if verify:
        # the same verification run (same sensor-noise seed) through every table set, on a rig
        # with fresh noise
        check = paper_bench(seed, noise_seed=10_000 + seed).rig
        for name, t in tables.items():
            check.rng = np.random.default_rng(20_000 + seed)
            check.base, check.force = check.settings.start_position, 0.0
            vout = tmp / f"family-{seed}-{name}-verify.csv"
            collect_verification(check, spec, t.as_mapping(), vout, verification_settings(spec))
            vdata = read_data(vout, spec, kind="verification")
            report = evaluate_linearity(spec, vdata, tables=t)
            row[f"{name}_meas"] = report.apmd
    return row


def _f(row: dict[str, float | str], key: str) -> float:
    return float(row[key])


def rest_tables(rows: list[dict[str, float | str]], *, verify: bool) -> None:
    """The bias read at rest (the CLI's default) beside the bias on an open contact."""
    kinds = ["nf", "meas"] if verify else ["nf"]
    for kind in kinds:
        label = "measured (same verification run)" if kind == "meas" else "noise-free"
        print(f"\nrandom motors, paper collection, bias read AT REST (CLI default), {label}")
        print(f"{'motor':<24}{'rest/floor':>12}{'plain/floor':>13}{'open/floor':>12}{'warned':>8}")
        ratios: dict[str, list[float]] = {"rest": [], "rest_plain": [], "interp": []}
        for row in rows:
            fl = _f(row, f"floor_{kind}")
            for name, values in ratios.items():
                values.append(_f(row, f"{name}_{kind}") / fl)
            print(
                f"{str(row['motor'])[:22]:<24}{ratios['rest'][-1]:>12.2f}"
                f"{ratios['rest_plain'][-1]:>13.2f}{ratios['interp'][-1]:>12.2f}"
                f"{'yes' if _f(row, 'rest_warned') else '':>8}"
            )
        for name, label in (
            ("rest", "at rest, bias column used"),
            ("rest_plain", "at rest, rows as measured"),
            ("interp", "bias on an open contact"),
        ):
            v = np.array(ratios[name])
            print(f"  {label:<28} / floor: median {np.median(v):.2f}, worst {v.max():.2f}")


def family_tables(rows: list[dict[str, float | str]], *, verify: bool) -> None:
    """Print the per-motor table and the median / worst summary."""
    f = _f

    kinds = ["nf", "meas"] if verify else ["nf"]
    for kind in kinds:
        label = "measured (same verification run)" if kind == "meas" else "noise-free"
        print(f"\nrandom motors, paper collection, APMD {label} [%]")
        print(f"{'motor':<92}{'interp':>8}{'paper':>8}{'floor':>8}{'i/floor':>9}{'p/floor':>9}")
        for row in rows:
            i, p, fl = f(row, f"interp_{kind}"), f(row, f"paper_{kind}"), f(row, f"floor_{kind}")
            print(
                f"{row['motor']!s:<92}{100 * i:>8.2f}{100 * p:>8.2f}{100 * fl:>8.2f}"
                f"{i / fl:>9.2f}{p / fl:>9.2f}"
            )
        ratio = np.array([f(r, f"interp_{kind}") / f(r, f"floor_{kind}") for r in rows])
        paper = np.array([f(r, f"paper_{kind}") / f(r, f"floor_{kind}") for r in rows])
        better = sum(f(r, f"interp_{kind}") < f(r, f"paper_{kind}") for r in rows)
        rows_only = np.array([f(r, f"interp_rows_{kind}") / f(r, f"floor_{kind}") for r in rows])
        print(
            f"interp / floor: median {np.median(ratio):.2f}, worst {ratio.max():.2f}; "
            f"paper method / floor: median {np.median(paper):.2f}, worst {paper.max():.2f}; "
            f"interp better than the paper's method on {better} of {len(rows)} motors; "
            f"interp without the bias column (rows as measured) / floor: median "
            f"{np.median(rows_only):.2f}, worst {rows_only.max():.2f}"
        )
    warned = [r for r in rows if r["warnings"]]
    print(f"\nlinearize build warned on {len(warned)} of {len(rows)} motors")
    for r in warned:
        print(f"  {r['motor']!s:.40}: {r['warnings']}")
    print("\nCAPMD at commands 1-3, noise-free, median over motors [%]")
    for name in ("interp", "paper", "floor"):
        values = [
            f"{100 * float(np.median([f(r, f'{name}_c{c}') for r in rows])):.1f}" for c in (1, 2, 3)
        ]
        print(f"  {name:<8}" + "".join(f"{v:>9}" for v in values))
    if "rest_warned" in rows[0]:
        rest_tables(rows, verify=verify)


def family(
    seeds: list[int],
    *,
    verify: bool,
    bias_rest: bool = False,
    onset: dict[str, object] | None = None,
) -> None:
    """The random-motor section."""
    start = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds:
            rows.append(
                family_row(seed, Path(tmp), verify=verify, bias_rest=bias_rest, onset=onset)
            )
            print(f"  seed {seed} done ({time.perf_counter() - start:.0f} s)", file=sys.stderr)
    family_tables(rows, verify=verify)
    print(f"({len(seeds)} motors in {time.perf_counter() - start:.0f} s)")


def joints_section() -> int:
    rows: dict[str, dict[str, float]] = {}
    build_data = None
    with tempfile.TemporaryDirectory() as tmp:
        for index, (name, (rig, verify_rig)) in enumerate(joints().items()):
            spec = rig.motor_spec(ramping="wide")
            data = characterise(rig, spec, Path(tmp) / f"{name}.csv")
            if build_data is None:
                build_data = (spec, data)
            before = evaluate_linearity(spec, data)
            row = {"uncomp": before.apmd, "density": before.data_density}
            seed = 101 + index
            for method in ("interp", "paper"):
                tables = build_tables(spec, data.position, data.level, data.torque, method=method)
                out = Path(tmp) / f"{name}-{method}-verify.csv"
                after = measured(verify_rig, spec, tables, out, seed)
                row[method] = after.apmd
                row[f"{method}_10"] = after.apmd_above_10
                row[f"{method}_nf"] = noise_free(rig, tables).apmd
                row["t_pi"] = tables.torque_max
                if method == "interp":
                    tables_interp = tables
            row["interp_rest"] = noise_free(rig, tables_interp, above_rest=True).apmd
            best_rest = floor_tables(rig, spec, tables_interp, above_rest=True)
            row["floor_rest"] = noise_free(rig, best_rest, above_rest=True).apmd
            best = floor_tables(rig, spec, tables)
            if isinstance(rig.motor, BrushlessDcMotor):
                # the same collection with the bias read on an open contact (a second rig with
                # the same noise seed): the rows keep the cogging torque at rest
                open_rig = brushless_dc_rig(rng=index + 1, motor=rig.motor)
                d_open = characterise(
                    open_rig, spec, Path(tmp) / f"{name}-open.csv", bias_open=True
                )
                t_open = build_tables(spec, d_open.position, d_open.level, d_open.torque)
                row["interp_open"] = noise_free(rig, t_open).apmd
            f = noise_free(rig, best)
            row["floor"], row["floor_10"] = f.apmd, f.apmd_above_10
            out = Path(tmp) / f"{name}-floor-verify.csv"
            row["floor_meas"] = measured(verify_rig, spec, best, out, seed).apmd
            # the same verification loop on a noise-free twin of the rig (friction, compliance
            # and bias kept): the like-for-like noise-free comparison
            twin = SimRig(
                rig.motor,
                rig.amplifier,
                dataclasses.replace(rig.settings, noise=0.0),
                rng=0,
                name=rig.name,
            )
            for label, t in (("interp_twin", tables_interp), ("floor_twin", best)):
                out = Path(tmp) / f"{name}-{label}.csv"
                row[label] = measured(twin, spec, t, out, 0).apmd
            rows[name] = row
            print(f"  {name} done", file=sys.stderr)
    assert build_data is not None
    spec, data = build_data
    times = {}
    for method in ("interp", "paper"):
        runs = []
        for _ in range(7):
            start = time.perf_counter()
            build_tables(spec, data.position, data.level, data.torque, method=method)  # type: ignore[arg-type]
            runs.append(time.perf_counter() - start)
        times[method] = statistics.median(runs)

    names = list(rows)

    def line(label: str, values: list[str]) -> str:
        return f"{label:<44}" + "".join(f"{v:>10}" for v in values)

    def pct(key: str) -> list[str]:
        return [f"{100 * rows[k][key]:.2f}" for k in names]

    def ratio(a: str, b: str) -> list[str]:
        return [f"{rows[k][a] / rows[k][b]:.2f}" for k in names]

    print(line("APMD [%] (paper Eq 1)", names))
    print(line("paper: uncompensated", [f"{PAPER[k][0]:.1f}" for k in names]))
    print(line("paper: compensated", [f"{PAPER[k][1]:.1f}" for k in names]))
    print(line("paper: compensated above 10 % command", [f"{PAPER[k][2]:.1f}" for k in names]))
    print(line("uncompensated (characterisation data)", pct("uncomp")))
    print(line("compensated, interp (measured)", pct("interp")))
    print(line("  above 10 % command", pct("interp_10")))
    print(line("compensated, paper method (measured)", pct("paper")))
    print(line("  above 10 % command", pct("paper_10")))
    print(line("FLOOR, measured (same verification run)", pct("floor_meas")))
    print(line("FLOOR, noise-free (best table, sensed torque)", pct("floor")))
    print(line("  FLOOR above 10 % command", pct("floor_10")))
    print(line("tables noise-free, interp", pct("interp_nf")))
    print(line("tables noise-free, paper", pct("paper_nf")))
    print(line("interp / floor, measured", ratio("interp", "floor_meas")))
    print(line("interp, noise-free twin of the loop", pct("interp_twin")))
    print(line("FLOOR, noise-free twin of the loop", pct("floor_twin")))
    print(line("interp / floor, noise-free twin", ratio("interp_twin", "floor_twin")))
    print(line("interp / floor, noise-free", ratio("interp_nf", "floor")))
    print(line("tables noise-free above rest, interp", pct("interp_rest")))
    print(line("FLOOR, noise-free above rest", pct("floor_rest")))
    print(line("interp / floor, noise-free above rest", ratio("interp_rest", "floor_rest")))
    print(
        line(
            "interp / floor, noise-free, bias open",
            [
                f"{rows[k]['interp_open'] / rows[k]['floor']:.2f}"
                if "interp_open" in rows[k]
                else "-"
                for k in names
            ],
        )
    )
    print(line("position-independent torque [N m]", [f"{rows[k]['t_pi']:.2f}" for k in names]))
    print(line("data density [%]", pct("density")))
    print(
        f"build_tables, 3 phases x {spec.positions_per_cycle} x {2**spec.command_bits}, "
        f"{data.position.size} rows: interp {times['interp'] * 1e3:.0f} ms, "
        f"paper {times['paper'] * 1e3:.0f} ms (median of 7)"
    )
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="random motors only, noise-free")
    parser.add_argument(
        "--motors",
        type=int,
        default=20,
        help="random motors (default 20; 0: the four joints alone)",
    )
    parser.add_argument("--first-seed", type=int, default=0, help="first seed (default 0)")
    parser.add_argument("--no-joints", action="store_true", help="skip the four joints")
    parser.add_argument(
        "--bias-rest",
        action="store_true",
        help="random motors: also the CLI's default collection, the bias read at rest, its "
        "tables with and without DATA.csv's bias column (a second collection per motor)",
    )
    parser.add_argument(
        "--onset-form",
        choices=("power", "amplifier", "choose"),
        help="random motors: build_tables' onset_form for the interp tables (default: its own)",
    )
    parser.add_argument(
        "--onset-window",
        choices=("choose",),
        help="random motors: build_tables' onset_window for the interp tables (default: its "
        "own, 0.3; docs/linearize.md, 'stop 44 (L67)')",
    )
    parser.add_argument(
        "--onset-search",
        choices=("all", "measured"),
        help="random motors: build_tables' onset_search for the interp tables (default: its own)",
    )
    parser.add_argument(
        "--nyquist",
        choices=("warned", "tested", "off"),
        help="random motors: build_tables' nyquist for the interp tables, 'warned' (True), "
        "'tested' or 'off' (False) (default: its own, 'tested'; docs/linearize.md, 'stop 41 "
        "(L45)')",
    )
    args = parser.parse_args()
    onset: dict[str, object] = {
        key: value
        for key, value in (
            ("onset_form", args.onset_form),
            ("onset_search", args.onset_search),
            ("onset_window", args.onset_window),
        )
        if value is not None
    }
    if args.nyquist is not None:
        onset["nyquist"] = {"warned": True, "tested": "tested", "off": False}[args.nyquist]
    seeds = list(range(args.first_seed, args.first_seed + args.motors))
    if args.motors < 0:
        parser.error("--motors must be >= 0")
    if not (args.quick or args.no_joints):
        joints_section()
    if seeds:  # --motors 0: the four joints alone
        family(seeds, verify=not args.quick, bias_rest=args.bias_rest, onset=onset)
    return 0


if __name__ == "__main__":
    sys.exit(main())
