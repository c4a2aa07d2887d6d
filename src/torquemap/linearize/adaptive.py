"""Adaptive collection: measure where the torque surface bends, not on a fixed grid (beyond §4.3).

The paper's collection measures every 4th position and pulse width. Most of that surface is
flat in position (a phase's plateau) or straight in pulse width (above the onset), where
linear interpolation between far fewer rows is as good. :func:`collect_adaptive` spends a budget
of sensor readings (by default a third of the paper grid's, bias readings included) in passes,
with the readings per row chosen so that the first pass takes at most half the budget
(:func:`coarse_readings`; the table builder pools the noise over every row, so more rows with
fewer readings each beat fewer rows):

1. A coarse pass: every ``2 position_step``-th position (at most ``P / 4 m`` apart, the gap the
   table builder interpolates across), every ``2 level_step``-th pulse width.
2. The pulse widths: from the coarse blocks (their low-rank fit,
   :func:`torquemap.linearize.denoise.denoise_blocks`, so that the noise is not taken for
   curvature), the level grid is thinned where the curves are straight, keeping the levels whose removal would cost more than ``tolerance`` of the
   torque (relative to each level's mean torque, so the onset keeps its density).
3. Position passes, one sweep of the cycle each: every gap between measured positions gets
   the score ``gap^2 max_level |second difference| / mean torque`` (the linear interpolation
   error across it, from the curvature at its ends); the midpoints of the highest-scoring
   gaps are measured at the kept levels, until the budget is spent.

Every block is measured by :func:`torquemap.linearize.collect.measure_block`, as in
:func:`torquemap.linearize.collect.collect_characterisation`: it starts at level 0 after a bias
measurement (at rest, or on an open contact with ``settings.bias_open``), and each row keeps the
bias subtracted from it in the ``bias`` column. DATA.csv has the usual format
(``position, pulse_width, torque, bias``) and ``linearize build`` (its bias check, and its
low-rank denoising, which completes the levels a block skipped) reads it unchanged.

Resuming: a record ``DATA.csv.adaptive.json`` lists the blocks done as (target position, pulse
widths, rows), the run's settings (readings, budget, grid, where the bias is read) and the motor
(phases, cycle, actuation range, a digest of the ramp); a run whose settings or motor differ
from the record's is refused, naming each difference. The plan is a function of the
data alone, so a rerun re-plans from the rows kept and continues with the first block not done;
a block cut short is measured again. An older file of three columns (without ``bias``) is
resumed in its own format; a run whose ``bias_open`` differs from the record's is refused.

This module talks to hardware only through the :class:`~torquemap.linearize.collect.Rig`
protocol; it never imports the simulator.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.io import atomic_output
from torquemap.linearize.collect import (
    CHARACTERISATION_COLUMNS,
    CollectionSettings,
    Rig,
    bias_opener,
    data_header,
    measure_block,
    move_to_target,
    parse_data_rows,
)
from torquemap.linearize.count import check_grid_fits
from torquemap.linearize.denoise import denoise_blocks
from torquemap.linearize.motor import MotorSpec, ramped_actuation
from torquemap.linearize.resume import (
    adaptive_record_path,
    check_same_settings,
    motor_identity,
)
from torquemap.linearize.resume import (
    record_path as grid_record_path,
)


@dataclass(frozen=True, slots=True, eq=False)
class AdaptiveResult:
    """What an adaptive collection did.

    Attributes
    ----------
    path
        The data file.
    rows
        Data rows in the file at the end.
    readings
        Sensor readings spent (rows and biases) over the whole file.
    budget
        The readings allowed.
    grid_readings
        Readings of the full grid of the settings (the reference the budget is a fraction of).
    blocks
        Blocks (target visits) in the file.
    positions
        Distinct target positions measured.
    levels
        Pulse widths of the position passes, shape (k,).
    resumed_blocks
        Blocks found done in the file and kept.
    row_readings
        Sensor readings averaged per row (:func:`coarse_readings` unless given).
    elapsed
        Wall time of this call [s].
    bias_column
        Whether the file has the ``bias`` column (False: an older file resumed in its own
        three-column format).
    """

    path: str
    rows: int
    readings: int
    budget: int
    grid_readings: int
    blocks: int
    positions: int
    levels: NDArray[np.int64]
    resumed_blocks: int
    row_readings: int
    elapsed: float
    bias_column: bool = True


def _grid_levels(top: int, step: int) -> list[int]:
    levels = list(range(0, top + 1, step))
    if levels[-1] != top:
        levels.append(top)
    return levels


def grid_readings(spec: MotorSpec, settings: CollectionSettings) -> int:
    """Sensor readings of the settings' full grid: rows times readings plus the biases."""
    targets = settings.targets(spec).size
    levels = len(_grid_levels(spec.actuation_max, settings.level_step))
    return targets * (levels * settings.readings + settings.bias_count)


def coarse_readings(positions: int, levels: int, settings: CollectionSettings, budget: int) -> int:
    """Readings per row: the most (up to the settings') with which the coarse pass takes at
    most half the budget, so that at least half is spent where the surface bends.

    The bias of a block is read over ``settings.bias_count`` scaled by the same ratio. Never
    below 1 (the caller refuses a budget the coarse pass does not fit in).

    Examples
    --------
    >>> s = CollectionSettings.paper(progress=False)  # 10 a row, the bias over 100
    >>> coarse_readings(64, 33, s, 32_000)  # 64 x (33 r + 10 r) <= 16000: r = 5
    5
    """
    per_reading = positions * (levels + settings.bias_count / settings.readings)
    return int(max(1, min(settings.readings, (budget / 2) // per_reading)))


def _blocks_matrix(
    rows: list[tuple[int, int, float]], blocks: list[tuple[int, list[int], int]]
) -> tuple[NDArray[np.int64], dict[int, dict[int, float]]]:
    """Per target: level -> torque (the block's rows)."""
    out: dict[int, dict[int, float]] = {}
    i = 0
    for target, _levels, count in blocks:
        out.setdefault(target, {}).update({lv: t for _, lv, t in rows[i : i + count]})
        i += count
    return np.array(sorted(out), dtype=np.int64), out


def _mean_abs(curves: NDArray[np.float64]) -> NDArray[np.float64]:
    """``nanmean(|curves|, axis=0)`` without numpy's warning on a level no block reached (NaN
    there, as before): a saturated sensor cut every coarse block of an 8-phase VR motor short
    (QA stop 36), and ``Mean of empty slice`` reached the user's terminal."""
    a = np.abs(curves)
    count = np.sum(np.isfinite(a), axis=0)
    total = np.nansum(a, axis=0)
    out: NDArray[np.float64] = np.where(count > 0, total / np.maximum(count, 1), np.nan)
    return out


def choose_levels(
    curves: NDArray[np.float64], levels: NDArray[np.int64], *, tolerance: float
) -> NDArray[np.int64]:
    """Thin a level grid where every curve is straight (greedy removal, smallest cost first).

    Parameters
    ----------
    curves
        Torque of each coarse block at each level [N m], shape (blocks, k); NaN where missing.
    levels
        The levels, increasing, shape (k,).
    tolerance
        Largest interpolation error a removal may cause, relative to the mean torque of the
        removed level over the blocks (and at least ``tolerance`` of the largest torque).

    Returns
    -------
    ndarray of int64
        The levels kept (first and last always), increasing.

    Examples
    --------
    >>> lv = np.arange(0, 17, 2)
    >>> choose_levels(np.array([lv * 1.0]), lv, tolerance=0.01).tolist()  # a straight line
    [0, 16]
    """
    keep = list(range(levels.size))
    c = np.where(np.isfinite(curves), curves, np.nan)
    top = float(np.nanmax(np.abs(c)))
    scale = np.maximum(_mean_abs(c), max(tolerance, 1e-6) * top + 1e-300)
    while len(keep) > 2:
        costs = []
        for j in range(1, len(keep) - 1):
            a, b, x = keep[j - 1], keep[j + 1], keep[j]
            f = (levels[x] - levels[a]) / (levels[b] - levels[a])
            err = np.abs(c[:, x] - (c[:, a] + f * (c[:, b] - c[:, a])))
            costs.append(float(np.nanmax(err, initial=0.0)) / float(scale[x]))
        j = int(np.argmin(costs))
        if costs[j] > tolerance:
            break
        del keep[j + 1]
    return levels[keep].astype(np.int64)


def refine_levels(
    curves: NDArray[np.float64],
    levels: NDArray[np.int64],
    *,
    tolerance: float,
    finest: int,
) -> NDArray[np.int64]:
    """Add levels inside the gaps where linear interpolation across them would miss.

    The error of interpolating a curve linearly across a gap of width ``h`` is at most
    ``h^2 |f''| / 8``; ``f''`` at a gap is the larger of the second divided differences at
    its two ends (largest over the blocks, relative to the smaller of the two levels' mean
    torques, as in :func:`choose_levels`). A gap whose error exceeds ``tolerance`` is split evenly into
    steps of ``sqrt(8 tolerance / |f''|)``, never finer than ``finest``.

    Parameters
    ----------
    curves
        Torque of each block at each level [N m], shape (blocks, k); NaN where missing.
    levels
        The levels the curves are at, increasing, shape (k,).
    tolerance
        Largest relative interpolation error allowed across a gap.
    finest
        Smallest step between levels.

    Returns
    -------
    ndarray of int64
        ``levels`` and the levels added, increasing.

    Examples
    --------
    >>> lv = np.arange(0, 65, 16)
    >>> refine_levels(np.array([np.maximum(lv - 16.0, 0.0)]), lv, tolerance=0.01,
    ...               finest=4).tolist()
    [0, 4, 8, 12, 16, 20, 24, 28, 32, 48, 64]
    """
    x = levels.astype(np.float64)
    if x.size < 3:
        return levels.astype(np.int64)
    c = np.where(np.isfinite(curves), curves, np.nan)
    top = float(np.nanmax(np.abs(c)))
    scale = np.maximum(_mean_abs(c), max(tolerance, 1e-6) * top + 1e-300)
    slope = np.diff(c, axis=1) / np.diff(x)[None, :]
    d2 = np.abs(np.diff(slope, axis=1)) / (0.5 * (x[2:] - x[:-2]))[None, :]
    d2 = np.concatenate([d2[:, :1], d2, d2[:, -1:]], axis=1)  # at every level
    out = set(levels.tolist())
    for i in range(x.size - 1):
        h = x[i + 1] - x[i]
        # the curvature at either end against the smaller torque of the two
        worst = float(
            np.nanmax(np.maximum(d2[:, i], d2[:, i + 1]), initial=0.0) / min(scale[i], scale[i + 1])
        )
        if h <= finest or h * h * worst / 8.0 <= tolerance:
            continue
        step = max(float(finest), float(np.sqrt(8.0 * tolerance / worst)))
        pieces = int(np.ceil(h / step))
        out.update(round(x[i] + h * j / pieces) for j in range(1, pieces))
    return np.array(sorted(out), dtype=np.int64)


def position_scores(
    positions: NDArray[np.int64], curves: NDArray[np.float64], period: int
) -> NDArray[np.float64]:
    """Interpolation error score of every gap between measured positions (cyclic).

    ``score_i = gap_i^2 max(|d2_i|, |d2_{i+1}|)`` per level over the level's mean torque, the
    largest over the levels; ``d2`` is the second divided difference at each measured position
    from its neighbours. Gap ``i`` runs from ``positions[i]`` to the next (shape (n,)).
    """
    n = positions.size
    nxt = np.roll(positions, -1)
    gap = (nxt - positions) % period
    gap = np.where(gap == 0, period, gap).astype(np.float64)
    prev_gap = np.roll(gap, 1)
    c = np.where(np.isfinite(curves), curves, 0.0)
    scale = np.maximum(np.abs(c).mean(axis=0), 1e-3 * np.abs(c).max() + 1e-300)
    slope_next = (np.roll(c, -1, axis=0) - c) / gap[:, None]
    slope_prev = (c - np.roll(c, 1, axis=0)) / prev_gap[:, None]
    d2 = np.abs(slope_next - slope_prev) / (0.5 * (gap + prev_gap))[:, None]
    d2 = d2 / scale[None, :]
    end = np.maximum(d2, np.roll(d2, -1, axis=0))
    score: NDArray[np.float64] = gap**2 * end.max(axis=1)
    if n < 3:
        score = np.asarray(gap, dtype=np.float64) ** 2
    return score


def _read_state(
    path: Path,
    record_path: Path,
    top: int,
    bias_open: bool,
    plan: dict[str, object] | None = None,
    motor: dict[str, object] | None = None,
) -> tuple[list[str], list[tuple[int, list[int], int]], bool]:
    """The data lines the record lists, the blocks done and whether the file has the ``bias``
    column (an older file of three columns keeps its format; a new or empty one gets it).

    A record that holds the run's ``settings`` and ``motor`` (:func:`motor_identity`) must
    match ``plan`` and ``motor``: blocks planned from other settings (readings a row, budget,
    grid) or measured through another ramp would be mixed into one file. Older records hold
    ``bias_open`` alone, which is compared."""
    lines, has_bias = parse_data_rows(path, CHARACTERISATION_COLUMNS, list(range(top + 1)))
    if not record_path.exists():
        if lines:
            grid = grid_record_path(path)
            raise InputError(
                f"cannot resume an adaptive collection without its record {record_path.name}"
                + (
                    f" (its record {grid.name} is a grid collection's: resume it without "
                    "--adaptive)"
                    if grid.exists()
                    else ""
                ),
                path=path,
            )
        return [], [], True
    try:
        record = json.loads(record_path.read_text())
        blocks = [(int(t), [int(v) for v in lv], int(c)) for t, lv, c in record["blocks"]]
        opened = record.get("bias_open", False)  # older records: the bias was read at rest
        theirs = (dict(record["settings"]), dict(record["motor"])) if "settings" in record else None
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise InputError(f"unreadable adaptive record ({exc})", path=record_path) from None
    if opened != bias_open:
        where = {True: "on an open contact", False: "at rest"}
        raise InputError(
            f"cannot resume: the file's bias was read {where[bool(opened)]}, this run reads it "
            f"{where[bias_open]} (use the file's --bias-open setting, or another output file)",
            path=path,
        )
    if theirs is not None and plan is not None and motor is not None:
        check_same_settings((plan, motor), theirs, path)
    total = sum(c for _, _, c in blocks)
    if total > len(lines):
        raise InputError(
            f"cannot resume: the record lists {total} rows, the file holds {len(lines)}",
            path=path,
        )
    return lines[:total], blocks, has_bias or total == 0


def collect_adaptive(
    rig: Rig,
    spec: MotorSpec,
    out_csv: str | os.PathLike[str],
    settings: CollectionSettings | None = None,
    *,
    fraction: float = 1.0 / 3.0,
    tolerance: float = 0.005,
    row_readings: int | None = None,
    coarse_level_step: int | None = None,
    coarse_position_factor: int = 2,
    saturation: float | None = None,
    refine: bool = False,
) -> AdaptiveResult:
    """Collect DATA.csv adaptively within a fraction of the settings' grid's readings.

    Parameters
    ----------
    rig
        The bench.
    spec
        The motor.
    out_csv
        DATA.csv (``position, pulse_width, torque, bias``); resumed if it exists with its
        record (an older file without ``bias`` in its own format).
    settings
        Readings per row and per bias, where the bias is read (``bias_open``: on an open
        contact, the rig's ``open_contact()``), and the grid whose readings the budget is a
        fraction of (``position_step``, ``level_step``; default the paper's). ``transitions``
        is not used.
    fraction
        Budget: this fraction of the grid's readings (rows and biases), in (0, 1].
    tolerance
        Relative interpolation error below which a pulse width is not measured (step 2).
    row_readings
        Sensor readings averaged per row (default :func:`coarse_readings`: the most, up to
        ``settings.readings``, with which the coarse pass takes at most half the budget); the
        bias of each block gets ``settings.bias_count`` scaled by the same ratio.
    coarse_level_step
        Pulse-width step of the coarse pass (default ``2 settings.level_step``).
    coarse_position_factor
        The coarse pass visits every ``coarse_position_factor * settings.position_step``-th
        position (at most ``P / 4 m`` apart).
    saturation
        Sensor range [N m] (default the rig's ``saturation`` attribute): a reading at or beyond
        it ends the block.
    refine
        Add pulse widths (down to ``settings.level_step`` apart) inside the gaps of the kept
        ones where the coarse curves bend (:func:`refine_levels`): the onset.

    Returns
    -------
    AdaptiveResult
        Rows, readings spent, positions and levels measured.

    Raises
    ------
    InputError
        A fraction outside (0, 1] or a budget below the coarse pass, an output folder that does
        not exist, the bias to be read on an open contact on a rig without ``open_contact()``,
        or a file that cannot be resumed (no record, malformed rows, a record listing more rows
        than the file has, the bias read otherwise than the record says), or a motor file
        whose grid is larger than the tables are built on (before any reading).
    """
    check_grid_fits(spec.positions_per_cycle, spec.actuation_max, path=spec.path)
    start = time.perf_counter()
    grid = CollectionSettings.paper() if settings is None else settings
    if not 0 < fraction <= 1:
        raise InputError(f"the budget fraction must be in (0, 1], got {fraction}")
    n, top = spec.positions_per_cycle, spec.actuation_max
    reference = grid_readings(spec, grid)
    budget = int(fraction * reference)
    # no wider than the gap the table builder interpolates across (P / 4 m)
    coarse_step = max(1, min(coarse_position_factor * grid.position_step, n // (4 * spec.phases)))
    coarse_targets = sorted({(j * n) // -(-n // coarse_step) for j in range(-(-n // coarse_step))})
    coarse_levels = _grid_levels(top, coarse_level_step or 2 * grid.level_step)
    per_row = (
        coarse_readings(len(coarse_targets), len(coarse_levels), grid, budget)
        if row_readings is None
        else int(row_readings)
    )
    if per_row < 1:
        raise InputError(f"readings per row must be >= 1, got {row_readings}")
    s = CollectionSettings(
        readings=per_row,
        bias_readings=max(1, round(grid.bias_count * per_row / grid.readings)),
        bias_open=grid.bias_open,
        position_step=grid.position_step,
        level_step=grid.level_step,
        progress=False,
    )
    coarse_cost = len(coarse_targets) * (len(coarse_levels) * s.readings + s.bias_count)
    if coarse_cost > budget:
        raise InputError(
            f"a budget of {budget} readings does not cover the coarse pass ({coarse_cost}: "
            f"{len(coarse_targets)} positions x {len(coarse_levels)} pulse widths); raise "
            "the budget or the settings' steps"
        )
    open_contact = bias_opener(rig, s)
    path = Path(out_csv)
    if not path.parent.exists():
        raise InputError("output folder does not exist", path=path.parent)
    record_path = adaptive_record_path(path)
    # what the plan and the rows depend on, compared on resume
    plan: dict[str, object] = {
        "readings": grid.readings,
        "bias_readings": grid.bias_count,
        "bias_open": grid.bias_open,
        "position_step": grid.position_step,
        "level_step": grid.level_step,
        "budget": fraction,
        "tolerance": tolerance,
        "row_readings": per_row,
        "coarse_level_step": coarse_level_step or 2 * grid.level_step,
        "coarse_position_factor": coarse_position_factor,
        "refine": refine,
    }
    motor = motor_identity(spec)
    kept_lines, done, has_bias = _read_state(path, record_path, top, s.bias_open, plan, motor)
    rows = [(int(p), int(lv), float(t)) for p, lv, t, *_ in (x.split(",") for x in kept_lines)]
    resumed = len(done)
    with atomic_output(path) as tmp:
        header = data_header(CHARACTERISATION_COLUMNS, bias=has_bias)
        tmp.write_text("\n".join([header, *kept_lines]) + "\n")
    limit = saturation if saturation is not None else getattr(rig, "saturation", None)
    off = [0] * spec.phases
    cursor = 0  # planned blocks so far; the first ``len(done)`` are in the file

    def spent() -> int:
        """Readings of the blocks planned so far (on resume, the file may hold more)."""
        return sum(c * s.readings + s.bias_count for _, _, c in done[:cursor])

    def known() -> tuple[list[tuple[int, int, float]], list[tuple[int, list[int], int]]]:
        """Rows and blocks planned so far (the plan must not see blocks it has not reached),
        their torques replaced by the low-rank fit so that the curvature is not the noise's."""
        blocks = done[:cursor]
        mine = rows[: sum(c for _, _, c in blocks)]
        level = np.array([lv for _, lv, _ in mine], dtype=np.int64)
        fit = denoise_blocks(level, np.array([t for _, _, t in mine])).torque
        return [(p, lv, float(t)) for (p, lv, _), t in zip(mine, fit, strict=True)], blocks

    def save_record() -> None:
        with atomic_output(record_path) as tmp:
            blocks = [[t, lv, c] for t, lv, c in done]
            tmp.write_text(
                json.dumps(
                    {
                        "blocks": blocks,
                        "bias_open": s.bias_open,
                        "readings": s.readings,  # linearize build's bias weight
                        "bias_readings": s.bias_count,
                        "settings": plan,
                        "motor": motor,
                    }
                )
            )

    save_record()  # from the first reading on, a rerun finds the record and resumes
    handle = path.open("a")

    def measure(target: int, levels: list[int]) -> None:
        nonlocal cursor
        cursor += 1
        if cursor <= len(done):
            if done[cursor - 1][0] != target or done[cursor - 1][1] != levels:
                raise InputError(
                    f"cannot resume: block {cursor} of the record is position "
                    f"{done[cursor - 1][0]}, this run plans {target} (other settings?)",
                    path=path,
                )
            return
        move_to_target(rig, target, n, off, max_steps=100 * n)
        measured, _ = measure_block(
            rig,
            handle,
            levels,
            lambda level, position: ramped_actuation(level, position, spec.ramp).tolist(),
            s,
            limit=limit,
            bias_column=has_bias,
            open_contact=open_contact,
        )
        rows.extend(measured)
        os.fsync(handle.fileno())
        done.append((target, levels, len(measured)))
        save_record()

    try:
        for t in coarse_targets:
            measure(int(t), coarse_levels)
        targets, table = _blocks_matrix(*known())
        lv = np.array(coarse_levels, dtype=np.int64)
        curves = np.array([[table[int(t)].get(int(v), np.nan) for v in lv] for t in targets])
        kept = [int(v) for v in choose_levels(curves, lv, tolerance=tolerance)]
        if refine:
            kc = np.array([[table[int(t)].get(v, np.nan) for v in kept] for t in targets])
            kept = [
                int(v)
                for v in refine_levels(
                    _fill_levels(kc), np.array(kept), tolerance=tolerance, finest=s.level_step
                )
            ]
        cost = len(kept) * s.readings + s.bias_count
        min_gap = max(1, s.position_step // 2)
        while spent() + cost <= budget:
            targets, table = _blocks_matrix(*known())
            curves = np.array(
                [[table[int(t)].get(v, np.nan) for v in kept] for t in targets], dtype=np.float64
            )
            curves = _fill_levels(curves)
            score = position_scores(targets, curves, n)
            gap = (np.roll(targets, -1) - targets) % n
            gap = np.where(gap == 0, n, gap)
            score = np.where(gap >= 2 * min_gap, score, -np.inf)
            affordable = (budget - spent()) // cost
            take = min(int(affordable), max(1, targets.size // 4))
            order = np.argsort(-score, kind="stable")[:take]
            order = order[np.isfinite(score[order])]
            if order.size == 0:
                break
            new = sorted(int((targets[i] + gap[i] // 2) % n) for i in order)
            for t in new:
                measure(t, kept)
        rig.apply(off)
    finally:
        handle.close()
    targets, _ = _blocks_matrix(rows, done)
    return AdaptiveResult(
        path=os.fspath(path),
        rows=len(rows),
        readings=spent(),
        budget=budget,
        grid_readings=reference,
        blocks=len(done),
        positions=int(targets.size),
        levels=np.array(kept, dtype=np.int64),
        resumed_blocks=resumed,
        row_readings=s.readings,
        elapsed=time.perf_counter() - start,
        bias_column=has_bias,
    )


def _fill_levels(curves: NDArray[np.float64]) -> NDArray[np.float64]:
    """Fill each block's missing levels (above a saturated end) with its last value."""
    out = curves.copy()
    for row in out:
        bad = ~np.isfinite(row)
        if bad.all():
            row[:] = 0.0
        elif bad.any():
            idx = np.maximum.accumulate(np.where(~bad, np.arange(row.size), 0))
            row[:] = row[idx]
    return out
