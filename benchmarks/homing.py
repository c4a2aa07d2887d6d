"""Homing from the phases' equilibria on four simulated joints beside the Adept II paper's Table 1.

Run: ``.venv/bin/python benchmarks/homing.py`` (a few minutes on 2 cores).

For each joint (the motors of ``benchmarks/linearize.py``): power the simulated free motor up
once (a hidden encoder offset), then REPEATS times displace it by hand to a random table position
and home it (:func:`torquemap.linearize.homing.home_motor`, full-scale pulse width). The error
of each homing is its offset minus the hidden one. Reported: the standard deviation over the
homings (the repeatability, Table 1's measure), their mean (the bias) and the largest error, in
table positions and in degrees of motor rotation; beside them the same from the readings reached
from below only (a one-way homing), with bearing friction of 1 % and 3 % of a phase's peak torque.

With the tables in place: tables are built from the paper's collection on the characterisation
rig (10 readings a row, every 4th position and pulse width), then evaluated noise-free (Eq 1 over
every cell of the torque the sensor would see, motor minus the rig's friction) with the tables
looked up at the position the homed counter gives: APMD at the exact registration, at the worst
homing of the run, and at the worst one-way homing.

The paper's Table 1 is the standard deviation of the joint positions after placing the robot
against its hard stops by hand ten times, without and with the homing program run before each
placement; its units are not printed (degrees for the rotary joints 1, 2 and 4 is the natural
reading; joint 3 is a ball screw). Ours is the homing's own error, which the paper's second row
holds together with the placement's.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

from torquemap.linearize.collect import CollectionSettings, collect_characterisation
from torquemap.linearize.homing import circular_difference, circular_mean, home_motor
from torquemap.linearize.metrics import LinearityReport, apmd_report
from torquemap.linearize.tables import TableSet, build_tables, read_data
from torquemap.sim.free_motor import free_motor_rig
from torquemap.sim.motors import BrushlessDcMotor, Motor, VariableReluctanceMotor
from torquemap.sim.rig import SimRig, sim_rig

PAPER = {  # Table 1: standard deviation without / with homing (units not printed)
    "J1 VR": (0.0077, 0.0062),
    "J2 VR": (0.0226, 0.0267),
    "J3 BLDC": (0.0117, 0.0036),
    "J4 BLDC": (0.2646, 0.2278),
}
REPEATS = 20


def motors() -> dict[str, tuple[str, Motor]]:
    """The joints of benchmarks/linearize.py."""
    return {
        "J1 VR": ("vr", VariableReluctanceMotor()),
        "J2 VR": (
            "vr",
            VariableReluctanceMotor(
                peak_torque=55.0, second_harmonic=0.25, phase_gain=(1.0, 1.06, 0.97)
            ),
        ),
        "J3 BLDC": ("bldc", BrushlessDcMotor()),
        "J4 BLDC": ("bldc", BrushlessDcMotor(harmonics=(0.08, 0.02), cogging=0.04)),
    }


def registered_apmd(rig: SimRig, tables: TableSet, shift: int) -> LinearityReport:
    """Eq 1 over every cell, noise-free, with the tables looked up ``shift`` positions off."""
    n, cmax = tables.positions_per_cycle, tables.command_max
    p = np.arange(n)
    act = np.moveaxis(tables.phases[:, (p + shift) % n, : cmax + 1], 0, -1)  # (P, C + 1, m)
    torque = np.maximum(rig.true_torque(p[:, None], act) - rig.settings.friction, 0.0)
    pp, cc = np.meshgrid(p, np.arange(cmax + 1), indexing="ij")
    return apmd_report(
        pp.ravel(), cc.ravel(), torque.ravel(), command_max=cmax, positions_per_cycle=n
    )


def main() -> int:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for index, (name, (kind, motor)) in enumerate(motors().items()):
            rig = sim_rig(kind, rng=index + 1, motor=motor)
            spec = rig.motor_spec(ramping="wide")
            n = spec.positions_per_cycle
            out = Path(tmp) / f"{name}.csv"
            collect_characterisation(rig, spec, out, CollectionSettings.paper(progress=False))
            data = read_data(out, spec, kind="characterisation")
            tables = build_tables(spec, data.position, data.level, data.torque)
            degrees = 360.0 / (n * motor.cycles_per_revolution)  # per table position
            for friction in (0.01, 0.03):
                free = free_motor_rig(
                    kind, motor=motor, amplifier=rig.amplifier, rng=100 + index,
                    friction_fraction=friction,
                )  # fmt: skip
                truth = free.encoder_offset
                both, one_way = [], []
                for _ in range(REPEATS):
                    free.x = float(free.rng.uniform(0, n))
                    r = home_motor(free, spec)
                    both.append(r.offset)
                    eq = np.asarray(spec.equilibrium_positions)
                    one_way.append(circular_mean(r.forward - eq, n))
                row: dict[str, object] = {"name": name, "friction": friction, "deg": degrees}
                for label, values in (("both", both), ("one", one_way)):
                    err = circular_difference(values, truth, n)
                    shifts = round(truth) - np.rint(np.asarray(values) % n).astype(int)
                    shifts = (shifts + n // 2) % n - n // 2
                    worst = int(shifts[np.argmax(np.abs(shifts))])
                    row[label] = (
                        float(np.std(err, ddof=1)),
                        float(np.mean(err)),
                        float(np.max(np.abs(err))),
                        worst,
                        registered_apmd(rig, tables, worst).apmd,
                    )
                row["exact"] = registered_apmd(rig, tables, 0).apmd
                rows.append(row)
            print(f"  {name} done", file=sys.stderr)

    print("Homing repeatability over", REPEATS, "homings (error = homed offset - hidden offset)")
    head = (
        f"{'joint':<8}{'fric':>5}  {'paper w/o':>9}{'paper w/':>9}  "
        f"{'std [pos]':>9}{'std [deg]':>10}{'mean':>7}{'max':>6}  "
        f"{'1-way std':>9}{'mean':>7}{'max':>6}  "
        f"{'APMD exact':>10}{'homed':>7}{'1-way':>7}"
    )
    print(head)
    for row in rows:
        name = str(row["name"])
        b, o = row["both"], row["one"]
        assert isinstance(b, tuple) and isinstance(o, tuple)
        deg = float(row["deg"])  # type: ignore[arg-type]
        print(
            f"{name:<8}{100 * float(row['friction']):>4.0f}%  "  # type: ignore[arg-type]
            f"{PAPER[name][0]:>9.4f}{PAPER[name][1]:>9.4f}  "
            f"{b[0]:>9.3f}{b[0] * deg:>10.5f}{b[1]:>+7.2f}{b[2]:>6.2f}  "
            f"{o[0]:>9.3f}{o[1]:>+7.2f}{o[2]:>6.2f}  "
            f"{100 * float(row['exact']):>9.2f}%"  # type: ignore[arg-type]
            f"{100 * b[4]:>6.2f}%{100 * o[4]:>6.2f}%"
        )
    print(
        "std/mean/max in table positions; std [deg] of motor rotation; APMD noise-free through "
        "the tables at the exact registration and at the worst homing's integer registration"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
