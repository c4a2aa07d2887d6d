"""Does a task log's torque channel lag its position as the identification logs' did?

The whole-log identification finds each joint's torque channel delay (current-loop latency,
a host's polling, a bus) with an interval (``[identification.joints.<j>]
channel_delay_interval``), and ``estimate`` undoes that delay on the task log. A task logged
through another path than the no-load sweeps (the sweeps from the drive's own buffer, the task
over USB or ROS, or the reverse) lags by another delay, and the forces are off by the model's
inertia and friction torques moved in time, with no flag and sigmas that do not cover it (a
random SCARA of the family with the sweeps' delay 0.09 s and the task's 0.2 s: 13.7 % of the
spring force against 0.9 % with its own model, 47 % of the errors within 2 sigma).

The task log says which delay it has: the estimator keeps the external torque below its
cut-off and takes what lies above it for the model's misfit, and a torque shifted against the
motion it answers adds to that misfit in proportion to the motion's acceleration and friction
reversals. :func:`task_delay_warnings` scans the delay on a grid about the model's and compares
the misfit above the cut-off at the model's delay with its least.

The same scan tells a task log whose current's sign is flipped against the identification
logs' (a drive, a wiring or a logger that reverses one joint): above the cut-off the torque is
then the model's negated, which the misfit with the torque negated shows. Before, such a log
gave forces off by twice the model's torque (167.6 % of the spring on a random SCARA of the
family), exit 0 and no word.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from torquemap.io import Log
from torquemap.model import Model, pdtv_torque

#: Half width [s] of the scanned delays about the model's (the identification's own search
#: bound, :func:`torquemap.delay.find_delay`'s ``max_delay``).
SPAN = 0.25

#: Step [s] of the scanned delays.
STEP = 0.01

#: At most this many samples (the middle of the log) are scanned: the check's cost stays
#: bounded on long logs.
MAX_SAMPLES = 200_000

#: The misfit above the cut-off at the model's delay must be at least this many times its
#: least over the scan: half of it or more is the delay's.
COST_RATIO = 2.0


def delay_intervals(model: Model) -> dict[str, tuple[float, float, float]]:
    """Per joint, ``(delay, low, high)`` [s]: the delay identification found and its interval
    (joints whose notes lack either are left out)."""
    out: dict[str, tuple[float, float, float]] = {}
    joints = model.notes.get("joints", {})
    if not isinstance(joints, Mapping):
        return out
    for name, entry in joints.items():
        if not isinstance(entry, Mapping):
            continue
        d = entry.get("channel_delay")
        iv = entry.get("channel_delay_interval")
        if not isinstance(d, int | float) or not isinstance(iv, list | tuple) or len(iv) != 2:
            continue
        lo, hi = (float(x) if isinstance(x, int | float) else math.nan for x in iv)
        if all(math.isfinite(x) for x in (d, lo, hi)) and lo <= hi:
            out[str(name)] = (float(d), lo, hi)
    return out


def _high_band(
    t: NDArray[np.float64], x: NDArray[np.float64], cutoff: float
) -> NDArray[np.float64]:
    from torquemap.filters import lowpass

    return x - lowpass(t, x, cutoff=cutoff)


def task_delay_warnings(
    model: Model,
    log: Log,
    *,
    window: float,
    cutoff: float,
    rates: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None = None,
    channel_delay: Mapping[str, float] | None = None,
) -> list[str]:
    """One line per joint whose task log lags by another delay than identification found.

    For each joint with an identified delay ``d0`` and interval ``[lo, hi]``, the torque
    channel is shifted by each delay of a grid of ``STEP`` over ``d0 +- SPAN``; the model's
    no-load torque (inertia, friction, PDTV) is subtracted and the mean square of what lies
    above the ``cutoff`` (the estimator's own band for misfit) is taken over the log less
    ``1 / cutoff`` at each end (the high-pass is applied once to the torque and once to the
    model's torque, and the filtered torque shifted: a filter commutes with a shift). A line is written where the least lies at a delay ``d`` outside
    ``[lo - w, hi + w]`` (``w = hi - lo``: twice the interval's reach) and the misfit at ``d0``
    is at least ``COST_RATIO`` times that least. A joint whose least misfit with the torque
    negated is ``COST_RATIO`` times below the least without gets a line saying its current's
    sign is flipped instead (checked on every joint, with or without an interval; the scan is
    then about the model's delay, or 0). With ``channel_delay`` (the user's delays, which the
    estimate undoes instead of the model's) only the sign is checked, the scan about those
    delays.

    Parameters
    ----------
    model
        The model (its notes give the delays; a model without them gets no delay line, only
        the sign check).
    log
        One piece of the task log without gaps (sanitised); its middle ``MAX_SAMPLES`` are
        used.
    window
        Differentiator window [s].
    cutoff
        The estimate's low-pass cut-off [Hz].
    rates
        ``(velocity, acceleration, modulation)``, each shape (n, nj): the motor velocity
        [rad/s] and acceleration [rad/s^2] differentiated with ``window`` over the whole
        ``log``, and the arm's inertia modulation [-] at ``log.q``, when the caller has them
        (the estimate's own, :func:`torquemap.estimate._signal`). Taken where the scan covers
        the whole log (at most ``MAX_SAMPLES`` samples): the same numbers as without them, no
        differentiation. A longer log's middle is differentiated on its own, as without them.
    channel_delay
        Delay [s] per joint name given by the user (``estimate --channel-delay``), undone by
        the estimate instead of the model's (a joint not named: none): the sign check's scan
        is centred there and no delay line is written.

    Returns
    -------
    list of str
        The warnings (empty when the delays and signs agree, or the log is too short to tell).
    """
    from torquemap.delay import shift_channel
    from torquemap.estimate import _signal, identified_delays

    intervals = delay_intervals(model)
    # the delays the estimate undoes: the model's, or the user's (a joint not named: none)
    undone = identified_delays(model) if channel_delay is None else dict(channel_delay)
    names = [j.name for j in model.robot.joints if j.name in model.joints]
    if not names:
        return []
    n = log.t.size
    if rates is not None and any(x.shape != log.q.shape for x in rates):
        raise ValueError(f"rates of shape {[x.shape for x in rates]} for a log of {log.q.shape}")
    if n > MAX_SAMPLES:
        start = (n - MAX_SAMPLES) // 2
        sl = slice(start, start + MAX_SAMPLES)
        log = dataclasses.replace(log, t=log.t[sl], q=log.q[sl], motor_torque=log.motor_torque[sl])
        # the middle's own derivatives differ from the whole log's near its ends: not taken
        rates = None
    t = log.t
    if t.size < 16:
        return []
    edge = 1.0 / cutoff
    inner_mask = (t >= t[0] + edge) & (t <= t[-1] - edge)
    per_window = max(1, int(window / float(np.median(np.diff(t)))))
    if np.count_nonzero(inner_mask) < 8 * per_window:  # too short to tell
        return []
    first, last = np.flatnonzero(inner_mask)[[0, -1]]
    inner = slice(int(first), int(last) + 1)
    if rates is None:
        t_est, angle, velocity, _ = _signal(model, log, window=window)
    else:
        from torquemap.filters import Rates

        v, a, modulation = rates
        given = [
            Rates(
                velocity=np.ascontiguousarray(v[:, k]), acceleration=np.ascontiguousarray(a[:, k])
            )
            for k in range(v.shape[1])
        ]
        t_est, angle, velocity, _ = _signal(
            model, log, window=window, modulation=modulation, rates=given
        )
    index = {j.name: k for k, j in enumerate(model.robot.joints)}
    out: list[str] = []
    for name in names:
        k = index[name]
        d0, lo, hi = intervals.get(name, (math.nan, math.nan, math.nan))
        if channel_delay is not None or name not in intervals:
            d0 = float(undone.get(name, 0.0))
        tau = log.motor_torque[:, k]
        lines = model.joints[name].pdtv
        # the model's no-load torque at each sample: what the estimation signal subtracted
        no_load = tau - t_est[:, k]
        if lines:
            no_load = no_load + pdtv_torque(angle[:, k], lines, velocity=velocity[:, k])
        # the high-pass commutes with the shift: each filtered once, the torque's shifted
        high_tau = _high_band(t, tau, cutoff)
        high_model = _high_band(t, no_load, cutoff)[inner]

        grid = d0 + np.arange(-SPAN, SPAN + STEP / 2, STEP)
        costs = np.empty(grid.size + 1)
        # with the torque negated: mean((-a - b)^2) = mean((a - b)^2) + 4 mean(a b)
        negated = np.empty(grid.size + 1)
        for i, d in enumerate((*grid, d0)):
            shifted = shift_channel(t, high_tau, float(d))[inner]
            costs[i] = np.mean((shifted - high_model) ** 2)
            negated[i] = costs[i] + 4.0 * float(np.dot(shifted, high_model)) / shifted.size
        flipped = _flipped_line(name, costs[:-1], negated[:-1], cutoff)
        if flipped is not None:
            out.append(flipped)
            continue
        if name not in intervals or channel_delay is not None:
            continue
        at_model, costs = float(costs[-1]), costs[:-1]
        best = int(np.argmin(costs))
        d, least = float(grid[best]), float(costs[best])
        reach = hi - lo
        if not (least > 0 and at_model >= COST_RATIO * least):
            continue
        if lo - reach <= d <= hi + reach:
            continue
        out.append(
            f"joint {name}: the log's torque channel lags its position by about "
            f"{1000 * d:.0f} ms, not the {1000 * d0:.0f} ms identification found "
            f"({1000 * lo:.0f} to {1000 * hi:.0f} ms): above the {cutoff:g} Hz cut-off the "
            f"torque the model leaves is {at_model / least:.2g} times what it leaves at "
            f"{1000 * d:.0f} ms. Was this log recorded through another path than the no-load "
            "logs (the drive's buffer, a host, a bus)? The model's delay is undone, not the "
            f"log's, and tau_ext_{name} and the forces are off beyond their sigmas; record "
            "both alike, or identify from no-load logs recorded the way this one was"
        )
    return out


def _flipped_line(
    name: str, costs: NDArray[np.float64], negated: NDArray[np.float64], cutoff: float
) -> str | None:
    """The warning for a joint whose torque above ``cutoff`` the model answers far better
    negated (the least misfit over the delays, ``negated`` against ``costs``, by at least
    :data:`COST_RATIO`), else None."""
    least, least_negated = float(np.min(costs)), float(np.min(negated))
    if not (least_negated > 0 and least >= COST_RATIO * least_negated):
        return None
    return (
        f"joint {name}: above the {cutoff:g} Hz cut-off the log's torque is the model's with "
        f"its sign reversed (the torque the model leaves is {least / least_negated:.2g} times "
        f"what it leaves with i_{name} negated): is the current's sign flipped in this log "
        "against the identification logs' (a drive, wiring or logger that reverses it)? "
        f"tau_ext_{name} and the forces are off by about twice the model's torque; negate "
        f"i_{name} (or tau_{name}) in this log (docs/formats.md)"
    )
