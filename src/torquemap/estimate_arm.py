"""External torques and end-effector wrench of an arm with rigid-body dynamics (docs/arm.md).

Two methods, both on the identified model of :mod:`torquemap.identify_arm`:

``acceleration``
    ``tau_ext = M(q) qdd + C(q, qd) qd + g(q) - tau_drive`` at every sample, with ``tau_drive``
    the drives' joint torque net of the motor-side friction, PDTV and rotor inertia
    (:func:`torquemap.arm_model.drive_torque`), the accelerations from the differentiator and
    the torques smoothed by the same kernel; then a zero-phase low-pass at ``cutoff``.
``momentum``
    The generalised-momentum observer (De Luca & Mattone 2003; Haddadin, De Luca & Albu-Schaeffer
    2017, Eq 31): with ``p = M'(q) qd`` (``M'`` includes the reflected rotor inertias),
    ``r = K (p - p(0) - integral(tau_drive + C^T qd - g + r) dt)`` follows ``tau_ext`` through a
    first-order lag of bandwidth ``K = 2 pi cutoff``. No acceleration is needed; it is causal,
    as on a robot controller.

The wrench on the end effector comes from the damped pseudo-inverse of ``J^T``
(:meth:`torquemap.robots.urdf.UrdfArm.wrench_from_joint_torque`). Sigmas combine the
identification's parameter covariance (the external torque is linear in every identified
parameter) and its residual noise, plus, near zero motor speed, the friction at rest that the
velocity does not determine, and where the force changes faster than the final filter follows,
what the filter removed (:mod:`torquemap.arm_fast`).
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from torquemap.arm_fast import band_noise_floor, fast_torque_message, fast_torque_variance
from torquemap.arm_model import (
    ArmSignals,
    arm_signals,
    column_names,
    drive_torque,
    joint_columns,
    joint_parameters,
)
from torquemap.arm_noise import arm_noise_levels, noise_excess_variance
from torquemap.arm_null import null_space_message, null_space_share
from torquemap.arm_units import angles_beyond_limits
from torquemap.errors import InputError
from torquemap.estimate import torque_scale_warnings
from torquemap.filters import lowpass
from torquemap.identify_arm import is_rigid_body_arm
from torquemap.io import Log
from torquemap.model import Model
from torquemap.sanitize import max_gap_for, no_stretch_message

ArmMethod = Literal["acceleration", "momentum"]
ARM_METHODS: tuple[ArmMethod, ...] = ("acceleration", "momentum")

FLAG_SINGULAR = 1
"""Flag bit: the pose is near a singularity; the wrench is NaN (the joint torques stand)."""
FLAG_GAP = 8
"""Flag bit (as :data:`torquemap.estimate.FLAG_GAP`): within ``1 / cutoff`` of a gap in time
longer than :func:`torquemap.sanitize.max_gap_for` the window, where the filters see data on one
side only (answered, not sound)."""
SIGMA_STRIDE = 10
"""The parameter part of the sigmas is computed on every this-many samples and interpolated."""
POSE_TOLERANCE = 0.1
"""A joint angle beyond the identified range by more than this share of the range's width is
far outside it: warned about (the parameter sigmas grow with the distance in any case)."""
UNDER_COVERED = 10.0
"""A motor speed is under-covered where a log holds this many times the share of its samples
near it (within a factor of 2) that the identification held."""
SPEED_SHARE = 0.1
"""Warn when more than this share of a log's samples is at under-covered motor speeds."""


@dataclass(frozen=True, slots=True, eq=False)
class ArmEstimate:
    """External torques and wrench estimated from one log of an arm.

    Attributes
    ----------
    t
        Time [s], shape (n,).
    joint_names
        Joints, robot file order.
    q
        Smoothed joint positions [rad], shape (n, nj).
    tau_ext
        Joint-side torque exerted by the environment [N m], shape (n, nj).
    tau_ext_sigma
        Its standard deviation [N m], shape (n, nj).
    wrench_axes
        Names of the wrench components (``fx, fy, fz`` and with six or more joints
        ``mx, my, mz``).
    wrench
        Force [N] and moment [N m] exerted by the environment on the end effector, base frame,
        shape (n, len(wrench_axes)); NaN at singular poses.
    wrench_sigma
        Its standard deviation, same shape.
    flag
        ``FLAG_SINGULAR`` where the pose is near a singularity, else 0, shape (n,).
    method
        ``"acceleration"`` or ``"momentum"``.
    zero_phase
        True for the forward-backward momentum observer.
    cutoff
        Low-pass cut-off or observer bandwidth [Hz].
    warnings
        One line each.
    extrapolation
        How far each sample's pose lies outside the poses the identification saw: the largest
        over the joints of the distance beyond the identified range in units of the range's
        width [-], 0 inside, shape (n,) (zeros when the model records no range).
    """

    t: NDArray[np.float64]
    joint_names: tuple[str, ...]
    q: NDArray[np.float64]
    tau_ext: NDArray[np.float64]
    tau_ext_sigma: NDArray[np.float64]
    wrench_axes: tuple[str, ...]
    wrench: NDArray[np.float64]
    wrench_sigma: NDArray[np.float64]
    flag: NDArray[np.int64]
    method: ArmMethod
    zero_phase: bool
    cutoff: float
    warnings: tuple[str, ...] = ()
    extrapolation: NDArray[np.float64] = dataclasses.field(default_factory=lambda: np.zeros(0))


def _speed_coverage(
    speed: NDArray[np.float64],
    quantiles: NDArray[np.float64],
    levels: NDArray[np.float64],
    floor: float,
) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """Samples whose motor speed the identification saw far less often than the log holds it.

    On a log-spaced grid of speeds from ``floor`` (the friction law's transition width: below
    it the joint is at rest, which the friction-at-rest sigma covers) up, the share of the
    identification's samples within a factor of 2 (from its quantiles ``quantiles`` at
    ``levels``) is compared with the log's own share there; where the log's exceeds
    :data:`UNDER_COVERED` times the identification's, its samples are under-covered (above
    the fastest speed identified the identification's share is 0).

    Returns
    -------
    (under, near)
        Shape (n,) each: True where under-covered; the nearest covered grid speed [rad/s].
    """
    top = max(float(quantiles[-1]), float(speed.max(initial=0.0)), 2.0 * floor)
    grid = np.geomspace(floor, top, 64)
    ordered = np.sort(speed)

    def share_log(v: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.searchsorted(ordered, v, side="right") / max(speed.size, 1)

    def share_identified(v: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.interp(v, quantiles, levels, left=0.0, right=1.0)

    half = math.sqrt(2.0)
    mine = share_log(grid * half) - share_log(grid / half)
    theirs = share_identified(grid * half) - share_identified(grid / half)
    covered = mine <= UNDER_COVERED * theirs
    near = np.full(speed.size, np.nan)
    under = np.zeros(speed.size, dtype=bool)
    if covered.all() or not covered.any():
        if not covered.any():  # nothing covered: the fastest speed identified is the edge
            moving = speed > floor
            under[moving] = True
            near[moving] = float(quantiles[-1])
        return under, near
    at = np.clip(
        np.searchsorted(np.log(grid), np.log(np.maximum(speed, floor)), side="left"),
        0,
        grid.size - 1,
    )
    under = (speed > floor) & ~covered[at]
    good = np.flatnonzero(covered)
    pos = np.clip(np.searchsorted(good, at[under]), 0, good.size - 1)
    below = good[np.clip(pos - 1, 0, good.size - 1)]
    above = good[pos]
    pick = np.where(np.abs(above - at[under]) <= np.abs(at[under] - below), above, below)
    near[under] = grid[pick]
    return under, near


def _beyond_range(
    q: NDArray[np.float64],
    lowest: NDArray[np.float64],
    highest: NDArray[np.float64],
    period: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Distance [rad or m] of each angle ``q`` (n, nj) from the range ``[lowest, highest]``
    (nj,) its joint was identified over, 0 inside. A joint whose pose repeats every
    ``period`` (nj,; a revolute joint's 2 pi, ``inf`` for a prismatic one) is as near as
    its nearest turn: a wrist one turn further is at a pose the model saw."""
    linear = np.maximum(np.maximum(lowest - q, q - highest), 0.0)
    finite = np.isfinite(period)
    if not finite.any():
        return linear
    p = np.where(finite, period, 1.0)
    width = highest - lowest
    d = np.mod(q - lowest, p)  # [0, p): how far above the range's start, within a turn
    wrapped = np.where(d <= width, 0.0, np.minimum(d - width, p - d))
    wrapped = np.where(width >= p, 0.0, wrapped)
    out: NDArray[np.float64] = np.where(finite, wrapped, linear)
    return out


ANOTHER_ROBOT_SHARE = 0.9
"""Share of a log's samples outside the identified poses from which the warning also asks
whether the log is of the model's robot."""
ANOTHER_ROBOT = "; or is the log of another robot, or are its columns of other joints?"
"""(a Z1's task log read with a 6-axis Talos arm's model: 106 N against the true 12 N, with
only the poses' warning; docs/arm.md, new-user QA)"""


def fit_warnings(info: Mapping[str, Any] | None) -> str | None:
    """One warning repeating what the model's identification said of its fit to its logs (a
    joint's torque the model explains poorly, a rigid-body gain far from the URDF's: a robot
    file at odds with the arm), or None. ``identify`` prints them; ``estimate`` of that model
    used to say nothing (a Talos arm on a wall, identified with a robot file saying gravity
    -z: forces 45 N against the true 9 N)."""
    said = info.get("warnings") if isinstance(info, Mapping) else None
    if not isinstance(said, list):
        return None
    found, lags = [], []
    heavier = False  # a gain above 1 may be a load the URDF lacks, which identification takes in
    for w in said:
        if not isinstance(w, str):
            continue
        share = re.match(r"joint (\S+): the identified model explains only (\S+)", w)
        gain = re.match(r"joint (\S+): its rigid-body torque is (\S+) times the URDF's", w)
        lag = re.match(
            r"the logs' motor currents \(or torques\) (lag|lead) their joint angles by about (\S+ ms)",
            w,
        )
        if share:
            found.append(f"{share[1]} explains {share[2]} of its torque")
        elif gain:
            found.append(f"{gain[1]}'s rigid-body torque {gain[2]}x the URDF's")
            heavier = heavier or float(gain[2]) > 1.0
        elif lag:  # (torquemap.arm_lag; new-user QA, stop 37)
            lags.append(f"its logs' currents {lag[1]} their angles by about {lag[2]}")
    if not found and not lags:
        return None
    checks = []
    if found:
        checks.append(
            "check the robot file's gravity, gear ratios and torque constants"
            + (
                " (or a load the URDF lacks, which identification takes in: the forces are then right)"
                if heavier
                else ""
            )
        )
    if lags:
        checks.append("align the log's current and angle columns in time")
    return (
        "the model's identification found it at odds with its logs ("
        + "; ".join(found + lags)
        + "): "
        + "; ".join(checks)
        + ("; else the forces carry that error" if heavier else "; the forces carry that error")
    )


def _extrapolation(
    info: Mapping[str, Any] | None, robot: Any, joints: Mapping[str, Any], signals: ArmSignals
) -> tuple[NDArray[np.float64], NDArray[np.float64], list[str]]:
    """Where a log leaves what the identification saw (``[identification.arm]``
    ``position_range`` and ``motor_speed_quantiles``).

    Returns
    -------
    (reach, edge, warnings)
        ``reach`` (n,): the largest distance of a joint angle beyond its identified range in
        units of the range's width; ``edge`` (n, nj): where a sample's motor speed is one the
        identification saw far less often than the log holds it (:func:`_speed_coverage`),
        the nearest speed it saw well [rad/s] (signed as the sample's), NaN elsewhere.
    """
    n, nj = signals.q.shape
    reach = np.zeros(n)
    edge = np.full((n, nj), np.nan)
    warnings: list[str] = []
    if not isinstance(info, Mapping):
        return reach, edge, warnings
    names = robot.joint_names
    pos = np.asarray(info.get("position_range", []), dtype=float)
    if pos.shape == (nj, 2):
        width = np.maximum(pos[:, 1] - pos[:, 0], 1e-3)
        period = np.asarray(getattr(robot.arm, "angle_period", np.full(nj, np.inf)), dtype=float)
        beyond = _beyond_range(signals.q, pos[:, 0], pos[:, 1], period)
        reach = np.max(beyond / width, axis=1)
        far = beyond > POSE_TOLERANCE * width
        if far.any():
            worst = ", ".join(
                f"{names[k]} up to {beyond[:, k].max():.3g} "
                f"{'rad' if np.isfinite(period[k]) else 'm'}"  # a prismatic joint's is metres
                for k in range(nj)
                if far[:, k].any()
            )
            share = float(far.any(axis=1).mean())
            warnings.append(
                f"{share:.0%} of the samples lie at poses outside those the "
                f"model was identified from ({worst} beyond the identified range); the model "
                "extrapolates there and its sigmas grow with the distance: excite about the "
                "working poses (torquemap excite --centre)"
                + (ANOTHER_ROBOT if share >= ANOTHER_ROBOT_SHARE else "")
            )
    levels = np.asarray(info.get("motor_speed_levels", []), dtype=float)
    quantiles = np.asarray(info.get("motor_speed_quantiles", []), dtype=float)
    if levels.ndim == 1 and quantiles.shape == (nj, levels.size) and levels.size >= 2:
        w = signals.gear * signals.qd
        described = []
        for k in range(nj):
            floor = float(joints[names[k]].friction.zero_velocity)
            under, near = _speed_coverage(np.abs(w[:, k]), quantiles[k], levels, floor)
            edge[under, k] = np.sign(w[under, k]) * near[under]
            if under.mean() > SPEED_SHARE:
                speeds = np.abs(w[under, k])
                described.append(
                    f"{names[k]} in {under.mean():.0%} of the samples "
                    f"({speeds.min():.3g}-{speeds.max():.3g} rad/s)"
                )
        if described:
            warnings.append(
                "the friction is extrapolated to motor speeds the identification saw "
                f"{UNDER_COVERED:g} times less often than this log: "
                + ", ".join(described)
                + "; sigmas grow there: excite at those speeds too (torquemap excite --speeds)"
            )
    return reach, edge, warnings


def momentum_observer(
    t: NDArray[np.float64],
    momentum: NDArray[np.float64],
    power_terms: NDArray[np.float64],
    *,
    gain: float,
) -> NDArray[np.float64]:
    """The generalised-momentum residual ``r``, which follows the external torque.

    Parameters
    ----------
    t
        Time [s], shape (n,).
    momentum
        ``p = M(q) qd`` [N m s], shape (n, nj).
    power_terms
        ``tau_drive + C(q, qd)^T qd - g(q)`` [N m], shape (n, nj): ``dp/dt`` without the
        external torque.
    gain
        Observer gain ``K`` [1/s]; ``r`` is ``tau_ext`` through ``K / (s + K)``.

    Returns
    -------
    ndarray
        ``r`` [N m], shape (n, nj), zero at the first sample.

    Notes
    -----
    Discretised exactly for a piecewise-constant ``power_terms + tau_ext`` over each step
    ``h``: ``r_k = e^{-K h} r_{k-1} + (1 - e^{-K h}) (dp_k / h - power_{k-1})``, which is the
    continuous observer's response and stays stable at any ``K h``.

    Examples
    --------
    >>> t = np.arange(2001) * 1e-3
    >>> p = 0.5 * t[:, None]   # a constant external torque 0.5 N m, nothing else
    >>> r = momentum_observer(t, p, np.zeros((2001, 1)), gain=50.0)
    >>> round(float(r[-1, 0]), 6)
    0.5
    """
    from scipy.signal import lfilter

    n = t.size
    r = np.zeros_like(momentum)
    h = np.diff(t)
    a = np.exp(-gain * h)
    drive = np.diff(momentum, axis=0) / h[:, None] - power_terms[:-1]
    if np.allclose(h, h[0], rtol=1e-9, atol=0.0):
        # a uniform step: one first-order recursion, done by lfilter along time
        r[1:] = lfilter([1.0 - a[0]], [1.0, -a[0]], drive, axis=0)
        return r
    for k in range(1, n):
        r[k] = a[k - 1] * r[k - 1] + (1.0 - a[k - 1]) * drive[k - 1]
    return r


def noise_bandwidth(method: ArmMethod, cutoff: float, *, zero_phase: bool = False) -> float:
    """Equivalent noise bandwidth [Hz] of a method's final filter.

    Forward-backward second-order Butterworth: ``|H|^4 = (1 + (f/fc)^4)^-2`` integrates to
    ``3 pi / (8 sqrt 2) fc``; the momentum observer ``K / (s + K)``: ``pi / 2 fc``; run both
    ways (``K^2 / (K^2 + w^2)``): ``pi / 4 fc``.
    """
    if method == "acceleration":
        return 3.0 * math.pi / (8.0 * math.sqrt(2.0)) * cutoff
    return (math.pi / 4.0 if zero_phase else math.pi / 2.0) * cutoff


def _measured_share(
    info: Mapping[str, Any], noise: NDArray[np.float64], bandwidth: float
) -> NDArray[np.float64] | None:
    """Share of the residual variance left at the estimate's filter, from the residual's
    low-passed sigmas the identification measured (log-log interpolation over the cut-off of
    the Butterworth with the same noise bandwidth); None when the model lacks them."""
    cut = info.get("residual_lowpass_hz")
    table = info.get("residual_sigma_lowpass")
    if not isinstance(cut, list) or not isinstance(table, list) or not cut:
        return None
    fc = np.asarray(cut, dtype=float)
    sig = np.asarray(table, dtype=float)
    if sig.shape != (fc.size, noise.size):
        return None
    equivalent = bandwidth / (3.0 * math.pi / (8.0 * math.sqrt(2.0)))
    out = np.empty(noise.size)
    for k in range(noise.size):
        ok = np.isfinite(sig[:, k]) & (sig[:, k] > 0)
        if not ok.any():
            return None
        value = np.exp(np.interp(np.log(equivalent), np.log(fc[ok]), np.log(sig[ok, k])))
        out[k] = min(1.0, (value / max(noise[k], 1e-300)) ** 2)
    return out


def _sigma(
    model: Model,
    arm: Any,
    signals: ArmSignals,
    tau_ext_shape: tuple[int, int],
    bandwidth: float,
    reach: NDArray[np.float64],
    edge: NDArray[np.float64],
) -> tuple[NDArray[np.float64], list[str]]:
    """One-sigma external torque [N m] from the identification's covariance and noise.

    Outside what the identification saw the sigmas grow: the parameter part by
    ``(1 + reach)^2`` in variance (``reach``: the distance beyond the identified poses in
    units of their range's width), and at motor speeds outside the identified ones (``edge``
    not NaN) by the change the friction law predicts from the edge of those speeds to the
    sample's, taken as its own uncertainty (the law's shape is not known there).

    The identification's residual was seen through the differentiator's kernel, whose noise
    bandwidth is ``1.2 / (2 window)``; the estimate's own filter passes ``bandwidth`` of it
    (white residual assumed: residual model errors slower than that are underestimated).
    """
    n, nj = tau_ext_shape
    warnings: list[str] = []
    info = model.notes.get("arm") if isinstance(model.notes, Mapping) else None
    var = np.zeros((n, nj))
    robot = model.robot
    gear = signals.gear
    if isinstance(info, Mapping) and "covariance" in info and "residual_sigma" in info:
        noise = np.asarray(info["residual_sigma"], dtype=float)
        window = float(info.get("window", signals.window))
        noise_share = np.full(nj, min(1.0, bandwidth / (1.2 / (2.0 * window))))
        measured = _measured_share(info, noise, bandwidth)
        if measured is not None:
            noise_share = measured
        if noise.shape == (nj,):
            var += noise_share * (gear * noise) ** 2
        names: list[str] = list(arm.parameter_names)
        orders = []
        for joint in robot.joints:
            _, o = joint_parameters(model.joints[joint.name])
            orders.append(o)
            names += column_names(joint.name, model.joints[joint.name], o)
        if names == list(info.get("parameter_names", [])):
            cov = np.asarray(info["covariance"], dtype=float)
            idx = np.unique(np.r_[np.arange(0, n, SIGMA_STRIDE), n - 1])
            Yb = arm.regressor(signals.q[idx], signals.qd[idx], signals.qdd[idx])
            pb = Yb.shape[-1]
            start = pb
            part = np.empty((idx.size, nj))
            for k, joint in enumerate(robot.joints):
                cols = joint_columns(model.joints[joint.name], signals, k, orders[k], smooth=True)
                cols = cols[idx]
                width = cols.shape[1]
                sel = np.r_[np.arange(pb), np.arange(start, start + width)]
                row = np.concatenate([Yb[:, k, :], gear[k] * cols], axis=1)  # joint side
                C = cov[np.ix_(sel, sel)]
                part[:, k] = np.einsum("ni,ij,nj->n", row, C, row)
                start += width
            grow = (1.0 + reach) ** 2
            for k in range(nj):
                var[:, k] += grow * np.interp(np.arange(n), idx, np.maximum(part[:, k], 0.0))
        else:
            warnings.append(
                "the model's parameters differ from those its covariance was identified for; "
                "sigmas hold the residual noise only"
            )
    else:
        warnings.append("the model holds no identification covariance; sigmas are friction only")
    for k, joint in enumerate(robot.joints):
        law = model.joints[joint.name].friction
        levels = law.static_levels()
        rest = 0.5 * (abs(levels[0]) + abs(levels[1]))
        w = gear[k] * signals.qd[:, k]
        near = np.exp(-((w / max(law.zero_velocity, 1e-9)) ** 2))
        var[:, k] += (gear[k] * rest * near) ** 2
        out = np.isfinite(edge[:, k])
        if out.any():
            change = law.torque(w[out]) - law.torque(edge[out, k])
            var[out, k] += (gear[k] * change) ** 2
    return np.sqrt(var), warnings


def _still_joints(arm: Any, q: NDArray[np.float64]) -> str:
    """A note naming the joints that never move the end effector on the log's poses (its
    origin on their axis: every pose singular, whatever the motion), or ""."""
    J = np.asarray(arm.jacobian(q[:: max(1, q.shape[0] // 200)]), dtype=np.float64)
    still = [n for k, n in enumerate(arm.joint_names) if np.max(np.abs(J[:, :, k])) < 1e-9]
    if not still:
        return ""
    return (
        f": joint{'s' if len(still) > 1 else ''} {', '.join(repr(n) for n in still)} "
        f"do{'' if len(still) > 1 else 'es'} not move the end effector "
        f"{arm.end_effector!r} (its origin lies on the joint's axis); choose an end effector "
        "beyond it in the robot file"
    )


def _longest_stretch(t: NDArray[np.float64], limit: float) -> float:
    """Duration [s] of the longest stretch of ``t`` without a step longer than ``limit``."""
    if t.size < 2:
        return 0.0
    edges = np.flatnonzero(np.diff(t) > limit) + 1
    starts = np.r_[0, edges]
    ends = np.r_[edges, t.size] - 1
    return float(np.max(t[ends] - t[starts]))


def _near_gaps(t: NDArray[np.float64], limit: float, reach: float) -> NDArray[np.bool_]:
    """Samples within ``reach`` [s] of a step in time longer than ``limit`` [s]."""
    steps = np.flatnonzero(np.diff(t) > limit)
    out = np.zeros(t.size, dtype=bool)
    for i in steps:
        out |= ((t >= t[i] - reach) & (t <= t[i])) | ((t >= t[i + 1]) & (t <= t[i + 1] + reach))
    return out


def _louder(
    info: Mapping[str, Any] | None, robot: Any, joints: Mapping[str, Any], signals: ArmSignals
) -> NDArray[np.float64]:
    """Per joint, the log's noise level above 20 Hz over the identification's
    (``noise_high_psd``), NaN where either is not known."""
    nj = len(robot.joints)
    own = info.get("noise_high_psd") if isinstance(info, Mapping) else None
    if not isinstance(own, list) or len(own) != nj:
        return np.full(nj, math.nan)
    ref = np.array([float(v) for v in own])
    level = arm_noise_levels(robot, joints, signals)
    out: NDArray[np.float64] = np.where(ref > 0, level / np.where(ref > 0, ref, 1.0), math.nan)
    return out


def _unfiltered(
    arm: Any, robot: Any, joints: Mapping[str, Any], signals: ArmSignals
) -> NDArray[np.float64]:
    """The external torque before any final filter [N m], shape (n, nj): the rigid-body
    torques less the drives', both seen through the differentiator's kernel."""
    drive = drive_torque(robot, dict(joints), signals, smooth=True)
    out: NDArray[np.float64] = arm.inverse_dynamics(signals.q, signals.qd, signals.qdd) - drive
    return out


def estimate_arm(
    model: Model,
    log: Log,
    *,
    method: ArmMethod = "acceleration",
    cutoff: float = 2.0,
    window: float = 0.05,
    singular_threshold: float | None = None,
    zero_phase: bool = False,
) -> ArmEstimate:
    """Estimate the external joint torques and end-effector wrench of an arm.

    Parameters
    ----------
    model
        Identified model of an arm with rigid-body dynamics (:func:`identify_arm`); a plain
        URDF robot file works too (the URDF's inertial parameters, no friction).
    log
        The log.
    method
        ``"acceleration"`` or ``"momentum"`` (see the module docstring).
    cutoff
        Low-pass cut-off, or the observer's bandwidth [Hz].
    window
        Differentiator window [s].
    singular_threshold
        Smallest singular value of the Jacobian [m] below which a pose is flagged (the arm's
        default when None).
    zero_phase
        ``momentum`` only: average the observer run forwards and backwards in time, which
        removes its lag (response ``K^2 / (K^2 + w^2)``, no phase) for logs processed offline.
        The default is the causal observer a robot controller runs.

    Returns
    -------
    ArmEstimate
        Torques, wrench, sigmas and flags; warnings where the log leaves the poses or motor
        speeds the model was identified from (its sigmas grow there, ``extrapolation``).

    Raises
    ------
    InputError
        When the arm has no rigid-body dynamics, on an unknown method, a cut-off at or above
        the Nyquist frequency, or a log too short for the window.
    """
    arm: Any = model.robot.arm
    if not is_rigid_body_arm(arm):
        raise InputError(
            f"estimate_arm needs an arm with rigid-body dynamics (kinematics = 'urdf'), "
            f"not {model.robot.kinematics!r}"
        )
    if method not in ARM_METHODS:
        raise InputError(f"method must be one of {', '.join(ARM_METHODS)}, got {method!r}")
    if not cutoff > 0:
        raise InputError(f"cutoff must be positive, got {cutoff!r}")
    robot = model.robot
    joints = dict(model.joints)
    if _longest_stretch(log.t, max_gap_for(window)) < window:
        # before the filters, which would refuse a log stamped in ns with a cut-off's range
        # or, for the observer, answer every sample (all flagged as near a gap)
        raise InputError(no_stretch_message(log.t, window), path=log.path)
    problem = angles_beyond_limits(log.q, arm)
    if problem is not None:
        raise InputError(problem, path=log.path)
    signals = arm_signals(log, robot, window=window)
    drive = drive_torque(robot, joints, signals, smooth=method == "acceleration")
    if method == "acceleration":
        raw = arm.inverse_dynamics(signals.q, signals.qd, signals.qdd) - drive
        tau_ext = np.column_stack(
            [lowpass(signals.t, raw[:, k], cutoff=cutoff) for k in range(raw.shape[1])]
        )
    else:
        armature = np.array(
            [joints[j.name].inertia.constant * j.gear_ratio**2 for j in robot.joints]
        )
        M = arm.mass_matrix(signals.q)
        M[:, np.arange(M.shape[1]), np.arange(M.shape[1])] += armature
        p = np.einsum("nij,nj->ni", M, signals.qd)
        C = arm.coriolis_matrix(signals.q, signals.qd)
        g = arm.gravity_torque(signals.q)
        power = drive + np.einsum("nji,nj->ni", C, signals.qd) - g
        # the armature's inertia is in p; its torque must not be subtracted twice
        power += armature * signals.qdd
        gain = 2.0 * np.pi * cutoff
        tau_ext = momentum_observer(signals.t, p, power, gain=gain)
        if zero_phase:
            # in reversed time dp/dt' = -(power + tau_ext): the observer then follows -tau_ext
            back = momentum_observer(-signals.t[::-1], p[::-1], -power[::-1], gain=gain)
            tau_ext = 0.5 * (tau_ext - back[::-1])
    bandwidth = noise_bandwidth(method, cutoff, zero_phase=zero_phase)
    info = model.notes.get("arm") if isinstance(model.notes, Mapping) else None
    reach, edge, outside = _extrapolation(info, robot, joints, signals)
    sigma, warnings = _sigma(model, arm, signals, tau_ext.shape, bandwidth, reach, edge)
    louder, note = noise_excess_variance(info, robot, joints, signals, bandwidth)
    sigma = np.sqrt(sigma**2 + louder)
    # what the final filter removed from a force that changes faster than it (stop 38, Q45)
    unfiltered = raw if method == "acceleration" else _unfiltered(arm, robot, joints, signals)
    floor = band_noise_floor(info, signals.gear, cutoff, _louder(info, robot, joints, signals))
    fast = fast_torque_variance(signals.t, unfiltered, tau_ext, cutoff, floor)
    fast_note = fast_torque_message(fast, sigma**2, cutoff, robot.joint_names)
    sigma = np.sqrt(sigma**2 + fast)
    if note is not None:
        warnings.append(note)
    if fast_note is not None:
        warnings.append(fast_note)
    warnings += outside
    odds = fit_warnings(info)
    if odds is not None:
        warnings.insert(0, odds)
    warnings += torque_scale_warnings(model, signals.motor_torque)
    A, singular = arm.wrench_map(signals.q, singular_threshold=singular_threshold)
    wrench = np.einsum("nij,nj->ni", A, tau_ext)
    wrench_sigma = np.sqrt(np.einsum("nij,nj->ni", A**2, sigma**2))
    wrench[singular] = np.nan
    flag = np.where(singular, FLAG_SINGULAR, 0).astype(np.int64)
    near_gap = _near_gaps(signals.t, max_gap_for(window), 1.0 / cutoff)
    # torques no end-effector wrench gives: contact elsewhere, or swapped columns (QA, stop 37)
    inner = (signals.t > signals.t[0] + 1.0 / cutoff) & (signals.t < signals.t[-1] - 1.0 / cutoff)
    identified = isinstance(info, Mapping) and "covariance" in info  # else no sigmas to judge by
    if identified and len(robot.joints) > len(arm.wrench_axes):
        share = null_space_share(
            arm.jacobian(signals.q), tau_ext, sigma, inner & ~singular & ~near_gap
        )
        swapped = None if share is None else null_space_message(share)
        if swapped is not None:
            warnings.append(swapped)
    if near_gap.any():
        flag[near_gap] |= FLAG_GAP
        warnings.append(
            f"{int(near_gap.sum())} of {near_gap.size} samples within {1.0 / cutoff:.3g} s of a "
            f"gap in time longer than {max_gap_for(window):.3g} s (answered, flag 8: the "
            "filters see data on one side only)"
        )
    if singular.any():
        warnings.append(
            f"{int(singular.sum())} of {singular.size} samples at near-singular poses "
            "(wrench NaN, flag 1)" + _still_joints(arm, signals.q)
        )
    return ArmEstimate(
        t=signals.t,
        joint_names=robot.joint_names,
        q=signals.q,
        tau_ext=tau_ext,
        tau_ext_sigma=sigma,
        wrench_axes=tuple(arm.wrench_axes),
        wrench=wrench,
        wrench_sigma=wrench_sigma,
        flag=flag,
        method=method,
        zero_phase=zero_phase and method == "momentum",
        cutoff=cutoff,
        warnings=tuple(warnings),
        extrapolation=reach,
    )


def arm_forces_columns(estimate: ArmEstimate) -> dict[str, NDArray[Any]]:
    """The forces file's columns (docs/formats.md): ``t``, ``tau_ext_<j>``,
    ``tau_ext_<j>_sigma``, the wrench axes and their ``_sigma``, ``flag``."""
    out: dict[str, NDArray[Any]] = {"t": estimate.t}
    for k, name in enumerate(estimate.joint_names):
        out[f"tau_ext_{name}"] = estimate.tau_ext[:, k]
    for k, name in enumerate(estimate.joint_names):
        out[f"tau_ext_{name}_sigma"] = estimate.tau_ext_sigma[:, k]
    for k, axis in enumerate(estimate.wrench_axes):
        out[axis] = estimate.wrench[:, k]
    for k, axis in enumerate(estimate.wrench_axes):
        out[f"{axis}_sigma"] = estimate.wrench_sigma[:, k]
    out["flag"] = estimate.flag
    return out
