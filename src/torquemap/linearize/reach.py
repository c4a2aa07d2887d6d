"""Positions where the forward model reaches no torque: what the refusal says (QA stop 36).

The builder refuses a position where the largest torque of the filled forward model is below
the noise floor: no positive command could be met there. Two motors other than the family's
reached it with a line that did not say why (docs/linearize.md, "New-user QA, stop 36"):

* **No model at all** at a position: no rows were read there, and its neighbours' rows share no
  pulse width to interpolate between (with few positions per cycle the rig's compliance moves a
  block's higher pulse widths to the next position: 6 positions per cycle, every 4th collected,
  left position 0 with pulse widths 0 .. 96 and position 4 with 132 .. 255). The line read
  ``largest -inf N m``.
* **A stretch of the cycle where no phase pushes the positive way**: a motor file that lists a
  winding driven both ways as one phase (a two-phase bipolar stepper given as 2 phases: its
  pulse widths drive each winding one way only, which covers three quarters of the cycle), or
  phases wired in another order than the motor file's (a stepper's four phases one place round:
  half of every phase's stretch without torque). The line named the first such position alone;
  it now lists them and asks about both.

This module never imports the simulator.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def _runs(positions: np.ndarray, n: int) -> str:
    """``"56 .. 15, 30"``: runs of consecutive positions, a run through ``P - 1`` and 0 as one."""
    runs: list[list[int]] = []
    for p in positions.tolist():
        if runs and p == runs[-1][1] + 1:
            runs[-1][1] = p
        else:
            runs.append([p, p])
    if len(runs) > 1 and runs[0][0] == 0 and runs[-1][1] == n - 1:
        runs[0][0] = runs.pop()[0]  # the cycle wraps
    out = [f"{a} .. {b}" if a != b else f"{a}" for a, b in runs]
    return ", ".join(out[:4]) + (", ..." if len(out) > 4 else "")


def unreachable_message(reach: ArrayLike, floor: float, *, phases: int) -> str:
    """The refusal for positions where no torque is reachable, or "" when there are none.

    Parameters
    ----------
    reach
        Largest torque of the filled forward model per table position [N m], shape (P,);
        ``-inf`` (or NaN) where the model holds nothing.
    floor
        The noise floor [N m].
    phases
        The motor file's phases ``m``.

    Returns
    -------
    str
        One line: the first position without a model and why; else the positions without
        torque, with the motor-file hint when they span at least ``P / (4 m)`` positions.

    Examples
    --------
    >>> reach = np.full(64, 1.0); reach[:16] = 0.01
    >>> unreachable_message(reach, 0.05, phases=2)[:63]
    'no torque is reachable at positions 0 .. 15 (16 of 64 positions'
    >>> reach = np.full(6, 1.0); reach[5] = -np.inf
    >>> unreachable_message(reach, 0.05, phases=3)[:52]
    'no torque can be estimated at position 5: no rows we'
    >>> unreachable_message(np.ones(8), 0.05, phases=1)
    ''
    """
    r = np.asarray(reach, dtype=np.float64)
    n = r.size
    empty = ~np.isfinite(r)
    if empty.any():
        p = int(np.argmax(empty))
        more = int(empty.sum()) - 1
        return (
            f"no torque can be estimated at position {p}"
            + (f" (and {more} more)" if more else "")
            + ": no rows were read there and its neighbours' rows share no pulse width to "
            f"interpolate between (with {n} positions per cycle the rig's compliance can move a "
            "block's higher pulse widths to the next position); collect every position "
            "(--position-step 1)"
        )
    bad = np.flatnonzero(r <= floor)
    if bad.size == 0:
        return ""
    p = int(bad[0])
    if bad.size == 1:
        return (
            f"no torque is reachable at position {p} (largest {r[p]:.3g} N m; noise floor "
            f"{floor:.3g} N m)"
        )
    line = (
        f"no torque is reachable at positions {_runs(bad, n)} ({bad.size} of {n} positions; "
        f"the largest there {float(r[bad].max()):.3g} N m, noise floor {floor:.3g} N m)"
    )
    if bad.size >= n / (4.0 * phases):
        line += (
            ": no phase the ramp energises there pushes the positive way. Are the phases wired "
            "in the motor file's order (the ramp energises phase k over the k-th m-th of the "
            "cycle, phases 1 .. m in the positive direction), and is each direction of a "
            "winding driven both ways a phase of its own (a two-phase bipolar stepper: four "
            "phases, A+ B+ A- B-)?"
        )
    return line
