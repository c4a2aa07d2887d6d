"""A time delay between a log's torque (current) channel and its position channel.

Host-polled logs and drives that filter their current report record the torque some time after
the position it belongs to. At a perfectly constant speed such a delay is indistinguishable from
an angle offset of the PDTV (a harmonic fit absorbs it in its phases); where the speed varies
along a pass, the same delay shifts the angle by different amounts, and the PDTV only stays a
function of the motor angle at the right delay. :func:`estimate_delay` finds the delay that
minimises the residual of a harmonic model of the motor angle, and keeps it only when it explains
significantly more than no delay does.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from torquemap.free_law import MAX_ROWS, free_law_rows
from torquemap.pdtv import fit_harmonics


@dataclass(frozen=True, slots=True, eq=False)
class DelayEstimate:
    """Result of :func:`estimate_delay`.

    Attributes
    ----------
    delay
        The torque channel's delay behind the position [s] (0 when not significant).
    best
        The residual-minimising delay on the grid, refined [s], whether kept or not.
    rss_zero, rss_best
        Residual sums of squares of the harmonic model at zero delay and at ``best``.
    f_statistic
        ``(rss_zero - rss_best) / (rss_best / dof)`` (one extra parameter).
    significant
        Whether ``delay`` was kept.
    """

    delay: float
    best: float
    rss_zero: float
    rss_best: float
    f_statistic: float
    significant: bool


def _shifted(t: NDArray[np.float64], y: NDArray[np.float64], delay: float) -> NDArray[np.float64]:
    """``y(t + delay)``: the torque recorded ``delay`` later, brought back to time ``t``."""
    return np.asarray(np.interp(t + delay, t, y), dtype=np.float64)


def shift_channel(
    t: NDArray[np.float64], y: NDArray[np.float64], delay: float
) -> NDArray[np.float64]:
    """Undo a channel delay: the value each sample's channel reported ``delay`` [s] later.

    Examples
    --------
    >>> t = np.arange(5.0)
    >>> shift_channel(t, 10 * t, 1.0).tolist()
    [10.0, 20.0, 30.0, 40.0, 40.0]
    """
    return _shifted(t, y, delay)


def estimate_delay(
    t: Sequence[NDArray[np.float64]],
    angle: Sequence[NDArray[np.float64]],
    torque: Sequence[NDArray[np.float64]],
    spans: Sequence[tuple[int, int, int]],
    orders: Sequence[float],
    *,
    max_delay: float = 0.25,
    steps: int = 41,
    confidence: float = 1.0 - 1e-6,
) -> DelayEstimate:
    """Estimate the torque channel's delay from passes and the PDTV orders.

    Parameters
    ----------
    t, angle, torque
        Per log: time [s], motor angle [rad] and torque residual [N m] (torque minus friction
        and inertia), each shape (n_log,).
    spans
        ``(log index, start, stop)`` of the passes used: each gets its own offset.
    orders
        PDTV orders [CPR] of the harmonic model.
    max_delay
        Delays searched in ``[-max_delay, max_delay]`` [s].
    steps
        Grid points (then a parabola through the best three).
    confidence
        Level of the F test (one parameter) that the delay explains more than noise.

    Returns
    -------
    DelayEstimate
    """
    from scipy import stats

    if not orders or not spans:
        return DelayEstimate(0.0, 0.0, math.nan, math.nan, 0.0, False)
    grid = np.linspace(-max_delay, max_delay, steps)
    if not np.any(grid == 0):
        grid = np.sort(np.append(grid, 0.0))
    # at most about 60000 samples: every ``stride``-th of each pass (the criterion only needs
    # the shape of the residual against the delay)
    total = sum(b - a for _, a, b in spans)
    stride = max(1, total // 60000)
    idx = [np.arange(a, b, stride) for _, a, b in spans]
    y = np.concatenate([torque[li][i] for (li, _, _), i in zip(spans, idx, strict=True)])
    groups = np.concatenate([np.full(i.size, g) for g, i in enumerate(idx)])

    def rss(delay: float) -> float:
        # pair each torque sample with the (smooth) angle ``delay`` earlier: the noisy torque
        # itself is never interpolated, so every delay is scored on the same samples
        theta = np.concatenate(
            [
                np.interp(t[li][i] - delay, t[li], angle[li])
                for (li, _, _), i in zip(spans, idx, strict=True)
            ]
        )
        fit = fit_harmonics(theta, y, orders=orders, groups=groups)
        return float(fit.residual_rms**2 * y.size)

    values = np.array([rss(float(d)) for d in grid])
    k = int(np.argmin(values))
    best = float(grid[k])
    rss_best = float(values[k])
    if 0 < k < grid.size - 1:
        y0, y1, y2 = values[k - 1], values[k], values[k + 1]
        den = y0 - 2 * y1 + y2
        if den > 0:
            step = float(grid[k + 1] - grid[k])
            best = float(grid[k] + 0.5 * step * (y0 - y2) / den)
            rss_best = min(rss(best), rss_best)
    rss_zero = float(values[int(np.argmin(np.abs(grid)))])
    dof = max(y.size - 2 * len(orders) - len(spans) - 1, 1)
    f = (rss_zero - rss_best) / max(rss_best / dof, np.finfo(float).tiny)
    interior = 0 < k < grid.size - 1
    significant = bool(interior and f > stats.f.ppf(confidence, 1, dof))
    return DelayEstimate(
        delay=best if significant else 0.0,
        best=best,
        rss_zero=rss_zero,
        rss_best=rss_best,
        f_statistic=float(f),
        significant=significant,
    )


def estimate_motion_delay(
    t: Sequence[NDArray[np.float64]],
    angle: Sequence[NDArray[np.float64]],
    acceleration: Sequence[NDArray[np.float64]],
    torque: Sequence[NDArray[np.float64]],
    rows: Sequence[NDArray[np.bool_]],
    orders: Sequence[float],
    *,
    window: float,
    inertia_modulation: Sequence[NDArray[np.float64]] | None = None,
    max_delay: float = 0.25,
    steps: int = 41,
    confidence: float = 1.0 - 1e-6,
    max_rows: int = MAX_ROWS,
) -> DelayEstimate:
    """Estimate the torque channel's delay from the moving samples, ramps included.

    Each trial delay ``d`` pairs the motion at each row with the torque ``d`` later and fits,
    by linear least squares, inertia times acceleration, a friction law of no fixed form
    (per direction, piecewise linear in the log speed on knots 1.8x apart over the speeds
    the rows hold) and the PDTV ``orders``; the residual-minimising delay is kept when an F
    test says it explains more than noise. Ramps show a delay far more strongly than the
    constant-speed passes (where it is only an angle offset of the PDTV), and a law fitted
    anew at every trial cannot absorb it, as friction and inertia identified from a
    misaligned torque do. The regression is :func:`torquemap.free_law.free_law_rows`'s: the
    torque and every column but the acceleration are smoothed by the kernel through which the
    differentiator sees acceleration, so both sides carry one filter and a ramp's start or
    end does not bias the delay; friction is evaluated at a central difference of the angle
    over +-1/8 window, which does not smear a ramp's start; at most ``max_rows`` rows, as
    contiguous stretches of every run of moving rows (its ramps and evenly spaced stretches
    between), so the cost does not grow with the log.

    Parameters
    ----------
    t, angle, acceleration, torque
        Per log: time [s], motor angle [rad], differentiated acceleration [rad/s^2] and motor
        torque [N m], each shape (n_log,).
    rows
        Per log: the samples that may be fitted (the joint moving alone, faster than friction
        is known), boolean shape (n_log,).
    orders
        PDTV orders [CPR].
    window
        The differentiator's window [s]; neighbouring rows within it share their noise, and
        the F test counts one independent residual per window's worth of rows.
    inertia_modulation
        Per log, the factor of a second inertia column (``cos`` of the elbow angle), or None.
    max_delay, steps, confidence
        As :func:`estimate_delay`.
    max_rows
        The rows fitted at most (:func:`torquemap.free_law.select_stretches`).

    Returns
    -------
    DelayEstimate
    """
    from scipy import stats

    if sum(int(np.count_nonzero(r)) for r in rows) < 10:
        return DelayEstimate(0.0, 0.0, math.nan, math.nan, 0.0, False)
    free = free_law_rows(
        t,
        angle,
        acceleration,
        torque,
        rows,
        orders,
        window=window,
        inertia_modulation=inertia_modulation,
        max_rows=max_rows,
        max_shift=max_delay,
    )
    design = free.design
    n_cols = design.shape[1]

    # the design is the same at every trial delay: factor it once (an SVD with lstsq's
    # cut-off) and project each trial's torque on its column space
    u, sv, _ = np.linalg.svd(design, full_matrices=False)
    basis = u[:, sv > np.finfo(float).eps * max(design.shape) * float(sv[0])] if sv.size else u

    def rss(delay: float) -> float:
        y = free.torque_at(delay)
        r = y - basis @ (basis.T @ y)
        return float(r @ r)

    grid = np.linspace(-max_delay, max_delay, steps)
    if not np.any(grid == 0):
        grid = np.sort(np.append(grid, 0.0))
    values = np.array([rss(float(d)) for d in grid])
    k = int(np.argmin(values))
    best, rss_best = float(grid[k]), float(values[k])
    interior = 0 < k < grid.size - 1
    if interior:
        y0, y1, y2 = values[k - 1], values[k], values[k + 1]
        den = y0 - 2 * y1 + y2
        if den > 0:
            trial = float(grid[k] + 0.5 * float(grid[k + 1] - grid[k]) * (y0 - y2) / den)
            r_trial = rss(trial)
            if r_trial <= rss_best:
                best, rss_best = trial, r_trial
    rss_zero = float(values[int(np.argmin(np.abs(grid)))])
    rows_n = design.shape[0]
    # neighbouring rows within a window share their noise: the change in the residual has
    # ``c`` times the variance that independent rows would give it
    c = free.correlation
    sigma2 = rss_best / max(rows_n - n_cols, 1)
    dof = max(rows_n / c - n_cols, 1.0)
    f = (rss_zero - rss_best) / max(sigma2 * c, np.finfo(float).tiny)
    significant = bool(interior and f > stats.f.ppf(confidence, 1, dof))
    return DelayEstimate(
        delay=best if significant else 0.0,
        best=best,
        rss_zero=rss_zero,
        rss_best=rss_best,
        f_statistic=float(f),
        significant=significant,
    )
