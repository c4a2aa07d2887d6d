"""Which servo ticks a simulated log keeps (:class:`torquemap.sim.scara.Logging`).

A controller's own log keeps every tick; a host that polls the drive gets a jittered subset at
its own rate, loses stretches of it (a busy bus, a dropped USB frame), and receives the current
some time after the position it is stored with.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from torquemap.sim.scara import Logging


def logged_ticks(
    ticks: int, servo_rate: float, logging: Logging, rng: np.random.Generator
) -> NDArray[np.int64]:
    """Indices of the servo ticks a log keeps, strictly increasing.

    Parameters
    ----------
    ticks
        Number of servo ticks of the run.
    servo_rate
        [Hz].
    logging
        The logger's settings.
    rng
        Source of the jitter and of the gaps' lengths and places (not drawn from when
        ``logging`` keeps every tick).

    Returns
    -------
    NDArray[np.int64]
        Tick indices; the first and last tick are always kept.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> logged_ticks(9, 4.0, Logging(rate=2.0), rng).tolist()
    [0, 2, 4, 6, 8]
    """
    if logging.rate is None and logging.gaps == 0:
        return np.arange(ticks, dtype=np.int64)
    duration = (ticks - 1) / servo_rate
    polls: NDArray[np.float64]
    if logging.rate is None:
        polls = np.arange(ticks) / servo_rate
    else:
        count = math.floor(duration * logging.rate + 1e-9) + 1
        polls = np.arange(count, dtype=np.float64)
        if logging.jitter:
            polls += rng.uniform(-logging.jitter, logging.jitter, size=count)
        polls /= logging.rate
    idx = np.unique(np.clip(np.rint(polls * servo_rate), 0, ticks - 1).astype(np.int64))
    t = idx / servo_rate
    keep = np.ones(idx.size, dtype=bool)
    lo, hi = logging.gap_durations
    for _ in range(logging.gaps):
        length = float(rng.uniform(lo, hi))
        if duration <= 2 * length:
            continue
        start = float(rng.uniform(0.5 * length, duration - 1.5 * length))
        keep &= (t < start) | (t >= start + length)
    keep[0] = keep[-1] = True
    out: NDArray[np.int64] = idx[keep]
    return out


def delayed_ticks(ticks: NDArray[np.int64], servo_rate: float, delay: float) -> NDArray[np.int64]:
    """The tick whose current a sample at each of ``ticks`` holds, ``delay`` [s] earlier.

    Rounded to whole ticks and clipped at the first (the run starts at rest).

    Examples
    --------
    >>> delayed_ticks(np.array([0, 5, 10]), 1000.0, 0.004).tolist()
    [0, 1, 6]
    """
    shift = round(delay * servo_rate)
    out: NDArray[np.int64] = np.maximum(ticks - shift, 0)
    return out
