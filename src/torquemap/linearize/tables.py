"""Torque-linearisation look-up tables from characterisation data (Adept II paper, §3 and §4.3).

The builder turns DATA.csv rows (table position, base pulse width, torque) into one table per
phase: entry ``[p, c mod 2**bits]`` is the actuation, already ramped, that the phase receives at
table position ``p`` for the signed torque command ``c``. The steps (docs/linearize.md):

1. Torque scaling: the largest position-independent torque ``t_pi`` (the deepest valley of the
   torque surface: the minimum over positions of the largest torque reachable there) divided by
   the largest positive command gives ``torque_per_count``; every positive command is then
   reachable at every position. The reachable torque per position comes from the forward model
   (step 3 of ``"interp"``), so positions whose rows were split by the rig's compliance do not
   count as valleys.
2. ``method="paper"``: each row's torque is quantised to a torque index; where several pulse
   widths land on one (position, index) cell, the median is kept. ``method="interp"``: rows
   are averaged per (position, pulse width) cell and made monotone in pulse width per position
   (isotonic regression), a forward model ``torque(position, pulse width)``.
3. Voids are filled by linear interpolation along constant-position and constant-torque (or
   constant-pulse-width) contours, smaller voids first; the position axis is cyclic. For
   ``"interp"`` the filled forward model is then inverted at the exact target torque of each
   command (linear interpolation between the two bracketing pulse widths).
4. Phase ``k`` entry ``= rint(base * ramp[p, k])`` (:func:`torquemap.linearize.motor.ramped_actuation`).
5. :func:`monotonic_filter` (paper §5.6).
6. Negative commands by reflection about each phase's equilibrium position ``e_i``: for command
   ``-c`` at position ``p``, phase ``i`` gets its entry for ``+c`` at ``(2 e_i - p) mod P``. The
   most negative command ``-2**(bits-1)`` has no positive twin and reuses ``+(2**(bits-1) - 1)``.
7. Command 0 gives 0 actuation.

This module never imports the simulator.
"""

from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import isotonic_regression

from torquemap.errors import InputError
from torquemap.io import numeric_column, read_table
from torquemap.linearize.bias import check_bias
from torquemap.linearize.count import MAX_GRID_CELLS as MAX_GRID_CELLS  # defined here before
from torquemap.linearize.count import check_grid_fits, within_count_advice
from torquemap.linearize.denoise import denoise_blocks, restore_misfit
from torquemap.linearize.detent import detent_correction, fit_detent
from torquemap.linearize.handover import check_handover, fill_handover
from torquemap.linearize.held import compliance_from_blocks, held_rows
from torquemap.linearize.knee import check_uncensored, knee_levels, pool_onset, uncensored_residual
from torquemap.linearize.knee_track import cut_below_knee, knee_at, knee_between
from torquemap.linearize.motor import MotorSpec
from torquemap.linearize.onset import CensoredUse, OnsetForm, extend_below, fit_onset
from torquemap.linearize.outliers import check_outliers, row_order_advice
from torquemap.linearize.reach import unreachable_message
from torquemap.linearize.resume import check_collected_for
from torquemap.linearize.sampling import (
    MATTERS,
    check_position_sampling,
    check_stated_cogging,
    hidden_wave_advice,
    unheld_gap_advice,
)
from torquemap.linearize.sign import check_torque_sign, pulse_width_hint
from torquemap.linearize.surface import (
    SurfaceFit,
    carried_shape,
    fit_surface,
    hidden_wave,
    rest_basis,
    surface_prediction,
)
from torquemap.linearize.window import WINDOWS, OnsetWindow, choose_window
from torquemap.robust import robust_scale

CommandScaling = Literal["linear", "log"]
Method = Literal["interp", "paper"]
DataKind = Literal["characterisation", "verification"]
#: Which positions' cells the onset law's search reads: ``"all"`` (the forward model at every
#: position, interpolated between the measured ones) or ``"measured"`` (the measured positions
#: alone: between them the forward model is an interpolation of their curves, not readings at
#: those positions' ramp shares).
OnsetSearch = Literal["all", "measured"]

DEFAULT_LOG_CURVATURE = 4.0


@dataclass(frozen=True, slots=True, eq=False)
class LinearizeData:
    """Rows of DATA.csv (characterisation) or of a verification run.

    Attributes
    ----------
    position
        Table position of each row, ``0 .. P - 1``, shape (n,).
    level
        Base pulse width (characterisation) or signed torque command (verification), shape (n,).
    torque
        Measured torque [N m], shape (n,).
    kind
        ``"characterisation"`` or ``"verification"``.
    path
        The file, or None.
    bias
        The bias the collection subtracted from each row [N m], shape (n,); None for a file
        without the ``bias`` column (an older collection, or data from elsewhere).
    """

    position: NDArray[np.int64]
    level: NDArray[np.int64]
    torque: NDArray[np.float64]
    kind: DataKind
    path: str | None
    bias: NDArray[np.float64] | None = None


@dataclass(frozen=True, slots=True, eq=False)
class TableSet:
    """Per-phase look-up tables and how they were built.

    Attributes
    ----------
    phases
        Actuation per phase, shape (m, P, 2**command_bits), int64; column ``c mod 2**bits``
        holds the signed command ``c`` (two's complement).
    torque_per_count
        Torque per command unit [N m]: command ``c`` asks for ``c * torque_per_count`` (linear
        scaling); with log scaling, the mean slope ``torque_max / command_max``.
    torque_max
        Torque of the largest positive command [N m] (the position-independent torque).
    command_scaling
        ``"linear"`` or ``"log"`` (see :func:`torque_from_command`).
    log_curvature
        ``k`` of the log law (0 for linear).
    base
        The inverse model before ramping: base pulse width [motor actuation units] for
        position ``p`` and command ``c = 0 .. command_max``, shape (P, command_max + 1).
    ramp
        The ramping function used, shape (P, m).
    motor_name, ramping, method
        Metadata.
    command_bits
        Width of the signed command [bits].
    actuation_max
        Largest table entry (full scale of the table's actuation units).
    motor_actuation_max
        Full-scale pulse width of the characterisation data (the motor file's).
    positions_per_cycle
        ``P``.
    equilibrium_positions
        One per phase.
    monotonic
        Whether :func:`monotonic_filter` was applied.
    voids_filled
        Cells of the working grid filled by interpolation.
    median_cells
        Cells where several rows landed (median for ``"paper"``, mean for ``"interp"``).
    monotonic_fixes
        Table entries raised by the monotonic filter.
    denoise_rank
        Singular values kept by :func:`torquemap.linearize.denoise.denoise_blocks` (0: the
        rows were used as measured).
    handover_cells
        Cells between measured positions estimated with a phase read at its own actuation
        (:mod:`torquemap.linearize.handover`; 0: linear interpolation everywhere).
    detent_harmonics
        Periods per cycle of the torque at rest taken between measured positions
        (:mod:`torquemap.linearize.detent`; empty: interpolated).
    surface
        Whether the forward model between measured positions came from the structured
        surface (:mod:`torquemap.linearize.surface`).
    warnings
        What the data cannot hold and what to collect instead, one line each (for example
        cogging sampled at most twice a period: :mod:`torquemap.linearize.sampling`); not
        saved with the tables.
    bias_drift
        Harmonics of the bias column's smooth drift the rows were re-zeroed on
        (:mod:`torquemap.linearize.bias`); -1 when they were used as measured (no ``bias``
        column, or a bias whose drift could not be told from a load). Not saved.
    onset_window
        The onset law's window top used, as a fraction of the position-independent torque
        (``build_tables``' ``onset_window``; NaN: no onset law). Not saved.
    """

    phases: NDArray[np.int64]
    torque_per_count: float
    torque_max: float
    command_scaling: CommandScaling
    log_curvature: float
    base: NDArray[np.float64]
    ramp: NDArray[np.float64]
    motor_name: str
    ramping: str
    method: str
    command_bits: int
    actuation_max: int
    motor_actuation_max: int
    positions_per_cycle: int
    equilibrium_positions: tuple[int, ...]
    monotonic: bool
    voids_filled: int
    median_cells: int
    monotonic_fixes: int
    denoise_rank: int = 0
    handover_cells: int = 0
    detent_harmonics: tuple[int, ...] = ()
    surface: bool = False
    warnings: tuple[str, ...] = ()
    bias_drift: int = -1
    onset_window: float = float("nan")

    @property
    def command_max(self) -> int:
        """Largest positive command, ``2**(command_bits - 1) - 1``."""
        return (1 << (self.command_bits - 1)) - 1

    def as_mapping(self) -> dict[str, NDArray[np.int64]]:
        """``phase_1 .. phase_m`` to their tables (for collect_verification)."""
        return {f"phase_{k + 1}": self.phases[k] for k in range(self.phases.shape[0])}


# -- reading data ---------------------------------------------------------------------------


def _integer_column(
    columns: dict[str, NDArray[np.generic]], name: str, path: str, low: int, high: int
) -> NDArray[np.int64]:
    values = numeric_column(columns, name, path)
    bad = values != np.round(values)
    if bad.any():
        row = int(np.argmax(bad))
        raise InputError(
            f"column {name!r} must hold integers (data row {row + 1}: {values[row]:g})", path=path
        )
    bad = (values < low) | (values > high)  # on the floats: no int64 overflow on 1e308
    if bad.any():
        row = int(np.argmax(bad))
        other = ""
        if name == "position" and float(values.max()) > high:
            # a collection of a motor with more positions per cycle than the motor file's
            other = (
                f", the motor file's {high + 1} positions per cycle (the data reach "
                f"{float(values.max()):.15g}): data from another motor? Give that motor's file"
            )
        raise InputError(
            f"{name} {values[row]:.15g} at data row {row + 1} is outside {low} .. {high}{other}",
            path=path,
        )
    return values.astype(np.int64)


def read_data(path: str | os.PathLike[str], spec: MotorSpec, *, kind: DataKind) -> LinearizeData:
    """Read DATA.csv (``position, pulse_width, torque`` and, optionally, ``bias``) or
    verification data (``position, command, torque``, optionally ``bias``), CSV or Parquet.

    Parameters
    ----------
    path
        The file.
    spec
        The motor: positions must be in ``0 .. P - 1``, pulse widths in ``0 .. actuation_max``,
        commands in ``-2**(bits-1) .. 2**(bits-1) - 1``.
    kind
        ``"characterisation"`` or ``"verification"``.

    Returns
    -------
    LinearizeData
        The rows.

    Raises
    ------
    InputError
        On a missing file or column, NaN, non-integer or out-of-range positions and levels, a
        ``bias`` column that holds anything but finite numbers, or a collection record beside
        the file that names another motor (:func:`torquemap.linearize.resume.check_collected_for`).
    """
    p = os.fspath(path)
    columns = read_table(p)
    check_collected_for(p, spec, kind)
    n = spec.positions_per_cycle
    position = _integer_column(columns, "position", p, 0, n - 1)
    if kind == "characterisation":
        try:
            level = _integer_column(columns, "pulse_width", p, 0, spec.actuation_max)
        except InputError as exc:
            # a sign-magnitude drive or a current in amperes: say what the column holds
            hint = pulse_width_hint(numeric_column(columns, "pulse_width", p), spec.actuation_max)
            if not hint:
                raise
            raise InputError(exc.message + hint, path=p) from None
    else:
        half = 1 << (spec.command_bits - 1)
        level = _integer_column(columns, "command", p, -half, half - 1)
    torque = numeric_column(columns, "torque", p)
    bias = numeric_column(columns, "bias", p) if "bias" in columns else None
    return LinearizeData(
        position=position, level=level, torque=torque, kind=kind, path=p, bias=bias
    )


# -- the command law --------------------------------------------------------------------------


def torque_from_command(
    command: ArrayLike,
    *,
    torque_max: float,
    command_max: int,
    scaling: CommandScaling = "linear",
    log_curvature: float = DEFAULT_LOG_CURVATURE,
) -> NDArray[np.float64]:
    """Torque [N m] a signed command asks for.

    Linear: ``tau = c torque_max / C``. Log (paper §6.2): ``tau = sign(c) torque_max
    expm1(k |c| / C) / expm1(k)``, fine steps at low torque and coarse ones at high torque;
    ``C`` is ``command_max``, ``k`` the curvature.

    Examples
    --------
    >>> torque_from_command([-127, 0, 1, 127], torque_max=12.7, command_max=127).tolist()
    [-12.7, 0.0, 0.1, 12.7]
    >>> t = torque_from_command([1, 127], torque_max=12.7, command_max=127, scaling="log")
    >>> bool(t[0] < 0.1 / 5) and bool(abs(t[1] - 12.7) < 1e-12)
    True
    """
    c = np.asarray(command, dtype=np.float64)
    if scaling == "linear":
        out: NDArray[np.float64] = c * (torque_max / command_max)
        return out
    k = float(log_curvature)
    return np.sign(c) * torque_max * np.expm1(k * np.abs(c) / command_max) / math.expm1(k)


def command_from_torque(
    torque: ArrayLike,
    *,
    torque_max: float,
    command_max: int,
    scaling: CommandScaling = "linear",
    log_curvature: float = DEFAULT_LOG_CURVATURE,
) -> NDArray[np.float64]:
    """The (real-valued) command for a torque [N m]; the inverse of :func:`torque_from_command`.

    Round it to the nearest integer before sending it to the tables.

    Examples
    --------
    >>> command_from_torque([0.1, 12.7], torque_max=12.7, command_max=127).tolist()
    [1.0, 127.0]
    """
    t = np.asarray(torque, dtype=np.float64)
    if scaling == "linear":
        out: NDArray[np.float64] = t * (command_max / torque_max)
        return out
    k = float(log_curvature)
    return np.sign(t) * command_max / k * np.log1p(np.abs(t) / torque_max * math.expm1(k))


# -- grid helpers ---------------------------------------------------------------------------


def _neighbours(valid: NDArray[np.bool_]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Index of the previous and next valid cell along the last axis (-1 / n when none)."""
    n = valid.shape[-1]
    idx = np.broadcast_to(np.arange(n), valid.shape)
    prev = np.maximum.accumulate(np.where(valid, idx, -1), axis=-1)
    nxt = np.minimum.accumulate(np.where(valid, idx, n)[..., ::-1], axis=-1)[..., ::-1]
    return prev, nxt


def _axis_fill(
    grid: NDArray[np.float64], *, cyclic: bool, coords: NDArray[np.float64] | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Linear interpolation of every NaN along the last axis, and its gap length (inf if open).

    ``coords`` (non-cyclic only) are the coordinates of the columns; default their indices.
    On a cyclic axis a gap may wrap around the end: the neighbours are then taken from the
    other end, one period away.
    """
    n = grid.shape[-1]
    valid = ~np.isnan(grid)
    prev, nxt = _neighbours(valid)
    if cyclic:
        last = prev[..., -1:]
        first = nxt[..., :1]
        prev = np.where(prev < 0, last - n, prev)  # wrap to the last valid cell, a period back
        nxt = np.where(nxt >= n, first + n, nxt)  # wrap to the first, a period on
        bounded = np.broadcast_to(valid.any(axis=-1, keepdims=True), valid.shape)
    else:
        bounded = (prev >= 0) & (nxt < n)
    pc = np.mod(prev, n) if cyclic else np.clip(prev, 0, n - 1)
    nc = np.mod(nxt, n) if cyclic else np.clip(nxt, 0, n - 1)
    lo = np.take_along_axis(grid, pc, axis=-1)
    hi = np.take_along_axis(grid, nc, axis=-1)
    x: NDArray[np.float64]
    if coords is None or cyclic:
        x = np.arange(n, dtype=np.float64)
        xp = prev.astype(np.float64) if cyclic else pc.astype(np.float64)
        xn = nxt.astype(np.float64) if cyclic else nc.astype(np.float64)
    else:
        x, xp, xn = coords, coords[pc], coords[nc]
    span = np.where(xn > xp, xn - xp, 1)
    value = lo + (hi - lo) * (x - xp) / span
    gap = (nxt - prev - 1) if cyclic else (nc - pc - 1)
    length = np.where(bounded, gap.astype(np.float64), np.inf)
    return value, length


def fill_voids(
    grid: ArrayLike,
    *,
    max_position_gap: int | None = None,
    levels: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Fill NaN cells of a (position, level) grid by linear interpolation, smaller voids first.

    Every pass measures, for each NaN cell, the gap it lies in along the level axis (axis 1,
    bounded on both sides) and along the position axis (axis 0, cyclic), and fills the cells
    whose shorter gap is the shortest of all (the mean of both axes where they tie). Cells left
    open (no data above them at any position in reach) keep NaN.

    Parameters
    ----------
    grid
        Shape (P, n), NaN where there is no data.
    max_position_gap
        Longest gap [positions] interpolated along the position axis (None: no limit).
    levels
        Level of each column, increasing, shape (n,) (default ``0 .. n - 1``): interpolation
        along the level axis is linear in it.

    Returns
    -------
    ndarray
        The filled grid (a copy).

    Examples
    --------
    >>> g = np.array([[0.0, np.nan, 2.0], [np.nan, np.nan, np.nan], [0.0, 1.0, np.nan]])
    >>> fill_voids(g).tolist()
    [[0.0, 1.0, 2.0], [0.0, 1.0, 2.0], [0.0, 1.0, 2.0]]
    """
    out = np.array(grid, dtype=np.float64)
    coords = None if levels is None else np.asarray(levels, dtype=np.float64)
    limit = np.inf if max_position_gap is None else float(max_position_gap)
    missing = np.isnan(out)
    v_level = np.zeros_like(out)
    l_level = np.full(out.shape, np.inf)
    v_pos = np.zeros_like(out)
    l_pos = np.full(out.shape, np.inf)

    def measure(rows: NDArray[np.int64], cols: NDArray[np.int64]) -> None:
        # gaps change only in the rows and columns where cells were just filled
        if rows.size:
            v, g = _axis_fill(out[rows], cyclic=False, coords=coords)
            v_level[rows], l_level[rows] = v, g
        if cols.size:
            v, g = _axis_fill(np.ascontiguousarray(out[:, cols].T), cyclic=True)
            v_pos[:, cols], l_pos[:, cols] = v.T, np.where(g <= limit, g, np.inf).T

    measure(np.flatnonzero(missing.any(axis=1)), np.flatnonzero(missing.any(axis=0)))
    while missing.any():
        length = np.where(missing, np.minimum(l_level, l_pos), np.inf)
        shortest = length.min()
        if not np.isfinite(shortest):
            break
        take = missing & (length == shortest)
        both = take & (l_level == shortest) & (l_pos == shortest)
        value = np.where(l_level == shortest, v_level, v_pos)
        value = np.where(both, 0.5 * (v_level + v_pos), value)
        out[take] = value[take]
        missing &= ~take
        measure(np.flatnonzero(take.any(axis=1)), np.flatnonzero(take.any(axis=0)))
    return out


def monotonic_filter(table: ArrayLike, *, command_bits: int | None = None) -> NDArray[np.int64]:
    """Make every position's entries non-decreasing in the command magnitude (paper §5.6).

    Scanning the commands upward at each position, an entry smaller than the previous one is
    replaced by the previous one (a running maximum).

    Parameters
    ----------
    table
        Integer table(s), shape (..., P, n). Without ``command_bits`` the last axis is scanned
        in order (pass the positive half, columns ``0 .. C``). With ``command_bits`` the last axis
        holds ``2**command_bits`` two's-complement columns: the positive half is scanned
        ``0, 1, ..., C`` and the negative half ``-1, -2, ..., -(C + 1)``.
    command_bits
        Command width when ``table`` holds both directions.

    Returns
    -------
    ndarray of int64
        The filtered table, same shape.

    Examples
    --------
    >>> monotonic_filter([[0, 5, 3, 7, 6]]).tolist()
    [[0, 5, 5, 7, 7]]
    >>> monotonic_filter([[0, 5, 1, 3]], command_bits=2).tolist()  # columns 0, 1, -2, -1
    [[0, 5, 3, 3]]
    """
    t = np.asarray(table).astype(np.int64)
    if command_bits is None:
        out: NDArray[np.int64] = np.maximum.accumulate(t, axis=-1)
        return out
    width = 1 << command_bits
    if t.shape[-1] != width:
        raise ValueError(f"table has {t.shape[-1]} columns, expected 2**{command_bits}")
    half = width // 2
    out = t.copy()
    out[..., :half] = np.maximum.accumulate(t[..., :half], axis=-1)
    neg = t[..., half:][..., ::-1]  # -1, -2, ..., -half
    out[..., half:] = np.maximum.accumulate(neg, axis=-1)[..., ::-1]
    return out


def reflect_negative(
    positive: ArrayLike, *, equilibrium: int, command_bits: int
) -> NDArray[np.int64]:
    """One phase's full two's-complement table from its positive half (paper §4.3).

    For ``-c`` at position ``p`` the phase gets its ``+c`` entry at ``(2 e - p) mod P``; ``-2**(b-1)``
    reuses ``+(2**(b-1) - 1)``.

    Parameters
    ----------
    positive
        Entries for commands ``0 .. 2**(b-1) - 1``, shape (P, 2**(b-1)).
    equilibrium
        The phase's equilibrium position ``e``.
    command_bits
        ``b``.

    Returns
    -------
    ndarray of int64
        Shape (P, 2**b).

    Examples
    --------
    >>> pos = np.arange(8).reshape(4, 2)  # P = 4, b = 2: commands 0, 1
    >>> reflect_negative(pos, equilibrium=1, command_bits=2)[3].tolist()  # p = 3 mirrors to 3
    [6, 7, 7, 7]
    """
    pos = np.asarray(positive).astype(np.int64)
    n, half = pos.shape
    if half != 1 << (command_bits - 1):
        raise ValueError(f"positive half has {half} columns, expected 2**{command_bits - 1}")
    mirror = (2 * int(equilibrium) - np.arange(n)) % n
    c = np.arange(1, half + 1)  # magnitudes of -1 .. -half
    neg = pos[mirror][:, np.minimum(c, half - 1)]
    out = np.empty((n, 2 * half), dtype=np.int64)
    out[:, :half] = pos
    out[:, 2 * half - c] = neg
    return out


# -- building -------------------------------------------------------------------------------


def _check_rows(
    spec: MotorSpec,
    position: ArrayLike,
    pulse_width: ArrayLike,
    torque: ArrayLike,
    path: str | None,
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    pos = np.asarray(position)
    pw = np.asarray(pulse_width, dtype=np.float64)
    tau = np.asarray(torque, dtype=np.float64)
    if not (pos.ndim == pw.ndim == tau.ndim == 1 and pos.size == pw.size == tau.size):
        raise ValueError("position, pulse_width and torque must be 1-D arrays of one length")
    if pos.size == 0:
        raise InputError("no data rows", path=path)
    for name, values in (
        ("position", pos.astype(np.float64)),
        ("pulse_width", pw),
        ("torque", tau),
    ):
        if not np.isfinite(values).all():
            row = int(np.argmax(~np.isfinite(values)))
            raise InputError(f"{name} holds NaN or inf (data row {row + 1})", path=path)
    n = spec.positions_per_cycle
    bad = (pos < 0) | (pos > n - 1) | (pos != np.round(pos))
    if bad.any():
        row = int(np.argmax(bad))
        raise InputError(
            f"position {pos[row]} at data row {row + 1} is outside 0 .. {n - 1}", path=path
        )
    bad = (pw < 0) | (pw > spec.actuation_max) | (pw != np.round(pw))
    if bad.any():
        row = int(np.argmax(bad))
        raise InputError(
            f"pulse_width {pw[row]:g} at data row {row + 1} is outside 0 .. {spec.actuation_max}",
            path=path,
        )
    return pos.astype(np.int64), pw, tau


def _check_bias_column(bias: ArrayLike, rows: int, path: str | None) -> NDArray[np.float64]:
    b = np.asarray(bias, dtype=np.float64)
    if b.shape != (rows,):
        raise ValueError("bias must be a 1-D array as long as the rows")
    if not np.isfinite(b).all():
        row = int(np.argmax(~np.isfinite(b)))
        raise InputError(f"bias holds NaN or inf (data row {row + 1})", path=path)
    return b


def _noise_floor(pw: NDArray[np.float64], tau: NDArray[np.float64]) -> float:
    """Torque below which a reading is indistinguishable from no torque [N m]."""
    zero = tau[pw == 0]
    sigma = float(np.std(zero)) if zero.size >= 2 else 0.0
    return max(4.0 * sigma, 0.02 * float(np.max(np.abs(tau))), 1e-12)


def _check_signal(
    pos: NDArray[np.int64], pw: NDArray[np.float64], tau: NDArray[np.float64], path: str | None
) -> None:
    """Refuse data that cannot make a table: one pulse width only (a saturated amplifier or a
    step past full scale), or no torque above the sensor's noise."""
    if np.ptp(tau) == 0:
        raise InputError(
            f"every row reads torque {tau[0]:g} N m: the sensor saw no torque curve (is it "
            "connected, the torque column the right one?)",
            path=path,
        )
    levels = np.unique(pw)
    if levels.size < 2:
        raise InputError(
            f"every row has pulse width {levels[0]:g}: no torque curve to invert (was the "
            "amplifier saturated, or the pulse-width step beyond full scale?)",
            path=path,
        )
    sigma = _row_noise(pw, tau)
    top = np.full(int(pos.max()) + 1, -np.inf)
    np.maximum.at(top, pos, tau)
    at_top = float(np.median(top[np.isfinite(top)]))
    if sigma > 0 and at_top <= 5.0 * sigma:
        raise InputError(
            f"the rig never read torque above its noise: the median over positions of the "
            f"largest torque is {at_top:.3g} N m, the noise of a row {sigma:.3g} N m (is the "
            "motor powered, the sensor connected?)",
            path=path,
        )


def _other_motor_hint(spec: MotorSpec, pos: NDArray[np.int64]) -> str:
    """``": the data's positions ..."`` when they end well short of the motor file's cycle (a
    collection of a motor with fewer positions per cycle), else ``""``.

    Examples
    --------
    >>> from torquemap.linearize.motor import MotorSpec
    >>> spec = MotorSpec.__new__(MotorSpec)
    >>> object.__setattr__(spec, "positions_per_cycle", 512)
    >>> object.__setattr__(spec, "phases", 3)
    >>> _other_motor_hint(spec, np.arange(0, 192, 4)).startswith(": the data reach positions 0 .. 188")
    True
    >>> _other_motor_hint(spec, np.arange(0, 512, 4))
    ''
    """
    n = spec.positions_per_cycle
    read = np.unique(pos)
    step = int(np.median(np.diff(read))) if read.size > 1 else 1
    top = int(read.max(initial=0))
    if top + 2 * max(step, 1) >= n:
        return ""
    return (
        f": the data reach positions {int(read.min(initial=0))} .. {top} of the motor file's "
        f"{n} ({spec.phases} phases): data from another motor? Give that motor's file"
    )


def _check_phases(
    spec: MotorSpec,
    pos: NDArray[np.int64],
    pw: NDArray[np.float64],
    tau: NDArray[np.float64],
    floor: float,
    path: str | None,
) -> None:
    ramp = spec.ramp[pos]
    for k in range(spec.phases):
        others = np.delete(ramp, k, axis=1)
        alone = (ramp[:, k] > 0) & (others.max(axis=1, initial=0.0) == 0) & (pw > 0)
        if not alone.any():
            alone = (ramp[:, k] >= others.max(axis=1, initial=0.0)) & (ramp[:, k] > 0) & (pw > 0)
        if not alone.any():
            raise InputError(
                f"phase {k + 1} was never energised in the data (no rows where it leads)"
                + _other_motor_hint(spec, pos),
                path=path,
            )
        best = float(tau[alone].max())
        if best <= floor:
            raise InputError(
                f"phase {k + 1} never produced torque (largest {best:.3g} N m over "
                f"{int(alone.sum())} rows where it leads; noise floor {floor:.3g} N m): is "
                "it connected, and, on a permanent-magnet (BLDC) motor, wired the way round "
                "the others are? A phase wired backwards pushes the negative way, which the "
                "rig does not read",
                path=path,
            )


def _check_coverage(
    spec: MotorSpec, pos: NDArray[np.int64], max_gap: int, path: str | None
) -> None:
    n = spec.positions_per_cycle
    has = np.zeros(n, dtype=bool)
    has[pos] = True
    if not has.any():
        raise InputError("no data rows", path=path)
    tripled = np.concatenate([has, has, has])
    prev, nxt = _neighbours(tripled)
    gap = nxt[n : 2 * n] - prev[n : 2 * n] - 1
    far = ~has & (gap > max_gap)
    if far.any():
        p = int(np.argmax(far))
        first = (int(prev[n + p]) + 1) % n
        last = (int(nxt[n + p]) - 1) % n
        raise InputError(
            f"no data at positions {first} .. {last} ({int(gap[p])} positions; at most "
            f"{max_gap} can be interpolated)",
            path=path,
        )


def _measured_positions(
    pos: NDArray[np.int64], pw: NDArray[np.float64], n: int
) -> NDArray[np.bool_]:
    """The positions a block was measured at (a row at pulse width 0), shape (n,)."""
    out = np.zeros(n, dtype=bool)
    out[np.unique(pos[pw == 0])] = True
    return out


def _cells(
    pos: NDArray[np.int64],
    col: NDArray[np.int64],
    values: NDArray[np.float64],
    shape: tuple[int, int],
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Mean of ``values`` per (position, column) cell (NaN where empty) and the row counts."""
    flat = pos * shape[1] + col
    count = np.bincount(flat, minlength=shape[0] * shape[1])
    total = np.bincount(flat, weights=values, minlength=shape[0] * shape[1])
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(count > 0, total / np.maximum(count, 1), np.nan)
    return mean.reshape(shape), count.reshape(shape)


def _forward_model(
    spec: MotorSpec,
    pos: NDArray[np.int64],
    pw: NDArray[np.float64],
    tau: NDArray[np.float64],
    max_gap: int,
    *,
    handover: bool = False,
    detent: bool = False,
) -> tuple[NDArray[np.float64], NDArray[np.float64], int, int, int, tuple[int, ...]]:
    """Torque on the (position, measured pulse width) grid, monotone in pulse width.

    With ``handover``, the cells between measured positions where one phase's ramp changes
    are estimated with that phase read at its own actuation
    (:mod:`torquemap.linearize.handover`), when the measured cells inside the ramps say that
    predicts better than the linear interpolation.

    With ``detent``, the torque at rest (cogging) between measured positions is taken from its
    spectrum (:mod:`torquemap.linearize.detent`) instead of the linear interpolation.

    Returns the grid (P, n_levels), the levels, the cells filled, the cells averaged, the
    cells the hand-over estimated and the cogging harmonics used.
    """
    levels, col = np.unique(pw, return_inverse=True)
    n = spec.positions_per_cycle
    mean, count = _cells(pos, col.astype(np.int64), tau, (n, levels.size))
    for p in np.flatnonzero(count.sum(axis=1)):
        have = count[p] > 0
        mean[p, have] = isotonic_regression(mean[p, have], weights=count[p, have]).x
    filled = fill_voids(mean, max_position_gap=max_gap, levels=levels)
    cells = 0
    if handover:
        ramp = np.asarray(spec.ramp, dtype=np.float64)
        first = _fine(np.fmax.accumulate(filled, axis=1), levels, spec.actuation_max)
        if check_handover(mean, levels, first, ramp, max_gap=max_gap).preferred:
            grid, cells = fill_handover(mean, levels, first, ramp, max_gap=max_gap)
            filled = fill_voids(grid, max_position_gap=max_gap, levels=levels)
    voids = int(np.isnan(mean).sum() - np.isnan(filled).sum())
    harmonics: tuple[int, ...] = ()
    if detent:
        anchors = np.flatnonzero(np.isfinite(mean[:, 0]))  # the blocks' targets (level 0)
        fit = fit_detent(mean, np.asarray(spec.ramp, dtype=np.float64), anchors)
        if fit.harmonics:
            harmonics = fit.harmonics
            shift = detent_correction(fit.torque, anchors)[:, None]
            # the cells the interpolation filled, where the sensor reads torque
            filled = np.where(np.isnan(mean) & (filled > 0), np.maximum(filled + shift, 0), filled)
    forward = np.fmax.accumulate(filled, axis=1)
    return forward, levels, voids, int((count > 1).sum()), cells, harmonics


def _reach(forward: NDArray[np.float64]) -> NDArray[np.float64]:
    """The largest torque of each position's forward model [N m] (-inf where it has none)."""
    out: NDArray[np.float64] = np.nanmax(np.where(np.isnan(forward), -np.inf, forward), axis=1)
    return out


def _relookup_change(
    fit: SurfaceFit, ramp: NDArray[np.float64], pos: NDArray[np.int64], pw: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The surface's torque at each row (its position, pulse width and shares) [N m], and
    that less the torque under the previous row's shares (the actuation the block's force
    rose under before the rig moved), both shape (n,)."""
    prev = np.r_[pos[:1], pos[:-1]]

    def drive(shares: NDArray[np.float64]) -> NDArray[np.float64]:
        a = np.clip(np.rint(shares * pw[:, None]).astype(np.int64), 0, fit.phi.size - 1)
        f = fit.phi[a]
        if fit.coupling:
            f = f * (1.0 - fit.coupling * (f.sum(axis=-1, keepdims=True) - f))
        out: NDArray[np.float64] = fit.rest[pos] + np.sum(fit.gain[pos] * f, axis=1)
        return out

    here = drive(ramp[pos])
    return here - drive(ramp[prev]), here


#: The rows the friction held (:mod:`torquemap.linearize.held`) are dropped only while the
#: position-independent torque keeps this fraction of what it is with them: they over-read by at
#: most twice the friction (a few per cent of the torque), so a larger fall means a position
#: lost the levels only those rows reached.
HELD_REACH = 0.9


def _fine(
    forward: NDArray[np.float64], levels: NDArray[np.float64], top: int
) -> NDArray[np.float64]:
    """The forward model on every base pulse width ``0 .. top`` (linear between levels; NaN
    past a position's last known level)."""
    u = np.arange(top + 1, dtype=np.float64)
    out = np.full((forward.shape[0], u.size), np.nan)
    for p, row in enumerate(forward):
        ok = np.isfinite(row)
        if ok.sum() >= 2:
            out[p] = np.interp(u, levels[ok], row[ok], right=np.nan)
        elif ok.any():
            out[p, u <= levels[ok][0]] = row[ok][0]
    return out


def _row_noise(pw: NDArray[np.float64], tau: NDArray[np.float64]) -> float:
    """Noise of one row [N m]: robust spread of the rows at zero pulse width."""
    zero = tau[pw == 0]
    if zero.size < 4:
        return 0.0
    return robust_scale(zero)


def _surface_grid(
    spec: MotorSpec,
    pos: NDArray[np.int64],
    pw: NDArray[np.float64],
    tau: NDArray[np.float64],
    levels: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The surface's cells: each (position, level)'s mean row, monotone in the level by
    isotonic regression, shape (P, J); NaN where not measured."""
    col = np.searchsorted(levels, pw).astype(np.int64)
    mean, count = _cells(pos, col, tau, (spec.positions_per_cycle, levels.size))
    for p in np.flatnonzero(count.sum(axis=1)):
        have = count[p] > 0
        mean[p, have] = isotonic_regression(mean[p, have], weights=count[p, have]).x
    return mean


def _surface_forward(
    spec: MotorSpec,
    pos: NDArray[np.int64],
    pw: NDArray[np.float64],
    tau: NDArray[np.float64],
    levels: NDArray[np.float64],
    onset_law: tuple[float, float, float],
    readable: float,
    noise: float,
    *,
    knee: bool = True,
    nyquist: bool = False,
    carried: NDArray[np.float64] | None = None,
    pool: bool = False,
    track: bool = False,
    raw: NDArray[np.float64] | None = None,
    coupling: bool | Literal["checked"] = False,
) -> tuple[NDArray[np.float64], SurfaceFit]:
    """Sensed torque on every base pulse width from the structured surface
    (:mod:`torquemap.linearize.surface`) plus what it misses at the measured cells,
    interpolated between them, shape (P, A + 1); and the surface. ``noise``: one row's
    noise [N m]; ``pool``: where the knee's uncensored residual is used, its offsets pooled
    over the measured positions (:func:`torquemap.linearize.knee.pool_onset`); ``track``: the
    forward model held at zero below the knee placed per position from the rows as read
    (``raw``, default ``tau``) and carried between measured positions in the surface's drive
    (:mod:`torquemap.linearize.knee_track`)."""
    n = spec.positions_per_cycle
    col = np.searchsorted(levels, pw)
    mean = _surface_grid(spec, pos, pw, tau, levels)
    ramp = np.asarray(spec.ramp, dtype=np.float64)
    fit = fit_surface(
        mean,
        levels,
        ramp,
        actuation_max=spec.actuation_max,
        readable=readable,
        dead_zone=onset_law[0],
        exponent=onset_law[1],
        curve=onset_law[2],
        nyquist=nyquist,
        carried=carried,
        coupling=coupling,
    )
    pred = surface_prediction(fit, ramp, levels)
    y_adj = mean - fit.offset[:, None]
    res = np.where((pred <= 0) & (y_adj <= 0), 0.0, y_adj - pred)
    res = np.where(np.isfinite(mean), res, np.nan)
    # below the knee, the residual carried in the uncensored torque where the data prefer it
    # (torquemap.linearize.knee)
    if knee:
        unc = uncensored_residual(res, y_adj, pred, noise=noise)
        anchors = np.flatnonzero(np.isfinite(mean[:, 0]))
        if check_uncensored(res, unc, y_adj, pred, anchors).preferred:
            res = unc
            if pool:
                # the knee's offsets pooled over the measured positions through a smooth
                # torque at rest (torquemap.linearize.knee.pool_onset)
                ks = knee_levels(y_adj, noise)
                has = ks >= 1
                offset = np.where(has, unc[:, 0], np.nan)
                pooled = pool_onset(offset, fit.rest, anchors, noise=noise)
                for p in np.flatnonzero(has):
                    res[p, : ks[p]] = pooled[p]
    res = fill_voids(res, levels=levels)
    u = np.arange(spec.actuation_max + 1, dtype=np.float64)
    res_fine = np.stack([np.interp(u, levels, np.nan_to_num(r)) for r in res])
    out = np.maximum(surface_prediction(fit, ramp, u) + res_fine, 0.0)
    out = np.maximum.accumulate(out, axis=1)
    if track:
        # the knee from the rows as read (``raw``; the low-rank denoiser smooths it over the
        # blocks), less the blocks' bias errors the surface read
        rows = tau if raw is None else raw
        read, _ = _cells(pos, col.astype(np.int64), rows, (n, levels.size))
        anchors = np.flatnonzero(np.isfinite(mean[:, 0]))
        drive = surface_prediction(fit, ramp, u) - fit.rest[:, None]
        drive = np.maximum.accumulate(drive, axis=1)
        knees = knee_at(read - fit.offset[:, None], levels, noise=noise)
        out = cut_below_knee(out, knee_between(knees, anchors, drive))
    return out, fit


#: The structured surface replaces the interpolation between measured curves where a phase's
#: share changes by more than this between consecutive measured positions (the ramp is
#: sampled fewer than 14 times): chosen on the family's seeds 0 to 19 (docs/linearize.md).
SURFACE_SHARE_STEP = 1.0 / 14.0


def ramp_share_step(ramp: NDArray[np.float64], anchors: NDArray[np.int64]) -> float:
    """Largest change of any phase's share across a gap between measured positions.

    Only gaps with unmeasured positions count (a collection with the ramp's transitions
    measures every position where the ramp changes: nothing is bridged there).

    Parameters
    ----------
    ramp
        The ramping function, shape (P, m).
    anchors
        The measured positions, ascending, shape (k,).

    Returns
    -------
    float
        ``max |ramp[a_{i+1}] - ramp[a_i]|`` over consecutive anchors (cyclic) more than one
        position apart, and over phases; 0 when no gap is bridged.

    Examples
    --------
    >>> from torquemap.linearize.motor import ramp_function
    >>> r = ramp_function("narrow", phases=3, positions_per_cycle=24)
    >>> ramp_share_step(r, np.arange(0, 24, 4))
    0.5
    >>> ramp_share_step(r, np.arange(24))
    0.0
    """
    n = ramp.shape[0]
    if anchors.size < 2:
        return 0.0
    nxt = np.roll(anchors, -1)
    bridged = (nxt - anchors) % n > 1
    if not bridged.any():
        return 0.0
    return float(np.max(np.abs(ramp[nxt[bridged]] - ramp[anchors[bridged]])))


def _snap(
    fine: NDArray[np.float64], base: NDArray[np.float64], target: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The integer pulse width, of the two around ``base``, whose torque is nearer the target."""
    top = fine.shape[1] - 1
    lo = np.clip(np.floor(base), 0, top).astype(np.int64)
    hi = np.minimum(lo + 1, top)
    t_lo = np.take_along_axis(fine, lo, axis=1)
    t_hi = np.take_along_axis(fine, hi, axis=1)
    e_lo = np.abs(np.where(np.isnan(t_lo), np.inf, t_lo - target[None, :]))
    e_hi = np.abs(np.where(np.isnan(t_hi), np.inf, t_hi - target[None, :]))
    return np.where(e_hi < e_lo, hi, lo).astype(np.float64)


def _invert(
    forward: NDArray[np.float64], levels: NDArray[np.float64], target: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Pulse width at which each position's monotone torque curve reaches each target."""
    out = np.empty((forward.shape[0], target.size))
    for p, row in enumerate(forward):
        curve = np.where(np.isnan(row), -np.inf, row)
        j = np.searchsorted(curve, target, side="left")
        j = np.clip(j, 0, levels.size - 1)
        lo = np.maximum(j - 1, 0)
        t0, t1 = curve[lo], curve[j]
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = np.where((j > 0) & (t1 > t0) & np.isfinite(t0), (target - t0) / (t1 - t0), 1.0)
        out[p] = levels[lo] + np.clip(frac, 0.0, 1.0) * (levels[j] - levels[lo])
    return out


def _paper_inverse(
    spec: MotorSpec,
    pos: NDArray[np.int64],
    pw: NDArray[np.float64],
    tau: NDArray[np.float64],
    index: NDArray[np.float64],
    command_max: int,
    max_gap: int,
) -> tuple[NDArray[np.float64], int, int]:
    """The paper's inverse model: median pulse width per (position, torque index) cell, voids
    filled by interpolation. Returns the base table (P, C + 1), cells filled, median cells."""
    k = np.rint(index).astype(np.int64)
    keep = k >= 0
    pos, pw, k = pos[keep], pw[keep], k[keep]
    n = spec.positions_per_cycle
    width = max(int(k.max()), command_max) + 1
    cell = pos * width + k
    order = np.lexsort((pw, cell))
    cell_sorted, pw_sorted = cell[order], pw[order]
    first, start, count = np.unique(cell_sorted, return_index=True, return_counts=True)
    median = 0.5 * (pw_sorted[start + (count - 1) // 2] + pw_sorted[start + count // 2])
    flat = np.full(n * width, np.nan)
    flat[first] = median
    grid = flat.reshape(n, width)
    filled = fill_voids(grid, max_position_gap=max_gap)
    voids = int(np.isnan(grid).sum() - np.isnan(filled).sum())
    filled = np.fmax.accumulate(filled, axis=1)  # open cells above the data: the last value
    filled = np.where(np.isnan(filled), 0.0, filled)
    return filled[:, : command_max + 1], voids, int((count > 1).sum())


#: A phase whose peak torque is under this share of the strongest phase's is reported: the
#: phases of one motor are built alike (the simulated family's gains differ by 0.85 .. 1.15).
WEAK_PHASE = 0.5


def weak_phase_advice(reach: NDArray[np.float64], ramp: NDArray[np.float64]) -> str:
    """A line when one phase reaches less than :data:`WEAK_PHASE` of the strongest phase's
    torque (each phase's: the median over the positions where its ramp leads of the largest
    torque reached there, ``reach`` [N m] per position), else "". The tables' full scale is the
    smallest torque reached anywhere, so a weak phase cuts it for every position.

    >>> ramp = np.repeat(np.eye(3), 4, axis=0)  # 12 positions, one phase each in turn
    >>> weak_phase_advice(np.r_[np.full(4, 2.0), np.full(4, 0.4), np.full(4, 2.1)], ramp)[:36]
    'phase 2 reaches 0.4 N m at most (19%'
    """
    if ramp.ndim != 2 or ramp.shape[1] < 2 or ramp.shape[0] != reach.size:
        return ""
    lead = np.argmax(ramp, axis=1)
    peaks = np.array(
        [
            float(np.median(reach[lead == k])) if np.any(lead == k) else np.nan
            for k in range(ramp.shape[1])
        ]
    )
    if not np.isfinite(peaks).any():
        return ""
    strong = int(np.nanargmax(peaks))
    low = int(np.nanargmin(peaks))
    if not peaks[low] < WEAK_PHASE * peaks[strong]:
        return ""
    return (
        f"phase {low + 1} reaches {peaks[low]:.3g} N m at most ({peaks[low] / peaks[strong]:.0%} "
        f"of phase {strong + 1}'s {peaks[strong]:.3g} N m), which sets the tables' full scale for every "
        "position: a weak winding, connector or amplifier channel? Check that phase before using "
        "the tables"
    )


#: A row's noise (one reading's over the square root of the readings a row) beyond this many
#: times the torque of one command count (``torque_max / command_max``) sets the lowest
#: commands' tables by the noise: the family's benches at the paper's and dense settings read
#: 0.08 to 1.2 times (QA benches 301 to 330), a sensor 5 times noisier 3.0 and 5.8 times, its
#: tables at 3.1x and 9.0x the floor against 1.5x and 2.9x; checked on benches 101 to 120 at
#: the paper's settings: 0.13 to 1.6 times, and 2.3 on 112 (noise 1 % of full torque, the
#: family's largest; its tables at 2.95x the floor) (docs/linearize.md).
NOISY_ROWS = 2.0


def noise_advice(row_noise: float, torque_per_count: float) -> str:
    """A line when the rows' noise [N m] exceeds :data:`NOISY_ROWS` times the torque of one
    command count [N m], else "".

    >>> noise_advice(0.3, 0.1)[:52]
    "the rows' noise (0.3 N m, from the rows at pulse wid"
    >>> noise_advice(0.1, 0.1)
    ''
    """
    if not (torque_per_count > 0 and row_noise > NOISY_ROWS * torque_per_count):
        return ""
    ratio = row_noise / torque_per_count
    return (
        f"the rows' noise ({row_noise:.3g} N m, from the rows at pulse width 0) is "
        f"{ratio:.1f} times the torque of one command count ({torque_per_count:.3g} N m): the "
        "lowest commands are set by the sensor's noise; collect with more readings per row "
        f"(--readings; about {math.ceil(ratio**2)} times as many for one count, the noise "
        "falling as their square root)"
    )


def build_tables(
    spec: MotorSpec,
    position: ArrayLike,
    pulse_width: ArrayLike,
    torque: ArrayLike,
    *,
    command_scaling: CommandScaling = "linear",
    method: Method = "interp",
    monotonic: bool = True,
    log_curvature: float = DEFAULT_LOG_CURVATURE,
    actuation_bits: int | None = None,
    max_gap: int | None = None,
    denoise: bool = True,
    bias_weight: float = 10.0,
    onset: bool = True,
    onset_form: OnsetForm = "power",
    onset_censored: CensoredUse = "none",
    onset_search: OnsetSearch = "all",
    onset_window: OnsetWindow = WINDOWS[0],
    handover: bool = True,
    detent: bool = True,
    surface: bool = True,
    knee: bool = True,
    pool: bool = False,
    track: bool = False,
    nyquist: bool | Literal["tested"] = "tested",
    coupling: bool | Literal["checked"] = True,
    held: bool | Literal["model"] = "model",
    held_mask: ArrayLike | None = None,
    bias: ArrayLike | None = None,
    restore_bias: bool = True,
    bias_open: bool = False,
    path: str | os.PathLike[str] | None = None,
) -> TableSet:
    """Build the per-phase torque-linearisation tables from characterisation data (paper §4.3).

    Parameters
    ----------
    spec
        The motor: phases, positions per cycle, command width, full-scale pulse width,
        equilibrium positions, ramp.
    position
        Table position of each row, ``0 .. P - 1``, shape (n,).
    pulse_width
        Base pulse width of each row (before ramping), ``0 .. actuation_max``, shape (n,).
    torque
        Measured torque [N m], positive direction, shape (n,).
    command_scaling
        ``"linear"``: command ``c`` asks for ``c * torque_per_count``; ``"log"``: the law of
        :func:`torque_from_command` (paper §6.2).
    method
        ``"interp"``: invert the monotone forward model at the exact target torques;
        ``"paper"``: medians of quantised (position, torque index) cells and void filling.
    monotonic
        Apply :func:`monotonic_filter` (paper §5.6).
    log_curvature
        ``k`` of the log law.
    actuation_bits
        Width of the table entries [bits]: entries are rescaled so that ``2**bits - 1`` is the
        motor's full-scale pulse width. None: entries in the motor's own units
        (``0 .. actuation_max``).
    max_gap
        Longest run of positions without data that may be interpolated across
        (default ``P // (4 m)``).
    denoise
        ``"interp"`` only: replace the rows by the low-rank fit of their (block x level) matrix
        (:func:`torquemap.linearize.denoise.denoise_blocks`), when the row order holds the
        collection's blocks, with what the fit misses beyond the rows' noise given back
        (:func:`torquemap.linearize.denoise.restore_misfit`). The paper's method always uses the rows as measured.
    bias_weight
        Denoising: the weight of each block's bias measurement in rows (the collection's
        ``bias_readings / readings``, 10 by default); each block is re-zeroed on the readings
        its fit censors, weighed against it.
    onset
        ``"interp"`` only: below the smallest torque the rig reads reliably (three times a
        row's noise), extend each position's curve with the physical onset law of
        :mod:`torquemap.linearize.onset` fitted to the readings above it (the friction zone),
        and invert on every pulse width.
    onset_form
        With ``onset``: the law's form (:func:`torquemap.linearize.onset.fit_onset`):
        ``"power"`` (``max(a - d, 0)^n``) or ``"amplifier"`` (the amplifier's curved current
        past its dead zone, torque ~ current or ~ current squared), or ``"choose"``: the
        amplifier's form only where it predicts each measured position's lowest reading in the
        window, held out, better than the power law (docs/linearize.md, "stop 43 (L61)").
        ``"power"`` by default (docs/linearize.md, "stop 35 (L37)").
    onset_censored
        With ``onset``: also score the law's search on the censored readings below each
        position's first reliable one: ``"score"`` or ``"ties"``
        (:func:`torquemap.linearize.onset.fit_onset`'s ``censored``). ``"none"`` by default
        (docs/linearize.md, "stop 35 (L38)").
    onset_search
        With ``onset``: the positions whose cells the law's search over dead zones, exponents
        and curves reads (:data:`OnsetSearch`): ``"all"`` or ``"measured"`` (the positions a
        block was measured at; between them the forward model interpolates their curves,
        which at a ramp's cross-fades are not the law at the shares there:
        :func:`torquemap.linearize.onset.fit_onset`'s ``search``). Each position's gains and
        friction are still solved wherever it has cells.
    onset_window
        With ``onset``: the top of the law's fitting window, as a fraction of the
        position-independent torque (0.3 by default), or ``"choose"``: among
        :data:`torquemap.linearize.window.WINDOWS`, where the structured surface is used, the
        narrower window's law only where it predicts the lowest readings of measured positions
        left out of the surface (fold by fold) significantly better
        (:func:`torquemap.linearize.window.choose_window`; docs/linearize.md, "stop 44 (L67)").
        Elsewhere ``"choose"`` keeps the default.
    handover
        ``"interp"`` only: between measured positions where one phase's ramp switches on or
        off, read that phase at its own actuation (:mod:`torquemap.linearize.handover`) when
        the measured cells inside the ramps confirm it predicts better than the linear
        interpolation.
    detent
        ``"interp"`` only: between measured positions, take the torque at rest (cogging) from
        a Fourier fit of one fundamental and its multiples (:mod:`torquemap.linearize.detent`),
        kept only while it predicts the measured curves better, instead of interpolating it.
    knee
        ``"interp"`` only, where the structured surface is used: below each measured
        position's knee, carry what the surface misses between measured positions in the
        uncensored torque (:mod:`torquemap.linearize.knee`), when the measured positions,
        predicted from their neighbours, confirm it predicts better.
    pool
        With ``knee``, where the uncensored residual is used: the offset below each measured
        position's knee (one reading's noise each) pooled over the measured positions through
        a smooth torque at rest (:func:`torquemap.linearize.knee.pool_onset`). Off by default:
        measured better on the family's seeds 40 to 59 and 80 to 99 and neutral on 140 to 159,
        but the worst of 120 to 139 went from 1.61x to 1.64x the floor (docs/linearize.md).
    track
        ``"interp"`` only, where the structured surface is used: the forward model held at zero
        below each position's knee (the pulse width where the sensed torque leaves zero),
        fitted at each measured position to the rows as read (censored: zero below it) and
        carried between them in the surface's drive (:mod:`torquemap.linearize.knee_track`),
        so that the tables do not switch the motor on early where the surface's torque at rest
        puts its knee low. Off by default: on the family's seeds 0 to 19 the measured median
        went from 1.18x to 1.21x the floor (the worst 1.39x to 1.37x) and the CAPMD at command
        1 from 53 % to 65 %: the knee carried between measured positions misses the cogging
        the surface's torque at rest holds, and a late knee over-delivers (docs/linearize.md,
        "The knee per position").
    nyquist
        ``"interp"`` only, where the structured surface is used and the torque at rest of the
        measured positions alternates (cogging sampled at most twice a period:
        :func:`torquemap.linearize.sampling.check_position_sampling`, which also warns): the
        surface is fitted again with the torque at rest between measured positions read as
        their interpolation plus the measured positions' Nyquist harmonic, from every row
        (:func:`torquemap.linearize.surface.rest_basis`; the rows the rig's compliance moved
        between the measured positions read the harmonic's phase). ``"tested"``: also where
        the measured positions do not show it (they can sit at the ripple's zeros: family
        motor 327, 16 cogging periods over 128 positions measured every 4th), the surface is
        fitted again with the harmonic between them, the series the first fit carried there
        held fixed (:func:`torquemap.linearize.surface.carried_shape`), and kept, with a
        warning, where the harmonic lowers the misfit beyond the F test of
        :func:`torquemap.linearize.surface.hidden_wave` (docs/linearize.md, "stop 41
        (L45)"); the default since stop 41. ``True``: only where the measured positions show
        it (the default before). False: never.
    coupling
        ``"interp"`` only, where the structured surface is used: fit the phases' mutual
        saturation with it (each phase's torque times ``1 - kappa`` times the sum of the other
        phases' rise, one ``kappa >= 0`` read from the cells two phases drive:
        :func:`torquemap.linearize.surface.fit_surface`), so that the loss where two phases
        are on is not spread over the phases' gains and carried into the hand-overs between
        measured positions. On by default: on the family's held-out seeds 140 to 159 the
        measured worst went from 1.78x to 1.65x the floor, on 180 to 199 the median from 1.20x
        to 1.18x, neutral or better on the medians and worsts of every other set measured
        (docs/linearize.md, "stop 36 (L39)").
        ``"checked"``: the same, ``kappa`` kept only where it lowers the cells' misfit by
        more than the fit's own spread (``fit_surface(coupling="checked")``); not the default
        (docs/linearize.md, "stop 36 (L40)": 197 1.16x -> 1.02x the floor, the median of
        seeds 0 to 19 1.174x -> 1.179x).
    held
        ``"interp"`` only, where the structured surface is used: drop the rows the friction
        held at the top of its band
        (:func:`torquemap.linearize.held.held_rows`): in collection order, the rows a block
        read after the rig's compliance moved it into a position where the ramp's total share
        falls (a phase switching off while the others hold), where the re-looked-up actuation
        gives less torque than the contact force rose under and the friction holds the force up
        to twice itself above the rising curve. Kept while the position-independent torque keeps
        :data:`HELD_REACH` of itself. ``"model"``: where the structured surface is used, the
        moves are judged by its torque instead: those that lower it by more than three rows'
        noise (a cross-fade too); the rest of the block at that position where the fall moves
        the motor back by half a position or more (the compliance read from the blocks' rows:
        it rocks between the two positions), else its rows there until the surface's torque has
        risen past the fall; the tables are then built again without them. ``"model"`` by
        default: on the family's seeds 0 to 19 the measured median went from 1.17x to 1.15x
        the floor and the worst from 1.37x to 1.27x, on the held-out 160 to 179 from 1.21x /
        2.57x to 1.19x / 2.07x, on 180 to 199 from 1.18x / 1.62x to 1.18x / 1.49x
        (docs/linearize.md, "stop 37 (L41)"). ``False``: the rows as read.
    held_mask
        The rows to drop as held, shape (n,), instead of the rule's (``held`` on).
    bias
        The bias the collection subtracted from each row (DATA.csv's ``bias`` column) [N m],
        shape (n,); None when the file has none. Split into the sensor's smooth drift and what
        lies above it (:func:`torquemap.linearize.bias.check_bias`): with ``restore_bias`` the
        rows are re-zeroed on the drift, which restores the torque at rest a bias read at rest
        swallowed (where cogging alone loads the contact) and replaces each block's own bias
        error by the drift's; when the bias varies beyond its noise and the drift, a warning
        says so.
    restore_bias
        Re-zero the rows on the bias's drift (else use them as measured, and warn only).
    bias_open
        The collection read the bias on an open contact (its record's ``bias_open``): the
        warning then does not take what lies above the drift for a load at rest.
    path
        The data file, named in error messages.

    Returns
    -------
    TableSet
        Tables, scale and reports.

    Raises
    ------
    InputError
        On positions or pulse widths out of range, NaN, a torque that never changes, a phase
        that never produced torque, positions without data and no data near them, a position
        where no torque is reachable, or a grid beyond
        :data:`torquemap.linearize.count.MAX_GRID_CELLS`.

    Notes
    -----
    Rows at one (position, pulse width) cell are averaged (``"interp"``), or their pulse
    widths are reduced to the median per (position, torque index) cell (``"paper"``).

    Examples
    --------
    >>> from torquemap.linearize.motor import motor_spec
    >>> spec = motor_spec("m", phases=1, positions_per_cycle=8, equilibrium_positions=(0,),
    ...                   command_bits=4, actuation_max=100)
    >>> p, w = np.meshgrid(np.arange(8), np.arange(0, 101, 5), indexing="ij")
    >>> t = (1 + 0.5 * np.cos(2 * np.pi * p / 8)) * w / 100.0
    >>> tab = build_tables(spec, p.ravel(), w.ravel(), t.ravel())
    >>> round(tab.torque_max, 3), tab.phases.shape
    (0.5, (1, 8, 16))
    """
    arguments = dict(locals())  # before any other name: held="model" builds again with them
    src = None if path is None else os.fspath(path)
    if command_scaling not in ("linear", "log"):
        raise ValueError(f"command_scaling must be 'linear' or 'log', got {command_scaling!r}")
    if method not in ("interp", "paper"):
        raise ValueError(f"method must be 'interp' or 'paper', got {method!r}")
    if onset_window != "choose" and not 0.0 < float(onset_window) <= 1.0:
        raise ValueError(f"onset_window must be in (0, 1] or 'choose', got {onset_window!r}")
    if onset_search not in ("all", "measured"):
        raise ValueError(f"onset_search must be 'all' or 'measured', got {onset_search!r}")
    if command_scaling == "log" and not log_curvature > 0:
        raise ValueError(f"log_curvature must be > 0, got {log_curvature}")
    if not bias_weight >= 0:
        raise ValueError(f"bias_weight must be >= 0, got {bias_weight}")
    if actuation_bits is not None and not 1 <= actuation_bits <= 32:
        raise ValueError(f"actuation_bits must be in 1 .. 32, got {actuation_bits}")
    check_grid_fits(
        spec.positions_per_cycle,
        spec.actuation_max,
        path=spec.path if spec.path is not None else src,
    )
    pos, pw, tau = _check_rows(spec, position, pulse_width, torque, src)
    check_outliers(pos, pw, tau, path=src)  # a hand edit or a glitch, before it bends the fit
    n, m = spec.positions_per_cycle, spec.phases
    # the rows' noise from their level-0 rows as read: the bias's re-zeroing below restores
    # the load at rest to some of them, which is not noise
    measured_noise = _row_noise(pw, tau)
    bias_advice, bias_drift = "", -1
    if bias is not None:
        b = _check_bias_column(bias, pos.size, src)
        found = check_bias(pos, pw, tau, b, positions_per_cycle=n, bias_weight=bias_weight)
        restored = restore_bias and found.separated
        if restored:
            tau, bias_drift = tau + found.restore, found.harmonics
        if found.varies:
            bias_advice = found.advice(restored=restored, bias_open=bias_open)
    gap = max(1, n // (4 * m)) if max_gap is None else int(max_gap)
    floor = _noise_floor(pw, tau)
    check_torque_sign(pos, pw, tau, path=src)  # before the signal check: a reversed sensor
    _check_signal(pos, pw, tau, src)
    _check_phases(spec, pos, pw, tau, floor, src)
    _check_coverage(spec, pos, gap, src)

    rank = 0
    raw_tau = tau
    order_advice = ""
    if denoise and method == "interp":
        cleaned = denoise_blocks(pw, tau, bias_weight=bias_weight)
        tau, rank = cleaned.torque, cleaned.rank
        order_advice = row_order_advice(cleaned.reason)
        if rank:
            # where the low-rank fit misses the torque beyond the noise, the readings back
            tau = restore_misfit(pw, raw_tau, tau, bias_weight=bias_weight).torque
    model = functools.partial(
        _forward_model,
        spec,
        max_gap=gap,
        handover=handover and method == "interp",
        detent=detent and method == "interp",
    )
    forward, levels, voids, averaged, handover_cells, harmonics = model(pos, pw, tau)
    rows_pos, rows_pw, rows_tau = pos, pw, raw_tau
    dropped = np.zeros(pos.size, dtype=bool)
    # the structured surface bridges the measured positions (below): only there do the held
    # rows reach the tables between them (a collection that measures every position where the
    # ramp changes reads each hand-over in its own block)
    bridged = ramp_share_step(np.asarray(spec.ramp, dtype=np.float64), np.unique(pos[pw == 0]))
    if held and method == "interp" and onset and surface and bridged > SURFACE_SHARE_STEP:
        # rows the friction held at the top of its band after the rig moved into a falling
        # ramp (torquemap.linearize.held): not readings of the rising curve
        if held_mask is None:
            marks = held_rows(pos, pw, spec.ramp)
        else:
            marks = np.asarray(held_mask, dtype=bool)
            if marks.shape != pos.shape:
                raise ValueError(f"held_mask must have shape {pos.shape}, got {marks.shape}")
        keep = ~marks
        if not keep.all():
            without = model(pos[keep], pw[keep], tau[keep])
            # unless a position loses the levels only those rows reached (the position-
            # independent torque would fall) or every row it had: then the rows as read
            before, after = _reach(forward), _reach(without[0])
            if (
                np.all(np.isfinite(after) >= np.isfinite(before))
                and after.min() >= HELD_REACH * before.min()
            ):
                forward, levels, voids, averaged, handover_cells, harmonics = without
                pos, pw, tau, raw_tau = pos[keep], pw[keep], tau[keep], raw_tau[keep]
                dropped = marks
    reach = _reach(forward)
    unreachable = unreachable_message(reach, floor, phases=m)
    if unreachable:
        raise InputError(unreachable, path=src)
    torque_max = float(reach.min())
    cmax = (1 << (spec.command_bits - 1)) - 1
    weak = weak_phase_advice(reach, np.asarray(spec.ramp, dtype=np.float64))
    law = {
        "torque_max": torque_max,
        "command_max": cmax,
        "scaling": command_scaling,
        "log_curvature": log_curvature,
    }
    surface_used = False
    window = float("nan")
    warnings: list[str] = [weak] if weak else []
    noisy = noise_advice(measured_noise, torque_max / cmax)
    if method == "interp":
        target = torque_from_command(np.arange(cmax + 1), **law)  # type: ignore[arg-type]
        if onset:
            ramp = np.asarray(spec.ramp, dtype=np.float64)
            sigma = _row_noise(pw, raw_tau)
            readable = max(3.0 * sigma, 1e-6 * float(np.max(np.abs(raw_tau))))
            fine = _fine(forward, levels, spec.actuation_max)
            onset_fit = functools.partial(
                fit_onset,
                forward,
                levels,
                ramp,
                readable=readable,
                actuation_max=spec.actuation_max,
                form=onset_form,
                censored=onset_censored,
                search=None if onset_search == "all" else _measured_positions(pos, pw, n),
                measured=_measured_positions(pos, pw, n) if onset_form == "choose" else None,
            )
            window = WINDOWS[0] if onset_window == "choose" else float(onset_window)
            fit = onset_fit(upper=window * torque_max)
            if (
                onset_window == "choose"
                and surface
                and ramp_share_step(ramp, np.unique(pos[pw == 0])) > SURFACE_SHARE_STEP
            ):
                # the window whose law predicts measured positions left out of the surface
                # (torquemap.linearize.window)
                fits = [fit] + [onset_fit(upper=w * torque_max) for w in WINDOWS[1:]]
                choice = choose_window(
                    _surface_grid(spec, pos, pw, tau, levels),
                    levels,
                    ramp,
                    [(f.dead_zone, f.exponent, f.curve) for f in fits],
                    readable=readable,
                    actuation_max=spec.actuation_max,
                    coupling=coupling,
                )
                fit, window = fits[choice.index], WINDOWS[choice.index]
            fine, _ = extend_below(
                fine,
                fit,
                ramp,
                readable=readable,
                actuation_max=spec.actuation_max,
                levels=levels,
            )
            base = _invert(fine, np.arange(spec.actuation_max + 1, dtype=np.float64), target)
            onset_law = (fit.dead_zone, fit.exponent, fit.curve)
            anchors = np.unique(pos[pw == 0])
            if surface and ramp_share_step(ramp, anchors) > SURFACE_SHARE_STEP:
                surface_forward = functools.partial(
                    _surface_forward,
                    spec,
                    pos,
                    pw,
                    tau,
                    levels,
                    onset_law,
                    readable,
                    sigma,
                    knee=knee,
                    pool=pool,
                    track=track,
                    raw=raw_tau,
                    coupling=coupling,
                )
                modelled, fitted = surface_forward()
                if held == "model" and held_mask is None:
                    # the moves the fitted surface says lowered the torque (cross-fades too)
                    change, model_torque = _relookup_change(fitted, ramp, rows_pos, rows_pw)
                    marks = held_rows(
                        rows_pos,
                        rows_pw,
                        ramp,
                        change=change,
                        torque=model_torque,
                        noise=sigma,
                        compliance=compliance_from_blocks(rows_pos, rows_pw, rows_tau, n),
                    )
                    if (marks != dropped).any():
                        # the window chosen (if asked) kept: the choice reads the rows as read
                        again = {**arguments, "held_mask": marks, "onset_window": window}
                        return build_tables(**again)
                fine = np.where(np.isnan(fine), np.nan, modelled)
                check = check_position_sampling(
                    fitted.rest, anchors, n, torque_per_count=torque_max / cmax
                )
                if check.undersampled:
                    warnings.append(check.advice())
                    if nyquist:
                        # the ripple the measured positions sample twice a period, read by
                        # the rows the compliance moved between them (surface.rest_basis)
                        modelled, fitted = surface_forward(nyquist=True)
                        fine = np.where(np.isnan(fine), np.nan, modelled)
                elif nyquist == "tested" and rest_basis(anchors, n) is not None:
                    # the measured positions can sit on the ripple's zeros and see nothing:
                    # the wave kept where the rows between them read it beyond their noise
                    waved, trial = surface_forward(
                        nyquist=True, carried=carried_shape(fitted.rest, anchors)
                    )
                    if hidden_wave(trial):
                        modelled, fitted = waved, trial
                        fine = np.where(np.isnan(fine), np.nan, modelled)
                        warnings.append(hidden_wave_advice(trial.nyquist_amplitude, anchors, n))
                if fitted.series is not None:
                    unheld, period = fitted.series.unheld_at(
                        anchors, matters=MATTERS * torque_max / cmax
                    )
                    if unheld.any():
                        warnings.append(unheld_gap_advice(unheld, anchors, n, period=period))
                base = _invert(fine, np.arange(spec.actuation_max + 1, dtype=np.float64), target)
                base = _snap(fine, base, target) if actuation_bits is None else base
                surface_used = True
        else:
            base = _invert(forward, levels, target)
    else:
        index = command_from_torque(tau, **law)  # type: ignore[arg-type]
        base, voids, averaged = _paper_inverse(spec, pos, pw, tau, index, cmax, gap)
    if spec.cogging_periods is not None and len(warnings) == bool(weak):
        stated = check_stated_cogging(spec.cogging_periods, np.unique(pos[pw == 0]), n)
        if stated:
            warnings.append(stated)
    if bias_advice:
        warnings.append(bias_advice)
    if noisy:
        warnings.append(noisy)
    within = within_count_advice(pos, pw, tau, spec.ramp)  # few positions per cycle
    if within:
        warnings.append(within)
    if order_advice:
        warnings.append(order_advice)
    base[:, 0] = 0.0
    base = np.clip(base, 0.0, float(spec.actuation_max))

    top = spec.actuation_max if actuation_bits is None else (1 << actuation_bits) - 1
    scale = top / spec.actuation_max
    positive = np.rint(base[None, :, :] * spec.ramp.T[:, :, None] * scale)
    positive = np.clip(positive, 0, top).astype(np.int64)
    fixes = 0
    if monotonic:
        filtered = monotonic_filter(positive)
        fixes = int((filtered != positive).sum())
        positive = filtered
    positive[:, :, 0] = 0
    phases = np.stack(
        [
            reflect_negative(
                positive[k],
                equilibrium=spec.equilibrium_positions[k],
                command_bits=spec.command_bits,
            )
            for k in range(m)
        ]
    )
    return TableSet(
        phases=phases,
        torque_per_count=torque_max / cmax,
        torque_max=torque_max,
        command_scaling=command_scaling,
        log_curvature=float(log_curvature) if command_scaling == "log" else 0.0,
        base=base,
        ramp=np.array(spec.ramp, dtype=np.float64),
        motor_name=spec.name,
        ramping=spec.ramping,
        method=method,
        command_bits=spec.command_bits,
        actuation_max=top,
        motor_actuation_max=spec.actuation_max,
        positions_per_cycle=n,
        equilibrium_positions=tuple(spec.equilibrium_positions),
        monotonic=monotonic,
        voids_filled=voids,
        median_cells=averaged,
        monotonic_fixes=fixes,
        denoise_rank=rank,
        handover_cells=handover_cells,
        detent_harmonics=harmonics,
        surface=surface_used,
        warnings=tuple(warnings),
        bias_drift=bias_drift,
        onset_window=window,
    )


def table_torque_law(tables: TableSet, command: ArrayLike) -> NDArray[np.float64]:
    """The torque [N m] command(s) ask for under the tables' stored law."""
    return torque_from_command(
        command,
        torque_max=tables.torque_max,
        command_max=tables.command_max,
        scaling=tables.command_scaling,
        log_curvature=tables.log_curvature or DEFAULT_LOG_CURVATURE,
    )
