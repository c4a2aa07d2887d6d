"""Reference trajectories of the simulated SCARA: trapezoidal sweeps and the tracked circle.

Each reference is sampled at the servo rate and gives joint-side position, velocity and
acceleration, which the controller of :mod:`torquemap.sim.engine` tracks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.sim.scara import ScaraBench


@dataclass(frozen=True, slots=True, eq=False)
class Reference:
    """A joint-side reference sampled at the servo rate.

    Attributes
    ----------
    t
        Time [s], ``k / servo_rate``, shape (n,).
    q, qd, qdd
        Joint angle [rad], velocity [rad/s], acceleration [rad/s^2], shape (n, 2).
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    qd: NDArray[np.float64]
    qdd: NDArray[np.float64]


@dataclass(frozen=True, slots=True, eq=False)
class Profile:
    """A scalar motion profile: position, velocity, acceleration at the requested times."""

    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]


def trapezoid_duration(distance: float, *, speed: float, acceleration: float) -> float:
    """Duration [s] of a trapezoidal move of ``|distance|`` (triangular when too short).

    Examples
    --------
    >>> trapezoid_duration(10.0, speed=5.0, acceleration=5.0)
    3.0
    """
    d, v, a = abs(distance), abs(speed), abs(acceleration)
    if d >= v * v / a:
        return d / v + v / a
    return 2.0 * math.sqrt(d / a)


def trapezoid(t: ArrayLike, distance: float, *, speed: float, acceleration: float) -> Profile:
    """A rest-to-rest trapezoidal move of ``distance`` sampled at times ``t`` [s] from its start.

    Parameters
    ----------
    t
        Times since the start of the move [s]; before 0 the profile is at 0, after the end at
        ``distance``.
    distance
        Signed travel [rad].
    speed
        Cruise speed [rad/s] (magnitude), reduced when the move is too short to reach it.
    acceleration
        Acceleration and deceleration [rad/s^2] (magnitude).

    Returns
    -------
    Profile
        Position from 0 [rad], velocity [rad/s], acceleration [rad/s^2].

    Examples
    --------
    >>> p = trapezoid([0.0, 1.5, 3.0], 10.0, speed=5.0, acceleration=5.0)
    >>> p.position.round(6), p.velocity.round(6)
    (array([ 0.,  5., 10.]), array([0., 5., 0.]))
    """
    tt = np.asarray(t, dtype=np.float64)
    d, a = abs(distance), abs(acceleration)
    v = min(abs(speed), math.sqrt(d * a))
    sign = 1.0 if distance >= 0 else -1.0
    t1 = v / a
    total = trapezoid_duration(d, speed=v, acceleration=a) if d > 0 else 0.0
    t2 = total - t1
    tc = np.clip(tt, 0.0, total)
    pos = np.where(
        tc < t1,
        0.5 * a * tc**2,
        np.where(tc <= t2, 0.5 * a * t1**2 + v * (tc - t1), d - 0.5 * a * (total - tc) ** 2),
    )
    vel = np.where(tc < t1, a * tc, np.where(tc <= t2, v, a * (total - tc)))
    acc = np.where(tc < t1, a, np.where(tc <= t2, 0.0, -a))
    inside = (tt >= 0) & (tt < total)
    vel = np.where(inside, vel, 0.0)
    acc = np.where(inside, acc, 0.0)
    return Profile(position=sign * pos, velocity=sign * vel, acceleration=sign * acc)


class _Builder:
    """Concatenates holds and single-joint moves sample by sample."""

    def __init__(self, start: tuple[float, float], rate: float) -> None:
        self.rate = rate
        self.q = np.array(start, dtype=np.float64)
        self.chunks: list[tuple[NDArray[np.float64], ...]] = []

    def hold(self, duration: float) -> None:
        n = max(1, round(duration * self.rate))
        z = np.zeros((n, 2))
        self.chunks.append((np.tile(self.q, (n, 1)), z, z.copy()))

    def move(self, joint: int, distance: float, *, speed: float, acceleration: float) -> None:
        total = trapezoid_duration(distance, speed=speed, acceleration=acceleration)
        n = math.ceil(total * self.rate)
        t = np.arange(n) / self.rate
        p = trapezoid(t, distance, speed=speed, acceleration=acceleration)
        q = np.tile(self.q, (n, 1))
        qd = np.zeros((n, 2))
        qdd = np.zeros((n, 2))
        q[:, joint] += p.position
        qd[:, joint] = p.velocity
        qdd[:, joint] = p.acceleration
        self.chunks.append((q, qd, qdd))
        self.q[joint] += distance

    def reference(self) -> Reference:
        q = np.concatenate([c[0] for c in self.chunks])
        qd = np.concatenate([c[1] for c in self.chunks])
        qdd = np.concatenate([c[2] for c in self.chunks])
        return Reference(t=np.arange(q.shape[0]) / self.rate, q=q, qd=qd, qdd=qdd)


def sweep_reference(bench: ScaraBench) -> Reference:
    """The no-load identification sweeps of scenario (a) (:class:`torquemap.sim.scara.Sweep`).

    Order: ``a`` at every speed at the first elbow angle; ``b`` moved to the second elbow angle;
    ``a`` at the fastest speeds there and ``b`` at every speed; ``b`` moved to each further
    elbow angle and ``a`` at the fastest speeds. Every pass goes forward then back.

    Examples
    --------
    >>> from torquemap.sim.scara import default_bench
    >>> ref = sweep_reference(default_bench())
    >>> bool(np.all(np.diff(ref.t) > 0))
    True
    """
    sw = bench.sweep
    na, nb = (ax.gear_ratio for ax in bench.axes)
    ratios = (na, nb)
    b = _Builder((0.0, sw.elbow_angles[0]), bench.controller.servo_rate)
    b.hold(sw.dwell)

    def passes(joint: int, speeds: tuple[float, ...]) -> None:
        n = ratios[joint]
        for v in speeds:
            travel = 2 * math.pi * sw.revolutions + v * v / sw.acceleration
            for sign in (1.0, -1.0):
                b.move(joint, sign * travel / n, speed=v / n, acceleration=sw.acceleration / n)
                b.hold(sw.dwell)

    fast = tuple(sorted(sw.speeds)[-sw.fast_speeds :]) if sw.fast_speeds > 0 else ()
    move_speed, move_acc = max(sw.speeds), sw.acceleration
    passes(0, sw.speeds)
    for k, elbow in enumerate(sw.elbow_angles[1:], start=1):
        b.move(1, elbow - float(b.q[1]), speed=move_speed / nb, acceleration=move_acc / nb)
        b.hold(sw.dwell)
        passes(0, fast)
        if k == 1:
            passes(1, sw.speeds)
    return b.reference()


def _inverse_kinematics(
    bench: ScaraBench, x: NDArray[np.float64], y: NDArray[np.float64]
) -> NDArray[np.float64]:
    l1, l2 = bench.links.lengths
    c2 = (x * x + y * y - l1 * l1 - l2 * l2) / (2 * l1 * l2)
    if np.any(np.abs(c2) > 1.0):
        raise ValueError("circle leaves the workspace")
    q2 = np.arccos(c2)
    q1 = np.arctan2(y, x) - np.arctan2(l2 * np.sin(q2), l1 + l2 * np.cos(q2))
    return np.stack([np.unwrap(q1), q2], axis=-1)


def circle_phase(t: ArrayLike, bench: ScaraBench) -> Profile:
    """Angle [rad] about the circle centre, its rate and acceleration, at times ``t`` [s].

    Hold, a raised-cosine ramp of the angular speed up to ``angular_speed``, cruise, the mirror
    ramp down, hold; the angle covered is ``turns * 2 pi``.
    """
    c = bench.circle
    tt = np.asarray(t, dtype=np.float64)
    w, tr = c.angular_speed, c.ramp
    cruise = c.turns * 2 * math.pi / w - tr
    if cruise < 0:
        raise ValueError("circle too short for its ramps")
    t1 = c.hold
    t2 = t1 + tr
    t3 = t2 + cruise
    t4 = t3 + tr
    u = np.clip(tt - t1, 0.0, tr)
    up_phase = w * (u / 2 - tr / (2 * math.pi) * np.sin(math.pi * u / tr))
    v = np.clip(tt - t3, 0.0, tr)
    down_phase = w * (v / 2 + tr / (2 * math.pi) * np.sin(math.pi * v / tr))
    phase = up_phase + w * np.clip(tt - t2, 0.0, cruise) + down_phase
    rate = np.where(
        tt < t1,
        0.0,
        np.where(
            tt < t2,
            w * (1 - np.cos(math.pi * u / tr)) / 2,
            np.where(tt < t3, w, np.where(tt < t4, w * (1 + np.cos(math.pi * v / tr)) / 2, 0.0)),
        ),
    )
    k = w * math.pi / (2 * tr)
    acc = np.where(
        (tt >= t1) & (tt < t2),
        k * np.sin(math.pi * u / tr),
        np.where((tt >= t3) & (tt < t4), -k * np.sin(math.pi * v / tr), 0.0),
    )
    return Profile(position=phase, velocity=rate, acceleration=acc)


def circle_duration(bench: ScaraBench) -> float:
    """Total duration of the circle scenario [s], holds and ramps included."""
    c = bench.circle
    return 2 * c.hold + c.turns * 2 * math.pi / c.angular_speed + c.ramp


def circle_reference(bench: ScaraBench) -> Reference:
    """The tracked circle of scenario (b), by inverse kinematics (elbow ``q_b > 0``).

    Examples
    --------
    >>> from torquemap.sim.scara import default_bench
    >>> ref = circle_reference(default_bench())
    >>> bool(ref.q[:, 1].min() > 0)
    True
    """
    c = bench.circle
    rate = bench.controller.servo_rate
    n = math.ceil(circle_duration(bench) * rate) + 1
    t = np.arange(n) / rate
    ph = circle_phase(t, bench)
    ang = c.start_angle + ph.position
    ca, sa = np.cos(ang), np.sin(ang)
    x = c.centre[0] + c.radius * ca
    y = c.centre[1] + c.radius * sa
    q = _inverse_kinematics(bench, x, y)
    xd = -c.radius * sa * ph.velocity
    yd = c.radius * ca * ph.velocity
    xdd = -c.radius * (sa * ph.acceleration + ca * ph.velocity**2)
    ydd = c.radius * (ca * ph.acceleration - sa * ph.velocity**2)
    l1, l2 = bench.links.lengths
    s1, c1 = np.sin(q[:, 0]), np.cos(q[:, 0])
    s12, c12 = np.sin(q[:, 0] + q[:, 1]), np.cos(q[:, 0] + q[:, 1])
    jac = np.empty((n, 2, 2))
    jac[:, 0, 0] = -l1 * s1 - l2 * s12
    jac[:, 0, 1] = -l2 * s12
    jac[:, 1, 0] = l1 * c1 + l2 * c12
    jac[:, 1, 1] = l2 * c12
    qd = np.asarray(
        np.linalg.solve(jac, np.stack([xd, yd], axis=-1)[..., None])[..., 0], dtype=np.float64
    )
    w1, w12 = qd[:, 0], qd[:, 0] + qd[:, 1]
    jdot_qd = np.stack(
        [-l1 * c1 * w1**2 - l2 * c12 * w12**2, -l1 * s1 * w1**2 - l2 * s12 * w12**2], axis=-1
    )
    rhs = np.stack([xdd, ydd], axis=-1) - jdot_qd
    qdd = np.asarray(np.linalg.solve(jac, rhs[..., None])[..., 0], dtype=np.float64)
    return Reference(t=t, q=q, qd=qd, qdd=qdd)
