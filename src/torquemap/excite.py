"""Exciting trajectories for identifying an arm's inertial parameters (``torquemap excite``).

Each joint follows a finite Fourier series (Swevers, Ganseman, Tukel, De Schutter & Van Brussel
1997, Eq 21)::

    q_j(t) = c_j + sum_l a_jl / (w l) sin(w l t) - b_jl / (w l) cos(w l t),   w = 2 pi / period

with the coefficients constrained so that every period starts and ends at ``c_j`` at rest with
zero acceleration (the user moves the robot to the first row first), scaled into the URDF's
position and velocity limits, and chosen by a random search for the smallest condition number
of the regressor stacked over one period: the base inertial parameters' columns and, per joint,
a friction offset, a Coulomb step and a viscous column (each column scaled to unit norm).
The path is played at several speeds in turn (``speeds``, default full speed, then a quarter):
the same poses at a spread of speeds, slow stretches included, so that friction at low speed is
seen where the robot will work and is not confused with gravity (docs/arm-bench.md).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError


class _Limited(Protocol):
    joint_names: tuple[str, ...]

    @property
    def position_limits(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...

    @property
    def velocity_limits(self) -> NDArray[np.float64]: ...

    def regressor(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]: ...


@dataclass(frozen=True, slots=True, eq=False)
class ExcitingTrajectory:
    """A periodic exciting trajectory.

    Attributes
    ----------
    t
        Time [s], shape (n,).
    q, qd, qdd
        Joint position [rad], velocity [rad/s], acceleration [rad/s^2], shape (n, nj).
    joint_names
        The joints, robot file order.
    period
        Fundamental period [s] of the path.
    speeds
        The speed schedule: the path is played at each of these fractions of its speed in
        turn, each for one traversal (``period / |v|`` seconds; negative: backwards).
    centre
        ``c_j`` [rad], the start and end pose, shape (nj,).
    sine, cosine
        Coefficients ``a_jl`` and ``b_jl`` [rad/s], shape (nj, harmonics).
    condition_number
        Condition number of the regressor (base inertial parameters and per joint a friction
        offset, Coulomb and viscous column; columns scaled to unit norm) stacked over one
        period at each speed of the schedule [-].
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    qd: NDArray[np.float64]
    qdd: NDArray[np.float64]
    joint_names: tuple[str, ...]
    period: float
    speeds: tuple[float, ...]
    centre: NDArray[np.float64]
    sine: NDArray[np.float64]
    cosine: NDArray[np.float64]
    condition_number: float


def fourier_trajectory(
    t: ArrayLike,
    centre: ArrayLike,
    sine: ArrayLike,
    cosine: ArrayLike,
    *,
    period: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Position [rad], velocity [rad/s] and acceleration [rad/s^2] of the Fourier series.

    Parameters
    ----------
    t
        Time [s], shape (n,).
    centre
        Shape (nj,) [rad].
    sine, cosine
        ``a_jl``, ``b_jl`` [rad/s], shape (nj, L).
    period
        Fundamental period [s].

    Returns
    -------
    (q, qd, qdd)
        Each shape (n, nj).

    Examples
    --------
    >>> q, qd, qdd = fourier_trajectory([0.0], [0.5], [[1.0]], [[0.0]], period=1.0)
    >>> float(q[0, 0]), float(qd[0, 0])
    (0.5, 1.0)
    """
    tt = np.asarray(t, dtype=np.float64)[:, None, None]
    a = np.asarray(sine, dtype=np.float64)[None]
    b = np.asarray(cosine, dtype=np.float64)[None]
    w = 2.0 * np.pi / period * np.arange(1, a.shape[-1] + 1)
    s, c = np.sin(w * tt), np.cos(w * tt)
    q = np.asarray(centre, dtype=np.float64) + np.sum((a * s - b * c) / w, axis=-1)
    qd = np.sum(a * c + b * s, axis=-1)
    qdd = np.sum(w * (-a * s + b * c), axis=-1)
    return q, qd, qdd


def _constrain(a: NDArray[np.float64], b: NDArray[np.float64], w: NDArray[np.float64]) -> None:
    """Project each joint's coefficients onto q(0) = c, qd(0) = 0, qdd(0) = 0 (in place)."""
    # sum_l a_l = 0 (velocity); sum_l b_l / w_l = 0 (position) and sum_l b_l w_l = 0 (accel.)
    a -= a.mean(axis=1, keepdims=True)
    cons = np.stack([1.0 / w, w])  # (2, L)
    proj = np.eye(w.size) - cons.T @ np.linalg.solve(cons @ cons.T, cons)
    b[:] = b @ proj.T


def _scale_into_limits(
    a: NDArray[np.float64],
    b: NDArray[np.float64],
    half_range: NDArray[np.float64],
    speed: NDArray[np.float64],
    period: float,
) -> None:
    t = np.linspace(0.0, period, 2000, endpoint=False)
    zero = np.zeros(a.shape[0])
    q, qd, _ = fourier_trajectory(t, zero, a, b, period=period)
    reach = np.max(np.abs(q), axis=0) / half_range
    fast = np.max(np.abs(qd), axis=0) / speed
    # 0.5 % margin: the peaks may fall between the grid's samples
    factor = 0.995 / np.maximum(np.maximum(reach, fast), 1e-12)
    a *= factor[:, None]
    b *= factor[:, None]


HARMONIC_DECAY = 1.0
"""The random search draws harmonic ``l``'s coefficients with standard deviation ``l^-decay``:
every harmonic then brings the same acceleration on average and the low ones most of the
travel, so that the joints span their ranges within their speed limits."""
ONE_TURN = np.pi
"""A joint swings at most this far [rad] from the centre: gravity and kinematics repeat every
turn, so joints of wider range (the UR5's +-2 pi) need not sweep more than +-pi."""
PERIOD_FACTOR = 2.0
"""The default period is this many times the slowest joint's ``2 pi A_j / v_j``: the
harmonics share the speed budget, and a path of the bare ``2 pi A / v`` would not reach the
range's ends."""
COULOMB_WIDTH = 0.01
"""The Coulomb column of the search's criterion is ``tanh(qd / (this * speed limit))``."""


def _condition(arm: _Limited, q: Any, qd: Any, qdd: Any, speed: NDArray[np.float64]) -> float:
    """Condition number of the regressor with joint columns, each column scaled to unit norm."""
    Y = arm.regressor(q, qd, qdd)
    n, nj, _ = Y.shape
    joint = np.zeros((n, nj, 3 * nj))
    for k in range(nj):  # a friction offset, a Coulomb step and viscous friction per joint
        joint[:, k, 3 * k] = 1.0
        joint[:, k, 3 * k + 1] = np.tanh(qd[:, k] / (COULOMB_WIDTH * speed[k]))
        joint[:, k, 3 * k + 2] = qd[:, k]
    W = np.concatenate([Y, joint], axis=2).reshape(n * nj, -1)
    W = W / (np.linalg.norm(W, axis=0) + 1e-300)
    # through the Gram matrix: a small symmetric eigenproblem, much cheaper than an SVD of W
    ev = np.linalg.eigvalsh(W.T @ W)
    return float(np.sqrt(ev[-1] / ev[0])) if ev[0] > 0 else float("inf")


def exciting_trajectory(
    arm: _Limited,
    *,
    duration: float | None = None,
    period: float | None = None,
    harmonics: int = 5,
    rate: float = 500.0,
    iterations: int = 80,
    position_margin: float = 0.1,
    speed_fraction: float = 0.7,
    centre: ArrayLike | None = None,
    speeds: Sequence[float] = (1.0, 0.25),
    rng: np.random.Generator | int | None = 0,
) -> ExcitingTrajectory:
    """An exciting trajectory within the arm's limits, chosen for a well-conditioned regressor.

    Parameters
    ----------
    arm
        The arm (``torquemap.robots.urdf.UrdfArm``): its limits and base regressor are used.
    duration
        Length [s]: the schedule's traversals in turn (repeated), whole traversals, rounded
        up; default one of each (``period * sum(1 / |speeds|)``, five periods by default).
    period
        Fundamental period [s] of the path at full speed. Default: :data:`PERIOD_FACTOR` times
        the longest time a joint's sine takes to swing over its range (up to +-pi) at its speed
        limit, ``2 pi A_j / v_j``, rounded up to 0.1 s: long enough for every joint to span its
        range within its speed limit, and no slower (Panda 19.2 s, UR5 18 s, the simulated
        leg 2.9 s); at most ``duration`` when that is given.
    harmonics
        Number of harmonics per joint.
    rate
        Sample rate of the output [Hz].
    iterations
        Candidate coefficient sets tried by the random search.
    position_margin
        Fraction of each joint's range kept free at both ends [-].
    speed_fraction
        Fraction of each joint's velocity limit used at most [-].
    centre
        Pose [rad] the motion swings about and starts and ends at, shape (nj,); default the
        middle of each joint's range. Excite about the poses the robot will work at: a model
        identified elsewhere extrapolates there (docs/arm-bench.md, the UR5).
    speeds
        Fractions of the path's speed (0 < |v| <= 1; negative: played backwards), one traversal
        each in turn. The default, full speed then a quarter, shows the friction at the task's
        low speeds at the same poses (docs/arm-bench.md).
    rng
        Random generator or seed.

    Returns
    -------
    ExcitingTrajectory
        The trajectory and its condition number.

    Raises
    ------
    InputError
        On a non-positive duration, period or rate, or a speed outside 0 < |v| <= 1.
    """
    schedule = tuple(float(v) for v in speeds)
    if not schedule or not all(0 < abs(v) <= 1 for v in schedule):
        raise InputError(f"speeds must be fractions 0 < |v| <= 1 of full speed, got {schedule}")
    gen = np.random.default_rng(rng)
    lo, hi = arm.position_limits
    # a URDF's <limit lower="0" upper="0"> (example-robot-data's double pendulum) often means
    # "no limit" (MuJoCo ignores it); read literally the joint cannot move, and the trajectory
    # was written standing still with an infinite condition number
    stuck = [n for n, a, b in zip(arm.joint_names, lo, hi, strict=True) if not b > a]
    if stuck:
        at = float(lo[list(arm.joint_names).index(stuck[0])])
        raise InputError(
            f"joint {stuck[0]!r} has no range in the URDF (lower = upper = {at:g}): give its "
            "<limit> the real lower and upper, or make it continuous"
            + (f" (also {', '.join(stuck[1:])})" if len(stuck) > 1 else ""),
            path=getattr(arm, "urdf_path", None),
        )
    lo = np.where(np.isfinite(lo), lo, -np.pi)
    hi = np.where(np.isfinite(hi), hi, np.pi)
    margin = position_margin * (hi - lo)
    if centre is None:
        mid = 0.5 * (lo + hi)
    else:
        mid = np.asarray(centre, dtype=np.float64).reshape(-1)
        if mid.size != lo.size or not np.all(np.isfinite(mid)):
            raise InputError(f"centre needs {lo.size} finite joint angles, got {mid.size}")
        if np.any(mid < lo + margin) or np.any(mid > hi - margin):
            raise InputError(
                "centre is outside the joints' limits (less the position margin): "
                + ", ".join(
                    f"{n}={c:.4g}"
                    for n, c, a, b in zip(
                        arm.joint_names, mid, lo + margin, hi - margin, strict=True
                    )
                    if not a <= c <= b
                )
            )
    centre = mid
    half_range = np.maximum(np.minimum(centre - lo, hi - centre) - margin, 1e-6)
    half_range = np.minimum(half_range, ONE_TURN)
    vmax = arm.velocity_limits
    speed = speed_fraction * np.where(np.isfinite(vmax), vmax, 2.0)
    if period is None:  # the slowest joint's swing over its range at its speed limit, twice
        period = math.ceil(10.0 * PERIOD_FACTOR * float(np.max(2 * np.pi * half_range / speed)))
        period /= 10.0
        if duration is not None:
            period = min(period, duration)
    if duration is None:
        duration = period * sum(1.0 / abs(v) for v in schedule)
    if not (duration > 0 and period > 0 and rate > 0 and harmonics >= 1):
        raise InputError("duration, period and rate must be positive, harmonics >= 1")
    nj = len(arm.joint_names)
    w: NDArray[np.float64] = 2.0 * np.pi / period * np.arange(1, harmonics + 1, dtype=np.float64)
    grid = np.linspace(0.0, period, max(8 * harmonics, 40), endpoint=False)

    weight = np.arange(1, harmonics + 1, dtype=np.float64) ** -HARMONIC_DECAY
    played = sorted({abs(v) for v in schedule})

    def draw() -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return (
            gen.standard_normal((nj, harmonics)) * weight,
            gen.standard_normal((nj, harmonics)) * weight,
        )

    def candidate(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
        _constrain(a, b, w)
        _scale_into_limits(a, b, half_range, speed, period)
        q, qd, qdd = fourier_trajectory(grid, centre, a, b, period=period)
        return _condition(
            arm,
            np.concatenate([q] * len(played)),
            np.concatenate([v * qd for v in played]),
            np.concatenate([v * v * qdd for v in played]),
            speed,
        )

    best_a, best_b = draw()
    best = candidate(best_a, best_b)
    step = 1.0
    for k in range(1, iterations):
        if k < iterations // 3:
            a, b = draw()
        else:
            scale = np.abs(best_a).mean() + np.abs(best_b).mean()
            a = best_a + step * scale * gen.standard_normal((nj, harmonics))
            b = best_b + step * scale * gen.standard_normal((nj, harmonics))
        value = candidate(a, b)
        if value < best:
            best, best_a, best_b = value, a, b
        elif k >= iterations // 3:
            step = max(step * 0.97, 0.05)
    starts, total = [], 0.0
    while total < duration - 1e-9:  # whole traversals of the schedule, in turn
        starts.append(total)
        total += period / abs(schedule[(len(starts) - 1) % len(schedule)])
    t = np.arange(round(total * rate) + 1) / rate
    q, qd, qdd = (np.empty((t.size, nj)) for _ in range(3))
    segment = np.searchsorted(np.asarray(starts), t + 0.5 / rate, side="right") - 1
    for k, t0 in enumerate(starts):
        v = schedule[k % len(schedule)]
        sel = segment == k
        tau = np.clip((t[sel] - t0) * abs(v), 0.0, period)
        if v < 0:  # backwards: the same poses, the velocity reversed
            tau = period - tau
        pq, pqd, pqdd = fourier_trajectory(tau, centre, best_a, best_b, period=period)
        q[sel], qd[sel], qdd[sel] = pq, v * pqd, v * v * pqdd
    return ExcitingTrajectory(
        t=t,
        q=q,
        qd=qd,
        qdd=qdd,
        joint_names=tuple(arm.joint_names),
        period=period,
        speeds=schedule,
        centre=centre,
        sine=best_a,
        cosine=best_b,
        condition_number=best,
    )


def trajectory_columns(trajectory: ExcitingTrajectory) -> dict[str, NDArray[np.float64]]:
    """Columns ``t``, ``q_<j>``, ``qd_<j>``, ``qdd_<j>`` of a trajectory file (docs/formats.md)."""
    out = {"t": trajectory.t}
    for k, name in enumerate(trajectory.joint_names):
        out[f"q_{name}"] = trajectory.q[:, k]
    for k, name in enumerate(trajectory.joint_names):
        out[f"qd_{name}"] = trajectory.qd[:, k]
    for k, name in enumerate(trajectory.joint_names):
        out[f"qdd_{name}"] = trajectory.qdd[:, k]
    return out
