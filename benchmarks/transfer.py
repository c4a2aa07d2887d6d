"""Transfer to second joints of the same motor type (Adept II paper, §6.2).

Run: ``.venv/bin/python benchmarks/transfer.py`` (about 10 minutes on 2 cores).

For each motor type (the default VR and BLDC rigs): the first joint is characterised with the
paper's collection (10 readings a row, every 4th position and pulse width). SIBLINGS second
joints are drawn around it (:func:`torquemap.sim.twins.sibling`: phase gains, equilibria, peak
torque, saturation, harmonics, cogging, amplifier dead band, curve and current limit). Each
second joint gets a handful of measurements (the ``2 m = 6`` region middles, pulse widths 0, 64,
128, 192, 255: 30 rows of 10 readings) and, for comparison, the paper's full collection. Three
table sets are scored on the second joint, noise-free (Eq 1 over every cell of the torque its
sensor would see, motor minus the rig's friction): the first joint's tables unchanged, the
tables built from the transferred data, and the tables of the second joint's full
characterisation. Median and worst over the siblings.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

from torquemap.linearize.collect import CollectionSettings, collect_characterisation
from torquemap.linearize.metrics import apmd_report
from torquemap.linearize.tables import TableSet, build_tables, read_data
from torquemap.linearize.transfer import transfer_characterisation
from torquemap.sim.rig import SimRig, sim_rig
from torquemap.sim.twins import sibling

SIBLINGS = 6


def apmd(rig: SimRig, tables: TableSet) -> float:
    """Eq 1 over every cell (p, c > 0) of the sensed torque through the tables, noise-free."""
    n, cmax = tables.positions_per_cycle, tables.command_max
    p = np.arange(n)
    act = np.moveaxis(tables.phases[:, :, : cmax + 1], 0, -1)
    torque = np.maximum(rig.true_torque(p[:, None], act) - rig.settings.friction, 0.0)
    pp, cc = np.meshgrid(p, np.arange(cmax + 1), indexing="ij")
    return apmd_report(
        pp.ravel(), cc.ravel(), torque.ravel(), command_max=cmax, positions_per_cycle=n
    ).apmd


def main() -> int:
    lines = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        for kind in ("vr", "bldc"):
            first = sim_rig(kind, rng=1)  # type: ignore[arg-type]
            spec1 = first.motor_spec()
            n = spec1.positions_per_cycle
            collect_characterisation(
                first, spec1, d / f"{kind}-first.csv", CollectionSettings.paper(progress=False)
            )
            data1 = read_data(d / f"{kind}-first.csv", spec1, kind="characterisation")
            tables1 = build_tables(spec1, data1.position, data1.level, data1.torque)
            rows = []
            for s in range(SIBLINGS):
                motor, amp = sibling(first.motor, first.amplifier, rng=1000 + s)
                rig = sim_rig(kind, rng=50 + s, motor=motor, amplifier=amp)  # type: ignore[arg-type]
                spec = rig.motor_spec()
                few_csv, full_csv = d / f"{kind}{s}-few.csv", d / f"{kind}{s}-full.csv"
                collect_characterisation(
                    rig,
                    spec,
                    few_csv,
                    CollectionSettings(
                        position_step=-(-n // (2 * spec.phases)), level_step=64, progress=False
                    ),
                )
                few = read_data(few_csv, spec, kind="characterisation")
                result = transfer_characterisation(spec1, data1, spec, few)
                moved = build_tables(spec, result.position, result.pulse_width, result.torque)
                collect_characterisation(
                    rig, spec, full_csv, CollectionSettings.paper(progress=False)
                )
                full = read_data(full_csv, spec, kind="characterisation")
                own = build_tables(spec, full.position, full.level, full.torque)
                rows.append(
                    (apmd(rig, tables1), apmd(rig, moved), apmd(rig, own), few.position.size,
                     full.position.size)
                )  # fmt: skip
                print(f"  {kind} sibling {s}: {rows[-1]}", file=sys.stderr)
            lines.append((kind, rows))

    print("Transfer to a second joint: APMD [%] noise-free on the second joint")
    print(
        f"{'motor':<6}{'sibling':>8}{'first unchanged':>17}{'transferred':>13}{'full':>8}"
        f"{'transf/full':>12}{'rows few/full':>15}"
    )
    for kind, rows in lines:
        for s, (a, b, c, nf, nfull) in enumerate(rows):
            print(
                f"{kind:<6}{s:>8}{100 * a:>16.2f}%{100 * b:>12.2f}%{100 * c:>7.2f}%"
                f"{b / c:>12.2f}{nf:>8}/{nfull}"
            )
        for label, pick in (("median", statistics.median), ("worst", max)):
            a = pick(r[0] for r in rows)
            b = pick(r[1] for r in rows)
            c = pick(r[2] for r in rows)
            ratio = pick(r[1] / r[2] for r in rows)
            print(
                f"{kind:<6}{label:>8}{100 * a:>16.2f}%{100 * b:>12.2f}%{100 * c:>7.2f}%"
                f"{ratio:>12.2f}"
            )
        wins = sum(r[1] < r[0] for r in rows)
        print(f"{kind}: transfer beats the first joint's tables on {wins} of {len(rows)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
