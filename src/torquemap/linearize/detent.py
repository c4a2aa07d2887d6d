"""The torque at rest (cogging, detent) between measured positions, from its spectrum.

A motor's cogging torque does not depend on the currents: it adds the same ``c(p)`` to every
row of a position's curve. It repeats with the slots and poles, often many times per actuation
cycle (a period of 10 table positions is common), so the paper's every 4th position samples it
two or three times per period: the linear interpolation between measured positions cuts its
peaks and valleys, and at the lowest commands (a fraction of a percent of full torque) that
error is the whole torque asked for. Sampled evenly, a periodic torque whose frequency lies
below half the number of measured positions is determined by its samples; what is missing is
how much of each measured curve is ``c(p)``.

Between three consecutive measured positions whose ramps give every phase the same share (a
plateau, or the overlap of a wide ramp), the curves differ by the phases' gains, which change
slowly, and by ``c``. Fitting the middle curve as ``o + g * (the neighbours' curves linearly
interpolated)`` over the readings above zero leaves ``o = c(p) - g * (linear interpolation of
c)``: one equation for ``c`` per such position. ``c`` is written as a Fourier series over the
cycle restricted to one fundamental and its multiples (a cogging torque repeats with one period,
the slot-pole period, and its harmonics), the fundamental being the single harmonic that fits
the equations best; multiples are added, and the fundamental itself kept, only while the
leave-one-out prediction error of the equations (PRESS) falls, so a motor without cogging gets
none. The correction is then ``c`` minus its linear interpolation between the measured
positions, added to the cells the interpolation filled.

This module never imports the simulator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: Fewest equations (positions between two others with the same ramp) for a fit.
MIN_EQUATIONS = 6
#: Fewest readings above zero a position and both its neighbours must share.
MIN_READINGS = 4
#: Tolerance on the ramp's shares.
SHARE_TOL = 1e-9


@dataclass(frozen=True, slots=True, eq=False)
class DetentFit:
    """The torque at rest fitted across the cycle.

    Attributes
    ----------
    harmonics
        Periods per cycle kept (the fundamental first); empty when none predicts.
    torque
        ``c(p)`` on every table position [N m], shape (P,) (zero when no harmonic is kept;
        defined up to a constant, which the correction does not use).
    equations
        Positions that gave an equation.
    """

    harmonics: tuple[int, ...]
    torque: NDArray[np.float64]
    equations: int


def _basis(p: NDArray[np.int64], harmonics: NDArray[np.int64], n: int) -> NDArray[np.float64]:
    angle = 2.0 * np.pi * np.outer(p, harmonics) / n
    return np.concatenate([np.cos(angle), np.sin(angle)], axis=1)


def _equations(
    mean: NDArray[np.float64], ramp: NDArray[np.float64], anchors: NDArray[np.int64]
) -> tuple[list[tuple[int, int, int, float, float]], list[float]]:
    """(left, middle, right, weight of left, gain) and offset for every usable middle anchor."""
    n = mean.shape[0]
    rows: list[tuple[int, int, int, float, float]] = []
    offsets: list[float] = []
    count = anchors.size
    for i in range(count):
        pl, pc, pr = int(anchors[i - 1]), int(anchors[i]), int(anchors[(i + 1) % count])
        if len({pl, pc, pr}) < 3:
            continue
        if np.any(np.abs(ramp[pl] - ramp[pc]) > SHARE_TOL) or np.any(
            np.abs(ramp[pr] - ramp[pc]) > SHARE_TOL
        ):
            continue
        ok = np.isfinite(mean[pl]) & np.isfinite(mean[pc]) & np.isfinite(mean[pr])
        ok &= (np.nan_to_num(mean[pl]) > 0) & (np.nan_to_num(mean[pc]) > 0)
        ok &= np.nan_to_num(mean[pr]) > 0
        if int(ok.sum()) < MIN_READINGS:
            continue
        left, right = (pc - pl) % n, (pr - pc) % n
        w = right / (left + right)
        ref = w * mean[pl, ok] + (1.0 - w) * mean[pr, ok]
        design = np.stack([np.ones(ref.size), ref], axis=1)
        (offset, gain), *_ = np.linalg.lstsq(design, mean[pc, ok], rcond=None)
        rows.append((pl, pc, pr, w, float(gain)))
        offsets.append(float(offset))
    return rows, offsets


def loo_press(
    design: NDArray[np.float64], target: NDArray[np.float64]
) -> tuple[float, NDArray[np.float64]]:
    """Leave-one-out prediction error of a least-squares fit, and its coefficients."""
    coef = np.asarray(np.linalg.lstsq(design, target, rcond=None)[0], dtype=np.float64)
    leverage = np.einsum("ij,ji->i", design, np.linalg.pinv(design))
    residual = target - design @ coef
    loo = residual / (1.0 - np.clip(leverage, 0.0, 0.999))
    return float(loo @ loo), coef


def fit_detent(
    mean: NDArray[np.float64], ramp: NDArray[np.float64], anchors: NDArray[np.int64]
) -> DetentFit:
    """Fit the torque at rest from the measured curves (module docstring).

    Parameters
    ----------
    mean
        Measured torque per (position, level) cell [N m], NaN where no data, shape (P, J).
    ramp
        The ramping function, shape (P, m).
    anchors
        The measured positions (the collection's targets), ascending.

    Returns
    -------
    DetentFit
        The harmonics kept and ``c(p)``.

    Examples
    --------
    Cogging of 6 periods per cycle on one phase's linear curves, measured every 4th position:

    >>> n, u = 64, np.arange(0.0, 256.0, 16.0)
    >>> p = np.arange(n)
    >>> c = 0.3 * np.sin(2 * np.pi * 6 * p / n + 0.4)
    >>> truth = (2.0 + np.cos(2 * np.pi * p / n))[:, None] * u / 255 + c[:, None] + 1.0
    >>> mean = np.full_like(truth, np.nan)
    >>> mean[::4] = truth[::4]
    >>> fit = fit_detent(mean, np.ones((n, 1)), np.arange(0, n, 4))
    >>> fit.harmonics, bool(np.abs(fit.torque - c).max() < 0.02)
    ((6,), True)
    """
    n = mean.shape[0]
    count = anchors.size
    top = (count - 1) // 2  # below half the number of measured positions
    if top < 1:
        return DetentFit((), np.zeros(n), 0)
    rows, offsets = _equations(mean, ramp, anchors)
    if len(rows) < MIN_EQUATIONS:
        return DetentFit((), np.zeros(n), len(rows))
    target = np.asarray(offsets)
    pl = np.array([r[0] for r in rows])
    pc = np.array([r[1] for r in rows])
    pr = np.array([r[2] for r in rows])
    w = np.array([r[3] for r in rows])[:, None]
    g = np.array([r[4] for r in rows])[:, None]

    def design(harmonics: list[int]) -> NDArray[np.float64]:
        h = np.asarray(harmonics, dtype=np.int64)
        out: NDArray[np.float64] = _basis(pc, h, n) - g * (
            w * _basis(pl, h, n) + (1.0 - w) * _basis(pr, h, n)
        )
        return out

    best_press = float(target @ target)  # nothing at rest
    kept: list[int] = []
    coef = np.zeros(0)
    while True:
        candidates = [
            h for h in range(1, top + 1) if h not in kept and (not kept or h % kept[0] == 0)
        ]
        if not candidates or 2 * (len(kept) + 1) + 2 > len(rows) // 2:
            break
        trials = []
        for h in candidates:
            d = design([*kept, h])
            sol, *_ = np.linalg.lstsq(d, target, rcond=None)
            r = target - d @ sol
            trials.append((float(r @ r), h))
        _, h = min(trials)
        press, sol = loo_press(design([*kept, h]), target)
        if not press < best_press:
            break
        best_press, coef = press, sol
        kept.append(h)
    if not kept:
        return DetentFit((), np.zeros(n), len(rows))
    torque = _basis(np.arange(n), np.asarray(kept, dtype=np.int64), n) @ coef
    return DetentFit(tuple(kept), np.asarray(torque, dtype=np.float64), len(rows))


def detent_correction(
    torque: NDArray[np.float64], anchors: NDArray[np.int64]
) -> NDArray[np.float64]:
    """``torque`` minus its linear interpolation between the measured positions (0 there).

    Parameters
    ----------
    torque
        ``c(p)`` on every table position, shape (P,).
    anchors
        The measured positions, ascending.

    Returns
    -------
    ndarray
        What the linear interpolation between measured positions misses, shape (P,).
    """
    n = torque.size
    ext = np.concatenate([anchors - n, anchors, anchors + n])
    linear = np.interp(np.arange(n), ext, np.tile(torque[anchors], 3))
    out: NDArray[np.float64] = torque - linear
    return out
