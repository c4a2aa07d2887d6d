"""Anti-cogging loop over a family of random actuators: calibrate from holds, apply, verify.

One command: ``python benchmarks/anticogging.py [--benches N] [--positions P]``. Each bench is the
test stand of ``torquemap simulate actuator`` with random PDTV lines (3 to 6 lines, orders 1 to
48 CPR, amplitudes 0.5 to 5 mN m, random phases; seeded). Per bench: position holds at P
positions out and back, quasi-static identification, a 1024-bin map, a 3 rad/s sweep without
and with the map, and ``verify_cogging``. Reported, median and worst over the family:

- lines: true lines missed / spurious lines found (false alarm 1 %);
- amplitude error of the found lines [% of the true amplitude] and phase error [rad];
- disturbance left: RMS of (true PDTV - applied feed-forward) over RMS of the true PDTV during
  the sweep with the map (truth the estimators never see);
- speed ripple removed, and the torque ripple removed, at the model's lines (``verify_cogging``
  with the sweep without the map as "before").
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from torquemap.cogging import verify_cogging
from torquemap.io import log_from_columns
from torquemap.pdtv_map import pdtv_map
from torquemap.quasistatic import identify_quasi_static
from torquemap.robot import robot_from_dict
from torquemap.sim.actuator import (
    Actuator,
    log_columns,
    robot_document,
    simulate_holds,
    simulate_sweep,
)
from torquemap.sim.scara import Harmonic


def random_actuator(rng: np.random.Generator) -> Actuator:
    """The default stand with random PDTV lines."""
    n = int(rng.integers(3, 7))
    orders = rng.choice(np.arange(1, 49), size=n, replace=False)
    lines = tuple(
        Harmonic(
            order=float(o),
            amplitude=float(rng.uniform(0.5e-3, 5e-3)),
            phase=float(rng.uniform(-np.pi, np.pi)),
        )
        for o in sorted(orders)
    )
    base = Actuator()
    return dataclasses.replace(base, axis=dataclasses.replace(base.axis, pdtv=lines))


def run(seed: int, positions: int) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    act = random_actuator(rng)
    robot = robot_from_dict(robot_document(act))
    holds = log_from_columns(
        log_columns(simulate_holds(act, positions=positions, rng=rng), act), robot
    )
    model = identify_quasi_static(robot, [holds]).model
    found = {ln.order: ln for ln in model.joints["a"].pdtv}
    truth = {h.order: h for h in act.axis.pdtv}
    amp_err = [
        abs(found[o].amplitude - h.amplitude) / h.amplitude for o, h in truth.items() if o in found
    ]
    ph_err = [
        abs(float(np.angle(np.exp(1j * (found[o].phase - h.phase)))))
        for o, h in truth.items()
        if o in found
    ]
    table = pdtv_map(model, "a", bins=1024).torque if found else np.zeros(1024)
    before = simulate_sweep(act, rng=seed + 1000)
    after = simulate_sweep(act, compensation=table, rng=seed + 1000)
    cruise = np.abs(after.velocity) > 2.0
    left = float(np.std((after.pdtv - after.compensation)[cruise]) / np.std(after.pdtv[cruise]))
    out = {
        "missed": float(len(set(truth) - set(found))),
        "spurious": float(len(set(found) - set(truth))),
        "amp_err": 100 * max(amp_err) if amp_err else float("nan"),
        "phase_err": max(ph_err) if ph_err else float("nan"),
        "left": 100 * left,
        "speed_removed": float("nan"),
        "torque_removed": float("nan"),
    }
    if found:
        res = verify_cogging(
            model,
            log_from_columns(log_columns(after, act), robot),
            log_from_columns(log_columns(before, act), robot),
        )
        out["speed_removed"] = 100 * res.speed_removed
        out["torque_removed"] = 100 * res.torque_removed
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--benches", type=int, default=10)
    parser.add_argument("--positions", type=int, default=128)
    args = parser.parse_args()
    t0 = time.perf_counter()
    rows = [run(seed, args.positions) for seed in range(args.benches)]
    elapsed = time.perf_counter() - t0
    keys = [
        ("missed", "true lines missed", "worst=max"),
        ("spurious", "spurious lines", "worst=max"),
        ("amp_err", "largest amplitude error [%]", "worst=max"),
        ("phase_err", "largest phase error [rad]", "worst=max"),
        ("left", "disturbance left with the map [% RMS]", "worst=max"),
        ("speed_removed", "speed ripple removed at the lines [%]", "worst=min"),
        ("torque_removed", "torque ripple removed at the lines [%]", "worst=min"),
    ]
    print(f"{args.benches} random actuators, {args.positions} hold positions, {elapsed:.0f} s")
    print(f"| {'quantity':40s} | median | worst |")
    print(f"|{'-' * 42}|--------|-------|")
    for key, label, worst in keys:
        v = np.array([r[key] for r in rows])
        w = np.nanmax(v) if worst == "worst=max" else np.nanmin(v)
        print(f"| {label:40s} | {np.nanmedian(v):6.3g} | {w:5.3g} |")


if __name__ == "__main__":
    main()
