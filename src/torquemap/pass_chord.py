"""How far a friction table departs from the chord between the steady passes around a speed.

A whole-log fit (:mod:`torquemap.identify_whole`) reads a joint's friction at its sweep's steady
pass speeds; between two passes the sweep crosses the speeds only on its ramps, so the table's
shape there is set by the ramps' rows (their inertia and delay misfit included), the passes'
speed ripple and the smoothness prior. The chord in log speed between the dry levels at the two
passes fits the same steady rows; where the table departs from it, that departure is uncertain
by its own size (as :func:`torquemap.uncertainty.extrapolation_spread` takes the table's
departure from a flat continuation below the slowest pass). Random robot 453 joint a, passes
at 0.45, 4.3 and 37.6 rad/s: the table rises 0.010 N m (motor side) above the chord at 7.6
rad/s where the true law is flat, and the parameters' covariance there says 0.002
(docs/estimation.md, "Stop 44 (F69)").
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray


def chord_spread(
    law: Any,
    velocity: NDArray[np.float64],
    width: float,
    pass_speeds: Sequence[float],
    *,
    chords: Literal["dry", "both"] = "dry",
) -> NDArray[np.float64]:
    """Departure [N m] of a speed table's dry friction from the chord between passes.

    Per direction, with ``S_a < |v| < S_b`` the two passes of that direction (signed
    ``pass_speeds`` [rad/s]) around the speed, ``|d(s) - c(s)|``: ``d`` the table's dry level
    (its level less the viscous term), ``c`` the straight line in ``log s`` between ``d(S_a)``
    and ``d(S_b)``; each direction weighted by its share ``p = (1 + tanh(v / width)) / 2``.
    Zero at a pass, below the slowest and above the fastest pass of the direction (those are
    extrapolations, not between passes), and for a law without ``levels`` (not a table).
    ``chords="both"``: the larger of that departure and the whole level's (viscous term
    included) from its own chord in ``log s``, two interpolations that fit the passes alike
    (the table interpolates the dry level in ``log s`` and adds a viscous term linear in ``s``).


    Examples
    --------
    >>> from torquemap.friction_law import SpeedTableFriction
    >>> f = SpeedTableFriction(speeds=(1.0, 2.0, 4.0), positive=(0.2, 0.25, 0.2),
    ...                        negative=(0.2, 0.2, 0.2), viscous=0.01, zero_velocity=0.01)
    >>> chord_spread(f, np.array([2.0, -2.0, 4.0, 8.0]), 0.01, [1.0, 4.0, -1.0, -4.0]).round(6)
    array([0.05, 0.  , 0.  , 0.  ])
    """
    v = np.asarray(velocity, dtype=np.float64)
    out = np.zeros(v.shape)
    levels = getattr(law, "levels", None)
    speeds = getattr(law, "speeds", None)
    if not callable(levels) or speeds is None:
        return out
    knots = np.log(np.asarray(speeds, dtype=np.float64))
    p = 0.5 * (1.0 + np.tanh(v / max(width, 1e-12)))
    x = np.log(np.maximum(np.abs(v), 1e-300))
    for dry, viscous, sign, share in (
        (np.asarray(law.positive, dtype=np.float64), float(law.viscous), 1.0, p),
        (np.asarray(law.negative, dtype=np.float64), float(law.viscous_negative), -1.0, 1.0 - p),
    ):
        anchors = sorted(
            {
                math.log(abs(float(s)))
                for s in pass_speeds
                if math.isfinite(float(s)) and float(s) * sign > 0
            }
        )
        if len(anchors) < 2:
            continue
        xa = np.asarray(anchors)
        inside = (x > xa[0]) & (x < xa[-1])
        if not inside.any():
            continue
        here = np.interp(x[inside], knots, dry)
        departure = np.abs(here - np.interp(x[inside], xa, np.interp(xa, knots, dry)))
        if chords == "both":
            whole = np.interp(xa, knots, dry) + viscous * np.exp(xa)
            line = np.interp(x[inside], xa, whole)
            level = here + viscous * np.exp(x[inside])
            departure = np.maximum(departure, np.abs(level - line))
        out[inside] += share[inside] * departure
    return out
