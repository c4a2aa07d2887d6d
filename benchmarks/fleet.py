"""Fleet identification: the speed-up of 2 Dask workers over 1 (issue: speed, memory, fleets).

A light simulated fleet of single motors (``simulate fleet --motors``: 6 s closed-form sweeps,
Coulomb friction growing 0-3 %/day) is identified with ``torquemap.fleet.identify_fleet`` on a
local cluster of 1 and then 2 single-threaded worker processes; then ``fleet drift`` is scored
against the known wear (every motor's Coulomb friction grows, so every Coulomb series whose
true growth over the period exceeds its standard error should be flagged).

    python benchmarks/fleet.py            # 25 motors x 4 days = 100 robot-days
    python benchmarks/fleet.py --quick    # 10 robot-days
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from torquemap.drift import fleet_drift
from torquemap.fleet import identify_fleet, read_fleet
from torquemap.sim.fleet import write_motor_fleet


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="5 motors x 2 days")
    parser.add_argument("--robots", type=int, default=25)
    parser.add_argument("--days", type=int, default=4)
    args = parser.parse_args()
    robots, days = (5, 2) if args.quick else (args.robots, args.days)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        t0 = time.perf_counter()
        fleet = read_fleet(write_motor_fleet(root / "fleet", robots=robots, days=days, seed=1))
        sim = time.perf_counter() - t0
        rows = []
        for workers in (1, 2):
            run = identify_fleet(fleet, root / f"out{workers}", workers=workers)
            rows.append((workers, run.seconds, len(run.outcomes) - len(run.failed)))
        drift = fleet_drift(root / "out2") if days >= 3 else None
    print(
        f"fleet: {robots} motors x {days} days = {robots * days} robot-days "
        f"(simulated in {sim:.1f} s)"
    )
    print("| workers | wall time [s] | robot-days identified | speed-up |")
    print("|---|---|---|---|")
    for workers, seconds, ok in rows:
        print(f"| {workers} | {seconds:.1f} | {ok} | {rows[0][1] / seconds:.2f}x |")
    if drift is not None:
        coulomb = [s for s in drift.series if s.parameter.startswith("friction.coulomb")]
        flagged = sum(s.flag for s in coulomb)
        print(
            f"drift: {flagged} of {len(coulomb)} Coulomb series flagged (all wear, at "
            "0-3 %/day; series whose wear is below their own noise are not)"
        )


if __name__ == "__main__":
    main()
