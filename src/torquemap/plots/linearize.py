"""Figures of torque linearisation (Adept II paper, Figs 5-8 and 13-20, Table 2).

Each function returns a :class:`matplotlib.figure.Figure` built without pyplot; the HTML report
reuses them. :func:`write_linearize_figures` draws the set for the CLI.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from torquemap.linearize.metrics import LinearityReport
from torquemap.linearize.motor import RampKind, ramp_function
from torquemap.linearize.tables import TableSet


def torque_surface_figure(
    position: ArrayLike,
    command: ArrayLike,
    torque: ArrayLike,
    *,
    command_label: str = "pulse width",
    title: str = "torque vs position vs command",
) -> Figure:
    """3-D scatter of torque [N m] vs table position vs command (paper Figs 5, 14, 17-20)."""
    fig = Figure(figsize=(6.5, 5.0))
    ax = fig.add_subplot(projection="3d")
    t = np.asarray(torque, dtype=np.float64)
    ax.scatter(np.asarray(position), np.asarray(command), t, c=t, s=2, cmap="viridis", linewidths=0)
    ax.set_xlabel("table position")
    ax.set_ylabel(command_label)
    ax.set_zlabel("torque [N m]")
    ax.set_title(title)
    return fig


def before_after_figure(
    before: LinearityReport, after: LinearityReport, *, title: str = ""
) -> Figure:
    """Torque vs position vs command before (pulse width) and after (torque command)."""
    fig = Figure(figsize=(12.0, 5.0))
    for i, (report, label, cmd) in enumerate(
        ((before, "uncompensated", "pulse width"), (after, "compensated", "torque command"))
    ):
        ax = fig.add_subplot(1, 2, i + 1, projection="3d")
        ax.scatter(
            report.cell_position,
            report.cell_command,
            report.cell_torque,
            c=report.cell_torque,
            s=2,
            cmap="viridis",
            linewidths=0,
        )
        ax.set_xlabel("table position")
        ax.set_ylabel(cmd)
        ax.set_zlabel("torque [N m]")
        ax.set_title(f"{label}: APMD {100 * report.apmd:.1f} %")
    if title:
        fig.suptitle(title)
    return fig


def table_surfaces_figure(tables: TableSet, *, stride: int = 4) -> Figure:
    """Look-up-table surfaces per phase (paper Figs 8, 16), positive commands; plus the base."""
    m = tables.phases.shape[0]
    fig = Figure(figsize=(4.5 * (m + 1), 4.5))
    p = np.arange(tables.positions_per_cycle)[::stride]
    c = np.arange(tables.command_max + 1)[::stride]
    pp, cc = np.meshgrid(p, c, indexing="ij")
    surfaces = [("inverse model (base)", tables.base[::stride, ::stride])]
    surfaces += [
        (f"phase {k + 1}", tables.phases[k][::stride, : tables.command_max + 1 : stride])
        for k in range(m)
    ]
    for i, (label, z) in enumerate(surfaces):
        ax = fig.add_subplot(1, m + 1, i + 1, projection="3d")
        ax.plot_surface(pp, cc, z, cmap="viridis", linewidth=0)
        ax.set_xlabel("table position")
        ax.set_ylabel("torque command")
        ax.set_zlabel("actuation")
        ax.set_title(label)
    fig.suptitle(f"{tables.motor_name}: look-up tables ({tables.ramping} ramping)")
    return fig


def ramps_figure(*, phases: int = 3, positions_per_cycle: int = 512) -> Figure:
    """The narrow and wide trapezoidal ramping functions (paper Figs 7 and 13)."""
    fig = Figure(figsize=(8.0, 5.0))
    axes = fig.subplots(2, 1, sharex=True)
    kinds: tuple[RampKind, RampKind] = ("narrow", "wide")
    for ax, kind in zip(axes, kinds, strict=True):
        ramp = ramp_function(kind, phases=phases, positions_per_cycle=positions_per_cycle)
        for k in range(phases):
            ax.plot(ramp[:, k], label=f"phase {k + 1}")
        ax.set_ylabel("proportion")
        ax.set_title(f"{kind} trapezoidal ramping")
        ax.set_ylim(-0.05, 1.1)
    axes[0].legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("table position")
    return fig


def pmd_figure(reports: Mapping[str, LinearityReport]) -> Figure:
    """PMD distribution, CAPMD (Eq 2) and PAPMD (Eq 3) for each labelled report."""
    fig = Figure(figsize=(14.0, 4.0))
    ax_hist, ax_c, ax_p = fig.subplots(1, 3)
    for label, r in reports.items():
        centres = 0.5 * (r.pmd_edges[1:] + r.pmd_edges[:-1])
        ax_hist.plot(100 * centres, 100 * r.pmd_density, label=label)
        ax_c.plot(np.arange(r.capmd.size), 100 * r.capmd, ".", ms=2, label=label)
        ax_p.plot(np.arange(r.papmd.size), 100 * r.papmd, ".", ms=2, label=label)
    ax_hist.set_xlabel("PMD [%]")
    ax_hist.set_ylabel("cells [%]")
    ax_hist.set_title("PMD distribution")
    ax_c.set_xlabel("command")
    ax_c.set_ylabel("CAPMD [%]")
    ax_c.set_yscale("log")
    ax_c.set_title("CAPMD (Eq 2)")
    ax_p.set_xlabel("table position")
    ax_p.set_ylabel("PAPMD [%]")
    ax_p.set_title("PAPMD (Eq 3)")
    ax_hist.legend(fontsize="small")
    return fig


def summary_figure(
    columns: Sequence[str], rows: Sequence[tuple[str, Sequence[str]]], *, title: str = ""
) -> Figure:
    """A table like the paper's Table 2: one column per joint, one row per quantity."""
    fig = Figure(figsize=(2.0 + 1.6 * len(columns), 0.4 * (len(rows) + 2)))
    ax = fig.add_subplot()
    ax.axis("off")
    table = ax.table(
        cellText=[list(values) for _, values in rows],
        rowLabels=[name for name, _ in rows],
        colLabels=list(columns),
        loc="center",
    )
    table.auto_set_font_size(False)
    table.set_fontsize(8)
    if title:
        ax.set_title(title)
    return fig


#: Every file :func:`write_linearize_figures` may write.
FIGURE_NAMES = ("torque_before.png", "ramps.png", "tables.png", "before_after.png", "pmd.png")


def write_linearize_figures(
    motor_path: str | os.PathLike[str],
    data_path: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    *,
    tables_path: str | os.PathLike[str] | None = None,
    verification_path: str | os.PathLike[str] | None = None,
) -> list[str]:
    """Draw the figure set into ``out_dir`` (PNG); returns the files written.

    Raises
    ------
    InputError
        On unreadable inputs, tables for another motor, a verification run without its tables
        or evaluated through other tables than its record's, and on the rows ``linearize
        evaluate`` refuses (a torque falling as the level rises, a row far off its neighbours).
    """
    from torquemap.errors import InputError
    from torquemap.io import Writer, figure_writer, output_folder, write_all
    from torquemap.linearize.export import load_tables
    from torquemap.linearize.metrics import check_tables_fit, evaluate_linearity
    from torquemap.linearize.motor import load_motor
    from torquemap.linearize.outliers import check_rows_read
    from torquemap.linearize.tables import read_data

    spec = load_motor(motor_path)
    if verification_path is not None and tables_path is None:
        raise InputError(
            "a verification run is drawn beside the tables it ran through: give them too "
            "(--tables TABLES.npz)",
            path=verification_path,
        )
    data = read_data(data_path, spec, kind="characterisation")
    # the rows build and evaluate refuse (a reversed sensor, a typed row): no figure of them
    check_rows_read(data.position, data.level, data.torque, path=os.fspath(data_path))
    tables = None if tables_path is None else load_tables(tables_path)
    if tables is not None:
        check_tables_fit(spec, tables, path=tables_path)
    before = evaluate_linearity(spec, data)
    figures: dict[str, Figure] = {
        "torque_before.png": torque_surface_figure(
            data.position, data.level, data.torque, title=f"{spec.name}: torque data"
        ),
        "ramps.png": ramps_figure(phases=spec.phases, positions_per_cycle=spec.positions_per_cycle),
    }
    reports = {"uncompensated": before}
    if tables is not None:
        figures["tables.png"] = table_surfaces_figure(tables)
    if verification_path is not None and tables is not None:
        verify = read_data(verification_path, spec, kind="verification")
        check_rows_read(
            verify.position,
            verify.level,
            verify.torque,
            what="command",
            path=os.fspath(verification_path),
        )
        after = evaluate_linearity(spec, verify, tables=tables, tables_path=tables_path)
        reports["compensated"] = after
        figures["before_after.png"] = before_after_figure(before, after, title=spec.name)
    figures["pmd.png"] = pmd_figure(reports)
    out = Path(out_dir)
    writers: dict[Path, Writer] = {
        out / name: figure_writer(fig, kind="png", dpi=90) for name, fig in figures.items()
    }
    with output_folder(out):  # all figures or none
        return [os.fspath(p) for p in write_all(writers)]
