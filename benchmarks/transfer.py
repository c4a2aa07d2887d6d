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

``--family FIRST LAST``: the random benches FIRST .. LAST of the family
(:func:`torquemap.sim.family.paper_bench`, e.g. 101 110 and the held-out 111 125) as first
joints, each with one sibling (``sibling(..., rng=seed)``, sensor noise seed ``seed + 1000``),
its handful (``2 m`` positions, pulse widths every 64) and its full paper collection: the
first joint's tables unchanged, the transferred tables (the handful's choice of scaling,
printed) and the full characterisation's; median, worst and how many transfers are worse than
the first joint unchanged. About 5 s of CPU a bench.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

from torquemap.linearize.collect import CollectionSettings, collect_characterisation
from torquemap.linearize.metrics import apmd_report
from torquemap.linearize.tables import TableSet, build_tables, read_data
from torquemap.linearize.transfer import transfer_characterisation
from torquemap.sim.family import paper_bench
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


def family_row(seed: int, d: Path) -> tuple[str, float, float, float, str]:
    """One random bench as the first joint: (kind, unchanged, transferred, full, scaling)."""
    bench = paper_bench(seed)
    first = bench.rig
    spec1 = first.motor_spec(ramping=bench.ramping)
    n = spec1.positions_per_cycle
    paper = CollectionSettings.paper(progress=False)
    collect_characterisation(first, spec1, d / f"{seed}-first.csv", paper)
    motor, amp = sibling(first.motor, first.amplifier, rng=seed)
    rig = SimRig(motor, amp, first.settings, rng=seed + 1000, name=f"sibling-{seed}")
    spec = rig.motor_spec(ramping=bench.ramping)
    few_settings = CollectionSettings(
        position_step=-(-n // (2 * spec.phases)), level_step=64, progress=False
    )
    collect_characterisation(rig, spec, d / f"{seed}-few.csv", few_settings)
    collect_characterisation(rig, spec, d / f"{seed}-full.csv", paper)
    data1 = read_data(d / f"{seed}-first.csv", spec1, kind="characterisation")
    few = read_data(d / f"{seed}-few.csv", spec, kind="characterisation")
    full = read_data(d / f"{seed}-full.csv", spec, kind="characterisation")
    result = transfer_characterisation(spec1, data1, spec, few)
    return (
        bench.kind,
        apmd(rig, build_tables(spec1, data1.position, data1.level, data1.torque)),
        apmd(rig, build_tables(spec, result.position, result.pulse_width, result.torque)),
        apmd(rig, build_tables(spec, full.position, full.level, full.torque)),
        result.model,
    )


def family(first_seed: int, last_seed: int) -> int:
    """The family table (``--family``)."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(first_seed, last_seed + 1):
            rows.append((seed, *family_row(seed, Path(tmp))))
            print(f"  bench {seed}: {rows[-1]}", file=sys.stderr)
    print(f"Transfer on random benches {first_seed}-{last_seed}: APMD [%] noise-free")
    print(f"{'seed':>5}{'motor':>6}{'unchanged':>11}{'transferred':>13}{'full':>8}  scaling")
    for seed, kind, a, b, c, model in rows:
        print(f"{seed:>5}{kind:>6}{100 * a:>10.2f}%{100 * b:>12.2f}%{100 * c:>7.2f}%  {model}")
    for label, pick in (("median", statistics.median), ("worst", max)):
        a, b, c = (pick([float(r[k]) for r in rows]) for k in (2, 3, 4))
        print(f"{label:>11}{100 * a:>10.2f}%{100 * b:>12.2f}%{100 * c:>7.2f}%")
    worse = sum(r[3] > r[2] for r in rows)
    print(f"transferred worse than the first joint unchanged on {worse} of {len(rows)}")
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument(
        "--family", nargs=2, type=int, metavar=("FIRST", "LAST"), help="random benches"
    )
    args = parser.parse_args()
    if args.family:
        return family(*args.family)
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
