"""Sensorless estimation of external joint torques and end-effector forces (Simpson et al., Eq 7).

From a log of motor currents (or torques) and encoder positions and an identified model, the
estimation signal of Eq 7 is formed per joint, motor side::

    T_est = T_motor - J(q) d2theta/dt2 - f(dtheta/dt)

(inertia, and the identified Coulomb, viscous and Stribeck friction ``f``). By Eq 8 it holds
the external torque, the PDTV and noise. Four methods take it further:

``raw``
    ``T_est`` as it is.
``lowpass``
    ``T_est`` through a zero-phase time-domain low-pass filter (first stage of the paper).
``paper``
    Low-pass, then each monotonic pass of the joint is turned into the discrete-position signal,
    notched at every identified PDTV order, and interpolated back to its samples (the paper's
    section 4). Passes are processed separately: a joint that reverses would otherwise average
    both directions into one curve.
``model`` (default)
    The identified PDTV model is subtracted at each sample's motor angle, then the low-pass.
    Works at any speed and at standstill, since it does not need a pass to filter.

The motor supplies the external load, so the joint-side torque exerted BY the environment is
``tau_ext = -gear_ratio * T_ext`` (docs/conventions.md), and for a planar2r arm the force on the
end effector is ``F = J(q)^-T tau_ext``, flagged near singular poses.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from torquemap._callable import make_callable as _make_callable
from torquemap.errors import InputError
from torquemap.filters import Rates, differentiate_rates, lowpass, regular_step
from torquemap.io import Log
from torquemap.log_quirks import (
    angle_unit_hint,
    check_register_angles,
    motor_angle_quantum,
    narrow_float_column,
)
from torquemap.model import Model, friction_torque, pdtv_torque
from torquemap.pdtv import (
    PositionSignal,
    bins_per_revolution,
    discrete_position_signal,
    notch_position_signal,
)
from torquemap.robot import Joint

Method = Literal["model", "paper", "lowpass", "raw"]
METHODS: tuple[Method, ...] = ("model", "paper", "lowpass", "raw")

TWO_PI = 2.0 * math.pi

#: Flag bits of :attr:`ForceEstimate.flag`.
FLAG_SINGULAR = 1
"""The pose is too close to a singularity to invert ``J^T``: force is NaN."""
FLAG_LOW_SPEED = 2
"""A joint moves slower than its friction model's zero-velocity band: friction at rest is not
determined by the velocity, so the estimate there carries up to the Coulomb friction as error."""
FLAG_NO_PASS = 4
"""``paper`` method only: the sample lies outside every monotonic pass long enough for the
position-domain filter, so it holds the low-pass value with its PDTV."""
FLAG_GAP = 8
"""A gap in time: the sample lies in a stretch between gaps too short to estimate, or repeats
the previous time stamp (no answer, NaN), or lies within the filters' support (the low-pass's
``1 / cutoff``) of a gap, where they see data on one side only (answered, not sound)."""
FLAG_IMPLAUSIBLE = 16
"""The sample holds an implausible value (a wild current, an encoder glitch): it was kept out of
every filter and its answer is bridged from its neighbours."""


@dataclass(frozen=True, slots=True, eq=False)
class Pass:
    """A monotonic pass of one joint: samples ``start:stop`` moving in one direction.

    Attributes
    ----------
    start, stop
        Sample slice.
    direction
        +1 or -1.
    revolutions
        Motor revolutions travelled.
    """

    start: int
    stop: int
    direction: int
    revolutions: float


@dataclass(frozen=True, slots=True, eq=False)
class ForceEstimate:
    """External torques and forces estimated from one log.

    Attributes
    ----------
    t
        Time [s], shape (n,).
    joint_names
        Joint names in the robot file's order.
    q
        Joint angles [rad], shape (n, nj).
    motor_angle
        Motor angles [rad] (``gear_ratio * q``), shape (n, nj).
    velocity
        Smoothed motor velocity [rad/s], shape (n, nj).
    t_est
        The estimation signal of Eq 7 [N m, motor side], shape (n, nj).
    filtered
        ``t_est`` after the time-domain low-pass [N m, motor side], shape (n, nj) (equal to
        ``t_est`` for ``raw``).
    motor_external
        The processed estimate of the motor torque that balances the external load [N m,
        motor side], shape (n, nj): the method's output before the sign and gear ratio.
    tau_ext
        External torque exerted by the environment on each joint [N m, joint side], shape (n, nj).
    force
        Wrench exerted by the environment on the end effector [N, N m], base frame, shape
        (n, len(wrench_axes)); NaN at singular poses. None when the robot's arm has no end
        effector.
    flag
        Bitwise OR of ``FLAG_*`` per sample, shape (n,); 0 where the estimate is sound.
    passes
        Monotonic passes per joint (used by ``paper``; found for every method).
    method
        The method used.
    cutoff
        The low-pass cut-off [Hz] (NaN for ``raw``).
    warnings
        One line each.
    wrench_axes
        Names of the columns of ``force`` (``("fx", "fy")`` for a planar arm).
    tau_ext_sigma
        One standard deviation of ``tau_ext`` [N m, joint side], shape (n, nj) (``model``
        method, from the identification's covariance and residual noise; NaN otherwise).
    force_sigma
        One standard deviation of each column of ``force`` [N], shape like ``force``.
    window
        The differentiator window used [s].
    """

    t: NDArray[np.float64]
    joint_names: tuple[str, ...]
    q: NDArray[np.float64]
    motor_angle: NDArray[np.float64]
    velocity: NDArray[np.float64]
    t_est: NDArray[np.float64]
    filtered: NDArray[np.float64]
    motor_external: NDArray[np.float64]
    tau_ext: NDArray[np.float64]
    force: NDArray[np.float64] | None
    flag: NDArray[np.int64]
    passes: tuple[tuple[Pass, ...], ...]
    method: Method
    cutoff: float
    warnings: tuple[str, ...] = ()
    wrench_axes: tuple[str, ...] = ()
    tau_ext_sigma: NDArray[np.float64] | None = None
    force_sigma: NDArray[np.float64] | None = None
    window: float = 0.05


def estimation_signal(
    model: Model,
    log: Log,
    *,
    window: float = 0.05,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The estimation signal of Eq 7, per joint.

    Parameters
    ----------
    model
        Identified model (a plain robot file gives ``T_est = T_motor``).
    log
        The log.
    window
        Length [s] of the local-quadratic differentiator's window
        (:func:`torquemap.filters.differentiate`).

    Returns
    -------
    (t_est, motor_angle, velocity)
        Each shape (n, nj): ``T_est`` [N m, motor side], motor angle [rad] (as measured) and
        smoothed motor velocity [rad/s].

    Raises
    ------
    InputError
        When the log is shorter than the differentiator's window.
    """
    t_est, angle, velocity, _ = _signal(model, log, window=window)
    return t_est, angle, velocity


def _signal(
    model: Model,
    log: Log,
    *,
    window: float,
    modulation: NDArray[np.float64] | None = None,
    rates: Sequence[Any] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`estimation_signal` plus the motor acceleration [rad/s^2] (``modulation``: the
    arm's inertia modulation at ``log.q`` when the caller has it already; ``rates``: per
    joint, the motor angle's velocity and acceleration when already differentiated, e.g.
    identification's :class:`torquemap.filters.Derivatives`)."""
    robot = model.robot
    n = log.t.size
    nj = len(robot.joints)
    acceleration = np.empty((n, nj))
    t_est = np.empty((n, nj))
    angle = np.empty((n, nj))
    velocity = np.empty((n, nj))
    if modulation is None:
        modulation = robot.arm.inertia_modulation(log.q)
    span = float(log.t[-1] - log.t[0])
    if span < window:
        raise InputError(
            f"log lasts {span:.3g} s, shorter than the {window:.3g} s differentiator window",
            path=log.path,
        )
    gears = np.array([joint.gear_ratio for joint in robot.joints], dtype=np.float64)
    thetas = log.q * gears  # each column as gear_ratio * q
    both = None
    try:
        if rates is None and nj > 1 and regular_step(log.t, rtol=1e-9) is None:
            # irregular time: every joint in one call, the windows and their sums of time
            # powers found once (a regular log's Savitzky-Golay runs per column anyway)
            both = differentiate_rates(log.t, thetas, window=window)
    except InputError as exc:
        raise InputError(exc.message, path=log.path) from None
    for k, joint in enumerate(robot.joints):
        theta = np.ascontiguousarray(thetas[:, k])
        if rates is not None:
            d = rates[k]
        elif both is not None:
            d = Rates(
                velocity=np.ascontiguousarray(both.velocity[:, k]),
                acceleration=np.ascontiguousarray(both.acceleration[:, k]),
            )
        else:
            try:
                d = differentiate_rates(log.t, theta, window=window)
            except InputError as exc:
                raise InputError(exc.message, path=log.path) from None
        jm = model.joints[joint.name]
        inertia = jm.inertia.constant + jm.inertia.cos_elbow * modulation[:, k]
        t_est[:, k] = (
            log.motor_torque[:, k]
            - inertia * d.acceleration
            - friction_torque(d.velocity, jm.friction)
        )
        angle[:, k] = theta
        velocity[:, k] = d.velocity
        acceleration[:, k] = d.acceleration
    return t_est, angle, velocity, acceleration


def monotonic_passes(
    t: NDArray[np.float64],
    motor_angle: NDArray[np.float64],
    velocity: NDArray[np.float64],
    *,
    speed_threshold: float,
    min_revolutions: float = 1.0,
) -> tuple[Pass, ...]:
    """Cut one joint's motion into monotonic passes (one direction between reversals).

    Samples move when ``|velocity| > speed_threshold``; stretches of one direction separated only
    by slow samples (no reversal of the angle) are one pass. Passes shorter than
    ``min_revolutions`` motor revolutions are dropped.

    Parameters
    ----------
    t
        Time [s], shape (n,).
    motor_angle
        Motor angle [rad], shape (n,).
    velocity
        Smoothed motor velocity [rad/s], shape (n,).
    speed_threshold
        [rad/s], > 0.
    min_revolutions
        Shortest pass kept [motor revolutions].

    Returns
    -------
    tuple of Pass

    Examples
    --------
    >>> t = np.linspace(0.0, 2.0, 2001)
    >>> theta = 40.0 * np.sin(np.pi * t)
    >>> w = 40.0 * np.pi * np.cos(np.pi * t)
    >>> [(p.direction, round(p.revolutions, 1)) for p in monotonic_passes(t, theta, w, speed_threshold=1.0)]
    [(1, 6.4), (-1, 12.7), (1, 6.4)]
    """
    sign = np.where(velocity > speed_threshold, 1, np.where(velocity < -speed_threshold, -1, 0))
    moving = np.flatnonzero(sign)
    passes: list[Pass] = []
    if moving.size == 0:
        return ()
    # consecutive moving samples with the same sign belong together, slow samples between
    # them too; a change of sign ends the pass
    s = sign[moving]
    breaks = np.flatnonzero(np.diff(s)) + 1
    for chunk in np.split(np.arange(moving.size), breaks):
        a, b = int(moving[chunk[0]]), int(moving[chunk[-1]]) + 1
        revs = abs(float(motor_angle[b - 1] - motor_angle[a])) / TWO_PI
        if revs >= min_revolutions and b - a >= 8:
            passes.append(Pass(start=a, stop=b, direction=int(s[chunk[0]]), revolutions=revs))
    return tuple(passes)


def reversal_mask(
    t: NDArray[np.float64], velocity: NDArray[np.float64], *, band: float, window: float
) -> NDArray[np.bool_]:
    """Samples where friction is undetermined: slower than ``band`` [rad/s], widened by half the
    differentiator ``window`` [s] on each side (the velocity estimate is smeared over the window,
    so its sign is unreliable that close to a reversal).

    Examples
    --------
    >>> t = np.arange(11) * 0.01
    >>> reversal_mask(t, t - 0.05, band=0.001, window=0.041).astype(int).tolist()
    [0, 0, 0, 1, 1, 1, 1, 1, 0, 0, 0]
    """
    slow = np.abs(velocity) < band
    if not slow.any():
        return slow
    idx = np.flatnonzero(slow)
    # a sample half a window away, to within a hundredth of a step, is in: whether it lands a
    # rounding error in or out would depend on the stamps' offset (Unix-epoch seconds)
    reach = 0.5 * window + 0.01 * float(t[-1] - t[0]) / max(t.size - 1, 1)
    lo = np.searchsorted(t, t[idx] - reach, side="left")
    hi = np.searchsorted(t, t[idx] + reach, side="right")
    edges = np.zeros(t.size + 1, dtype=np.int64)
    np.add.at(edges, lo, 1)
    np.add.at(edges, hi, -1)
    return np.cumsum(edges[:-1]) > 0


def _gap_runs(gaps: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """``(start, stop)`` of every run of True in ``gaps``."""
    if not gaps.size:
        return []
    change = np.flatnonzero(gaps[1:] != gaps[:-1]) + 1  # a run starts or stops here
    edges = [0, *change.tolist(), gaps.size]
    first = 0 if gaps[0] else 1  # runs of True are every other stretch between the edges
    return list(zip(edges[first:-1:2], edges[first + 1 :: 2], strict=False))


def bridge_gaps(
    t: NDArray[np.float64],
    values: NDArray[np.float64],
    gaps: NDArray[np.bool_],
    *,
    longest: float,
    support: float = 0.0,
    ends: bool = False,
    runs: Sequence[tuple[int, int]] | None = None,
) -> NDArray[np.float64]:
    """Replace each run of ``gaps`` lasting at most ``longest`` [s] by a straight line.

    The line joins the means of the samples within ``support`` [s] before and after the run
    (at least the one neighbour each side), so that noise on a single neighbour does not tilt
    it. Runs longer than ``longest`` are left as they are, and so are runs at the ends of the
    log unless ``ends`` is true: then they hold the mean of their one neighbouring side.
    ``runs``: the ``(start, stop)`` of the runs of ``gaps`` when the caller has them already.

    Examples
    --------
    >>> t = np.arange(6.0)
    >>> gaps = np.array([0, 1, 1, 0, 0, 0], bool)
    >>> bridge_gaps(t, np.array([0.0, 9, 9, 3, 4, 5]), gaps, longest=5).tolist()
    [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
    >>> gaps = np.array([1, 1, 0, 0, 0, 1], bool)
    >>> bridge_gaps(t, np.array([9.0, 9, 2, 3, 4, 9]), gaps, longest=5, ends=True).tolist()
    [2.0, 2.0, 2.0, 3.0, 4.0, 4.0]
    """
    from torquemap._estimate_kernels import bridge_runs

    out = np.array(values, dtype=np.float64)
    if gaps.all():
        return out
    # ties (a sample exactly ``support`` away) are in, to a hundredth of a step, and times are
    # taken from the run's start: the same answer for stamps from zero or Unix-epoch seconds
    tie = 0.01 * float(t[-1] - t[0]) / max(t.size - 1, 1)
    pairs = _gap_runs(gaps) if runs is None else runs
    if not pairs:
        return out
    # each side's mean of the samples it keeps and np.interp between them (_run_sides'
    # samples), compiled: the numpy loop's operations in its order, bit for bit
    bounds = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    bridge_runs(
        np.ascontiguousarray(t, dtype=np.float64),
        np.ascontiguousarray(values, dtype=np.float64),
        np.ascontiguousarray(gaps, dtype=np.bool_),
        np.ascontiguousarray(bounds[:, 0]),
        np.ascontiguousarray(bounds[:, 1]),
        float(longest),
        float(support),
        bool(ends),
        tie,
        out,
    )
    return out


def _run_sides(
    t: NDArray[np.float64], a: int, b: int, *, support: float, tie: float
) -> list[slice]:
    """The samples within ``support`` [s] (``tie`` [s] of slack) before and after the run
    ``a:b``, at least the one neighbour each side; none on a side the log ends at."""
    sides = []
    if a > 0:
        a0 = min(int(np.searchsorted(t, t[a - 1] - support - tie, side="left")), a - 1)
        sides.append(slice(a0, a))
    if b < t.size:
        b1 = max(int(np.searchsorted(t, t[b] + support + tie, side="right")), b + 1)
        sides.append(slice(b, b1))
    return sides


def bridged_runs(
    t: NDArray[np.float64],
    gaps: NDArray[np.bool_],
    *,
    longest: float,
    runs: Sequence[tuple[int, int]] | None = None,
) -> NDArray[np.bool_]:
    """The samples of the runs of ``gaps`` that :func:`bridge_gaps` bridges (``ends=False``):
    runs inside the log lasting at most ``longest`` [s] (``runs``: :func:`bridge_gaps`'s).

    Examples
    --------
    >>> t = np.arange(8.0)
    >>> gaps = np.array([1, 0, 1, 1, 0, 1, 1, 1], bool)
    >>> bridged_runs(t, gaps, longest=5).astype(int).tolist()
    [0, 0, 1, 1, 0, 0, 0, 0]
    """
    out = np.zeros(gaps.size, dtype=bool)
    for a, b in _gap_runs(gaps) if runs is None else runs:
        if a > 0 and b < gaps.size and t[b - 1] - t[a] <= longest:
            out[a:b] = True
    return out


#: Bridging in force space (F42; docs/estimation.md, "Bridging in force space"): ``"off"``
#: (every joint's ``T_est`` is bridged on its own, a line in time), ``"line"`` (default; over a
#: run where some joint is bridged, the force is the Cartesian line between the run's ends,
#: corrected only along what an answered joint's torque observes) or ``"quadratic"`` (a
#: quadratic in time fitted to the samples of both ends' windows instead of the line).
FORCE_BRIDGE: Literal["off", "line", "quadratic"] = "line"
#: Longest run [s] bridged in force space; longer runs keep the joint-space answer.
FORCE_BRIDGE_LONGEST = 0.5
#: Whether the runs at the log's ends are bridged in force space (the one side's mean, held).
#: Off: on robots 21-40 and 61-80 (which F42 never saw) it made the median force error worse
#: (6.02 -> 7.14 %, 6.15 -> 6.88 % of the spring) while bettering the worst; the interior runs
#: alone are neutral there (docs/estimation.md).
FORCE_BRIDGE_ENDS = False


def force_space_bridge(
    t: NDArray[np.float64],
    jac: NDArray[np.float64],
    force: NDArray[np.float64],
    tau: NDArray[np.float64],
    bridged: NDArray[np.bool_],
    *,
    longest: float,
    support: float,
    shape: Literal["line", "quadratic"] = "line",
    ends: bool = False,
) -> NDArray[np.float64]:
    """Bridge the force across runs where some joint's friction is undetermined, in Cartesian
    space: the external load (a spring, a contact) is smooth in the base frame, while the
    Jacobian turns under it, so a line in each joint's torque is not a line in force.

    Over each run of samples where any joint is ``bridged`` (inside the log and at most
    ``longest`` [s] long, or at its ends when ``ends``), the force is the line in time between the means of ``force`` over the
    samples within ``support`` [s] before and after the run (``shape="quadratic"``: a quadratic
    in time least-squares fitted to those samples), then corrected by the smallest change that
    makes each answered joint's torque hold (``J^T F = tau`` on the joints not bridged at that
    sample: a minimum-norm least-squares correction). At the log's ends (``ends``) the one
    side's mean is held, corrected as above, however long the run. Other runs keep ``force``.

    Parameters
    ----------
    t
        Time [s], shape (n,).
    jac
        Jacobian ``d x_i / d q_j`` at each sample, shape (n, axes, nj) (``tau = J^T F``).
    force
        The force answered joint by joint [N], shape (n, axes).
    tau
        The external joint torques [N m, joint side], shape (n, nj).
    bridged
        Per sample and joint, whether the joint's torque was bridged, shape (n, nj).
    longest, support
        [s].
    shape
        ``"line"`` or ``"quadratic"``.
    ends
        Bridge the runs at the log's ends too, whatever their length.

    Returns
    -------
    ndarray
        The force, shape (n, axes).

    Examples
    --------
    A constant force seen through a turning Jacobian, joint 0 bridged in the middle: joint 1's
    torque and the ends' force give it back exactly.

    >>> t = np.arange(10.0)
    >>> c, s = np.cos(0.2 * t), np.sin(0.2 * t)
    >>> jac = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], 1)
    >>> f = np.tile([1.0, 2.0], (10, 1))
    >>> tau = np.einsum("nij,ni->nj", jac, f)
    >>> mask = np.zeros((10, 2), bool); mask[3:7, 0] = True
    >>> bad = f.copy(); bad[3:7] = 9.0
    >>> np.allclose(force_space_bridge(t, jac, bad, tau, mask, longest=9, support=1), f)
    True
    """
    out = force.copy()
    union: NDArray[np.bool_] = np.asarray(bridged.any(axis=1), dtype=bool)
    if not union.any() or union.all():
        return out
    tie = 0.01 * float(t[-1] - t[0]) / max(t.size - 1, 1)
    lined = np.zeros(union.size, dtype=bool)  # the samples given the line, to be corrected
    for a, b in _gap_runs(union):
        at_end = a == 0 or b == union.size
        if (at_end and not ends) or (not at_end and t[b - 1] - t[a] > longest):
            continue
        origin = t[a]
        windows = _run_sides(t, a, b, support=support, tie=tie)
        sides = [np.arange(w.start, w.stop) for w in windows]
        sides = [i[~union[i] & np.isfinite(force[i]).all(axis=1)] for i in sides]
        if not sides or any(i.size == 0 for i in sides):
            continue
        x = t[a:b] - origin
        if len(sides) == 1:  # a run at the log's end: the one side's mean, held
            line = np.tile(force[sides[0]].mean(axis=0), (b - a, 1))
        elif shape == "quadratic" and sides[0].size + sides[1].size >= 3:
            idx = np.concatenate(sides)
            tx = t[idx] - origin
            span = max(float(t[windows[1].stop - 1] - t[windows[0].start]), 1e-12)
            basis = np.column_stack([np.ones_like(tx), tx / span, (tx / span) ** 2])
            coef, *_ = np.linalg.lstsq(basis, force[idx], rcond=None)
            line = np.column_stack([np.ones_like(x), x / span, (x / span) ** 2]) @ coef
        else:
            ts = [float((t[i] - origin).mean()) for i in sides]
            fs = [force[i].mean(axis=0) for i in sides]
            line = np.column_stack(
                [np.interp(x, ts, [fs[0][c], fs[1][c]]) for c in range(force.shape[1])]
            )
        out[a:b] = line
        lined[a:b] = True
    rows = np.flatnonzero(lined)
    answered = ~bridged[rows] & np.isfinite(tau[rows])
    # the smallest change making J^T F = tau hold on the joints answered: one batched
    # pseudo-inverse per pattern of answered joints (a handful), not one solve per sample
    code = answered.astype(np.int64) @ (1 << np.arange(answered.shape[1], dtype=np.int64))
    for value in np.unique(code):
        if value == 0:
            continue
        sel = rows[code == value]
        pattern = ((int(value) >> np.arange(answered.shape[1])) & 1).astype(bool)
        jt = np.swapaxes(jac[sel][:, :, pattern], 1, 2)  # (k, m, axes): tau_b = jt F
        miss = tau[sel][:, pattern] - np.einsum("kma,ka->km", jt, out[sel])
        if jt.shape[1] == 1:  # one answered joint: the pseudo-inverse of a row is a column
            row = jt[:, 0, :]
            norm = np.einsum("ka,ka->k", row, row)
            scale = np.divide(miss[:, 0], norm, out=np.zeros_like(norm), where=norm > 0)
            out[sel] += row * scale[:, None]
        else:
            out[sel] += np.einsum("kam,km->ka", np.linalg.pinv(jt), miss)
    return out


def _position_filter(
    angle: NDArray[np.float64],
    values: NDArray[np.float64],
    orders: list[float],
    *,
    width: float,
    samples_per_rev: float,
) -> tuple[NDArray[np.float64], list[float]]:
    """Notch one pass in the position domain and interpolate back to its samples."""
    bins = max(bins_per_revolution(samples_per_rev), 4)
    usable = [f for f in orders if f < bins / 2]
    skipped = [f for f in orders if f >= bins / 2]
    if not usable:
        return values.copy(), skipped
    signal = discrete_position_signal(angle, values, bin_width=TWO_PI / bins)
    # The external load drifts along a pass while the PDTV repeats every revolution: remove a
    # cubic trend first, so that extending the pass by whole revolutions (what the notch does to
    # keep its start-up transient outside the data) does not put a step at the pass's ends.
    x = (signal.angle - signal.angle.mean()) / max(float(np.ptp(signal.angle)), 1e-12)
    trend = np.polynomial.polynomial.polyval(
        x, np.polynomial.polynomial.polyfit(x, signal.value, min(3, signal.value.size - 1))
    )
    detrended = PositionSignal(
        angle=signal.angle,
        value=signal.value - trend,
        count=signal.count,
        bin_width=signal.bin_width,
    )
    notched = notch_position_signal(detrended, orders=usable, width=width) + trend
    return np.interp(angle, signal.angle, notched), skipped


def estimate_forces(
    model: Model,
    log: Log,
    *,
    method: Method = "model",
    cutoff: float = 2.0,
    window: float | None = None,
    notch_width: float = 0.5,
    min_revolutions: float = 1.0,
    min_sin_elbow: float = 0.05,
    bridge_reversals: float = 0.5,
    channel_delay: Mapping[str, float] | None = None,
    reversal_band: float | Mapping[str, float] | None = None,
    check_robot: bool = True,
    answers_only: bool = False,
    check_delay: bool = True,
) -> ForceEstimate:
    """Estimate the external joint torques and end-effector force from a log.

    The log is first sanitised (:func:`torquemap.sanitize.sanitize_log`): repeated time stamps
    dropped, implausible samples (a wild current, an encoder glitch) bridged from their
    neighbours and flagged ``FLAG_IMPLAUSIBLE`` so that they spoil no filter, and the log cut at
    gaps longer than the filters bridge; each piece is estimated on its own, and samples in
    pieces too short to estimate are flagged ``FLAG_GAP`` (NaN).

    Parameters
    ----------
    model
        Identified model (:func:`torquemap.identify.identify_model` or a model file).
    log
        The log (:func:`torquemap.io.read_log` with ``model.robot``).
    method
        ``"model"`` (default), ``"paper"``, ``"lowpass"`` or ``"raw"`` (module docstring).
    cutoff
        Time-domain low-pass cut-off [Hz]: the bandwidth of the external force that is kept.
    window
        Differentiator window [s] for velocity and acceleration; default the window the model
        was identified with (``[identification] differentiation_window``), else 0.05 s.
    notch_width
        -3 dB width of each position-domain notch [CPR] (``paper``).
    min_revolutions
        Shortest monotonic pass the position-domain filter processes [motor revolutions]
        (``paper``).
    min_sin_elbow
        Singular-pose guard of the arm (:meth:`torquemap.robots.Arm.wrench_from_joint_torque`;
        for planar2r the smallest ``|sin q2|``).
    bridge_reversals
        Longest stretch [s] of undetermined friction (:func:`reversal_mask`) bridged by a
        straight line in ``T_est`` before filtering; 0 turns bridging off. Bridged samples keep
        an answer, with a sigma that covers the friction band.
    channel_delay
        Delay [s] of each joint's torque channel behind its position, undone first; default:
        the delays identification found.
    reversal_band
        Motor speed [rad/s] (one for all joints, or per joint name) below which a joint's
        friction counts as undetermined. Default per joint: for a model identified from whole
        logs (friction through zero), 4 times its transition width (where the transition is
        complete); otherwise the larger of the
        friction model's ``zero_velocity`` and the slowest steady speed identification measured
        friction at. Such samples are flagged ``FLAG_LOW_SPEED`` only for models without a
        friction law through zero (pass method, hand-written): where the model knows friction
        through zero they keep their answer with a wider sigma.
    check_robot
        Refuse a log whose encoder steps do not match the model's (another robot).
    answers_only
        Compute only what the output table holds (:func:`forces_columns`): ``filtered`` is
        NaN for the joints whose ``motor_external`` it is not (``model`` method, joints with
        PDTV lines), sparing their low-pass, and ``passes`` is empty (except for ``paper``).
    check_delay
        Warn where the log's torque channel lags by another delay than identification found,
        or where a joint's current has the sign opposite to the identification logs'
        (:func:`torquemap.task_delay.task_delay_warnings`, on the longest piece; with
        ``channel_delay`` given, the sign only; not for ``raw``).

    Returns
    -------
    ForceEstimate

    Raises
    ------
    InputError
        On an unknown method, a log shorter than the filters, a log from another robot, or,
        for ``paper``, a log in which no joint with PDTV lines ever makes a monotonic pass of
        ``min_revolutions``.
    """
    from torquemap.sanitize import no_stretch_message, sanitize_log

    if method not in METHODS:
        raise InputError(f"unknown method {method!r} (choose from {', '.join(METHODS)})")
    if not (math.isfinite(cutoff) and cutoff > 0):
        raise InputError(f"cut-off must be a positive frequency, got {cutoff!r} Hz")
    win = model_window(model) if window is None else float(window)
    if not (math.isfinite(win) and win > 0):
        raise InputError(f"differentiation window must be positive, got {window!r} s")
    robot = model.robot
    if check_robot:
        check_log_angle_units(model, log)
        check_log_matches_model(model, log)
        check_log_steps_exact(model, log)
    n, nj = log.t.size, len(robot.joints)
    span = float(log.t[-1] - log.t[0]) if n else 0.0
    if span < win:
        raise InputError(
            f"log lasts {span:.3g} s, shorter than the {win:.3g} s differentiator window; "
            "record at least a second of motion",
            path=log.path,
        )
    clean = sanitize_log(log, window=win)
    if not clean.pieces:
        raise InputError(no_stretch_message(log.t, win), path=log.path)
    names = ("angle", "velocity", "t_est", "filtered", "external", "sigma", "rest")
    whole_log = len(clean.pieces) == 1 and _covers(clean.pieces[0].rows, n)
    # one piece that is the whole log (no gap, no dropped stamp): its arrays are the answer
    # else NaN where no piece answers: filled after the pieces, not written twice everywhere
    out = {} if whole_log else {name: np.empty((n, nj)) for name in names}
    answered = np.zeros(n, dtype=bool)
    flag = np.zeros(n, dtype=np.int64)
    flag[clean.unprocessed] |= FLAG_GAP
    flag[clean.implausible] |= FLAG_IMPLAUSIBLE
    # the filters' support next to a gap holds data on one side only: flagged (a gap)
    support = win if method == "raw" else max(win, 1.0 / cutoff)
    for before, after in clean.gaps:
        # the samples in [before - support, before] and [after, after + support]: slices of
        # the (non-decreasing) time, not masks of the whole log per gap
        for lo, hi in ((before - support, before), (after, after + support)):
            a = int(np.searchsorted(log.t, lo, side="left"))
            b = int(np.searchsorted(log.t, hi, side="right"))
            flag[a:b] |= FLAG_GAP
    warnings: list[str] = list(clean.warnings)
    from torquemap.filters import MIN_WINDOW_SAMPLES
    from torquemap.vertical import model_gravity_warnings

    spacing = float(np.median(np.diff(log.t))) if n > 1 else 0.0
    if spacing * (MIN_WINDOW_SAMPLES - 1) > win:
        warnings.append(
            f"the log's median sample interval {spacing:.3g} s leaves fewer than "
            f"{MIN_WINDOW_SAMPLES} samples in the {win:.3g} s differentiator window: velocity "
            f"and acceleration are smoothed over {spacing * (MIN_WINDOW_SAMPLES - 1):.3g} s "
            f"instead; record at {(MIN_WINDOW_SAMPLES - 1) / win:.3g} Hz or more, or pass a "
            "longer --window"
        )

    warnings += model_gravity_warnings(model)
    passes: list[list[Pass]] = [[] for _ in range(nj)]
    any_pass = False
    # the delay check scans the longest piece: its derivatives kept from its estimate
    delay_check = check_delay and method != "raw"
    longest = max(clean.pieces, key=lambda piece: piece.log.t[-1] - piece.log.t[0])
    longest_rates: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None
    longest_rates = None
    for piece in clean.pieces:
        piece_kw: dict[str, Any] = dict(
            method=method,
            cutoff=cutoff,
            window=win,
            notch_width=notch_width,
            min_revolutions=min_revolutions,
            bridge_reversals=bridge_reversals,
            channel_delay=channel_delay,
            reversal_band=reversal_band,
            answers_only=answers_only,
        )
        part = _estimate_piece(model, piece.log, **piece_kw)
        if END_RUNS != "hold" and method == "model" and bridge_reversals > 0:
            part = _choose_end_runs(model, piece.log, part, piece_kw, mode=END_RUNS)
        if delay_check and piece is longest and part.shared is not None:
            kept = part.shared
            longest_rates = (kept.velocity, kept.acceleration, kept.modulation)
        rows = piece.rows
        # consecutive rows (no repeated stamp dropped): a slice, not a gather, per column
        at: slice | NDArray[np.int64] = rows
        if rows.size and int(rows[-1]) - int(rows[0]) == rows.size - 1:
            at = slice(int(rows[0]), int(rows[-1]) + 1)
        if whole_log:
            out = {key: part.arrays[key] for key in names}
        for key in () if whole_log else names:
            out[key][at] = part.arrays[key]
        answered[at] = True
        flag[at] |= part.flag
        any_pass |= part.any_pass
        for k in range(nj):
            passes[k].extend(
                dataclasses.replace(p, start=int(rows[p.start]), stop=int(rows[p.stop - 1]) + 1)
                for p in part.passes[k]
            )
        for w in part.warnings:
            if w not in warnings:
                warnings.append(w)
    if not whole_log and not answered.all():
        for key in names:
            out[key][~answered] = np.nan
    if method == "paper" and not any_pass:
        raise InputError(
            "no joint with PDTV lines makes a monotonic pass of at least "
            f"{min_revolutions:g} motor revolutions: the paper method needs motion "
            "(use --method model)",
            path=log.path,
        )
    bands = _bands(model, reversal_band)
    whole = whole_fit_joints(model)
    for k, joint in enumerate(robot.joints):
        rest = out["rest"][:, k] > 0
        if rest.any() and joint.name not in whole:
            warnings.append(
                f"joint {joint.name}: {np.mean(rest):.1%} of samples at or near zero "
                f"velocity (motor slower than {bands[joint.name]:.3g} rad/s, the reversal band), "
                "where friction is undetermined (flagged)"
            )
    if method != "raw":
        warnings += edge_motion_warnings(log.t, out["velocity"], robot.joint_names, cutoff)
    warnings += slow_task_warnings(model, out["velocity"])
    if bridge_reversals > 0:
        warnings += held_end_warnings(
            model,
            log.t,
            out["velocity"],
            out["rest"],
            pieces=[piece.rows for piece in clean.pieces],
            sigma=out["sigma"] * np.array([j.gear_ratio for j in robot.joints]),
        )
    warnings += gap_task_warnings(model, out["velocity"])
    warnings += fast_task_warnings(model, out["velocity"])
    warnings += one_direction_task_warnings(model, out["velocity"])
    warnings += torque_scale_warnings(model, log.motor_torque)
    if delay_check:
        from torquemap.task_delay import task_delay_warnings

        warnings += task_delay_warnings(
            model,
            longest.log,
            window=win,
            cutoff=cutoff,
            rates=longest_rates,
            channel_delay=channel_delay,
        )
    warnings += unidentified_joint_warnings(model)
    gear = np.array([j.gear_ratio for j in robot.joints])
    tau_ext = -out["external"] * gear
    tau_sigma = out["sigma"] * gear
    force = force_sigma = None
    if robot.arm.wrench_axes:
        finite = np.isfinite(tau_ext).all(axis=1)
        if robot.arm.kind == "planar2r":
            # force and its sigma from one closed-form J^-T (five sines per sample, not nine)
            force, singular, force_sigma = _planar_force(
                robot.arm, log.q, tau_ext, tau_sigma, min_sin_elbow
            )
        else:
            f = robot.arm.wrench_from_joint_torque(
                log.q, np.nan_to_num(tau_ext), singular_threshold=min_sin_elbow
            )
            force = np.array(f.wrench, dtype=np.float64)
            singular = f.singular
            force_sigma = _force_sigma(robot.arm, log.q, tau_sigma, singular)
        if FORCE_BRIDGE != "off" and whole:
            lined = np.nan_to_num(out["rest"]) > 0
            lined[:, [j.name not in whole for j in robot.joints]] = False
            if lined.any():
                # the bridge reads J only where a joint is bridged: the rest NaN, not computed
                # (four sines and cosines a sample)
                need = lined.any(axis=1)
                jac = np.full(
                    (*log.q.shape[:1], len(robot.arm.wrench_axes), log.q.shape[1]), np.nan
                )
                jac[need] = robot.arm.jacobian(log.q[need])
                ok = ~singular & finite
                for piece in clean.pieces:  # each piece on its own, as its joints were bridged
                    kept = piece.rows[ok[piece.rows]]
                    sel: NDArray[np.int64] | slice = kept
                    if kept.size and int(kept[-1]) - int(kept[0]) == kept.size - 1:
                        sel = slice(int(kept[0]), int(kept[-1]) + 1)  # views, not gathers
                    if lined[sel].size and lined[sel].any():
                        force[sel] = force_space_bridge(
                            log.t[sel],
                            jac[sel],
                            force[sel],
                            tau_ext[sel],
                            lined[sel],
                            longest=FORCE_BRIDGE_LONGEST,
                            support=win,
                            shape=FORCE_BRIDGE,
                            ends=FORCE_BRIDGE_ENDS,
                        )
        force[~finite] = np.nan
        flag[singular] |= FLAG_SINGULAR
        if singular.any():
            warnings.append(
                f"{int(singular.sum())} samples near a singular pose (guard "
                f"{min_sin_elbow:g}): force not estimated there"
            )
    return ForceEstimate(
        t=log.t,
        joint_names=robot.joint_names,
        q=log.q,
        motor_angle=out["angle"],
        velocity=out["velocity"],
        t_est=out["t_est"],
        filtered=out["filtered"],
        motor_external=out["external"],
        tau_ext=tau_ext,
        force=force,
        flag=flag,
        passes=tuple(tuple(p) for p in passes),
        method=method,
        cutoff=float("nan") if method == "raw" else float(cutoff),
        warnings=tuple(warnings),
        wrench_axes=robot.arm.wrench_axes if force is not None else (),
        tau_ext_sigma=tau_sigma,
        force_sigma=force_sigma,
        window=win,
    )


#: What a whole-fit joint's run below its reversal band at an end of the log (or of a piece)
#: answers where the joint slides above its law's transition (``TRANSITION_SPAN`` widths):
#: ``"hold"`` (the answer next to the run, held: main's), ``"law"`` (the model's friction law
#: read there, only the transition held) or ``"choose"`` (per run, the one whose sigma is the
#: smaller over the run: the hold's grows with the neighbouring answer's rate of change times
#: the time from it, :func:`torquemap.uncertainty.bridge_departure`; the law's is its
#: parameters', sign and extrapolation spread at those speeds). ``"choose"`` measured on robots
#: 381-400 / held-out 401-420: median ratio 2.20x -> 2.20x / 2.27x -> 1.77x, worst 61.44x ->
#: 24.18x / 11.92x -> 11.92x (261-280: 1.55x -> 1.52x, 11.98x); the default since stop 41
#: (the lead: the forces are better or equal on every set's median and worst; 391's 2-sigma
#: share 91.8 -> 100 %, 420 and 268 lose). docs/estimation.md, "Stop 41 (F54)".
END_RUNS: Literal["hold", "law", "choose"] = "choose"


def law_end_runs(
    model: Model,
    t: NDArray[np.float64],
    velocity: NDArray[np.float64],
    rest: NDArray[np.float64],
    *,
    window: float,
) -> tuple[dict[int, NDArray[np.bool_]], dict[int, list[tuple[int, int]]]]:
    """The reversal masks with the law read in the runs at the ends of a piece.

    For each whole-fit joint ``k``, every run of ``rest[:, k] > 0`` that touches the piece's
    start or end and in which the joint slides above its law's transition
    (``TRANSITION_SPAN`` widths, motor ``velocity`` [rad/s], widened by half the
    differentiator ``window`` [s] as :func:`reversal_mask` does) keeps only the transition in
    the mask. Returns the new masks (joints with such runs only) and those runs' ``(start,
    stop)`` rows.

    Examples
    --------
    >>> from torquemap.friction_law import StribeckFriction
    >>> from torquemap.model import JointModel
    >>> from torquemap.robot import robot_from_dict
    >>> rb = robot_from_dict({"robot": {"name": "m", "kinematics": "none"}, "joints": {"a": {
    ...     "gear_ratio": 1.0, "torque_constant": 0.1, "encoder_counts_per_rev": 4096}}})
    >>> law = StribeckFriction(coulomb_positive=0.1, coulomb_negative=0.1, zero_velocity=0.01)
    >>> notes = {"joints": {"a": {"friction_fit": "whole", "friction_observed_speed": 2.0}}}
    >>> m = Model(robot=rb, joints={"a": JointModel(friction=law)}, notes=notes)
    >>> t = np.arange(10) * 0.1
    >>> v = np.array([0.0, 0.0, 1, 1, 1, 5, 5, 5, 5, 5])[:, None]
    >>> masks, runs = law_end_runs(m, t, v, (v < 2.0).astype(float), window=0.01)
    >>> masks[0].astype(int).tolist(), runs[0]
    ([1, 1, 0, 0, 0, 0, 0, 0, 0, 0], [(0, 5)])
    """
    whole = whole_fit_joints(model)
    masks: dict[int, NDArray[np.bool_]] = {}
    runs: dict[int, list[tuple[int, int]]] = {}
    n = t.size
    for k, name in enumerate(model.robot.joint_names):
        if name not in whole or name not in model.joints or n == 0:
            continue
        inside = np.nan_to_num(rest[:, k]) > 0
        width = TRANSITION_SPAN * _law_width(model.joints[name].friction)
        narrow = reversal_mask(t, velocity[:, k], band=width, window=window) & inside
        mask = inside.copy()
        chosen = []
        for a, b in _gap_runs(inside):
            if (a == 0 or b == n) and not narrow[a:b].all():
                mask[a:b] = narrow[a:b]
                chosen.append((int(a), int(b)))
        if chosen:
            masks[k] = mask
            runs[k] = chosen
    return masks, runs


def _choose_end_runs(
    model: Model,
    log: Log,
    part: _PieceEstimate,
    piece_kw: Mapping[str, Any],
    *,
    mode: str,
) -> _PieceEstimate:
    """``part`` with the law read in its end runs (:func:`law_end_runs`): in every such run
    (``mode == "law"``) or in those where the law's sigma is the smaller over the run
    (``"choose"``, root mean square over the run's samples)."""
    arrays = part.arrays
    masks, runs = law_end_runs(
        model, log.t, arrays["velocity"], arrays["rest"], window=float(piece_kw["window"])
    )
    if not masks:
        return part
    # the same piece with other masks: what the masks do not change is taken from ``part``,
    # and only the joints whose runs are read are computed
    alt = _estimate_piece(
        model, log, **piece_kw, rest_override=masks, shared=part.shared, joints=sorted(runs)
    ).arrays
    written = ("rest", "filtered", "external", "sigma")
    out = {key: value.copy() if key in written else value for key, value in arrays.items()}
    for k, chosen in runs.items():
        for a, b in chosen:
            if mode == "choose":
                held = float(np.sqrt(np.mean(arrays["sigma"][a:b, k] ** 2)))
                law = float(np.sqrt(np.mean(alt["sigma"][a:b, k] ** 2)))
                if not law < held:
                    continue
            for key in written:
                out[key][a:b, k] = alt[key][a:b, k]
    return dataclasses.replace(part, arrays=out)


def _covers(rows: NDArray[np.int64], n: int) -> bool:
    """Whether a piece's rows are every row ``0 .. n - 1`` of the log, in order."""
    return bool(rows.size == n and (n == 0 or (int(rows[0]) == 0 and int(rows[-1]) == n - 1)))


def _planar_force(
    arm: Any,
    q: NDArray[np.float64],
    tau: NDArray[np.float64],
    tau_sigma: NDArray[np.float64],
    guard: float,
) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]]:
    """Force ``F = A tau``, singular mask and the force's sigma from the planar arm's
    ``A = J^-T`` (:func:`torquemap.kinematics.force_and_sigma`, one compiled pass); NaN
    where singular, and the sigma where a joint's sigma is not finite."""
    from torquemap.kinematics import force_and_sigma

    return force_and_sigma(q, tau, tau_sigma, arm.link_lengths, min_sin_elbow=guard)


def _force_sigma(
    arm: Any,
    q: NDArray[np.float64],
    tau_sigma: NDArray[np.float64],
    singular: NDArray[np.bool_],
) -> NDArray[np.float64]:
    """One standard deviation of each wrench component ``F = pinv(J^T) tau`` from independent
    joint-torque sigmas."""
    out = np.full((q.shape[0], len(arm.wrench_axes)), np.nan)
    ok = ~singular & np.isfinite(q).all(axis=1) & np.isfinite(tau_sigma).all(axis=1)
    if not ok.any():
        return out
    every = bool(ok.all())  # no gather (a copy of every row) when every row is answered
    qk, sk = (q, tau_sigma) if every else (q[ok], tau_sigma[ok])
    jac = np.asarray(arm.jacobian(qk), dtype=np.float64)
    if jac.shape[-2:] == (2, 2):
        # J^T = [[a, b], [c, d]] inverted in closed form (batched pinv is an SVD each):
        # F = [[d, -b], [-c, a]] tau / det, so each component's variance is a sum of squares
        a, b, c, d = jac[:, 0, 0], jac[:, 1, 0], jac[:, 0, 1], jac[:, 1, 1]
        inv_det2 = 1.0 / (a * d - b * c) ** 2
        v0, v1 = sk[:, 0] ** 2, sk[:, 1] ** 2
        f0 = np.sqrt((d * d * v0 + b * b * v1) * inv_det2)
        f1 = np.sqrt((c * c * v0 + a * a * v1) * inv_det2)
        if every:
            out[:, 0], out[:, 1] = f0, f1
        else:
            out[ok, 0], out[ok, 1] = f0, f1
    else:
        jt = np.swapaxes(jac, -1, -2)
        m = np.asarray(np.linalg.pinv(jt), dtype=np.float64)  # (n, axes, nj): F = m @ tau
        out[ok] = np.sqrt(np.einsum("nij,nj->ni", m**2, sk**2))
    return out


@dataclass(frozen=True, slots=True, eq=False)
class _Shared:
    """What a piece's estimate computes that its reversal masks do not change, for a second
    estimate of the same piece with other masks (:func:`_choose_end_runs`) and the delay
    check (:func:`torquemap.task_delay.task_delay_warnings`).

    ``log``: the piece with its torque channels' delays undone; ``modulation``: the arm's
    inertia modulation at ``log.q``; ``t_est``, ``angle``, ``velocity``, ``acceleration``:
    :func:`_signal` of ``log``; per joint index, ``phasors`` (cos and sin of the motor angle)
    and ``residuals`` (``t_est`` less PDTV) of the joints with lines, ``extra`` (the noise
    excess) and ``sigma_terms`` (:func:`torquemap.uncertainty.joint_sigma`'s terms that do not
    depend on ``bridged``); ``coupling``: the planar coupling level (``None`` when none)."""

    log: Log
    modulation: NDArray[np.float64]
    t_est: NDArray[np.float64]
    angle: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    phasors: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]]
    residuals: dict[int, NDArray[np.float64]]
    extra: dict[int, float]
    sigma_terms: dict[int, dict[str, Any]]
    coupling: NDArray[np.float64] | None


@dataclass(frozen=True, slots=True, eq=False)
class _PieceEstimate:
    arrays: dict[str, NDArray[np.float64]]
    flag: NDArray[np.int64]
    passes: tuple[tuple[Pass, ...], ...]
    any_pass: bool
    warnings: tuple[str, ...]
    shared: _Shared | None = None


def _estimate_piece(
    model: Model,
    log: Log,
    *,
    method: Method,
    cutoff: float,
    window: float,
    notch_width: float,
    min_revolutions: float,
    bridge_reversals: float,
    channel_delay: Mapping[str, float] | None,
    reversal_band: float | Mapping[str, float] | None,
    answers_only: bool = False,
    rest_override: Mapping[int, NDArray[np.bool_]] | None = None,
    shared: _Shared | None = None,
    joints: Sequence[int] | None = None,
) -> _PieceEstimate:
    """:func:`estimate_forces` on one piece of a log (no gap, sound samples).

    ``rest_override``: per joint index, the reversal mask to use instead of the band's
    (:func:`_law_end_runs`). ``shared``: an earlier estimate's :class:`_Shared` of the same
    piece with the same options (its terms are taken, not computed again: the same numbers).
    ``joints``: the joint indices whose answers are computed (default all; the others' are
    NaN, without passes or rest)."""
    robot = model.robot
    if shared is None:
        delays = identified_delays(model) if channel_delay is None else dict(channel_delay)
        if any(delays.values()):
            from torquemap.delay import shift_channel

            tau = log.motor_torque.copy()
            for k, name in enumerate(robot.joint_names):
                if delays.get(name, 0.0):
                    tau[:, k] = shift_channel(log.t, tau[:, k], delays[name])
            log = dataclasses.replace(log, motor_torque=tau)
        modulation = robot.arm.inertia_modulation(log.q)
        t_est, angle, velocity, acceleration = _signal(
            model, log, window=window, modulation=modulation
        )
    else:
        log, modulation = shared.log, shared.modulation
        t_est, angle, velocity = shared.t_est, shared.angle, shared.velocity
        acceleration = shared.acceleration
    n, nj = t_est.shape
    todo = set(range(nj)) if joints is None else set(joints)
    warnings: list[str] = []
    flag = np.zeros(n, dtype=np.int64)
    all_passes: list[tuple[Pass, ...]] = []
    rests: list[NDArray[np.bool_]] = []
    whole = whole_fit_joints(model)
    bands = _bands(model, reversal_band)
    for name, band in bands.items():
        if not (math.isfinite(band) and band >= 0):
            raise InputError(f"reversal band of joint {name} must be >= 0, got {band!r} rad/s")
    for k, joint in enumerate(robot.joints):
        jm = model.joints[joint.name]
        w0 = max(bands[joint.name], 1e-9)
        rest = np.zeros(n, dtype=bool)
        if k not in todo:
            rests.append(rest)
            all_passes.append(())
            continue
        if max(jm.friction.static_levels()) > 0:
            if rest_override is not None and k in rest_override:
                rest = rest_override[k]
            else:
                rest = reversal_mask(log.t, velocity[:, k], band=w0, window=window)
            if joint.name not in whole:
                flag[rest] |= FLAG_LOW_SPEED
        rests.append(rest)
        if answers_only and method != "paper":
            all_passes.append(())  # the table holds no passes
            continue
        all_passes.append(
            monotonic_passes(
                log.t,
                angle[:, k],
                velocity[:, k],
                speed_threshold=w0,
                min_revolutions=min_revolutions,
            )
        )

    runs = [_gap_runs(rest) for rest in rests]  # once per joint: every bridge uses them

    def prepared(x: NDArray[np.float64], k: int) -> tuple[list[NDArray[np.float64]], Any]:
        """What the low-pass of ``x`` (joint ``k``) filters, and where the second column wins.

        Stretches too long to bridge (a hold, the log's ends) keep the model's value; they must
        not leak into the samples around them through the filter, which therefore sees them
        filled from their neighbours. Where the model knows friction through zero
        (whole-log identification) the answer there is the estimate carried over from the
        neighbours (its sigma covers the friction band): the external load is continuous,
        the friction at rest is not known.
        """
        if bridge_reversals <= 0 or not runs[k]:
            return [x], None
        gaps = rests[k]
        bridged = bridge_gaps(
            log.t, x, gaps, longest=bridge_reversals, support=window, runs=runs[k]
        )
        held = gaps & ~bridged_runs(log.t, gaps, longest=bridge_reversals, runs=runs[k])
        if not held.any():
            return [bridged], None
        filled = bridge_gaps(
            log.t, x, gaps, longest=math.inf, support=window, ends=True, runs=runs[k]
        )
        if robot.joints[k].name in whole:
            return [filled], None
        return [bridged, filled], held

    # every low-pass of the piece in one call (the filter and its checks run once)
    jobs: list[tuple[NDArray[np.float64], int]] = []
    lined = [k for k, j in enumerate(robot.joints) if model.joints[j.name].pdtv and k in todo]
    # ``filtered`` of a joint with lines is not an answer of the model method
    unfiltered = set(lined) if answers_only and method == "model" else set()
    smoothed_at: dict[int, int] = {}
    if method != "raw":
        for k in range(nj):
            if k not in unfiltered and k in todo:
                smoothed_at[k] = len(jobs)
                jobs.append((t_est[:, k], k))
    first_external = len(jobs)
    # cos and sin of each lined joint's motor angle, for its PDTV and its sigma's regressor
    phasors: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}
    residuals: dict[int, NDArray[np.float64]] = {}  # t_est less PDTV, for the noise level
    if shared is not None:
        phasors, residuals = shared.phasors, shared.residuals
        for k in lined if method == "model" else ():
            jobs.append((residuals[k], k))
    elif method == "model":
        for k in lined:
            lines = model.joints[robot.joints[k].name].pdtv
            theta = np.ascontiguousarray(angle[:, k])
            phasors[k] = (np.cos(theta), np.sin(theta))
            pdtv = pdtv_torque(theta, lines, velocity=velocity[:, k], phasor=phasors[k])
            residuals[k] = t_est[:, k] - pdtv
            jobs.append((residuals[k], k))
    plans: list[tuple[int, int, Any]] = []
    columns: list[NDArray[np.float64]] = []
    for x, k in jobs:
        cols, held = prepared(x, k)
        plans.append((len(columns), len(cols), held))
        columns.extend(cols)
    smoothed: list[NDArray[np.float64]] = []
    if columns:
        try:
            y = lowpass(log.t, np.column_stack(columns), cutoff=cutoff)
        except InputError as exc:
            raise InputError(exc.message, path=log.path) from None
        for first, count, held in plans:
            part = y[:, first]
            if count == 2:
                part = np.where(held, part, y[:, first + 1])
            smoothed.append(part)
    if method == "raw":
        filtered = t_est.copy()
        external = t_est.copy()
    else:  # every column written: no copy of t_est first
        filtered = np.empty_like(t_est)
        for k in range(nj):
            filtered[:, k] = smoothed[smoothed_at[k]] if k in smoothed_at else np.nan
    any_pass = False
    if method == "lowpass":
        external = filtered.copy()
    elif method == "model":
        external = filtered.copy()
        for i, k in enumerate(lined):
            external[:, k] = smoothed[first_external + i]
    elif method == "paper":
        external = filtered.copy()
        for k, joint in enumerate(robot.joints):
            orders = sorted({line.order for line in model.joints[joint.name].pdtv})
            if not orders:
                continue
            covered = np.zeros(n, dtype=bool)
            skipped: set[float] = set()
            for p in all_passes[k]:
                sl = slice(p.start, p.stop)
                spr = (p.stop - p.start) / p.revolutions
                external[sl, k], skip = _position_filter(
                    angle[sl, k], filtered[sl, k], orders, width=notch_width, samples_per_rev=spr
                )
                skipped.update(skip)
                covered[sl] = True
                any_pass = True
            flag[~covered] |= FLAG_NO_PASS
            if skipped:
                warnings.append(
                    f"joint {joint.name}: PDTV orders {', '.join(f'{f:g}' for f in sorted(skipped))} "
                    "CPR lie above the position Nyquist of some passes (too fast for the "
                    "sampling rate) and were not notched there"
                )
            if (~covered).any():
                warnings.append(
                    f"joint {joint.name}: {np.mean(~covered):.1%} of samples lie outside monotonic "
                    f"passes of {min_revolutions:g} motor revolutions and keep their PDTV"
                )
    sigma = np.full((n, nj), np.nan)
    coupling = None
    extras: dict[int, float] = {} if shared is None else shared.extra
    sigma_terms: dict[int, dict[str, Any]] = {} if shared is None else shared.sigma_terms
    if method == "model":
        from torquemap import uncertainty
        from torquemap._estimate_kernels import hypot_into
        from torquemap.tones import nominal_step
        from torquemap.uncertainty import (
            bridge_departure,
            joint_sigma,
            noise_excess,
            white_noise_excess,
        )

        rate = 1.0 / nominal_step(log.t) if n > 1 else math.nan
        coupling = None
        if shared is not None:
            coupling = shared.coupling
        elif uncertainty.COUPLING:
            coupling = uncertainty.coupling_level(
                model,
                t=log.t,
                q=log.q,
                velocity=velocity,
                acceleration=acceleration,
                cutoff=cutoff,
            )
        # the median step, once for every joint's noise level
        median_step = None
        if shared is None:
            median_step = float(np.median(np.diff(log.t))) if n > 1 else None
        for k, joint in enumerate(robot.joints):
            if k not in todo:
                continue
            if shared is not None:
                extra = shared.extra[k]
            else:
                # white noise this log holds beyond the identification logs' (a slower
                # logger); with WHITE_EXCESS only its white part (the same level above 20 Hz
                # and an eighth of the rate; measured, off)
                excess = white_noise_excess if uncertainty.WHITE_EXCESS else noise_excess
                extras[k] = extra = excess(
                    model,
                    joint.name,
                    t=log.t,
                    residual=residuals.get(k, t_est[:, k]),
                    velocity=velocity[:, k],
                    step=median_step,
                )
            # the widening terms by the compiled hypot (within an ulp of numpy's, a third of
            # its time), in one contiguous column written once
            column = np.array(
                joint_sigma(
                    model,
                    joint.name,
                    t=log.t,
                    theta=angle[:, k],
                    velocity=velocity[:, k],
                    acceleration=acceleration[:, k],
                    modulation=modulation[:, k],
                    cutoff=cutoff,
                    bridged=rests[k],
                    phasor=phasors.get(k),
                    extra_psd=extra,
                    support=window,
                    terms=sigma_terms.setdefault(k, {}),
                ),
                dtype=np.float64,
            )
            if runs[k] and joint.name in whole:
                # where the answer is a line carried over a bridged run: the load's departure
                departure = bridge_departure(
                    log.t, external[:, k], rests[k], cutoff=cutoff, runs=runs[k]
                )
                hypot_into(column, np.ascontiguousarray(departure, dtype=np.float64), column)
            if coupling is not None:
                # the other joint's inertia and the Coriolis torques Eq 7 leaves in the answer
                hypot_into(column, np.ascontiguousarray(coupling[:, k], dtype=np.float64), column)
            # a second estimate's warnings are not read (:func:`_choose_end_runs`): no median
            folded = _folded_tones(model, joint.name, rate, cutoff, column, warn=shared is None)
            if folded is not None:
                sd, line = folded
                hypot_into(column, np.full(n, sd), column)
                if line:
                    warnings.append(line)
            sigma[:, k] = column
    arrays = {
        "rest": np.column_stack(rests).astype(np.float64) if nj else np.zeros((n, 0)),
        "angle": angle,
        "velocity": velocity,
        "t_est": t_est,
        "filtered": filtered,
        "external": external,
        "sigma": sigma,
    }
    return _PieceEstimate(
        arrays=arrays,
        flag=flag,
        passes=tuple(all_passes),
        any_pass=any_pass,
        warnings=tuple(warnings),
        shared=shared
        or _Shared(
            log=log,
            modulation=modulation,
            t_est=t_est,
            angle=angle,
            velocity=velocity,
            acceleration=acceleration,
            phasors=phasors,
            residuals=residuals,
            extra=extras,
            sigma_terms=sigma_terms,
            coupling=coupling,
        ),
    )


#: A folded tone is reported when it widens the joint's median sigma by more than this share.
TONE_REPORT = 0.1


def _folded_tones(
    model: Model,
    joint: str,
    rate: float,
    cutoff: float,
    sigma: NDArray[np.float64],
    *,
    warn: bool = True,
) -> tuple[float, str] | None:
    """The standard deviation [N m, motor side] the model's tones add to this log's estimate of
    ``joint`` once folded to the log's ``rate`` [Hz] (:func:`torquemap.tones.folded_sd`), and a
    warning when it widens the median ``sigma`` by more than :data:`TONE_REPORT` (``warn``
    false: no warning, and no median taken); None when none folds into the band."""
    from torquemap.robust import exact_median
    from torquemap.tones import folded, folded_sd
    from torquemap.uncertainty import model_tones

    tones = model_tones(model, joint)
    if not tones or not (math.isfinite(rate) and math.isfinite(cutoff) and cutoff > 0):
        return None
    sd = folded_sd(tones, rate, cutoff)
    if not sd > 0:
        return None
    if not warn:
        return sd, ""
    # numpy's nanmedian: the median of the values that are not NaN
    base = exact_median(sigma[~np.isnan(sigma)]) if np.isfinite(sigma).any() else 0.0
    if math.hypot(base, sd) <= (1.0 + TONE_REPORT) * base:
        return sd, ""
    worst = max(tones, key=lambda x: folded_sd([x], rate, cutoff))
    line = (
        f"joint {joint}: the identification logs hold a {worst.frequency:.4g} Hz line of "
        f"{worst.amplitude:.3g} N m in the motor torque (fixed in time: amplifier or supply "
        f"ripple); this log, sampled at {rate:.4g} Hz, folds it to "
        f"{folded(worst.frequency, rate):.2g} Hz, inside the estimate's {cutoff:g} Hz band, "
        "where it reads as a load no filter can take out; the sigmas include it "
        f"({sd:.3g} N m, motor side). Log at a rate that does not fold it near 0 Hz, or "
        "through an anti-alias filter"
    )
    return sd, line


def check_answered(
    estimate: ForceEstimate,
    model: Model,
    *,
    reversal_band: float | Mapping[str, float] | None = None,
    path: str | None = None,
) -> None:
    """Refuse (InputError) an estimate in which every sample is flagged slow
    (``FLAG_LOW_SPEED``): the log is too slow for the model, and the line says what to record
    instead. ``torquemap estimate`` calls it before writing; the library returns such an
    estimate (every sample flagged, answered)."""
    slow = (estimate.flag & FLAG_LOW_SPEED) > 0
    if slow.size and slow.all():
        listed = ", ".join(
            f"{name} {value:.3g} rad/s" for name, value in _bands(model, reversal_band).items()
        )
        raise InputError(
            "at every sample of the log some joint moves slower than its reversal band "
            f"(motor side: {listed}), where this model's friction is undetermined (it has "
            "no friction law through zero speed): record every joint moving faster than "
            "that, or identify the model with --friction whole (friction through zero speed)",
            path=path,
        )


def _bands(model: Model, reversal_band: float | Mapping[str, float] | None) -> dict[str, float]:
    """Each joint's reversal band [rad/s, motor side] (:func:`estimate_forces`)."""
    robot = model.robot
    if reversal_band is None:
        whole = whole_fit_joints(model)
        slowest = identified_slowest_speeds(model)
        observed = observed_speeds(model)
        return {
            j.name: (
                max(
                    TRANSITION_SPAN * _law_width(model.joints[j.name].friction),
                    observed.get(j.name, 0.0),
                )
                if j.name in whole
                else max(_law_width(model.joints[j.name].friction), slowest.get(j.name, 0.0))
            )
            for j in robot.joints
        }
    if isinstance(reversal_band, Mapping):
        return {
            j.name: float(reversal_band.get(j.name, _law_width(model.joints[j.name].friction)))
            for j in robot.joints
        }
    return {j.name: float(reversal_band) for j in robot.joints}


#: Where a law's smooth transition through zero still blends the two branches, in units of its
#: width: ``tanh(4) = 0.9993``. Below it the sign of friction follows the measured velocity only
#: loosely (stick-slip at a reversal, creep), so ``T_est`` is bridged there.
TRANSITION_SPAN = 4.0


def _law_width(law: Any) -> float:
    """The friction law's transition half width [rad/s] (its ``zero_velocity``, else 0)."""
    return float(getattr(law, "zero_velocity", 0.0))


def whole_fit_joints(model: Model) -> set[str]:
    """Joints whose friction was identified through zero speed from whole logs (their notes say
    ``friction_fit = "whole"``)."""
    out: set[str] = set()
    joints = model.notes.get("joints", {})
    if isinstance(joints, Mapping):
        for name, entry in joints.items():
            if isinstance(entry, Mapping) and entry.get("friction_fit") == "whole":
                out.add(str(name))
    return out


def model_window(model: Model) -> float:
    """The differentiator window [s] the model was identified with, else 0.05 s."""
    value = model.notes.get("differentiation_window")
    if isinstance(value, int | float) and not isinstance(value, bool):
        if math.isfinite(value) and value > 0:
            return float(value)
    return 0.05


def _motor_steps(model: Model, log: Log) -> Iterator[tuple[int, Joint, float, NDArray[np.float64]]]:
    """Each joint with a recorded encoder count: its index, the joint, one count at the motor
    [rad] (``[identification.joints.<j>] motor_angle_quantum``) and the log's nonzero
    motor-angle steps [rad]."""
    joints = model.notes.get("joints", {})
    if not isinstance(joints, Mapping):
        return
    for k, joint in enumerate(model.robot.joints):
        entry = joints.get(joint.name)
        if not isinstance(entry, Mapping):
            continue
        quantum = entry.get("motor_angle_quantum")
        if not isinstance(quantum, int | float) or not (quantum > 0 and math.isfinite(quantum)):
            continue
        step = np.abs(np.diff(joint.gear_ratio * log.q[:, k]))
        yield k, joint, float(quantum), step[step > 1e-12]


def check_log_angle_units(model: Model, log: Log) -> None:
    """Refuse a log whose angles move by whole encoder counts of another unit or side of the
    gear than the model's robot (:func:`torquemap.log_quirks.angle_unit_hint`).

    Where identification recorded a joint's ``motor_angle_quantum`` and the log moves by
    whole multiples of its own smallest step (:func:`torquemap.log_quirks.motor_angle_quantum`),
    that step over the model's is 1 for the joint angle in rad, the gear ratio for the motor
    angle, ``gear_ratio / 2 pi`` for motor turns, and so on. Before (new-user QA, stop 36), a
    motor angle of the paper bench (100:1: whole counts, 100 at a time) passed the checks
    below, and other ratios were refused as "a log from another robot?". Angles computed from
    a count register that overflows are refused first
    (:func:`torquemap.log_quirks.check_register_angles`).
    """
    check_register_angles(log, model.robot)
    for k, joint, quantum, _ in _motor_steps(model, log):
        if joint.position_unit != "rad":
            continue
        own = motor_angle_quantum(log.q[:, k], joint.gear_ratio)
        if not own:
            continue
        ratio = own / quantum
        hint = angle_unit_hint(ratio, gear_ratio=joint.gear_ratio, column=f"q_{joint.name}")
        if hint is not None:
            raise InputError(
                f"joint {joint.name}: the log's motor angle moves in steps of {ratio:.4g} "
                f"encoder counts of the model's robot: {hint}",
                path=log.path,
            )


#: Steps of at most this many encoder counts decide whether a log is of the model's robot.
FEW_COUNTS = 10


def check_log_matches_model(model: Model, log: Log) -> None:
    """Refuse a log whose motor-angle steps are not whole encoder counts of the model's robot.

    Identification records each joint's motor-angle quantum (``[identification.joints.<j>]
    motor_angle_quantum``, one encoder count at the motor). A log of the same robot moves by
    whole counts; one from another robot (another encoder, another gear ratio) does not. Only
    quantised logs are checked, and only where the log moves; where it has at least 20 steps
    of at most ``FEW_COUNTS`` counts, only those (a step of many counts is whole within the 2 %
    tolerance for any encoder).
    """
    for k, joint, quantum, step in _motor_steps(model, log):
        if step.size < 20:
            continue
        ratio = step / quantum
        whole = np.abs(ratio - np.round(ratio)) < 0.02 * np.maximum(1.0, ratio)
        # within its 2 % tolerance a step of 25 counts or more is "whole" whatever the encoder:
        # a high-resolution encoder at speed moves hundreds of counts a sample, so the steps of
        # a few counts (near rest and reversals) decide where the log has enough of them
        few = np.round(ratio) <= FEW_COUNTS
        if int(few.sum()) >= 20:
            whole, ratio = whole[few], ratio[few]
        if float(np.mean(whole & (np.round(ratio) >= 1))) < 0.9:
            seen = float(np.min(step))
            if _narrow_float_whole(joint, log.q[:, k], quantum, log.path):
                continue
            # the decimals are those of the log's own unit: counts written "%.3f" (a drive's
            # counts with 1/64 fractions) were "a log from another robot"
            unit, scale, at = "rad", 1.0 / joint.gear_ratio, " at the joint"
            if joint.position_unit == "counts" and joint.encoder_counts_per_rev:
                unit, scale, at = "counts", joint.encoder_counts_per_rev / (2 * math.pi), ""
            elif joint.position_unit == "turns":
                unit, scale, at = "turns", 1.0 / (2 * math.pi), ""
            digits = _written_digits(step * scale)
            if digits is None:
                digits = _rounded_digits(step * scale)
            if digits is None:
                # counts written "%.6E" hold 7 significant digits: 1e-3 count above 1000
                values = joint.gear_ratio * log.q[:, k] * scale
                wraps = [values]
                if unit == "counts":
                    wraps.append(np.mod(values, float(joint.encoder_counts_per_rev or 0)))
                found = [_significant_digits(series, quantum * scale) for series in wraps]
                if any(d is not None for d in found):
                    significant = min(d for d in found if d is not None)
                    raise InputError(
                        f"joint {joint.name}: the log's q_{joint.name} is not whole "
                        f"encoder counts of the model's robot ({quantum * scale:.4g} "
                        f"{unit}{at}) but its values are rounded to {significant} "
                        "significant digits (a format such as '%.6E'): write the angles "
                        "with all their digits (e.g. '%.17g')",
                        path=log.path,
                    )
            if digits is not None:
                raise InputError(
                    f"joint {joint.name}: the log's q_{joint.name} moves in steps of "
                    f"1e-{digits:02d} {unit}, not whole encoder counts of the model's robot "
                    f"({quantum * scale:.4g} {unit}{at}): it was written with "
                    f"{digits} decimals; write the angles with all their digits"
                    + (
                        " (or as encoder counts, position_unit = 'counts')" if unit == "rad" else ""
                    ),
                    path=log.path,
                )
            raise InputError(
                f"joint {joint.name}: the log's motor angle moves in steps of {seen:.4g} rad, "
                f"not whole encoder counts of the model's robot ({quantum:.4g} rad = 2 pi / "
                f"{2 * math.pi / quantum:.0f} at the motor): a log from another robot (encoder "
                "or gear ratio differ)? Identify a model from this robot's own no-load logs",
                path=log.path,
            )


#: Steps of up to this many encoder counts are tested for being whole to ``EXACT_COUNT``.
EXACT_STEPS = 200
#: How far from a whole count [counts] a step of a few counts of the model's robot may be: a
#: log of that robot, written with all its digits, is whole to 1e-6 count or better.
EXACT_COUNT = 0.05


def check_log_steps_exact(model: Model, log: Log) -> None:
    """Refuse a log whose steps of a few encoder counts are not whole counts of the model's.

    :func:`check_log_matches_model` tolerates 2 % of a step (the steps of a high-resolution
    encoder at speed): a log from a robot with a coarser encoder and another gear ratio then
    passes when one of its counts is near a whole number of the model's (random SCARA 214's
    model on 213's circle: each step 9.118 of its counts, inside 2 % of 9; the forces 2.7
    times the truth, exit 0). Its steps of 1 to ``EXACT_STEPS`` counts are whole to
    ``EXACT_COUNT`` on the robot's own logs (to 3e-7 count on random SCARAs 200-219, circles
    and sweeps) and on none of such a log's: of the 1560 cross pairs (model, circle) among
    random SCARAs 200-239, :func:`check_log_matches_model` accepted 116, this check with steps
    up to 50 counts left 13 (a coarse log's smallest step above 50 of the model's counts),
    up to 200 none; all 40 own circles pass. Where a joint has at least 20 of them and fewer than
    half are whole to that, the log is refused, unless its angles were rounded when written
    (the rounding, not the robot, is then off; :func:`check_log_matches_model` names it).
    """
    for k, joint, quantum, step in _motor_steps(model, log):
        ratio = step / quantum
        few = (np.round(ratio) >= 1) & (np.round(ratio) <= EXACT_STEPS)
        if int(few.sum()) < 20:
            continue
        off = np.abs(ratio[few] - np.round(ratio[few]))
        if float(np.mean(off < EXACT_COUNT)) >= 0.5:
            continue
        joint_step = step / joint.gear_ratio
        if _written_digits(joint_step) is not None or _rounded_digits(joint_step) is not None:
            continue
        if _significant_digits(log.q[:, k], quantum / joint.gear_ratio) is not None:
            continue
        typical = float(np.median(ratio[few]))
        if _narrow_float_whole(joint, log.q[:, k], quantum, log.path):
            continue
        raise InputError(
            f"joint {joint.name}: the log's motor angle moves in steps of a few encoder counts "
            f"of the model's robot that are not whole ({float(np.min(ratio)):.4g}, median "
            f"{typical:.4g} counts of 2 pi / {2 * math.pi / quantum:.0f} rad at the motor): a "
            "log from another robot (encoder or gear ratio differ)? Identify a model from this "
            "robot's own no-load logs",
            path=log.path,
        )


def _narrow_float_whole(joint: Joint, q: NDArray[np.float64], quantum: float, path: str) -> bool:
    """Whether the log's angle column is a narrow float in a Parquet file
    (:func:`torquemap.log_quirks.narrow_float_column`) whose steps of a few counts are whole
    counts of the model's robot within what that float holds: then the log is of the robot,
    rounded by its float32 column (random SCARA 7's circle as float32: 0.06 count, refused as
    "a log from another robot?" before, new-user QA stop 36). InputError naming float32 when it
    cannot hold a quarter count; False otherwise (another robot: the caller refuses)."""
    column = f"q_{joint.name}"
    kind = narrow_float_column(path, column)
    if kind is None:
        return False
    narrow = np.float32 if kind == "float" else np.float16
    top = float(np.max(np.abs(q)))
    count = quantum / joint.gear_ratio  # one count at the joint [rad]
    rounding = float(np.spacing(narrow(top))) / count  # [counts]
    name = "float32" if kind == "float" else "float16"
    if rounding >= 0.25:
        raise InputError(
            f"joint {joint.name}: the log's {column} is {name}, which holds the angle near "
            f"{top:.3g} rad only to {rounding:.2g} encoder counts of the model's robot: write "
            "the angles as float64",
            path=path,
        )
    step = np.abs(np.diff(q)) / count
    few = (np.round(step) >= 1) & (np.round(step) <= EXACT_STEPS)
    if int(few.sum()) < 20:
        return False
    off = np.abs(step[few] - np.round(step[few]))
    return float(np.mean(off < 2.0 * rounding + EXACT_COUNT)) >= 0.5


def _written_digits(step: NDArray[np.float64]) -> int | None:
    """The number of decimals ``d`` (1 to 12) when the nonzero joint-angle steps ``step`` [rad]
    are, nine in ten, whole multiples of ``10^-d`` and the smallest is ``10^-d``: angles rounded
    when the log was written (a CSV exported with a fixed format), else None.

    Examples
    --------
    >>> _written_digits(np.array([1e-4, 2e-4, 1e-4, 3e-4]) * (1 + 1e-9))
    4
    >>> _written_digits(np.array([7.85e-6, 1.57e-5])) is None
    True
    """
    smallest = float(np.min(step))
    if not smallest > 0:
        return None
    digits = round(-math.log10(smallest))
    if not 1 <= digits <= 12 or abs(smallest * 10.0**digits - 1.0) > 0.02:
        return None
    ratio = step * 10.0**digits
    return digits if float(np.mean(np.abs(ratio - np.round(ratio)) < 0.02)) >= 0.9 else None


def _significant_digits(values: NDArray[np.float64], quantum: float) -> int | None:
    """The fewest significant digits ``s`` (1 to 12) to which the angles ``values`` are, nine
    in ten, rounded, when that rounding (each value off by up to half its last digit) explains
    nine in ten of the steps that are not whole ``quantum`` and is, in the median, at most a
    quarter of ``quantum`` (coarser, it would explain any step), else None: a log written with a format such as ``"%.6E"``.

    ``values`` and ``quantum`` are in the same unit (the log's own).

    Examples
    --------
    >>> q = 1000.0 + np.arange(200) / 64.0  # 1/64 counts
    >>> _significant_digits(np.array([float(f"{v:.6E}") for v in q]), 1 / 64)
    7
    >>> _significant_digits(1000.0 + np.arange(200) / 50.0, 1 / 64) is None
    True
    """
    values = np.asarray(values, dtype=np.float64)
    nonzero = values != 0
    if int(nonzero.sum()) < 20 or not quantum > 0:
        return None
    exponent = np.zeros_like(values)
    exponent[nonzero] = np.floor(np.log10(np.abs(values[nonzero])))
    ratio = np.diff(values) / quantum
    moved = ratio != 0
    off = np.abs(ratio - np.round(ratio))
    for digits in range(1, 13):
        last = np.where(nonzero, 10.0 ** (exponent - digits + 1), 0.0)
        held = values[nonzero] / last[nonzero]
        slack = np.maximum(1e-6, 8 * np.finfo(np.float64).eps * np.abs(held))
        if float(np.mean(np.abs(held - np.round(held)) <= slack)) < 0.9:
            continue
        bound = (last[1:] + last[:-1]) / 2.0 / quantum + 0.02
        if not moved.any() or float(np.median(last[nonzero])) > quantum / 4:
            return None
        explained = float(np.mean(off[moved] <= bound[moved] * (1 + 1e-9)))
        return digits if explained >= 0.9 else None
    return None


def _rounded_digits(step: NDArray[np.float64]) -> int | None:
    """The fewest decimals ``d`` (1 to 12) of which the nonzero steps ``step`` are, nine in
    ten, whole multiples, the smallest step holding at most 100 of them: values rounded when
    written, where the steps are a few of the last digit each (an encoder's 1/64 count
    written "%.3f": 0.015 and 0.016), else None.

    Examples
    --------
    >>> _rounded_digits(np.array([0.015, 0.016, 0.031, 0.047]) * (1 + 1e-12))
    3
    >>> _rounded_digits(np.array([0.015625, 0.03125, 0.046875])) is None
    True
    """
    smallest = float(np.min(step))
    if not smallest > 0:
        return None
    for digits in range(1, 13):
        if smallest * 10.0**digits > 100.0:
            return None
        ratio = step * 10.0**digits
        if float(np.mean(np.abs(ratio - np.round(ratio)) < 0.02)) >= 0.9:
            return digits if smallest * 10.0**digits >= 0.98 else None
    return None


def identified_slowest_speeds(model: Model) -> dict[str, float]:
    """Per joint, the slowest steady motor speed [rad/s] identification measured friction at
    (the smallest ``|speed|`` of ``[identification.joints.<j>] speeds`` in the model's notes);
    joints without such notes are left out.

    Examples
    --------
    >>> notes = {"joints": {"a": {"speeds": [2.0, -0.5, 1.0]}}}
    >>> m = Model(robot=None, joints={}, notes=notes)  # only the notes matter here
    >>> identified_slowest_speeds(m)
    {'a': 0.5}
    """
    return {name: min(values) for name, values in _identified_speeds(model).items()}


def _identified_speeds(model: Model, *, signed: bool = False) -> dict[str, list[float]]:
    """Per joint, the steady motor speeds [rad/s] of ``[identification.joints.<j>] speeds``
    (finite and nonzero; magnitudes unless ``signed``); joints without any are left out."""
    out: dict[str, list[float]] = {}
    joints = model.notes.get("joints", {})
    if isinstance(joints, Mapping):
        for name, entry in joints.items():
            speeds = entry.get("speeds") if isinstance(entry, Mapping) else None
            if isinstance(speeds, list | tuple):
                values = [float(v) for v in speeds if isinstance(v, int | float)]
                values = [v for v in values if math.isfinite(v) and v != 0]
                if values:
                    out[str(name)] = values if signed else [abs(v) for v in values]
    return out


def unidentified_joint_warnings(model: Model) -> list[str]:
    """One line per joint that identification left unidentified (its notes say no steady
    pass and no whole-log fit: the joint never moved in the identification logs). Its model is
    the robot file's (no friction, inertia or PDTV from data), so its external torque and the
    forces that use it are not the robot's.

    Examples
    --------
    >>> from torquemap.robot import robot_from_dict
    >>> rb = robot_from_dict({"robot": {"name": "m", "kinematics": "none"}, "joints": {"a": {
    ...     "gear_ratio": 1.0, "torque_constant": 0.1}}})
    >>> m = Model(robot=rb, joints={}, notes={"joints": {"a": {"passes": 0}}})
    >>> unidentified_joint_warnings(m)[0][:46]
    'joint a was not identified (it never moved at '
    """
    joints = model.notes.get("joints", {})
    out: list[str] = []
    if not isinstance(joints, Mapping):
        return out
    for name, entry in joints.items():
        if (
            isinstance(entry, Mapping)
            and entry.get("passes") == 0
            and entry.get("friction_fit") != "whole"
        ):
            out.append(
                f"joint {name} was not identified (it never moved at a steady speed in the "
                "identification logs): its model holds no friction, inertia or PDTV from data, "
                f"so tau_ext_{name} and the forces are not the robot's; identify from sweeps "
                f"that move joint {name}"
            )
    return out


#: How much faster than the fastest steady pass of identification a sample may run before
#: estimation says its friction is extrapolated (the sweeps' own ramps and ripple reach ~1.2x).
FAST_TASK_FACTOR = 1.5


def fast_task_warnings(model: Model, velocity: NDArray[np.float64]) -> list[str]:
    """One line per joint whose log runs, on at least ``SLOW_TASK_SHARE`` of its samples,
    faster than ``FAST_TASK_FACTOR`` times the fastest steady speed identification measured
    friction at (``[identification.joints.<j>] speeds``): there the friction law is
    extrapolated, or the log is not in the units the robot file says (degrees for radians).
    ``velocity`` is the motor velocity [rad/s], shape (n, n_joints).

    Examples
    --------
    >>> from torquemap.robot import robot_from_dict
    >>> rb = robot_from_dict({"robot": {"name": "m", "kinematics": "none"}, "joints": {"a": {
    ...     "gear_ratio": 1.0, "torque_constant": 0.1}}})
    >>> m = Model(robot=rb, joints={}, notes={"joints": {"a": {"speeds": [2.0, -2.2]}}})
    >>> fast_task_warnings(m, np.linspace(1.0, 10.0, 100)[:, None])[0][:30]  # 74 above 3.3
    'joint a: 74% of the samples ru'
    """
    out: list[str] = []
    speeds = _identified_speeds(model)
    for k, name in enumerate(model.robot.joint_names):
        if name not in speeds:
            continue
        top = max(speeds[name])
        speed = np.abs(velocity[:, k])
        speed = speed[np.isfinite(speed)]
        fast = speed[speed > FAST_TASK_FACTOR * top]
        if speed.size == 0 or fast.size < SLOW_TASK_SHARE * speed.size:
            continue
        out.append(
            f"joint {name}: {fast.size / speed.size:.0%} of the samples run at motor speeds "
            f"above {FAST_TASK_FACTOR:g} times the fastest steady sweep pass {top:.3g} rad/s "
            f"(up to {float(speed.max()):.3g} rad/s), where friction is extrapolated; record "
            "sweeps that fast, or check the log's units (q in rad, t in s)"
        )
    return out


#: How many times the identification logs' motor torque (99th percentile of its magnitude) a
#: log's may reach before estimation says so: a current logged in mA reads 1000 times too large
#: (a task's load on a friction-dominated joint reaches a few times the no-load level).
TORQUE_SCALE_FACTOR = 50.0


def identified_torque_levels(model: Model) -> dict[str, float]:
    """Per joint, the 99th percentile of ``|motor torque|`` [N m] in the identification logs
    (``[identification.joints.<j>] motor_torque_p99``, or ``[identification.arm]
    motor_torque_p99`` in the robot file's joint order); joints without it are left out (models
    written before it)."""
    notes = model.notes if isinstance(model.notes, Mapping) else {}
    out: dict[str, float] = {}
    joints = notes.get("joints", {})
    if isinstance(joints, Mapping):
        for name, entry in joints.items():
            if isinstance(entry, Mapping):
                level = entry.get("motor_torque_p99")
                if isinstance(level, int | float) and math.isfinite(level) and level > 0:
                    out[str(name)] = float(level)
    arm = notes.get("arm")
    levels = arm.get("motor_torque_p99") if isinstance(arm, Mapping) else None
    names = model.robot.joint_names
    if isinstance(levels, list) and len(levels) == len(names):
        for name, level in zip(names, levels, strict=True):
            if isinstance(level, int | float) and math.isfinite(level) and level > 0:
                out[name] = float(level)
    return out


def torque_scale_warnings(model: Model, motor_torque: NDArray[np.float64]) -> list[str]:
    """One line per joint whose log's motor torque (99th percentile of its magnitude) exceeds
    ``TORQUE_SCALE_FACTOR`` times the identification logs' (:func:`identified_torque_levels`):
    a current in mA, or a log whose current column is not the one identified from; the forces
    estimated from it are then off by as much. ``motor_torque`` [N m] has shape (n, n_joints).

    Examples
    --------
    >>> from torquemap.robot import robot_from_dict
    >>> rb = robot_from_dict({"robot": {"name": "m", "kinematics": "none"}, "joints": {"a": {
    ...     "gear_ratio": 1.0, "torque_constant": 0.1}}})
    >>> m = Model(robot=rb, joints={}, notes={"joints": {"a": {"motor_torque_p99": 0.05}}})
    >>> torque_scale_warnings(m, np.full((100, 1), 0.06))
    []
    >>> torque_scale_warnings(m, np.full((100, 1), 60.0))[0][:57]
    'joint a: the motor torque reaches 60 N m (99th percentile'
    """
    from torquemap.sanitize import top_percentile

    levels = identified_torque_levels(model)
    out: list[str] = []
    for k, name in enumerate(model.robot.joint_names):
        level = levels.get(name)
        column = np.abs(motor_torque[:, k])
        column = column[np.isfinite(column)]
        if level is None or column.size == 0:
            continue
        top = top_percentile(column, 99.0)  # numpy's percentile, bit for bit
        if top > TORQUE_SCALE_FACTOR * level:
            out.append(
                f"joint {name}: the motor torque reaches {top:.3g} N m (99th percentile), "
                f"{top / level:.3g} times the identification logs' {level:.3g} N m: check the "
                "log's units (current in A, not mA; tau in N m) and that it is of this robot; "
                f"tau_ext_{name} and the forces are off by as much as it is"
            )
    return out


#: Share of a log's samples below the slowest steady speed of identification (and above the
#: reversal band) from which estimation says so.
SLOW_TASK_SHARE = 0.05


def slow_task_warnings(model: Model, velocity: NDArray[np.float64]) -> list[str]:
    """One line per whole-fit joint whose log runs, on at least ``SLOW_TASK_SHARE`` of its
    samples, between its law's transition through zero (``TRANSITION_SPAN`` widths) and 80 %
    of the slowest steady speed identification measured friction at (``[identification.joints.<j>]
    speeds``): there friction comes from ramps and the table's prior, not from a steady pass,
    and the answer is bridged below the table's fitted speeds. ``velocity`` is the motor
    velocity [rad/s], shape (n, n_joints).

    Examples
    --------
    >>> from torquemap.robot import robot_from_dict
    >>> rb = robot_from_dict({"robot": {"name": "m", "kinematics": "none"}, "joints": {"a": {
    ...     "gear_ratio": 1.0, "torque_constant": 0.1, "encoder_counts_per_rev": 4096}}})
    >>> notes = {"joints": {"a": {"friction_fit": "whole", "speeds": [2.0, -2.2]}}}
    >>> m = Model(robot=rb, joints={}, notes=notes)
    >>> slow_task_warnings(m, np.linspace(0.5, 1.0, 100)[:, None])[0][:60]
    'joint a: 100% of the samples run at motor speeds below the s'
    """
    slowest = identified_slowest_speeds(model)
    whole = whole_fit_joints(model)
    out: list[str] = []
    for k, name in enumerate(model.robot.joint_names):
        top = slowest.get(name)
        if name not in whole or top is None:
            continue
        law = model.joints[name].friction if name in model.joints else None
        lower = TRANSITION_SPAN * _law_width(law)
        speed = np.abs(velocity[:, k])
        speed = speed[np.isfinite(speed)]
        # a pass's own speed ripple reaches below its mean: 80 % of it, as segmentation's
        slow = speed[(speed < 0.8 * top) & (speed >= lower)]
        if speed.size == 0 or slow.size < SLOW_TASK_SHARE * speed.size:
            continue
        low, typical = (float(x) for x in np.percentile(slow, [10, 50]))
        out.append(
            f"joint {name}: {slow.size / speed.size:.0%} of the samples run at motor speeds "
            f"below the slowest steady sweep pass {top:.3g} rad/s (median {typical:.3g}, 10 % "
            f"below {low:.3g} rad/s), where friction is extrapolated from ramps and the "
            f"identification's prior; record sweep passes down to about {low:.2g} rad/s"
        )
    return out


def held_end_warnings(
    model: Model,
    t: NDArray[np.float64],
    velocity: NDArray[np.float64],
    rest: NDArray[np.float64],
    *,
    pieces: Sequence[NDArray[np.int64]] | None = None,
    sigma: NDArray[np.float64] | None = None,
) -> list[str]:
    """One line per whole-fit joint whose runs below its reversal band at the ends of the log
    (or of a piece between gaps) hold, on at least ``SLOW_TASK_SHARE`` of the log's samples, a
    joint sliding above its law's transition (``TRANSITION_SPAN`` widths). :func:`estimate_forces`
    answers such a run with the answer next to it, held: a log that starts (or stops) with
    seconds of slow motion below the table's fitted speeds (``friction_observed_speed``) gets a
    constant there, whatever the load does (random robot 292: 5.3 s at the circle's start, 97 %
    of its squared force error, 47x the oracle's; its sigma covered it, no line named it).

    ``velocity``: motor velocity [rad/s] and ``rest``: the estimate's reversal mask (nonzero
    inside a run; NaN where not answered), shape (n, n_joints); ``pieces``: the rows of each
    piece (default one piece); ``sigma``: the joint-side sigma of ``tau_ext`` [N m], for the
    line.

    Examples
    --------
    >>> from torquemap.friction_law import StribeckFriction
    >>> from torquemap.model import JointModel
    >>> from torquemap.robot import robot_from_dict
    >>> rb = robot_from_dict({"robot": {"name": "m", "kinematics": "none"}, "joints": {"a": {
    ...     "gear_ratio": 1.0, "torque_constant": 0.1, "encoder_counts_per_rev": 4096}}})
    >>> law = StribeckFriction(coulomb_positive=0.1, coulomb_negative=0.1, zero_velocity=0.01)
    >>> notes = {"joints": {"a": {"friction_fit": "whole", "friction_observed_speed": 2.0}}}
    >>> m = Model(robot=rb, joints={"a": JointModel(friction=law)}, notes=notes)
    >>> t = np.arange(100) * 0.1
    >>> v = np.where(t < 3, 1.0, 5.0)[:, None]
    >>> held_end_warnings(m, t, v, (v < 2.0).astype(float))[0][:52]
    'joint a: 30% of the samples slide at motor speeds of'
    """
    n = t.size
    whole = whole_fit_joints(model)
    observed = observed_speeds(model)
    rows = [np.arange(n)] if pieces is None else list(pieces)
    out: list[str] = []
    for k, name in enumerate(model.robot.joint_names):
        if name not in whole or name not in model.joints or n == 0:
            continue
        width = TRANSITION_SPAN * _law_width(model.joints[name].friction)
        inside = np.nan_to_num(rest[:, k]) > 0
        speed = np.abs(velocity[:, k])
        moving = np.isfinite(speed) & (speed >= width)
        sliding = np.zeros(n, dtype=bool)
        spans: list[str] = []  # the held stretches with sliding samples
        for piece in rows:
            if piece.size == 0:
                continue
            for a, b in _gap_runs(inside[piece]):
                at = piece[a:b]
                if (a == 0 or b == piece.size) and moving[at].any():
                    sliding[at] = moving[at]
                    spans.append(f"{t[at[0]]:.3g}-{t[at[-1]]:.3g} s")
        if sliding.sum() < SLOW_TASK_SHARE * n:
            continue
        low = float(np.percentile(speed[sliding], 10))
        top = observed.get(name, float(np.max(speed[sliding])))
        widest = ""
        if sigma is not None and np.isfinite(sigma[sliding, k]).any():
            widest = (
                f" (sigma of tau_ext_{name} up to {float(np.nanmax(sigma[sliding, k])):.3g} N m)"
            )
        out.append(
            f"joint {name}: {sliding.mean():.0%} of the samples slide at motor speeds of "
            f"{width:.2g}-{top:.3g} rad/s, below the speeds its friction was fitted at, in the "
            f"stretches at the log's ends ({', '.join(spans)}): there the answer is not "
            f"computed but held from the samples next to each stretch{widest}, whatever the "
            f"load does; record sweep passes down to about {low:.2g} rad/s, or read those "
            "stretches as unsound"
        )
    return out


def one_direction_task_warnings(model: Model, velocity: NDArray[np.float64]) -> list[str]:
    """One line per joint that identification never saw move in one direction (its model's
    warnings say the direction took the other's friction) whose log moves that way on at least
    ``SLOW_TASK_SHARE`` of its samples (beyond the law's transition through zero): there the
    friction is the other direction's, copied, not measured, and the external torque carries
    their difference. ``velocity`` is the motor velocity [rad/s], shape (n, n_joints).

    Examples
    --------
    >>> from torquemap.robot import robot_from_dict
    >>> rb = robot_from_dict({"robot": {"name": "m", "kinematics": "none"}, "joints": {"a": {
    ...     "gear_ratio": 1.0, "torque_constant": 0.1, "encoder_counts_per_rev": 4096}}})
    >>> notes = {"warnings": ["joint a: never moved in the negative direction: it takes the "
    ...                       "positive direction's friction"]}
    >>> m = Model(robot=rb, joints={}, notes=notes)
    >>> one_direction_task_warnings(m, np.linspace(-2.0, 2.0, 100)[:, None])[0][:58]
    'joint a: 50% of the samples move in the negative direction'
    """
    from torquemap.friction_law import one_direction_note  # not identify_whole: scipy.stats

    notes = model.notes.get("warnings", [])
    said = [str(w) for w in notes] if isinstance(notes, list | tuple) else []
    out: list[str] = []
    for k, name in enumerate(model.robot.joint_names):
        for sign, way, other in ((-1.0, "negative", "positive"), (1.0, "positive", "negative")):
            note = f"joint {name}: {one_direction_note(way)}"
            if not any(w.startswith(note) for w in said):
                continue
            law = model.joints[name].friction if name in model.joints else None
            v = velocity[:, k]
            v = v[np.isfinite(v)]
            moving = np.count_nonzero(sign * v > TRANSITION_SPAN * _law_width(law))
            if v.size == 0 or moving < SLOW_TASK_SHARE * v.size:
                continue
            out.append(
                f"joint {name}: {moving / v.size:.0%} of the samples move in the {way} "
                "direction, which the identification logs never did: its friction there is "
                f"the {other} direction's, copied, not measured; identify from sweeps both ways"
            )
    return out


#: Steady passes farther apart than this speed ratio leave knots of the friction table that only
#: its prior holds (two of the table's knot steps, ``identify_whole.KNOT_RATIO ** 2``).
PASS_GAP = 1.8**2


def gap_task_warnings(model: Model, velocity: NDArray[np.float64]) -> list[str]:
    """One line per whole-fit joint whose log runs, on at least ``SLOW_TASK_SHARE`` of its
    samples each, between two steady sweep passes of one direction more than :data:`PASS_GAP`
    apart in speed (and a quarter beyond each, clear of their speed
    ripple): there the friction table is interpolated by its prior, not measured, and is off by
    what the law bends between the passes (random SCARA 107: 3.2 mN m at -20 rad/s between
    passes at 9.2 and 41.6 rad/s, 31 % of the spring force with its sigma under it).
    ``velocity`` is the motor velocity [rad/s], shape (n, n_joints).

    Examples
    --------
    >>> from torquemap.robot import robot_from_dict
    >>> rb = robot_from_dict({"robot": {"name": "m", "kinematics": "none"}, "joints": {"a": {
    ...     "gear_ratio": 1.0, "torque_constant": 0.1, "encoder_counts_per_rev": 4096}}})
    >>> notes = {"joints": {"a": {"friction_fit": "whole", "speeds": [1.0, 10.0, -1.0, -1.5]}}}
    >>> m = Model(robot=rb, joints={}, notes=notes)
    >>> gap_task_warnings(m, np.linspace(2.0, 6.0, 100)[:, None])[0][:62]
    'joint a: 100% of the samples run between steady sweep passes m'
    """
    whole = whole_fit_joints(model)
    identified = _identified_speeds(model, signed=True)
    out: list[str] = []
    for k, name in enumerate(model.robot.joint_names):
        signed = identified.get(name)
        if name not in whole or signed is None:
            continue
        v = velocity[:, k]
        v = v[np.isfinite(v)]
        if v.size == 0:
            continue
        gaps, count, near = [], 0, []
        for sign in (1.0, -1.0):
            passes = sorted({abs(x) for x in signed if x * sign > 0})
            speed = np.abs(v[v * sign > 0])
            for lo, hi in itertools.pairwise(passes):
                if hi <= PASS_GAP * lo:
                    continue
                inside = speed[(speed > 1.25 * lo) & (speed < hi / 1.25)]
                if inside.size < SLOW_TASK_SHARE * v.size:
                    continue
                count += inside.size
                gaps.append(f"{sign * lo:.3g} and {sign * hi:.3g}")
                near.append(f"{sign * float(np.median(inside)):.2g}")
        if gaps:
            out.append(
                f"joint {name}: {count / v.size:.0%} of the samples run between steady sweep "
                f"passes more than {PASS_GAP:.2g} times apart in speed ({'; '.join(gaps)} "
                "rad/s), where friction is interpolated by the identification's prior, not "
                f"measured; record sweep passes near {', '.join(near)} rad/s"
            )
    return out


#: How far from each end of a log [s] its motion is judged (two differentiator windows).
EDGE_SPAN = 0.1
#: A joint whose median motor speed over an end's ``EDGE_SPAN`` exceeds this share of its median
#: speed over the log is in motion at that end.
EDGE_MOTION_SHARE = 0.5


def edge_motion_warnings(
    t: NDArray[np.float64],
    velocity: NDArray[np.float64],
    joint_names: Sequence[str],
    cutoff: float,
) -> list[str]:
    """One line when the log starts or ends with a joint in motion (a log cut mid-task): the
    low-pass (and the differentiator) have no samples beyond the log's ends, and within
    ``1 / cutoff`` of an end cut in motion the forces are off by many times their error in
    the whole log, beyond their sigmas (the paper's bench cut to 8 s mid-circle: 1.19 N RMS
    over its first and last 0.1 s against 0.044 N on the same samples of the whole log;
    0.3 s cuts 27-51 % within 2 sigma). A log that starts and ends at rest (the issue's
    circles) is not concerned. ``velocity`` is the motor velocity [rad/s], shape (n,
    n_joints); ``t`` [s] shape (n,); ``cutoff`` [Hz].

    Examples
    --------
    >>> t = np.arange(0.0, 4.0, 0.001)
    >>> moving = np.c_[np.sin(np.pi * t / 4.0)]  # from rest to rest
    >>> edge_motion_warnings(t, moving, ["a"], 2.0)
    []
    >>> edge_motion_warnings(t[1000:3000], moving[1000:3000], ["a"], 2.0)[0][:48]
    'the log starts and ends in motion (joint a at 0.'
    """
    n = t.size
    if n < 3 or not (math.isfinite(cutoff) and cutoff > 0):
        return []
    speed = np.abs(np.asarray(velocity, dtype=np.float64))
    ends: list[str] = []
    moving: dict[str, float] = {}
    for name, sel in (
        ("starts", t - t[0] <= EDGE_SPAN),
        ("ends", t[-1] - t <= EDGE_SPAN),
    ):
        found = False
        for k, joint in enumerate(joint_names):
            column = speed[:, k]
            typical = float(np.nanmedian(column)) if np.isfinite(column).any() else 0.0
            at_end = column[sel]
            if not typical > 0 or not np.isfinite(at_end).any():
                continue
            level = float(np.nanmedian(at_end))
            if level > EDGE_MOTION_SHARE * typical:
                found = True
                moving[joint] = max(moving.get(joint, 0.0), level)
        if found:
            ends.append(name)
    if not ends:
        return []
    settle = 1.0 / cutoff
    which = " and ".join(ends)
    joints = ", ".join(f"joint {name} at {value:.3g} rad/s" for name, value in moving.items())
    return [
        f"the log {which} in motion ({joints} at the motor): within {settle:.3g} s of such "
        f"an end the {cutoff:g} Hz low-pass and the differentiator have no samples beyond "
        "it, and the forces there are off by several times their error inside the log, "
        "beyond their sigmas; record from rest to rest (start before the stretch you need, "
        f"stop after it), or read the {settle:.3g} s at that end as unsound"
    ]


def observed_speeds(model: Model) -> dict[str, float]:
    """Per joint, the slowest motor speed [rad/s] a whole-log fit fitted its friction table at
    (``[identification.joints.<j>] friction_observed_speed``); below it the table is held by
    its prior."""
    out: dict[str, float] = {}
    joints = model.notes.get("joints", {})
    if isinstance(joints, Mapping):
        for name, entry in joints.items():
            value = entry.get("friction_observed_speed") if isinstance(entry, Mapping) else None
            if isinstance(value, int | float) and math.isfinite(value) and value > 0:
                out[str(name)] = float(value)
    return out


def identified_delays(model: Model) -> dict[str, float]:
    """Per joint, the torque channel delay [s] identification recorded in the model's notes."""
    out: dict[str, float] = {}
    joints = model.notes.get("joints", {})
    if isinstance(joints, Mapping):
        for name, entry in joints.items():
            if isinstance(entry, Mapping):
                value = entry.get("channel_delay", 0.0)
                if isinstance(value, int | float) and math.isfinite(value):
                    out[str(name)] = float(value)
    return out


def forces_columns(estimate: ForceEstimate) -> dict[str, NDArray[Any]]:
    """Output columns of ``torquemap estimate`` (docs/formats.md).

    ``t``, ``tau_ext_<j>`` per joint [N m, joint side, exerted by the environment], ``fx``, ``fy``
    [N, base frame] for planar2r, ``tau_ext_<j>_sigma`` and ``fx_sigma``, ``fy_sigma`` (one
    standard deviation; NaN where not estimated), and ``flag`` (bits ``FLAG_*``; 0 = sound).
    """
    cols: dict[str, NDArray[Any]] = {"t": estimate.t}
    for k, name in enumerate(estimate.joint_names):
        cols[f"tau_ext_{name}"] = estimate.tau_ext[:, k]
    if estimate.force is not None:
        for a, axis in enumerate(estimate.wrench_axes):
            cols[axis] = estimate.force[:, a]
    if estimate.tau_ext_sigma is not None:
        for k, name in enumerate(estimate.joint_names):
            cols[f"tau_ext_{name}_sigma"] = estimate.tau_ext_sigma[:, k]
    if estimate.force is not None and estimate.force_sigma is not None:
        for a, axis in enumerate(estimate.wrench_axes):
            cols[f"{axis}_sigma"] = estimate.force_sigma[:, a]
    cols["flag"] = estimate.flag
    return cols


def __getattr__(name: str) -> Any:
    """``ForceEstimator``, the streaming estimator, lives in :mod:`torquemap.stream` (which
    imports this module): it is imported on first use."""
    if name == "ForceEstimator":
        from torquemap.stream import ForceEstimator

        return ForceEstimator
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# ``torquemap.estimate(...)`` calls :func:`torquemap.api.estimate` (the module stays a module).
_make_callable(__name__, "torquemap.api:estimate")
