"""A joint's torque model of no fixed form, fitted on a bounded set of a log's moving rows.

Two diagnostics of the pass method (``identify --friction passes``) regress the torque of every
sample where a joint moves, ramps included, on inertia times acceleration, a friction law of no
fixed form (per direction, hat functions of the log speed on knots 1.8x apart) and the PDTV
amplitudes: the torque channel's delay (:func:`torquemap.delay.estimate_motion_delay`) and the
test of the pass model (:func:`torquemap.pass_check.check_pass_model`). :func:`free_law_rows`
builds that regression for both.

Its cost does not grow with the log. At most ``max_rows`` rows are fitted, taken as contiguous
stretches of moving rows (:func:`select_stretches`: every run of moving rows gives its start and
end, where its ramps are, and evenly spaced stretches between), and the columns are formed and
smoothed only on each stretch widened by a window (and a few samples) either side. This is
exact, not an approximation: the smoothing (:func:`torquemap.filters.smooth_as_acceleration`)
at a sample depends on the samples within half a window of it and on the double integral only
through a quadratic fit's curvature; restarting the integral on a piece adds a linear function
of time to it (and subtracting the piece's own mean a quadratic), which that curvature passes
exactly. Inside a stretch the rows are consecutive, so neighbouring rows share their noise
within a window: the F tests count ``window / step`` rows as one independent residual
(:attr:`FreeLawRows.correlation`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: Rows fitted at most: about 60 000, whatever the log's length (all of them below that).
MAX_ROWS = 60_000

#: A stretch's length [differentiator windows] when the rows must be thinned: long enough to
#: hold a ramp of a fast pass, several times the window that each stretch adds either side.
STRETCH_WINDOWS = 4.0

#: Stretches a thinned run keeps at least: its start, its middle and its end.
FEWEST_STRETCHES = 3

#: Samples beyond the window either side of a stretch: where the sampling is sparse a
#: sample's window widens to ``MIN_WINDOW_SAMPLES`` (5) samples, 2 either side.
EDGE = 3

#: Pieces closer than this many samples are smoothed as one where each piece is a call of its
#: own (the inertia fit of :mod:`torquemap.identify`): a call costs about what filtering a few
#: thousand samples costs.
JOIN = 2048


def speed_knots(speeds: NDArray[np.float64]) -> NDArray[np.float64]:
    """Knots [rad/s] 1.8x apart from the 1st to the 99th percentile of ``speeds`` [rad/s].

    Examples
    --------
    >>> k = speed_knots(np.linspace(1.0, 10.0, 1001))
    >>> k.size, round(float(k[1] / k[0]), 3) <= 1.8
    (5, True)
    """
    lo = max(float(np.percentile(speeds, 1)), 1e-12)
    hi = max(float(np.percentile(speeds, 99)), 2 * lo)
    return np.geomspace(lo, hi, max(2, math.ceil(math.log(hi / lo) / math.log(1.8)) + 1))


def _friction_basis(
    velocity: NDArray[np.float64], knots: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Columns of a friction law of no fixed form: per direction, hat functions of the log
    speed at ``knots`` [rad/s] (constant beyond the end knots), shape (n, 2 * knots.size)."""
    s = np.log(np.maximum(np.abs(velocity), knots[0]))
    lk = np.log(knots)
    hats = np.empty((velocity.size, knots.size))
    for i in range(knots.size):
        e = np.zeros(knots.size)
        e[i] = 1.0
        hats[:, i] = np.interp(s, lk, e)
    pos = (velocity > 0)[:, None]
    return np.hstack([hats * pos, hats * ~pos])


def mask_runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """``(start, stop)`` of each run of True samples of ``mask``.

    Examples
    --------
    >>> mask_runs(np.array([0, 1, 1, 0, 1], dtype=bool))
    [(1, 3), (4, 5)]
    """
    step = np.diff(mask.astype(np.int8), prepend=0, append=0)
    starts, stops = np.flatnonzero(step == 1), np.flatnonzero(step == -1)
    return list(zip(starts.tolist(), stops.tolist(), strict=True))


def pieces_around(
    t: NDArray[np.float64],
    stretches: Sequence[tuple[int, int]],
    *,
    margin: float,
    join: int = JOIN,
) -> list[tuple[int, int]]:
    """``(start, stop)`` of pieces of a log that hold each stretch of rows with ``margin`` [s]
    and ``EDGE`` samples either side, cut at the log's ends, those that overlap or lie within
    ``join`` samples of each other merged (sorted stretches in, sorted pieces out).

    With ``margin`` the differentiator's window, a filter whose output at a sample depends
    only on the samples within half a window of it gives the same answer at a stretch's rows
    on its piece as on the whole log; a piece that reaches a log's end is cut there, where the
    whole log's filter shifts its window too.

    Examples
    --------
    >>> t = np.arange(10000) * 0.01
    >>> pieces_around(t, [(20, 21), (30, 31), (9000, 9001)], margin=0.05)
    [(13, 38), (8992, 9009)]
    """
    if not stretches:
        return []
    a = np.array([s for s, _ in stretches])
    b = np.array([e for _, e in stretches])
    lo = np.maximum(np.searchsorted(t, t[a] - margin, side="left") - EDGE, 0)
    hi = np.minimum(np.searchsorted(t, t[b - 1] + margin, side="right") + EDGE, t.size)
    out: list[tuple[int, int]] = []
    for p, q in zip(lo.tolist(), hi.tolist(), strict=True):
        if out and p <= out[-1][1] + join:
            out[-1] = (out[-1][0], max(out[-1][1], q))
        else:
            out.append((p, q))
    return out


def select_stretches(
    t: Sequence[NDArray[np.float64]],
    rows: Sequence[NDArray[np.bool_]],
    *,
    window: float,
    max_rows: int = MAX_ROWS,
) -> list[list[tuple[int, int]]]:
    """At most ``max_rows`` of the True rows, as contiguous stretches (all of them if fewer).

    Each run of True rows longer than three stretches of ``STRETCH_WINDOWS`` windows keeps its
    first and last stretch (where a pass's ramps are) and evenly spaced stretches between (at
    least one, in its middle), as many as keep the same share of every such run; that share is
    the largest within the budget; shorter runs are kept whole. When the runs are so many that
    three stretches each exceed the budget, the stretches shorten, down to one window; beyond
    that, evenly spaced runs are kept.

    Parameters
    ----------
    t
        Per log: time [s], shape (n_log,).
    rows
        Per log: the rows to choose from, boolean shape (n_log,).
    window
        The differentiator's window [s].
    max_rows
        The budget of rows.

    Returns
    -------
    list of list of (int, int)
        Per log, the sorted ``(start, stop)`` of the stretches (each within a run of True rows).

    Examples
    --------
    >>> t = np.arange(100000) * 1e-3
    >>> rows = np.zeros(t.size, dtype=bool); rows[1000:91000] = True
    >>> chosen = select_stretches([t], [rows], window=0.05, max_rows=6000)[0]
    >>> chosen[0], chosen[-1], sum(b - a for a, b in chosen) <= 6000
    ((1000, 1200), (90800, 91000), True)
    """
    runs = [mask_runs(np.asarray(m, dtype=bool)) for m in rows]
    sizes = np.array([b - a for r in runs for a, b in r], dtype=np.int64)
    if int(sizes.sum()) <= max_rows:
        return runs

    def per_run(windows: float) -> NDArray[np.int64]:
        """``windows`` differentiator windows in samples, at each run's log's mean step."""
        return np.concatenate(
            [
                np.full(len(r), max(1, math.ceil(windows * window / _mean_step(tl))))
                for tl, r in zip(t, runs, strict=True)
            ]
        ).astype(np.int64)

    length, shortest = per_run(STRETCH_WINDOWS), per_run(1.0)
    keep = np.ones(sizes.size, dtype=bool)
    count = sizes.size
    while True:
        least = int(np.where(keep, np.minimum(sizes, FEWEST_STRETCHES * length), 0).sum())
        if least <= max_rows:
            break
        if np.all(length <= shortest):
            # too many runs for three stretches of a window each: evenly spaced runs
            count = max(min(count - 1, count * max_rows // least), 1)
            keep[:] = False
            keep[np.round(np.linspace(0, sizes.size - 1, count)).astype(np.int64)] = True
            continue
        length = np.maximum(length * max_rows // least, shortest)

    def taken(fraction: float) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        k = np.maximum(FEWEST_STRETCHES, np.ceil(fraction * sizes / length)).astype(np.int64)
        return np.where(keep, np.minimum(k * length, sizes), 0), k

    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if int(taken(mid)[0].sum()) <= max_rows:
            lo = mid
        else:
            hi = mid
    counts, k = taken(lo)
    out: list[list[tuple[int, int]]] = []
    j = 0
    for r in runs:
        chosen: list[tuple[int, int]] = []
        for a, b in r:
            if counts[j] == b - a:
                chosen.append((a, b))
            elif counts[j] > 0:
                n = int(length[j])
                starts = a + np.round(np.linspace(0, b - a - n, int(k[j]))).astype(np.int64)
                chosen += [(s, s + n) for s in starts.tolist()]
            j += 1
        out.append(chosen)
    return out


def _mean_step(t: NDArray[np.float64]) -> float:
    return float(t[-1] - t[0]) / max(t.size - 1, 1) if t.size > 1 else 1.0


def _friction_velocity(
    t: NDArray[np.float64], angle: NDArray[np.float64], at: NDArray[np.float64], span: float
) -> NDArray[np.float64]:
    """The central difference of ``angle`` over ``at +- span`` [s] (cut at the log's ends)."""
    lo = np.maximum(at - span, t[0])
    hi = np.minimum(at + span, t[-1])
    rise = np.interp(hi, t, angle) - np.interp(lo, t, angle)
    return np.asarray(rise / np.maximum(hi - lo, 1e-300), dtype=np.float64)


@dataclass(frozen=True, slots=True, eq=False)
class FreeLawRows:
    """Result of :func:`free_law_rows`: the free model's regression at the chosen rows.

    Attributes
    ----------
    design
        Shape (n, p): acceleration [rad/s^2], the friction hats and the PDTV ``cos`` and
        ``sin`` (both smoothed), and, with an inertia modulation, acceleration times it;
        columns zero at every row dropped.
    torque
        The smoothed torque at the rows [N m], shape (n,).
    model
        The smoothed model torque at the rows [N m], shape (n,) (zeros when none was given).
    index
        Per log, the rows' sample indices, each shape (n_log_rows,) (empty for a log without
        rows).
    knots
        The friction law's knots [rad/s].
    correlation
        Rows per differentiator window (at least 1): rows within a window share their noise.
    shifted
        Per log with rows: the rows' times, the times of its pieces side by side and their
        smoothed torque (:meth:`torque_at`).
    """

    design: NDArray[np.float64]
    torque: NDArray[np.float64]
    model: NDArray[np.float64]
    index: tuple[NDArray[np.intp], ...]
    knots: NDArray[np.float64]
    correlation: float
    shifted: tuple[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]], ...]

    def torque_at(self, delay: float) -> NDArray[np.float64]:
        """The smoothed torque ``delay`` [s] after each row [N m], shape (n,)
        (``|delay|`` up to :func:`free_law_rows`'s ``max_shift``)."""
        return _interpolated(self.shifted, delay)


def _interpolated(
    shifted: Sequence[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]],
    delay: float,
) -> NDArray[np.float64]:
    parts = [np.interp(tr + delay, tp, yp) for tr, tp, yp in shifted]
    return np.asarray(np.concatenate([np.empty(0), *parts]), dtype=np.float64)


def _rows_of(stretches: Sequence[tuple[int, int]], offset: int = 0) -> NDArray[np.intp]:
    return np.concatenate([np.empty(0, np.intp), *(np.arange(a, b) - offset for a, b in stretches)])


def free_law_rows(
    t: Sequence[NDArray[np.float64]],
    angle: Sequence[NDArray[np.float64]],
    acceleration: Sequence[NDArray[np.float64]],
    torque: Sequence[NDArray[np.float64]],
    rows: Sequence[NDArray[np.bool_]],
    orders: Sequence[float],
    *,
    window: float,
    inertia_modulation: Sequence[NDArray[np.float64]] | None = None,
    model_torque: Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]
    | None = None,
    max_rows: int = MAX_ROWS,
    max_shift: float = 0.0,
) -> FreeLawRows:
    """The free model's design and smoothed torque at up to ``max_rows`` moving rows.

    Friction is evaluated at the central difference of the angle over +-1/8 window, which
    does not smear a ramp's start; the friction hats, the PDTV columns, the torque and the
    model torque are smoothed by the kernel through which the differentiator sees
    acceleration (:func:`torquemap.filters.smooth_as_acceleration`), so that both sides of
    the regression carry one filter. The rows are :func:`select_stretches`'s; every column
    is formed and smoothed only on the stretches widened by a window (exact, see the module).

    Parameters
    ----------
    t, angle, acceleration, torque
        Per log: time [s], motor angle [rad], differentiated acceleration [rad/s^2] and motor
        torque [N m], each shape (n_log,).
    rows
        Per log: the candidate rows (the joint moving), boolean shape (n_log,); at least one.
    orders
        PDTV orders [CPR].
    window
        The differentiator's window [s].
    inertia_modulation
        Per log, the factor of a second inertia column (``cos`` of the elbow angle), each
        shape (n_log,), or None.
    model_torque
        A torque [N m] as a function of the angle [rad] and the friction velocity [rad/s]
        (each shape (m,)), smoothed into :attr:`FreeLawRows.model`, or None.
    max_rows
        The budget of rows (all rows when they are fewer).
    max_shift
        The largest ``|delay|`` [s] :meth:`FreeLawRows.torque_at` is asked for.

    Returns
    -------
    FreeLawRows

    Raises
    ------
    ValueError
        If no row is True.

    Examples
    --------
    >>> t = np.arange(4000) * 1e-3
    >>> angle = 2.0 * t + 0.5 * t**2
    >>> acc = np.ones(t.size)
    >>> rows = [np.ones(t.size, dtype=bool)]
    >>> free = free_law_rows([t], [angle], [acc], [0.01 * acc], rows, [1.0], window=0.05)
    >>> free.design.shape, round(float(free.torque[2000]), 12)
    ((4000, 6), 0.01)
    """
    from torquemap.filters import _smooth_as_acceleration_at_step, regular_step

    chosen = select_stretches(t, rows, window=window, max_rows=max_rows)
    if not any(chosen):
        raise ValueError("no rows to fit")
    # Per log, the samples of every piece (a stretch widened by a window) side by side, smoothed
    # in one call: a row's smoothing sees only its own piece's samples (the next piece is
    # more than half a window away in samples and in time), and across a seam the double
    # integral runs on by a linear function of time, which the curvature passes.
    layouts = []
    for li, stretches in enumerate(chosen):
        tl = t[li]
        idx = _rows_of(stretches)
        held = _rows_of(pieces_around(tl, stretches, margin=window, join=0))
        v = _friction_velocity(tl, angle[li], tl[held], window / 8.0)
        layouts.append((idx, held, np.searchsorted(held, idx), v))
    knots = speed_knots(np.concatenate([np.abs(v[at]) for _, _, at, v in layouts]))

    blocks, models, steps, shifted, acc, mod = [], [], [], [], [], []
    for li, (stretches, (idx, held, at, v)) in enumerate(zip(chosen, layouts, strict=True)):
        if not stretches:
            continue
        tl = t[li]
        step = regular_step(tl, rtol=1e-9)  # the whole log's filter, on its pieces
        steps += [np.diff(tl[a:b]) for a, b in stretches]
        acc.append(acceleration[li][idx])
        if inertia_modulation is not None:
            mod.append(inertia_modulation[li][idx])
        th = angle[li][held]
        parts = [_friction_basis(v, knots)]
        parts += [np.c_[np.cos(n * th), np.sin(n * th)] for n in orders]
        if model_torque is not None:
            parts.append(np.asarray(model_torque(th, v), dtype=np.float64)[:, None])
        smooth = _smooth_as_acceleration_at_step(tl[held], np.hstack(parts), window, step)[at]
        if model_torque is not None:
            models.append(smooth[:, -1])
            smooth = smooth[:, :-1]
        blocks.append(smooth)
        # the torque on pieces wide enough for every trial shift
        wide = _rows_of(pieces_around(tl, stretches, margin=window + max_shift, join=0))
        y = _smooth_as_acceleration_at_step(tl[wide], torque[li][wide], window, step)
        shifted.append((tl[idx], tl[wide], y))
    a = np.concatenate(acc)
    cols = [a[:, None], np.vstack(blocks)]
    if inertia_modulation is not None:
        cols.append((a * np.concatenate(mod))[:, None])
    design = np.hstack(cols)
    design = design[:, np.any(design != 0, axis=0)]
    diffs = np.concatenate([np.empty(0), *steps])
    step_rows = float(np.median(diffs)) if diffs.size else math.inf
    return FreeLawRows(
        design=design,
        torque=_interpolated(shifted, 0.0),
        model=np.concatenate(models) if models else np.zeros(design.shape[0]),
        index=tuple(idx for idx, _, _, _ in layouts),
        knots=knots,
        correlation=max(window / max(step_rows, 1e-12), 1.0),
        shifted=tuple(shifted),
    )
