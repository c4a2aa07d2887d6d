"""Torque linearity measures of the Adept II paper (§5.3): APMD, CAPMD, PAPMD and friends.

The desired torque is the plane through ``c = 0, tau = 0`` and the average torque ``tau_ave`` on
the half-way contour ``c = C / 2``: ``tau_d(p, c) = c tau_ave / (C / 2)``. With ``PMD(p, c) =
|tau_d - tau| / |tau_d|`` (the percent magnitude deviation, here as a fraction):

* APMD (Eq 1): the mean PMD over all cells (``c = 1 .. C``, every position);
* CAPMD (Eq 2): the mean over positions, per command; PAPMD (Eq 3): the mean over commands, per
  position;
* the PMD distribution (histogram), the APMD above 10 % command, the largest
  position-independent torque and the data density (paper Table 2).

Data rows at the same (position, command) cell are averaged first; cells without data are
skipped (the paper's data covered every cell; ours may be sparse), so the means run over the
cells that hold data. With every cell present, the means of CAPMD and of PAPMD equal APMD.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError
from torquemap.linearize.motor import MotorSpec
from torquemap.linearize.tables import LinearizeData, TableSet, table_torque_law


@dataclass(frozen=True, slots=True, eq=False)
class LinearityReport:
    """Linearity of torque vs position vs command (paper §5.3, Table 2).

    Deviations are fractions (0.042 is the paper's 4.2 %).

    Attributes
    ----------
    apmd
        Overall APMD (Eq 1) about the fitted plane.
    apmd_above_10
        APMD over the cells with ``c > 0.1 C``.
    capmd
        CAPMD (Eq 2) for ``c = 0 .. C``, shape (C + 1,); NaN where no data (and at ``c = 0``).
    papmd
        PAPMD (Eq 3) per position, shape (P,); NaN where no data.
    pmd_edges, pmd_density
        The PMD distribution: bin edges (fractions), shape (k + 1,), and the fraction of cells
        per bin, shape (k,).
    tau_ave
        Mean torque on the half-way contour [N m].
    slope
        The plane's slope ``tau_ave / (C / 2)`` [N m per command unit].
    command_max
        ``C``.
    position_independent_torque
        Minimum over positions of the largest torque measured there [N m], over positions whose
        data reach at least 90 % of the largest command measured.
    data_density
        Fraction of the ``P x C`` cells holding data.
    command_range
        Largest command with data over ``C``.
    density_in_range
        Fraction of the cells up to the largest command with data that hold data.
    rows, cells
        Data rows used (``1 <= c <= C``) and cells they fill.
    cell_position, cell_command, cell_torque, cell_pmd
        The cells (sorted by position then command), shape (cells,).
    nominal_apmd, nominal_apmd_above_10
        APMD against the nominal torque the tables were built for (None without tables).
    """

    apmd: float
    apmd_above_10: float
    capmd: NDArray[np.float64]
    papmd: NDArray[np.float64]
    pmd_edges: NDArray[np.float64]
    pmd_density: NDArray[np.float64]
    tau_ave: float
    slope: float
    command_max: int
    position_independent_torque: float
    data_density: float
    command_range: float
    density_in_range: float
    rows: int
    cells: int
    cell_position: NDArray[np.int64]
    cell_command: NDArray[np.int64]
    cell_torque: NDArray[np.float64]
    cell_pmd: NDArray[np.float64]
    nominal_apmd: float | None
    nominal_apmd_above_10: float | None


def _half_way_torque(
    pos: NDArray[np.int64], cmd: NDArray[np.int64], tau: NDArray[np.float64], half: float
) -> float:
    """Mean over positions of the torque at ``c = half`` (linear in c between the cells)."""
    values = []
    bounds = np.flatnonzero(np.diff(pos)) + 1
    for a, b in zip(np.r_[0, bounds], np.r_[bounds, pos.size], strict=True):
        c, t = cmd[a:b], tau[a:b]
        if c[0] <= half <= c[-1]:
            values.append(float(np.interp(half, c, t)))
    if not values:
        below = int(np.count_nonzero(cmd < half))
        raise InputError(
            f"no position has data on both sides of the half-way command {half:g} (the "
            f"commands from 1 hold {np.unique(cmd).size} values, {int(cmd.min())} to "
            f"{int(cmd.max())}, {below} cells below it): collect commands on both sides of it "
            f"(a collection --step or --pulse-step of at most {max(int(half), 1)})"
        )
    return float(np.mean(values))


def apmd_report(
    position: ArrayLike,
    command: ArrayLike,
    torque: ArrayLike,
    *,
    command_max: int,
    positions_per_cycle: int,
    nominal_torque: ArrayLike | None = None,
    bins: int = 50,
) -> LinearityReport:
    """APMD (Eq 1), CAPMD (Eq 2), PAPMD (Eq 3) and the Table 2 quantities of torque data.

    Parameters
    ----------
    position
        Table position of each row, ``0 .. P - 1``, shape (n,).
    command
        Command of each row: pulse width before compensation, torque command after, shape (n,).
        Rows outside ``1 .. command_max`` are ignored.
    torque
        Measured torque [N m], shape (n,).
    command_max
        ``C``: the largest command (the half-way contour is ``C / 2``).
    positions_per_cycle
        ``P``.
    nominal_torque
        Torque each row's command asked for [N m], shape (n,): adds the APMD against it.
    bins
        Bins of the PMD distribution.

    Returns
    -------
    LinearityReport
        The measures.

    Raises
    ------
    InputError
        If no row has a command in ``1 .. C``, or no position has data on both sides of ``C / 2``.

    Examples
    --------
    >>> p, c = np.meshgrid(np.arange(4), np.arange(11), indexing="ij")
    >>> r = apmd_report(p.ravel(), c.ravel(), 0.3 * c.ravel(), command_max=10, positions_per_cycle=4)
    >>> round(r.apmd, 12), round(r.slope, 12), r.data_density
    (0.0, 0.3, 1.0)
    """
    pos = np.asarray(position).astype(np.int64)
    cmd = np.asarray(command).astype(np.int64)
    tau = np.asarray(torque, dtype=np.float64)
    nominal = None if nominal_torque is None else np.asarray(nominal_torque, dtype=np.float64)
    keep = (cmd >= 1) & (cmd <= command_max)
    if not keep.any():
        raise InputError(f"no data rows with a command in 1 .. {command_max}")
    pos, cmd, tau = pos[keep], cmd[keep], tau[keep]
    width = command_max + 1
    flat = pos * width + cmd
    cells, inverse, counts = np.unique(flat, return_inverse=True, return_counts=True)
    cell_tau = np.bincount(inverse, weights=tau) / counts
    cp, cc = cells // width, cells % width
    tau_ave = _half_way_torque(cp, cc, cell_tau, command_max / 2.0)
    slope = tau_ave / (command_max / 2.0)
    desired = cc * slope
    pmd = np.abs(desired - cell_tau) / np.abs(desired)
    above = cc > 0.1 * command_max

    def mean_by(index: NDArray[np.int64], size: int) -> NDArray[np.float64]:
        count = np.bincount(index, minlength=size)
        total = np.bincount(index, weights=pmd, minlength=size)
        with np.errstate(invalid="ignore"):
            out: NDArray[np.float64] = np.where(count > 0, total / np.maximum(count, 1), np.nan)
        return out

    top = max(1.0, float(np.ceil(pmd.max() * 20) / 20))
    hist, edges = np.histogram(pmd, bins=bins, range=(0.0, top))
    reach = np.full(positions_per_cycle, -np.inf)
    np.maximum.at(reach, cp, cell_tau)
    reach_cmd = np.zeros(positions_per_cycle, dtype=np.int64)
    np.maximum.at(reach_cmd, cp, cc)
    full = reach_cmd >= 0.9 * cc.max()
    nominal_apmd = nominal_above = None
    if nominal is not None:
        nom_cell = np.bincount(inverse, weights=nominal[keep]) / counts
        npmd = np.abs(nom_cell - cell_tau) / np.abs(nom_cell)
        nominal_apmd = float(npmd.mean())
        nominal_above = float(npmd[above].mean()) if above.any() else float("nan")
    return LinearityReport(
        apmd=float(pmd.mean()),
        apmd_above_10=float(pmd[above].mean()) if above.any() else float("nan"),
        capmd=mean_by(cc, width),
        papmd=mean_by(cp, positions_per_cycle),
        pmd_edges=edges,
        pmd_density=hist / pmd.size,
        tau_ave=tau_ave,
        slope=slope,
        command_max=command_max,
        position_independent_torque=float(reach[full].min()),
        data_density=cells.size / (positions_per_cycle * command_max),
        command_range=float(cc.max() / command_max),
        density_in_range=cells.size / (positions_per_cycle * int(cc.max())),
        rows=int(keep.sum()),
        cells=int(cells.size),
        cell_position=cp,
        cell_command=cc,
        cell_torque=cell_tau,
        cell_pmd=pmd,
        nominal_apmd=nominal_apmd,
        nominal_apmd_above_10=nominal_above,
    )


def check_tables_fit(
    spec: MotorSpec, tables: TableSet, *, path: str | os.PathLike[str] | None = None
) -> None:
    """Refuse tables built for another motor: phases, positions per cycle, command bits,
    full-scale pulse width or equilibria that differ from the motor file's.

    Raises
    ------
    InputError
        Naming every difference (and ``path``, the tables file).
    """
    pairs = (
        ("phases", tables.phases.shape[0], spec.phases),
        ("positions per cycle", tables.positions_per_cycle, spec.positions_per_cycle),
        ("command bits", tables.command_bits, spec.command_bits),
        ("full-scale pulse width", tables.motor_actuation_max, spec.actuation_max),
        (
            "equilibrium positions",
            tuple(tables.equilibrium_positions),
            tuple(spec.equilibrium_positions),
        ),
    )
    wrong = [f"{name} {got} (the motor: {want})" for name, got, want in pairs if got != want]
    if wrong:
        raise InputError(
            f"tables are for another motor ({tables.motor_name!r}, the motor file is "
            f"{spec.name!r}): " + "; ".join(wrong),
            path=path,
        )


def evaluate_linearity(
    spec: MotorSpec,
    data: LinearizeData,
    *,
    tables: TableSet | None = None,
    tables_path: str | os.PathLike[str] | None = None,
) -> LinearityReport:
    """Linearity of characterisation data (before) or of a verification run (after).

    Parameters
    ----------
    spec
        The motor.
    data
        Characterisation rows (command = pulse width, ``C = actuation_max``) or, with
        ``tables``, verification rows (command = torque command, ``C = 2**(bits-1) - 1``).
    tables
        The tables the verification ran through; adds the APMD against their nominal law.
    tables_path
        Their file, named when they are for another motor (:func:`check_tables_fit`).

    Returns
    -------
    LinearityReport
        The measures.

    Raises
    ------
    InputError
        If the tables do not fit the motor, are not those a verification run's record says it
        ran through (:func:`torquemap.linearize.resume.check_collected_through`), or the data
        cannot be evaluated.
    """
    try:
        if tables is None:
            return apmd_report(
                data.position,
                data.level,
                data.torque,
                command_max=spec.actuation_max,
                positions_per_cycle=spec.positions_per_cycle,
            )
        check_tables_fit(spec, tables, path=tables_path)
        if data.path is not None:
            from torquemap.linearize.resume import check_collected_through

            check_collected_through(data.path, tables.phases, tables_path)
        return apmd_report(
            data.position,
            data.level,
            data.torque,
            command_max=tables.command_max,
            positions_per_cycle=spec.positions_per_cycle,
            nominal_torque=table_torque_law(tables, data.level),
        )
    except InputError as exc:
        raise InputError(exc.message, path=exc.path or data.path) from None


def report_to_dict(report: LinearityReport) -> dict[str, Any]:
    """The report as JSON-ready values (NaN as None, deviations as fractions)."""

    def clean(values: NDArray[np.floating[Any]]) -> list[float | None]:
        return [None if not np.isfinite(v) else float(v) for v in values]

    return {
        "apmd": report.apmd,
        "apmd_above_10_percent_command": report.apmd_above_10,
        "nominal_apmd": report.nominal_apmd,
        "nominal_apmd_above_10_percent_command": report.nominal_apmd_above_10,
        "tau_ave_half_way_n_m": report.tau_ave,
        "plane_slope_n_m_per_command": report.slope,
        "command_max": report.command_max,
        "position_independent_torque_n_m": report.position_independent_torque,
        "data_density": report.data_density,
        "command_range_measured": report.command_range,
        "data_density_in_range": report.density_in_range,
        "rows": report.rows,
        "cells": report.cells,
        "capmd": clean(report.capmd),
        "papmd": clean(report.papmd),
        "pmd_histogram": {
            "edges": [float(e) for e in report.pmd_edges],
            "density": [float(d) for d in report.pmd_density],
        },
        "note": "rows at one (position, command) cell are averaged; cells without data are "
        "skipped; deviations are fractions",
    }


def format_report(report: LinearityReport, *, title: str = "") -> str:
    """A plain-text table of the report's scalars (deviations in percent)."""

    def pct(v: float | None) -> str:
        return "-" if v is None or not np.isfinite(v) else f"{100 * v:.2f} %"

    rows = [
        ("overall APMD (Eq 1, plane)", pct(report.apmd)),
        ("APMD above 10 % command", pct(report.apmd_above_10)),
        ("APMD vs nominal command law", pct(report.nominal_apmd)),
        ("  above 10 % command", pct(report.nominal_apmd_above_10)),
        ("largest CAPMD", pct(float(np.nanmax(report.capmd)))),
        ("largest PAPMD", pct(float(np.nanmax(report.papmd)))),
        ("tau_ave at C/2 [N m]", f"{report.tau_ave:.4g}"),
        ("position-independent torque [N m]", f"{report.position_independent_torque:.4g}"),
        ("data density", pct(report.data_density)),
        ("command range measured", pct(report.command_range)),
        ("data density in range", pct(report.density_in_range)),
        ("rows / cells", f"{report.rows} / {report.cells}"),
    ]
    width = max(len(r[0]) for r in rows)
    lines = [title] if title else []
    lines += [f"{name:<{width}}  {value}" for name, value in rows]
    return "\n".join(lines)


def characterisation_coverage_advice(
    position: ArrayLike, positions_per_cycle: int, phases: int
) -> str:
    """A line when a characterisation's positions leave part of the cycle unread, else "".

    A collection reads evenly spaced targets (every 4th position by default); data whose
    largest gap between read positions (around the cycle) is more than twice their median gap
    and wider than linearize build bridges (``positions_per_cycle // (4 phases)`` positions)
    were cut or pieced together: their APMD covers the positions read alone.

    >>> characterisation_coverage_advice([1, 2, 3, 4, 64, 65, 66, 67], 128, 3)[:45]
    'the data cover only 8 of the 128 positions (t'
    >>> characterisation_coverage_advice(np.arange(0, 512, 4), 512, 3)
    ''
    """
    read = np.unique(np.asarray(position, dtype=np.int64))
    if read.size < 2:
        return ""
    gaps = np.diff(np.append(read, read[0] + positions_per_cycle))
    widest = int(np.argmax(gaps))
    bridged = max(1, positions_per_cycle // (4 * max(phases, 1)))
    if gaps[widest] <= 2 * float(np.median(gaps)) or gaps[widest] - 1 <= bridged:
        return ""
    first = int(read[widest]) + 1
    last = (int(read[widest]) + int(gaps[widest]) - 1) % positions_per_cycle
    return (
        f"the data cover only {read.size} of the {positions_per_cycle} positions (the widest "
        f"gap: none at {first} .. {last}, {int(gaps[widest]) - 1} positions, where the reads are "
        f"{float(np.median(gaps)):g} apart): this APMD covers the positions read alone; "
        "collect the whole cycle (a cut collection resumes with linearize collect)"
    )


def coverage_advice(position: ArrayLike, positions_per_cycle: int) -> str:
    """A line when a verification run read fewer than all ``positions_per_cycle`` positions,
    else "": its APMD covers those alone, and where they are the characterisation's own (the
    paper's settings for both runs) the tables' interpolation between them goes unseen. On the QA benches of 2026-11-27 (docs/linearize.md) a
    verification at every 4th position, the characterisation's own, gave 0.86 % where every
    position gave 1.54 %.

    >>> coverage_advice(np.arange(0, 64, 4), 64)[:44]
    'the verification read 16 of the 64 positions'
    >>> coverage_advice(np.arange(64), 64)
    ''
    """
    read = np.unique(np.asarray(position, dtype=np.int64))
    if read.size >= positions_per_cycle:
        return ""
    steps = np.unique(np.diff(read)) if read.size > 1 else np.array([], dtype=np.int64)
    regular = f" (one in {int(steps[0])} from {int(read[0])})" if steps.size == 1 else ""
    return (
        f"the verification read {read.size} of the {positions_per_cycle} positions{regular}: "
        "its APMD covers those alone (where they are the positions the tables were measured "
        "at, their interpolation between them goes unseen); verify with --position-step 1 for "
        "the whole cycle"
    )
