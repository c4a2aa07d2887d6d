"""Lines of a fixed TIME frequency among the PDTV lines picked from passes at several speeds.

PDTV is a function of the motor angle: at every steady speed its lines sit at the same orders
[CPR] with about the same amplitude. A ripple of the current at a fixed frequency ``f`` [Hz]
(a PWM or commutation artefact, mains hum, a fan) sits at order ``2 pi f / |v|`` of a pass at
speed ``v`` [rad/s]: at another speed it moves to another order. Picked from the passes'
position spectrum, such a ripple looks like a PDTV line, and a map built from it (anti-cogging
feed-forward) injects a torque the motor does not have. :func:`time_frequency_lines` fits the
picked orders to each speed level separately and names the orders that one level holds and
another, which resolves them as well, does not.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.pdtv import fit_harmonics

#: Speeds within this relative distance form one level.
LEVEL_TOLERANCE = 0.1
#: A line is absent at a level where its amplitude is below this share of its largest.
ABSENT_SHARE = 0.25
#: Standard errors by which the present and absent amplitudes must differ (a line of a
#: motor-angle torque fitted on two independent stretches differs by noise only).
SIGNIFICANCE_Z = 5.0


@dataclass(frozen=True, slots=True, eq=False)
class TimeLine:
    """A picked order that follows time, not the motor angle.

    Attributes
    ----------
    order
        The picked order [CPR].
    speed
        Motor speed [rad/s] of the level where it is present (the largest amplitude).
    frequency
        Its time frequency at that speed, ``order |speed| / (2 pi)`` [Hz].
    present, absent
        Its amplitude at that level and at the level where it is absent [signal unit].
    absent_speed
        Motor speed [rad/s] of the level where it is absent.
    """

    order: float
    speed: float
    frequency: float
    present: float
    absent: float
    absent_speed: float


def time_frequency_lines(
    motor_angle: ArrayLike,
    values: ArrayLike,
    *,
    orders: Sequence[float],
    groups: ArrayLike,
    speed: ArrayLike,
) -> tuple[TimeLine, ...]:
    """Orders present at one steady speed and absent at another: time-frequency lines.

    The samples are split by ``|speed|`` into levels (speeds within ``LEVEL_TOLERANCE`` of
    each other); at each level the ``orders`` are fitted jointly by least squares
    (:func:`torquemap.pdtv.fit_harmonics`, one offset per group). An order is a time line when
    at some level its amplitude is under ``ABSENT_SHARE`` of its largest and differs from it
    by more than ``SIGNIFICANCE_Z`` combined standard errors, and that level holds a line at the
    same time frequency (``order * v_present / v_absent`` CPR) of at least half the amplitude: a
    line of the motor angle can fade with speed, a ripple moves. With one level nothing can be
    told and nothing is returned.

    Parameters
    ----------
    motor_angle
        Motor angle [rad], shape (n,).
    values
        The signal the orders were picked from (torque less friction and inertia) [N m],
        shape (n,).
    orders
        The picked orders [CPR].
    groups
        Pass label per sample, shape (n,).
    speed
        The steady speed of each sample's pass [rad/s], shape (n,).

    Returns
    -------
    tuple of TimeLine
        One per time line, in the order of ``orders``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> v = np.repeat([2.0, 5.0], 20000)
    >>> t = np.concatenate([np.arange(20000) / 2000.0] * 2)
    >>> theta = v * t
    >>> y = 0.01 * np.cos(4 * theta) + 0.01 * np.cos(2 * np.pi * 50.0 * t)
    >>> y = y + rng.normal(0.0, 0.002, y.size)
    >>> found = time_frequency_lines(theta, y, orders=[4.0, 157.0], groups=v > 3, speed=v)
    >>> [(ln.order, round(ln.frequency, 1)) for ln in found]
    [(157.0, 50.0)]
    """
    theta = np.asarray(motor_angle, dtype=np.float64)
    y = np.asarray(values, dtype=np.float64)
    grp = np.asarray(groups)
    level_of, centres = _levels(np.abs(np.asarray(speed, dtype=np.float64)))
    if centres.size < 2 or not len(orders):
        return ()
    amp = np.full((centres.size, len(orders)), np.nan)
    se = np.full_like(amp, np.nan)
    for lv in range(centres.size):
        sel = level_of == lv
        if sel.sum() < 4 * len(orders) + 10:
            continue
        fit = fit_harmonics(theta[sel], y[sel], orders=list(orders), groups=grp[sel])
        amp[lv], se[lv] = fit.amplitude, fit.amplitude_se
    out: list[TimeLine] = []
    for i, order in enumerate(orders):
        a, s = amp[:, i], se[:, i]
        if not np.isfinite(a).sum() >= 2:
            continue
        hi = int(np.nanargmax(a))
        for lo in np.flatnonzero(np.isfinite(a)):
            gap = a[hi] - a[lo]
            if not (
                a[lo] < ABSENT_SHARE * a[hi] and gap > SIGNIFICANCE_Z * math.hypot(s[hi], s[lo])
            ):
                continue
            # a line of the motor angle can fade with speed too (the differentiator's window
            # smooths the acceleration that carries it at high frequency: random SCARA 7's
            # true 39 CPR line, 4.1 mN m at 6.75 rad/s, under a quarter at 10.1): a ripple
            # fixed in time must show at the absent level at its own frequency
            if _moved_there(
                theta,
                y,
                grp,
                level_of == lo,
                float(order) * centres[hi] / centres[lo],
                float(a[hi]),
            ):
                out.append(
                    TimeLine(
                        order=float(order),
                        speed=float(centres[hi]),
                        frequency=float(order) * float(centres[hi]) / (2.0 * math.pi),
                        present=float(a[hi]),
                        absent=float(a[lo]),
                        absent_speed=float(centres[lo]),
                    )
                )
                break
    return tuple(out)


def _moved_there(
    theta: NDArray[np.float64],
    y: NDArray[np.float64],
    grp: NDArray[Any],
    sel: NDArray[np.bool_],
    order: float,
    present: float,
) -> bool:
    """Whether the samples ``sel`` (one speed level) hold a line at ``order`` [CPR] of at least
    half the ``present`` amplitude, ``SIGNIFICANCE_Z`` standard errors clear of zero: where a
    time ripple seen at another speed lands. False when the order is beyond the level's
    position Nyquist (half its samples per revolution), where it cannot be told."""
    steps = np.abs(np.diff(theta[sel]))
    steps = steps[(steps > 0) & (steps < math.pi)]
    if steps.size == 0 or order >= math.pi / float(np.median(steps)):
        return False
    fit = fit_harmonics(theta[sel], y[sel], orders=[order], groups=grp[sel])
    amp, se = float(fit.amplitude[0]), float(fit.amplitude_se[0])
    return amp >= 0.5 * present and amp > SIGNIFICANCE_Z * se


def _levels(speed: NDArray[np.float64]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Level index per sample and the levels' median speeds: sorted distinct speeds merged
    while within ``LEVEL_TOLERANCE`` of the level's first."""
    distinct = np.unique(speed)
    starts = [0]
    for i in range(1, distinct.size):
        if distinct[i] > distinct[starts[-1]] * (1.0 + LEVEL_TOLERANCE):
            starts.append(i)
    edges = np.append(distinct[starts], np.inf)
    level_of = np.searchsorted(edges, speed, side="right") - 1
    centres = np.array(
        [float(np.median(speed[level_of == lv])) for lv in range(len(starts))], dtype=np.float64
    )
    return level_of.astype(np.int64), centres
