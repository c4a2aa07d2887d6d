"""A lag between an arm log's motor currents and its joint angles (new-user QA, docs/arm.md).

Identification and estimation take each row's columns as sampled at once. A drive whose current
(or torque) column lags its encoder by a few milliseconds (a current loop's filter, a bus that
polls the currents a cycle late) breaks that silently: on a simulated UR3 a 5 ms lag left the
identification's fit and warnings as they were and raised the force error 3-8 times (0.095 /
0.33 / 0.081 N to 0.77 / 1.07 / 0.14 N, 84 % of fy's errors within 2 sigma); a 30 ms lag was
refused as "friction negative in both directions: check the robot file's gravity, gear ratios
and torque constants", the wrong cause.

:func:`current_lag` refits the identification's linear regression with the smoothed motor
torques read a shift later (or earlier) than the angles, over a grid of shifts, and returns the
shift that fits best and the share of the residual it removes.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from torquemap.arm_model import ArmSignals

#: Shifts tried [s]: the current read this much later than the angles (a lag), or earlier.
LAG_GRID = (0.0, 0.001, 0.002, 0.004, 0.007, 0.01, 0.015, 0.02, 0.03, 0.04, 0.05)
#: A lag is reported when its shift removes at least this share of the weighted residual's
#: sum of squares, and :data:`LAG_SIGNIFICANCE` of it in units of the rows' weights (which
#: count the independent samples: a chi-square of one degree of freedom if there were no
#: lag), and it is at least :data:`LAG_MIN` and 2 sampling intervals.
LAG_GAIN = 0.02
LAG_SIGNIFICANCE = 100.0
#: The smallest lag reported [s].
LAG_MIN = 0.002


def shifted_torques(
    signals: Sequence[ArmSignals],
    picks: Sequence[NDArray[np.intp]],
    shift: float,
    smoothed: Sequence[NDArray[np.float64]] | None = None,
) -> NDArray[np.float64]:
    """The smoothed motor torques (m, nj) read ``shift`` [s] after each picked sample's time
    (linear interpolation; held at the ends of each log). ``smoothed``: each log's smoothed
    motor torques, when already computed."""
    out = []
    for i, (sig, idx) in enumerate(zip(signals, picks, strict=True)):
        smooth = sig.smooth(sig.motor_torque) if smoothed is None else smoothed[i]
        at = sig.t[idx] + shift
        out.append(
            np.column_stack([np.interp(at, sig.t, smooth[:, k]) for k in range(smooth.shape[1])])
        )
    return np.concatenate(out, axis=0)


def current_lag(
    signals: Sequence[ArmSignals],
    picks: Sequence[NDArray[np.intp]],
    residual_for: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    weight: NDArray[np.float64],
) -> tuple[float, float, float]:
    """The lag [s] of the motor torques behind the angles that fits best, the share of the
    weighted residual sum of squares it removes against no shift (0 when none helps), and
    the sum it removes (in the weights' units).

    Parameters
    ----------
    signals, picks
        The identification's differentiated logs and the rows it regresses on.
    residual_for
        The regression's residual (m, nj) [N m, motor side] for given motor torques (m, nj).
    weight
        Per joint, the weight of its rows [1/(N m)^2].

    Notes
    -----
    Shifts of :data:`LAG_GRID` both ways (the torque read later: a lag; earlier: a lead),
    refined by a parabola through the best and its neighbours.
    """
    shifts = sorted({s * sign for s in LAG_GRID for sign in (1.0, -1.0)})
    smoothed = [sig.smooth(sig.motor_torque) for sig in signals]

    def cost(shift: float) -> float:
        r = residual_for(shifted_torques(signals, picks, shift, smoothed))
        return float(np.sum(weight * np.sum(r**2, axis=0)))

    costs = [cost(s) for s in shifts]
    zero = costs[shifts.index(0.0)]
    best = int(np.argmin(costs))
    lag, low = shifts[best], costs[best]
    if 0 < best < len(shifts) - 1:
        x0, x1, x2 = shifts[best - 1 : best + 2]
        c0, c1, c2 = costs[best - 1 : best + 2]
        # the vertex of the parabola through the three points
        den = (x0 - x1) * (x0 - x2) * (x1 - x2)
        a = (x2 * (c1 - c0) + x1 * (c0 - c2) + x0 * (c2 - c1)) / den
        b = (x2**2 * (c0 - c1) + x1**2 * (c2 - c0) + x0**2 * (c1 - c2)) / den
        if a > 0:
            vertex = -b / (2.0 * a)
            if x0 < vertex < x2:
                c = cost(vertex)
                if c < low:
                    lag, low = vertex, c
    gain = 1.0 - low / zero if zero > 0 else 0.0
    return float(lag), float(max(gain, 0.0)), float(max(zero - low, 0.0))


def lag_message(lag: float, gain: float, removed: float, dt: float) -> str | None:
    """The warning for a lag :func:`current_lag` found (``lag``, ``gain``, ``removed``), or
    None below the thresholds; ``dt`` is the logs' sampling interval [s]."""
    if gain < LAG_GAIN or removed < LAG_SIGNIFICANCE or abs(lag) < max(LAG_MIN, 2.0 * dt):
        return None
    way = "lag" if lag > 0 else "lead"
    return (
        f"the logs' motor currents (or torques) {way} their joint angles by about "
        f"{abs(lag) * 1e3:.0f} ms (read {abs(lag) * 1e3:.0f} ms {'later' if lag > 0 else 'earlier'}"
        f", the model fits {gain:.0%} better): torquemap takes a row's columns as sampled at "
        "once; align them (a current loop's filter, a bus polling late), or the model and the "
        "forces carry the lag's error"
    )
