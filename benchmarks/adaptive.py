"""Adaptive collection against the paper's grid on random motors of the family.

Run: ``.venv/bin/python benchmarks/adaptive.py [--count N] [--first-seed S] [--draws D]``
(N random motors from seed S, default 6 from 0; the adaptive collection is repeated over D
sensor-noise draws, default 4, and its APMD averaged: one draw's ratio to the grid varies by up
to 2x on the same motor; about 20 s of CPU a motor).

For each random bench (:func:`torquemap.sim.family.random_bench`, seeds 0 .. N-1) with the
paper's collection settings (10 readings a row, every 4th position and pulse width, the bias over
100 readings): three DATA.csv, each built with ``build_tables`` and scored noise-free (Eq 1 over
every cell of the torque the sensor would see, motor minus the rig's friction):

* the paper's grid (all its readings);
* the adaptive collection (:func:`torquemap.linearize.adaptive.collect_adaptive`) within a third
  of the grid's readings, on rigs with other sensor noise (noise seeds ``seed + 1000 k``,
  ``k = 1 .. D``; the mean APMD over the draws);
* a uniform grid of about the same readings (every 8th position and pulse width, 29 %), the
  non-adaptive way to spend a third.

Printed: APMD of each, the ratios to the grid, readings spent; median and worst.

``--noise-free``: every rig without sensor noise (one draw suffices), so that the ratio is what
the placement alone loses (positions and pulse widths not measured), not the noise of fewer
readings.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

from torquemap.linearize.adaptive import collect_adaptive, grid_readings
from torquemap.linearize.collect import CollectionSettings, collect_characterisation
from torquemap.linearize.metrics import apmd_report
from torquemap.linearize.tables import TableSet, build_tables, read_data
from torquemap.sim.family import Bench, random_bench
from torquemap.sim.rig import SimRig


def apmd(rig: SimRig, tables: TableSet) -> tuple[float, float]:
    """Eq 1 over every cell (p, c > 0) of the sensed torque through the tables, noise-free,
    and above 10 % command."""
    n, cmax = tables.positions_per_cycle, tables.command_max
    p = np.arange(n)
    act = np.moveaxis(tables.phases[:, :, : cmax + 1], 0, -1)
    torque = np.maximum(rig.true_torque(p[:, None], act) - rig.settings.friction, 0.0)
    pp, cc = np.meshgrid(p, np.arange(cmax + 1), indexing="ij")
    report = apmd_report(
        pp.ravel(), cc.ravel(), torque.ravel(), command_max=cmax, positions_per_cycle=n
    )
    return report.apmd, report.apmd_above_10


def _bench(seed: int, *, noise_seed: int | None = None, noise_free: bool = False) -> Bench:
    """The family's bench, its sensor noise set to zero when ``noise_free``."""
    bench = random_bench(seed, noise_seed=noise_seed)
    if noise_free:
        bench.rig.settings = dataclasses.replace(bench.rig.settings, noise=0.0)
    return bench


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--count", type=int, default=6, help="random motors (default 6)")
    parser.add_argument("--first-seed", type=int, default=0, help="first seed (default 0)")
    parser.add_argument(
        "--draws", type=int, default=4, help="noise draws of the adaptive run (default 4)"
    )
    parser.add_argument(
        "--noise-free",
        action="store_true",
        help="rigs without sensor noise: the loss of the placement alone",
    )
    args = parser.parse_args()
    quiet = bool(args.noise_free)
    seeds = range(args.first_seed, args.first_seed + args.count)
    paper = CollectionSettings.paper(progress=False)
    third = CollectionSettings(readings=10, position_step=8, level_step=8, progress=False)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        for seed in seeds:
            bench = random_bench(seed)
            spec = bench.rig.motor_spec(ramping=bench.ramping)
            scores = {}
            for label, settings in (("grid", paper), ("uniform", third)):
                out = d / f"{seed}-{label}.csv"
                collect_characterisation(_bench(seed, noise_free=quiet).rig, spec, out, settings)
                data = read_data(out, spec, kind="characterisation")
                tables = build_tables(spec, data.position, data.level, data.torque)
                scores[label] = apmd(bench.rig, tables)
            draws = []
            for k in range(1, args.draws + 1):
                out = d / f"{seed}-adaptive-{k}.csv"
                rig = _bench(seed, noise_seed=seed + 1000 * k, noise_free=quiet).rig
                result = collect_adaptive(rig, spec, out, paper)
                data = read_data(out, spec, kind="characterisation")
                tables = build_tables(spec, data.position, data.level, data.torque)
                draws.append(apmd(bench.rig, tables))
            scores["adaptive"] = (
                float(np.mean([a for a, _ in draws])),
                float(np.mean([b for _, b in draws])),
            )
            rows.append(
                (
                    bench.describe(),
                    scores,
                    result.readings / result.grid_readings,
                    grid_readings(spec, third) / result.grid_readings,
                    result.positions,
                    result.levels.size,
                )
            )
            print(f"  seed {seed} done", file=sys.stderr)

    print("Adaptive collection vs the paper's grid: APMD [%] noise-free, random motors")
    print(
        f"{'seed':<5}{'grid':>7}{'adaptive':>9}{'uniform':>8}{'ad/grid':>8}{'un/grid':>8}"
        f"{'ad reads':>9}{'un reads':>9}{'positions':>10}{'levels':>7}  motor"
    )
    for seed, (text, both, frac, ufrac, npos, nlev) in zip(seeds, rows, strict=True):
        sc = {k: v[0] for k, v in both.items()}
        print(
            f"{seed:<5}{100 * sc['grid']:>6.2f}%{100 * sc['adaptive']:>8.2f}%"
            f"{100 * sc['uniform']:>7.2f}%{sc['adaptive'] / sc['grid']:>8.2f}"
            f"{sc['uniform'] / sc['grid']:>8.2f}{100 * frac:>8.0f}%{100 * ufrac:>8.0f}%"
            f"{npos:>10}{nlev:>7}  {text.split(': ', 1)[1]}"
        )
    ad = [r[1]["adaptive"][0] / r[1]["grid"][0] for r in rows]
    un = [r[1]["uniform"][0] / r[1]["grid"][0] for r in rows]
    ad10 = [r[1]["adaptive"][1] / r[1]["grid"][1] for r in rows]
    print(
        "above 10 % command [%]: "
        + "; ".join(
            f"{s}: grid {100 * r[1]['grid'][1]:.2f} adaptive {100 * r[1]['adaptive'][1]:.2f} "
            f"uniform {100 * r[1]['uniform'][1]:.2f}"
            for s, r in zip(seeds, rows, strict=True)
        )
    )
    print(f"ratio above 10 %: adaptive median {statistics.median(ad10):.2f} worst {max(ad10):.2f}")
    print(
        f"ratio to the grid: adaptive median {statistics.median(ad):.2f} worst {max(ad):.2f}; "
        f"uniform third median {statistics.median(un):.2f} worst {max(un):.2f}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
