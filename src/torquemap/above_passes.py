"""The friction table above a direction's fastest pass that holds its speed.

A sweep's fastest passes may be too short for the joint to settle: random robot 479 joint b,
commanded to 120 rad/s over 4.6 motor revolutions, runs 24 -> 185 -> 58 rad/s in 0.24 s (18 %
of the pass within 25 % of its mean speed), and two other moves of 0.1-0.2 s count as passes at
+23.7 and +84 rad/s (8 and 14 %). Above the fastest steady pass (29.6 rad/s) the whole-log fit
(:mod:`torquemap.identify_whole`) then reads friction only from such transients, where the
inertial torque is 7-10 times the friction and the motion lasts about one torque-channel delay:
the table there follows the delay at the millisecond level (0.9 ms off the truth: +53 % at 84
rad/s; over the delay's 95 % interval of 73-96 ms: -100 % to +596 %), which its parameter
covariance, conditional on the delay, does not carry.

Above its Stribeck region friction is Coulomb plus viscous, linear in speed. So, like the table
between two passes far apart (:mod:`torquemap.between_passes`), the knots above the fastest pass
that holds its speed are redrawn: continued from that pass's knot by the secant in speed of the
two fastest such passes (>= 0). The whole fit takes the mean of the redrawn and the fitted
knots, and their difference enters the covariance (``identify_whole.REDRAWN_WEIGHT``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from torquemap.between_passes import anchor_knots
from torquemap.friction_law import SpeedTableFriction

__all__ = ["HOLD_SHARE", "HOLD_TOLERANCE", "hold_share", "redraw_above"]

#: Relative distance from a pass's mean speed within which a sample holds the speed.
HOLD_TOLERANCE = 0.25
#: Least share of a pass's samples that hold its speed for the pass to anchor the table above it
#: (random family 461-480: steady passes 76-100 %, stick-slip passes 16-65 %, the transients of
#: robot 479 8-19 %; a stick-slip pass is slow, never the fastest, so the rule does not touch it
#: where it acts).
HOLD_SHARE = 0.5


def hold_share(velocity: ArrayLike, speed: float, tolerance: float = HOLD_TOLERANCE) -> float:
    """Share of a pass's samples whose velocity lies within ``tolerance`` (relative) of the
    pass's mean ``speed`` [rad/s, signed].

    Parameters
    ----------
    velocity
        Motor velocity over the pass [rad/s], shape (n,).
    speed
        The pass's mean speed [rad/s], signed, nonzero.
    tolerance
        Relative distance [-].

    Returns
    -------
    float
        The share in [0, 1]; 0 for an empty pass or a zero speed.

    Examples
    --------
    >>> hold_share([1.0, 1.1, 0.7, 2.0], 1.0)
    0.5
    """
    v = np.asarray(velocity, dtype=np.float64)
    if v.size == 0 or not (math.isfinite(speed) and speed != 0.0):
        return 0.0
    return float(np.mean(np.abs(v / speed - 1.0) <= tolerance))


def redraw_above(law: SpeedTableFriction, anchors: Sequence[float]) -> SpeedTableFriction:
    """``law`` with each direction's knots above the knot of its fastest anchor redrawn along
    the secant in speed of its two fastest anchor knots (>= 0).

    Parameters
    ----------
    law
        The table.
    anchors
        Signed motor speeds [rad/s] of the passes that hold their speed; a direction with fewer
        than two anchor knots (:func:`torquemap.between_passes.anchor_knots`) is kept as it is.

    Returns
    -------
    SpeedTableFriction
        The table; the viscous coefficients kept, the magnitude ``level + viscous * s`` redrawn.

    Examples
    --------
    >>> law = SpeedTableFriction(speeds=(1.0, 2.0, 4.0, 8.0), positive=(1.0, 1.2, 1.6, 9.0),
    ...                          negative=(1.0, 1.2, 1.6, 9.0))
    >>> out = redraw_above(law, [2.0, 4.0, -1.0, -2.0, -4.0, -8.0])
    >>> [round(x, 6) for x in out.positive], out.negative == law.negative
    ([1.0, 1.2, 1.6, 2.4], True)
    """
    s = np.asarray(law.speeds, dtype=np.float64)
    signed = [float(x) for x in anchors if math.isfinite(x) and x]
    new = []
    parts = ((1.0, law.positive, law.viscous), (-1.0, law.negative, law.viscous_negative))
    for sign, levels, viscous in parts:
        g = np.asarray(levels, dtype=np.float64) + viscous * s
        idx = anchor_knots(law.speeds, [sign * x for x in signed if sign * x > 0])
        if idx.size >= 2:
            i, j = int(idx[-2]), int(idx[-1])
            c = max(0.0, (g[j] - g[i]) / (s[j] - s[i]))
            g[j + 1 :] = g[j] + c * (s[j + 1 :] - s[j])
        new.append(g - viscous * s)
    return law.with_linear_parameters(np.r_[new[0], new[1], law.viscous, law.viscous_negative])
