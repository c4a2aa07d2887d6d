"""A log's joint angles against the URDF's limits: a log in degrees (or mm) is refused.

An arm's log holds joint angles in rad (m for a prismatic joint), or encoder counts or turns
that the robot file converts. A log written in degrees reads 57 times too far and too fast:
on a simulated 6-axis arm, ``estimate`` answered a degree task log with a median force of
319 N against the true 12 N (exit 0, warned only as poses and speeds beyond the
identification's), and ``identify`` refused it blaming gravity, gear ratios or another
robot's log (new-user QA, docs/arm.md). The URDF's limits tell: a joint can be a turn off
(an encoder's zero a turn away), not many widths of its range beyond them.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray


def angles_beyond_limits(q: NDArray[np.float64], arm: Any) -> str | None:
    """What is wrong when some joint's angles leave its URDF limits by more than the range's
    width plus a turn (``2 pi`` for a revolute joint; the width alone for a prismatic one),
    else None.

    Parameters
    ----------
    q
        Joint positions [rad or m], shape (n, nj), the arm's joint order.
    arm
        The arm (:class:`torquemap.robots.urdf.UrdfArm`: ``position_limits``,
        ``angle_period``, ``joint_names``); None for an arm without limits.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> arm = SimpleNamespace(position_limits=(np.array([-1.0]), np.array([1.0])),
    ...                       angle_period=np.array([2 * np.pi]), joint_names=("elbow",))
    >>> angles_beyond_limits(np.array([[0.5], [-0.9]]), arm) is None
    True
    >>> print(angles_beyond_limits(np.degrees(np.array([[0.5], [-0.9]])), arm))
    joint elbow: q_elbow reaches -51.6 rad, beyond its URDF limits [-1, 1] rad by more than
    their width and a turn: is the log in degrees? q_<j> must be in rad (or encoder counts or
    turns: position_unit in the robot file)
    """
    limits = getattr(arm, "position_limits", None)
    if limits is None or q.size == 0:
        return None
    lo, hi = (np.asarray(v, dtype=float) for v in limits)
    period = np.asarray(getattr(arm, "angle_period", np.full(lo.size, np.inf)), dtype=float)
    low, high = np.min(q, axis=0), np.max(q, axis=0)
    for k, name in enumerate(arm.joint_names):
        if not (math.isfinite(lo[k]) and math.isfinite(hi[k]) and hi[k] > lo[k]):
            continue
        width = hi[k] - lo[k]
        turn = period[k] if math.isfinite(period[k]) else 0.0
        beyond = max(lo[k] - low[k], high[k] - hi[k])
        if beyond > width + turn:
            worst = low[k] if lo[k] - low[k] >= high[k] - hi[k] else high[k]
            unit = "rad" if math.isfinite(period[k]) else "m"
            guess = "degrees" if unit == "rad" else "mm"
            return (
                f"joint {name}: q_{name} reaches {worst:.3g} {unit}, beyond its URDF limits "
                f"[{lo[k]:.3g}, {hi[k]:.3g}] {unit} by more than their width"
                f"{' and a turn' if turn else ''}: is the log in {guess}? q_<j> must be in "
                f"{unit} (or encoder counts or turns: position_unit in the robot file)"
            )
    return None
