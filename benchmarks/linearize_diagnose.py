"""Where one random motor's APMD excess over the floor comes from (docs/linearize.md, "Seeds 53,
68 and 81: where the excess is").

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/linearize_diagnose.py SEED [--draws N]``.

For the family's motor ``SEED`` at the benchmark's collection (``benchmarks/linearize.py``: the
paper's settings, the bias on an open contact) it builds the interp tables from

* the rig's rows (as the benchmark does),
* the same rows without sensor noise (the rig collected again with ``noise=0``: same rows,
  positions and bias column, only the noise removed),
* the noise-free rows with the noise put back only on the rows below 5 % of the largest torque
  (the knee and the friction zone), and only on the rows above it,

and prints for each the noise-free APMD ratio to the floor (Eq 1 over every cell of the sensed
surface, :func:`linearize.noise_free`), the excess by command band, the CAPMD at commands 1 to
3, and the pulse-width error against the floor's table at commands 1 to 3 by a position's offset
in its block of measured positions (0: measured; 1 to 3: between), and the share of the PAPMD
excess (Eq 3) at the ramp's hand-overs (positions within half a position step of a phase's
fractional share; docs/linearize.md, "Seed 160"). ``--draws N``: also the
measured ratio through N verification runs with different noise (the benchmark's run is draw 0).

This reads the simulator's truth (the floor, the noise-free rig): a benchmark-side diagnosis,
never part of an estimator.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from linearize import floor_tables, noise_free, sensed, verification_settings

from torquemap.linearize.collect import (
    collect_characterisation,
    collect_verification,
)
from torquemap.linearize.metrics import evaluate_linearity
from torquemap.linearize.motor import ramped_actuation
from torquemap.linearize.tables import LinearizeData, TableSet, build_tables, read_data
from torquemap.sim.family import paper_bench

BANDS = ((1, 3), (4, 12), (13, 40), (41, 127))


def rows(seed: int, out: Path, *, noise: float | None = None) -> LinearizeData:
    """The benchmark's characterisation of motor ``seed`` (``noise``: the sensor's, if given)."""
    bench = paper_bench(seed)
    rig = bench.rig
    if noise is not None:
        rig.settings = dataclasses.replace(rig.settings, noise=noise)
    spec = rig.motor_spec(ramping=bench.ramping)
    collect_characterisation(rig, spec, out, dataclasses.replace(bench.settings, bias_open=True))
    return read_data(out, spec, kind="characterisation")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("seed", type=int)
    parser.add_argument("--draws", type=int, default=0, help="verification runs (measured)")
    args = parser.parse_args(argv)
    seed = args.seed
    bench = paper_bench(seed)
    rig = bench.rig
    spec = rig.motor_spec(ramping=bench.ramping)
    tmp = Path(tempfile.mkdtemp())
    noisy = rows(seed, tmp / "noisy.csv")
    exact = rows(seed, tmp / "exact.csv", noise=0.0)
    if not (
        np.array_equal(noisy.position, exact.position) and np.array_equal(noisy.level, exact.level)
    ):
        raise SystemExit("the noise-free collection visited other rows: no like-for-like")
    low = exact.torque < 0.05 * float(np.max(exact.torque))
    variants = {
        "rig's rows": (noisy.torque, noisy.bias),
        "noise-free rows": (exact.torque, exact.bias),
        "noise below 5 % only": (np.where(low, noisy.torque, exact.torque), exact.bias),
        "noise above 5 % only": (np.where(low, exact.torque, noisy.torque), exact.bias),
    }
    tables: dict[str, TableSet] = {
        name: build_tables(spec, noisy.position, noisy.level, tau, bias=bias)
        for name, (tau, bias) in variants.items()
    }
    floor = floor_tables(rig, spec, tables["noise-free rows"])
    fl = noise_free(rig, floor)
    cmax = floor.command_max
    tpc = floor.torque_per_count
    n = spec.positions_per_cycle
    p = np.arange(n)
    print(bench.describe())
    s = rig.settings
    print(
        f"one count {tpc:.4g} N m; friction {s.friction / tpc:.1f} counts; a row's noise "
        f"{s.noise / np.sqrt(bench.settings.readings) / tpc:.2f} counts; floor APMD "
        f"{100 * fl.apmd:.3f} %, CAPMD 1-3 {np.round(100 * fl.capmd[1:4], 1).tolist()}"
    )
    top = spec.actuation_max
    act = ramped_actuation(np.arange(top + 1)[None, :], p[:, None], spec.ramp)
    surface = sensed(rig, p[:, None], act)
    want = np.arange(cmax + 1) * tpc
    best = np.abs(surface[:, :, None] - want[None, None, :]).argmin(axis=1)  # the floor's base
    step = int(np.median(np.diff(np.unique(noisy.position[noisy.level == 0]))))
    ramp = np.asarray(spec.ramp, dtype=np.float64)
    fractional = np.any((ramp > 0) & (ramp < 1), axis=1)
    handover = np.zeros(n, dtype=bool)
    for shift in range(-(step // 2), step // 2 + 1):
        handover |= np.roll(fractional, shift)
    for name, t in tables.items():
        r = noise_free(rig, t)
        excess = (np.nan_to_num(r.capmd) - np.nan_to_num(fl.capmd)) / cmax
        bands = ", ".join(f"{a}-{b} {100 * excess[a : b + 1].sum():.3f}" for a, b in BANDS)
        print(f"{name}: {r.apmd / fl.apmd:.2f}x; excess points by command {bands}")
        print(f"    CAPMD 1-3 {np.round(100 * r.capmd[1:4], 1).tolist()} %")
        papmd = np.nan_to_num(r.papmd) - np.nan_to_num(fl.papmd)
        if handover.any() and papmd.sum() > 0:
            print(
                f"    hand-overs ({handover.sum()} of {n} positions): "
                f"{100 * papmd[handover].sum() / papmd.sum():.0f} % of the PAPMD excess"
            )
        for c in (1, 2, 3):
            err = t.base[:, c] - best[:, c]
            by = [f"{err[p % step == k].mean():+.1f}" for k in range(step)]
            print(f"    command {c}: base pulse width - floor's by offset in block {by}")
    for draw in range(args.draws):
        check = paper_bench(seed, noise_seed=10_000 + seed + 1000 * draw).rig
        apmd = {}
        for name in ("rig's rows", "noise-free rows"):
            check.rng = np.random.default_rng(20_000 + seed + 1000 * draw)
            check.base, check.force = check.settings.start_position, 0.0
            out = tmp / f"verify-{draw}-{name.split()[0]}.csv"
            collect_verification(
                check, spec, tables[name].as_mapping(), out, verification_settings(spec)
            )
            data = read_data(out, spec, kind="verification")
            apmd[name] = evaluate_linearity(spec, data, tables=tables[name]).apmd
        check.rng = np.random.default_rng(20_000 + seed + 1000 * draw)
        check.base, check.force = check.settings.start_position, 0.0
        out = tmp / f"verify-{draw}-floor.csv"
        collect_verification(check, spec, floor.as_mapping(), out, verification_settings(spec))
        fm = evaluate_linearity(spec, read_data(out, spec, kind="verification"), tables=floor).apmd
        rig_rows, free_rows = apmd["rig's rows"] / fm, apmd["noise-free rows"] / fm
        print(
            f"measured, draw {draw}: rig's rows {rig_rows:.2f}x, noise-free rows "
            f"{free_rows:.2f}x (floor {100 * fm:.3f} %)"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
