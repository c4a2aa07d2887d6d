"""Force accuracy on the simulated circle: raw Eq 7, low-pass, paper, model and an oracle.

One command: ``python benchmarks/force_accuracy.py [--seed N] [--cutoff HZ]``. Simulates the SCARA
bench, identifies the model from the no-load sweeps, estimates the spring force on the 130 mm
circle with each method and prints the RMS error in N and in % of the paper's 3.5 N. The oracle
runs the model method with the simulator's true inertia, friction and PDTV (truth.toml).

Errors are scored on the samples no estimate flagged (all joints faster than their friction
model's zero-velocity band, pose away from singular); the column "all" scores every sample
(standstill at the ends of the circle included, where friction at rest is undetermined).
Targets (issue 3): model < 3 % of 3.5 N and <= 1.3x the oracle; paper clearly below low-pass.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from torquemap.estimate import estimate_forces
from torquemap.identify import identify_model
from torquemap.io import read_log, read_table
from torquemap.model import load_model
from torquemap.sim.bench import write_scara_bench
from torquemap.sim.score import PAPER_FORCE, common_mask, force_error


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cutoff", type=float, default=2.0, help="low-pass cut-off [Hz]")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        t0 = time.perf_counter()
        write_scara_bench(d, seed=args.seed)
        t_sim = time.perf_counter() - t0
        truth_model = load_model(d / "truth.toml")
        robot = truth_model.robot
        sweep = read_log(d / "sweep.csv", robot)
        circle = read_log(d / "circle.csv", robot)
        truth = read_table(d / "truth.csv")
    true_force = np.c_[truth["fx"], truth["fy"]]
    t0 = time.perf_counter()
    identified = identify_model(robot, [sweep]).model
    t_id = time.perf_counter() - t0
    runs = [
        ("raw Eq 7", identified, "raw"),
        ("low-pass only", identified, "lowpass"),
        ("paper", identified, "paper"),
        ("model", identified, "model"),
        ("oracle (true model)", truth_model, "model"),
    ]
    results = []
    for label, model, method in runs:
        t0 = time.perf_counter()
        est = estimate_forces(model, circle, method=method, cutoff=args.cutoff)  # type: ignore[arg-type]
        results.append((label, est, time.perf_counter() - t0))
    mask = common_mask([est.flag for _, est, _ in results])
    print(
        f"Force accuracy on the simulated circle (seed {args.seed}, cut-off {args.cutoff:g} Hz, "
        f"{circle.t.size} samples, {mask.mean():.1%} scored; spring force {PAPER_FORCE} N)"
    )
    print(f"simulate {t_sim:.1f} s, identify {t_id:.1f} s")
    head = f"{'method':<22}{'RMS [N]':>9}{'% of 3.5 N':>12}{'max [N]':>9}{'all: RMS [N]':>14}{'time [s]':>10}"
    print(head)
    print("-" * len(head))
    scores = {}
    for label, est, dt in results:
        assert est.force is not None
        s = force_error(est.force, true_force, mask=mask)
        a = force_error(est.force, true_force)
        scores[label] = s.rms
        print(
            f"{label:<22}{s.rms:>9.4f}{s.percent:>11.2f}%{s.max_abs:>9.3f}{a.rms:>14.4f}{dt:>10.2f}"
        )
    ratio = scores["model"] / scores["oracle (true model)"]
    print(
        f"\nmodel / oracle = {ratio:.2f} (target <= 1.3); model {scores['model'] / PAPER_FORCE:.1%} "
        f"of 3.5 N (target < 3 %); paper / low-pass = "
        f"{scores['paper'] / scores['low-pass only']:.2f} (target clearly < 1)"
    )


if __name__ == "__main__":
    main()
