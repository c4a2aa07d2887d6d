"""Wrench accuracy on the MuJoCo benches: the URDF as given, identified, and an oracle.

One command: ``python benchmarks/arm_accuracy.py [--seeds 0 1 2] [--arms panda ur5 xarm7 z1 leg]``. For
each arm and seed it simulates the bench (``torquemap simulate arm``: MuJoCo, true masses within
15 % of the URDF, a tool the URDF lacks, gears, rotor inertia, a friction law of another form
than the fitted one, torque ripple, encoder quantisation, current noise, computed-torque control
on the nominal model), identifies the arm from ``free.csv`` (``identify_arm``), estimates the
wrench on ``task.csv`` (Panda, UR5: the end effector pressing 5-20 N on a surface while it
slides; leg: the foot stepping on a compliant ground) with the acceleration method, the causal
momentum observer and the zero-phase one, and prints the RMS force error [N] (and moment error
[N m]) against the simulator's truth for:

* the URDF as given (no friction, no rotor inertia, no tool),
* the identified model (``--law fit``, the default and what ``torquemap identify`` does: every
  joint's friction shape fitted; ``default``, ``guess`` and ``true`` keep a given shape and fit
  only the law's linear parameters: the robot file's default law, linear transition 1e-3 rad/s,
  Stribeck velocity 1 rad/s, exponent 2; smooth 0.5 rad/s and Stribeck 5 rad/s; the truth's
  exponent 1, 3 rad/s and 1.5 rad/s tanh),
* for the leg also the model identified from ``task.csv`` alone, its contact samples found and
  excluded (``exclude_contact``: identified from the flight phases),
* the oracle: the true URDF (tool included), the true rotor inertia, friction and ripple through
  the same estimator.

Scored on samples the estimator did not flag, after the first 2 s and before the last 0.5 s,
with a 2 Hz low-pass for the arms (slow forces) and 10 Hz for the leg (``--leg-cutoff``: its
contact lasts 0.3-0.5 s per step, which a 2 Hz filter smears into 2 N of error even with the
true model). Targets (issue 13): identified <= 1.5x the oracle on every arm, and at least 3x
better than the URDF as given.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy.signal import lfilter

from torquemap.estimate_arm import estimate_arm
from torquemap.filters import lowpass
from torquemap.friction_law import StribeckFriction
from torquemap.identify_arm import identify_arm
from torquemap.io import Log, read_log, read_table
from torquemap.model import Model, load_model
from torquemap.sim import arm as sim

METHODS = (
    ("acceleration", "acceleration", False),
    ("momentum", "momentum", False),
    ("momentum zero-phase", "momentum", True),
)


def _law(shape: str) -> StribeckFriction:
    if shape in ("default", "fit"):  # what `torquemap identify robot.toml` fits: the law's defaults
        return StribeckFriction()
    if shape == "true":  # diagnostic: the truth's nonlinear settings
        return StribeckFriction(
            stribeck_velocity=sim.STRIBECK_VEL,
            zero_velocity=sim.TANH_VEL,
            stribeck_exponent=1.0,
            transition="smooth",
        )
    return StribeckFriction(stribeck_velocity=5.0, zero_velocity=0.5, transition="smooth")


def _oracle(robot_path: Path, folder: Path) -> Model:
    return sim.oracle_model(robot_path, folder)


Errors = dict[str, tuple[float, float, float, int]]


def _filtered(
    t: np.ndarray, x: np.ndarray, method: str, cutoff: float, zero_phase: bool
) -> np.ndarray:
    """``x`` (n, c) through a method's final filter: the zero-phase low-pass of the
    acceleration method, or the observer's first-order lag ``K / (s + K)`` (run both ways and
    averaged for the zero-phase observer), discretised as the observer is."""
    if method == "acceleration":
        return np.column_stack([lowpass(t, x[:, i], cutoff=cutoff) for i in range(x.shape[1])])
    a = math.exp(-2.0 * math.pi * cutoff * float(np.median(np.diff(t))))

    def lag(v: np.ndarray) -> np.ndarray:
        out = np.zeros_like(v)
        out[1:] = lfilter([1.0 - a], [1.0, -a], v[:-1], axis=0)
        return out

    forward = lag(x)
    return 0.5 * (forward + lag(x[::-1])[::-1]) if zero_phase else forward


def _errors(model: Model, task: Log, truth: dict[str, Any], cutoff: float) -> Errors:
    """Per method: RMS force error [N], RMS moment error [N m], the share of force components
    within two sigmas of the truth seen through the method's own filter (the sigmas cover
    noise and model errors, not the filter's lag or attenuation of fast force changes), and
    the number of extrapolation warnings. The observers lag the joint torques, mapped to a
    force at the current pose: they are compared with the true ``J^T F`` through that lag,
    mapped so (the force itself lagged misses them by 0.1 N on these moving arms, the pose
    having changed over the lag)."""
    t = np.asarray(truth["t"], dtype=float)
    force = np.column_stack([truth[a] for a in ("fx", "fy", "fz")])
    moment = np.column_stack([truth[a] for a in ("mx", "my", "mz")])
    out = {}
    for label, method, zero_phase in METHODS:
        est = estimate_arm(model, task, method=method, cutoff=cutoff, zero_phase=zero_phase)  # type: ignore[arg-type]
        ok = (est.flag == 0) & (t > 2.0) & (t < t[-1] - 0.5) & np.isfinite(est.wrench).all(axis=1)
        ef = est.wrench[ok, :3] - force[ok]
        if est.wrench.shape[1] >= 6:
            em = est.wrench[ok, 3:6] - moment[ok]
            moment_error = float(np.sqrt(np.mean(np.sum(em**2, axis=1))))
        else:  # fewer than six joints: no moments estimated
            moment_error = math.nan
        if method == "acceleration":
            seen = _filtered(t, force, method, cutoff, zero_phase)
        else:  # the observer lags the joint torques, mapped at the current pose afterwards
            arm: Any = model.robot.arm
            torque = np.einsum("nij,ni->nj", arm.jacobian(est.q)[:, :3, :], force)
            lagged = _filtered(t, torque, method, cutoff, zero_phase)
            seen = np.einsum("nij,nj->ni", arm.wrench_map(est.q)[0], lagged)[:, :3]
        within = float(
            np.mean(np.abs(est.wrench[ok, :3] - seen[ok]) < 2.0 * est.wrench_sigma[ok, :3])
        )
        extrapolated = sum("extrapolat" in w for w in est.warnings)
        out[label] = (
            float(np.sqrt(np.mean(np.sum(ef**2, axis=1)))),
            moment_error,
            within,
            extrapolated,
        )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument(
        "--arms", nargs="+", default=["panda", "ur5", "leg"], choices=list(sim.ARM_NAMES)
    )
    parser.add_argument("--cutoff", type=float, default=2.0, help="low-pass cut-off [Hz], arms")
    parser.add_argument(
        "--leg-cutoff", type=float, default=10.0, help="low-pass cut-off [Hz], the leg"
    )
    parser.add_argument(
        "--free-centre",
        choices=("middle", "task"),
        default="middle",
        help="the exciting motion swings about the middle of the joints' ranges (default) or "
        "about the task's start pose (excite --centre)",
    )
    parser.add_argument(
        "--free-duration",
        type=float,
        default=100.0,
        metavar="S",
        help="length of free.csv [s], whole traversals of the exciting path (default 100)",
    )
    parser.add_argument(
        "--free-period",
        type=float,
        default=None,
        metavar="S",
        help="the exciting path's period [s] (default: torquemap excite's, from the limits)",
    )
    parser.add_argument(
        "--free-speeds",
        type=lambda text: tuple(float(v) for v in text.split(",")),
        default=(1.0, 0.25),
        metavar="V1,V2",
        help="the exciting path's speed schedule (default 1,0.25: full speed, then a quarter)",
    )
    parser.add_argument(
        "--law",
        choices=("fit", "default", "guess", "true"),
        default="fit",
        help="fit: the friction shape fitted per joint (default); or a fixed shape, only the "
        "law's linear parameters fitted: the robot file's default (linear transition 1e-3 "
        "rad/s, Stribeck 1 rad/s, exponent 2), a guess (smooth 0.5 rad/s, Stribeck 5 rad/s) "
        "or the truth's (diagnostic)",
    )
    args = parser.parse_args()
    rows: list[tuple[str, str, Errors]] = []
    keys = []
    for arm_name, seed in [(a, s) for a in args.arms for s in args.seeds]:
        key = f"{arm_name}, seed {seed}"
        keys.append(key)
        with tempfile.TemporaryDirectory() as tmp:
            d = Path(tmp)
            t0 = time.perf_counter()
            sim.write_arm_bench(
                d,
                seed=seed,
                arm=arm_name,
                free_centre=args.free_centre,
                free_duration=args.free_duration,
                free_period=args.free_period,
                free_speeds=args.free_speeds,
            )
            t_sim = time.perf_counter() - t0
            robot_path = d / "robot.toml"
            start = load_model(robot_path)
            guess = {
                n: dataclasses.replace(jm, friction=_law(args.law))
                for n, jm in start.joints.items()
            }
            free = read_log(d / "free.csv", start.robot)
            task = read_log(d / "task.csv", start.robot)
            truth = read_table(d / "truth.csv")
            oracle = _oracle(robot_path, d)
            t0 = time.perf_counter()
            shaped = args.law == "fit"
            result = identify_arm(
                dataclasses.replace(start, joints=guess), [free], fit_friction_shape=shaped
            )
            t_id = time.perf_counter() - t0
            fz = np.asarray(truth["fz"])[np.asarray(truth["t"]) > 2.0]
            print(
                f"{key}: simulated in {t_sim:.1f} s, identified in {t_id:.1f} s, "
                f"fz {fz.min():.1f}..{fz.max():.1f} N, consistent={result.consistent}",
                flush=True,
            )
            models = [
                ("URDF as given", start),
                ("identified", result.model),
                ("oracle", oracle),
            ]
            if arm_name == "leg":  # identified from the task's flight phases alone
                t0 = time.perf_counter()
                flight = identify_arm(
                    dataclasses.replace(start, joints=guess),
                    [task],
                    fit_friction_shape=shaped,
                    exclude_contact=True,
                )
                contact = np.asarray(truth["fz"]) > 0
                print(
                    f"{key}: from task.csv in {time.perf_counter() - t0:.1f} s, "
                    f"{flight.excluded} of {flight.excluded + flight.samples} samples excluded "
                    f"as contact (truth: {contact.mean():.0%} of the log in contact)",
                    flush=True,
                )
                models.insert(2, ("identified (task, contact excluded)", flight.model))
            cutoff = args.leg_cutoff if arm_name == "leg" else args.cutoff
            for label, model in models:
                rows.append((key, label, _errors(model, task, truth, cutoff)))
                errs = rows[-1][2]
                print(
                    f"  {label}: "
                    + ", ".join(
                        f"{m} {e[0]:.3g} N ({e[2]:.0%} within 2 sigma"
                        + (f", {e[3]} extrapolation warnings)" if e[3] else ")")
                        for m, e in errs.items()
                    ),
                    flush=True,
                )
    _print(rows, keys)


def _print(rows: list[tuple[str, str, Errors]], seeds: list[str]) -> None:
    labels = [m[0] for m in METHODS]
    print()
    print("| arm | model | " + " | ".join(labels) + " |")
    print("|---|---|" + "---|" * len(labels))
    table = {(s, lab): e for s, lab, e in rows}
    for seed, label, errs in rows:
        cells = []
        for m in labels:
            f, mo, *_ = errs[m]
            cell = f"{f:.3g} N" + ("" if math.isnan(mo) else f" / {mo:.3g} N m")
            if label.startswith("identified"):
                cell += f" ({f / table[(seed, 'oracle')][m][0]:.2f}x oracle)"
            cells.append(cell)
        print(f"| {seed} | {label} | " + " | ".join(cells) + " |")
    print()
    for group in (*sim.ARM_NAMES, ""):
        keys = [s for s in seeds if s.startswith(group)]
        if not keys:
            continue
        print(f"{group or 'all'} ({len(keys)} benches):")
        for m in labels:
            ratio = [table[(s, "identified")][m][0] / table[(s, "oracle")][m][0] for s in keys]
            gain = [
                table[(s, "URDF as given")][m][0] / table[(s, "identified")][m][0] for s in keys
            ]
            within = [table[(s, "identified")][m][2] for s in keys]
            warned = sum(table[(s, "identified")][m][3] > 0 for s in keys)
            print(
                f"  {m}: identified/oracle median {np.median(ratio):.2f}x worst "
                f"{max(ratio):.2f}x; URDF/identified median {np.median(gain):.1f}x worst "
                f"{min(gain):.1f}x; force components within 2 sigma median "
                f"{np.median(within):.0%} lowest {min(within):.0%}; extrapolation warned on "
                f"{warned} of {len(keys)}"
            )


if __name__ == "__main__":
    main()
