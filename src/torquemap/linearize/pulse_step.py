"""Is the pulse width sampled finely enough? The knee between two measured pulse widths.

The collection measures every ``h``-th pulse width (the paper: every 4th). Between two measured
pulse widths the tables follow the rows' interpolation; where the torque law bends (the knee,
where the torque overcomes the dead zone and the friction) the truth leaves that line. A kink
inside a step of ``h`` pulse widths, with the torque rising ``s`` N m per pulse width above it,
is missed by up to ``s h / 4`` (at a quarter of the step: ``s h f (1 - f)``, largest at
``f = 1/2``). The tables themselves resolve no better than one entry: one pulse width's torque
``s`` or one command count's ``torque_per_count``, whichever is larger. The check warns when the
knee's miss exceeds twice that resolution, and names the coarsest step that keeps within it:
``h <= 8 max(s, torque_per_count) / s``.

Both ``s`` (the steepest rise per pulse width of each sweep, median over the sweeps) and ``h``
(the median step between consecutive measured pulse widths) are read from the data. On the
random family ``simulate rig --random 0..19`` (docs/linearize.md) the paper's step of 4 stays
silent everywhere; a step of 64 on rig 5 (verification APMD 18.0 % against 5.9 % at step 4)
warns.

This module never imports the simulator.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from torquemap.linearize.sampling import _nth

#: The knee's miss, in units of the tables' resolution, above which the step is named.
RESOLUTIONS = 2.0


def pulse_step_advice(pulse_width: ArrayLike, torque: ArrayLike, torque_per_count: float) -> str:
    """One line when the collection's pulse-width step is too coarse for the tables to hold the
    torque law near the knee (module docstring), else "".

    Parameters
    ----------
    pulse_width
        The rows' pulse widths in collection order, shape (n,); each sweep (one target
        position) a run of increasing pulse widths.
    torque
        The rows' torques [N m], shape (n,).
    torque_per_count
        The tables' torque per command count [N m].

    Examples
    --------
    >>> pw = np.tile(np.arange(0, 256, 64.0), 8)
    >>> tau = np.maximum(0.0, pw - 40.0) * 0.05  # knee at 40, 0.05 N m a pulse width
    >>> pulse_step_advice(pw, tau, 0.05)[:46]
    'the collection measured every 64th pulse width'
    >>> pw = np.tile(np.arange(0, 256, 4.0), 8)
    >>> pulse_step_advice(pw, np.maximum(0.0, pw - 40.0) * 0.05, 0.05)
    ''
    """
    pw = np.asarray(pulse_width, dtype=np.float64)
    tau = np.asarray(torque, dtype=np.float64)
    if pw.size < 3 or not torque_per_count > 0:
        return ""
    starts = np.flatnonzero(np.r_[True, np.diff(pw) <= 0])
    ends = np.r_[starts[1:], pw.size]
    steps: list[float] = []
    rises: list[float] = []
    for a, b in zip(starts, ends, strict=True):
        if b - a < 3:
            continue
        dw = np.diff(pw[a:b])
        steps.extend(dw.tolist())
        rises.append(float(np.max(np.diff(tau[a:b]) / dw)))
    if not rises:
        return ""
    h = float(np.median(steps))
    s = float(np.median(rises))
    if not (s > 0 and h > 1):
        return ""
    resolution = max(s, torque_per_count)
    miss = s * h / 4.0
    if miss <= RESOLUTIONS * resolution:
        return ""
    finest = max(1, math.floor(4.0 * RESOLUTIONS * resolution / s))
    return (
        f"the collection measured every {_nth(round(h))} pulse width: near the knee (where the torque "
        f"overcomes the dead zone and friction) the tables may miss the torque law by up to "
        f"{miss:.3g} N m between measured pulse widths ({s:.3g} N m a pulse width times "
        f"{h:g} / 4), {miss / resolution:.1f} times their resolution ({resolution:.3g} N m); "
        f"collect every {_nth(finest)} pulse width or finer (--pulse-step {finest})"
    )


def pulse_step_advice_rows(
    position: ArrayLike, pulse_width: ArrayLike, torque: ArrayLike, torque_per_count: float
) -> str:
    """:func:`pulse_step_advice` on rows in any order.

    :func:`pulse_step_advice` reads the sweeps from the collection's row order. A DATA.csv whose
    rows were reordered (sorted or shuffled in a spreadsheet: QA stop 36) breaks the sweeps
    into runs across positions, and the line named "every 56th pulse width" of a collection
    that measured every 4th. When fewer than half the runs of increasing pulse widths start at
    the smallest one (a collection's sweeps all do), the rows are taken by position, then pulse
    width, each position's rows one sweep.

    Parameters
    ----------
    position
        The rows' table positions, shape (n,).
    pulse_width, torque, torque_per_count
        As for :func:`pulse_step_advice`.

    Examples
    --------
    >>> pos = np.repeat(np.arange(8), 64)
    >>> pw = np.tile(np.arange(0, 256, 4.0), 8)
    >>> tau = np.maximum(0.0, pw - 40.0) * 0.05
    >>> order = np.random.default_rng(0).permutation(pw.size)
    >>> pulse_step_advice(pw[order], tau[order], 0.05)[:46]
    'the collection measured every 50th pulse width'
    >>> pulse_step_advice_rows(pos[order], pw[order], tau[order], 0.05)
    ''
    """
    pos = np.asarray(position)
    pw = np.asarray(pulse_width, dtype=np.float64)
    tau = np.asarray(torque, dtype=np.float64)
    if pw.size == 0:
        return ""
    starts = np.flatnonzero(np.r_[True, np.diff(pw) <= 0])
    if np.mean(pw[starts] == pw.min()) < 0.5:
        order = np.lexsort((pw, pos))
        pw, tau = pw[order], tau[order]
    return pulse_step_advice(pw, tau, torque_per_count)


__all__ = ["RESOLUTIONS", "pulse_step_advice", "pulse_step_advice_rows"]
