"""The motor-side model of an arm with rigid-body dynamics, shared by identification and estimation.

For joint ``j`` with gear ratio ``N_j`` the motor torque balances (motor side, docs/arm.md)::

    tau_m_j = [Y(q, qd, qdd) pi]_j / N_j + J_a,j N_j qdd_j + f_j(N_j qd_j) + PDTV_j(N_j q_j)
              - tau_ext_j / N_j

with ``Y pi`` the rigid bodies' inverse dynamics (the arm's regressor, joint side), ``J_a`` the
rotor inertia (armature, motor side: reflected to the joint by ``N^2``), ``f`` the joint's
friction law at the motor velocity, the PDTV lines at the motor angle and ``tau_ext`` the
joint-side torque exerted by the environment. Every term but ``tau_ext`` is linear in its
parameters: the columns of one joint are :func:`joint_columns`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.filters import differentiate, smooth_as_acceleration
from torquemap.io import Log
from torquemap.model import JointModel, PdtvLine, pdtv_torque
from torquemap.robot import Robot


@dataclass(frozen=True, slots=True, eq=False)
class ArmSignals:
    """A log differentiated for an arm (joint side unless stated).

    Attributes
    ----------
    t
        Time [s], shape (n,).
    q, qd, qdd
        Smoothed joint position [rad], velocity [rad/s], acceleration [rad/s^2], shape (n, nj).
    q_measured
        The log's joint positions [rad], shape (n, nj) (motor angle = gear * q_measured).
    motor_torque
        Motor torque [N m, motor side] as logged, shape (n, nj).
    gear
        Gear ratios, shape (nj,).
    window
        The differentiator's window [s].
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    qd: NDArray[np.float64]
    qdd: NDArray[np.float64]
    q_measured: NDArray[np.float64]
    motor_torque: NDArray[np.float64]
    gear: NDArray[np.float64]
    window: float

    def smooth(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """``x`` (n,) or (n, c) through the kernel the accelerations were seen through
        (:func:`torquemap.filters.smooth_as_acceleration`), column by column: whatever is
        regressed on the accelerations must be filtered alike, or a fast PDTV line and the
        friction step at a reversal would not match."""
        if x.ndim == 1:
            return smooth_as_acceleration(self.t, x, window=self.window)
        return np.column_stack(
            [smooth_as_acceleration(self.t, x[:, i], window=self.window) for i in range(x.shape[1])]
        )


def arm_signals(log: Log, robot: Robot, *, window: float) -> ArmSignals:
    """Differentiate a log's joint angles.

    Parameters
    ----------
    log
        The log.
    robot
        Its robot.
    window
        Differentiator window [s] (:func:`torquemap.filters.differentiate`).

    Raises
    ------
    InputError
        When the log is shorter than the window.
    """
    span = float(log.t[-1] - log.t[0])
    if span < 2 * window:
        raise InputError(
            f"log lasts {span:.3g} s, too short for the {window:.3g} s differentiator window",
            path=log.path,
        )
    n, nj = log.q.shape
    q, qd, qdd = (np.empty((n, nj)) for _ in range(3))
    for k in range(nj):
        try:
            d = differentiate(log.t, log.q[:, k], window=window)
        except InputError as exc:
            raise InputError(exc.message, path=log.path) from None
        q[:, k], qd[:, k], qdd[:, k] = d.position, d.velocity, d.acceleration
    gear = np.array([j.gear_ratio for j in robot.joints])
    return ArmSignals(
        t=log.t,
        q=q,
        qd=qd,
        qdd=qdd,
        q_measured=log.q,
        motor_torque=log.motor_torque,
        gear=gear,
        window=window,
    )


def column_names(joint: str, joint_model: JointModel, orders: tuple[float, ...]) -> list[str]:
    """Names of :func:`joint_columns`: armature, friction parameters, PDTV cos/sin pairs."""
    names = [f"{joint}.armature"]
    names += [f"{joint}.friction.{p}" for p in joint_model.friction.linear_parameter_names]
    for order in orders:
        names += [f"{joint}.pdtv.{order:g}.cos", f"{joint}.pdtv.{order:g}.sin"]
    return names


def joint_columns(
    joint_model: JointModel,
    signals: ArmSignals,
    k: int,
    orders: tuple[float, ...],
    *,
    smooth: bool,
) -> NDArray[np.float64]:
    """Columns (n, c) of joint ``k``'s motor-side terms, linear in its parameters.

    ``[N qdd, friction.basis(N qd), cos(o N q), sin(o N q), ...]`` for the armature [kg m^2],
    the friction law's linear parameters and, per PDTV order ``o`` [CPR], ``A cos(phase)`` and
    ``-A sin(phase)`` [N m] (so that ``A cos(o theta + phase)`` is their combination). With
    ``smooth`` the friction and PDTV columns go through :meth:`ArmSignals.smooth` (the
    acceleration already has).
    """
    gear = float(signals.gear[k])
    theta = gear * signals.q_measured[:, k]
    other = [joint_model.friction.basis(gear * signals.qd[:, k])]
    for order in orders:
        other.append(np.stack([np.cos(order * theta), np.sin(order * theta)], axis=1))
    rest = np.concatenate(other, axis=1)
    if smooth:
        rest = signals.smooth(rest)
    return np.concatenate([gear * signals.qdd[:, k, None], rest], axis=1)


def joint_parameters(joint_model: JointModel) -> tuple[NDArray[np.float64], tuple[float, ...]]:
    """The values of :func:`joint_columns`'s parameters in a joint model, and the PDTV orders.

    Directional PDTV lines are dropped (the arm model uses lines for both directions).
    """
    lines = [ln for ln in joint_model.pdtv if ln.direction == "both"]
    values = [joint_model.inertia.constant, *joint_model.friction.linear_parameters()]
    for ln in lines:
        values += [ln.amplitude * math.cos(ln.phase), -ln.amplitude * math.sin(ln.phase)]
    return np.array(values, dtype=np.float64), tuple(ln.order for ln in lines)


def pdtv_lines(orders: tuple[float, ...], values: NDArray[np.float64]) -> tuple[PdtvLine, ...]:
    """PDTV lines from the cos/sin parameters of :func:`joint_columns` (pairs per order)."""
    out = []
    for k, order in enumerate(orders):
        c, s = float(values[2 * k]), float(values[2 * k + 1])
        out.append(PdtvLine(order=order, amplitude=math.hypot(c, s), phase=math.atan2(-s, c)))
    return tuple(out)


def drive_torque(
    robot: Robot, joints: Mapping[str, JointModel], signals: ArmSignals, *, smooth: bool
) -> NDArray[np.float64]:
    """Joint-side torque the drives deliver to the links [N m], shape (n, nj).

    ``N (tau_m - f(N qd) - PDTV(N q)) - N^2 J_a qdd``: the motor torque net of the motor-side
    friction, PDTV and rotor inertia, through the gear; with ``smooth`` the net motor torque
    goes through :meth:`ArmSignals.smooth` first (to match the accelerations).
    """
    out = np.empty_like(signals.q)
    for k, joint in enumerate(robot.joints):
        jm = joints[joint.name]
        n = signals.gear[k]
        net = (
            signals.motor_torque[:, k]
            - jm.friction.torque(n * signals.qd[:, k])
            - pdtv_torque(n * signals.q_measured[:, k], jm.pdtv, velocity=signals.qd[:, k])
        )
        if smooth:
            net = signals.smooth(net)
        out[:, k] = n * (net - jm.inertia.constant * n * signals.qdd[:, k])
    return out


def without_rigid_body(log: Log, robot: Robot, *, window: float) -> Log:
    """``log`` with the arm's rigid-body torque taken out of its motor torques: ``tau_m -
    [Y(q, qd, qdd) pi]_j / N_j`` (the robot's arm, the identified one in a model), velocity and
    acceleration from :func:`arm_signals`. What is left is the joints' own torque (armature,
    friction, PDTV) plus what the arm's model misses: a per-joint method (the PDTV spectrum of
    a pass) then sees no gravity or coupling, which vary along a pass and read as low orders.

    Examples
    --------
    >>> from pathlib import Path
    >>> from torquemap.robots.urdf import urdf_arm
    >>> arm = urdf_arm(Path("tests/data/arm/two_link.urdf"), ["shoulder"], end_effector="tool",
    ...                gravity=(0.0, -9.81, 0.0))
    >>> from torquemap.robot import Joint
    >>> rb = Robot(name="p", kinematics="urdf", link_lengths=(), arm=arm,
    ...            joints=(Joint(name="shoulder", gear_ratio=10.0, torque_constant=0.1),))
    >>> t = np.arange(0.0, 2.0, 1e-3)
    >>> q = 0.3 * t[:, None]
    >>> g = arm.gravity_torque(q)[:, 0] / 10.0  # constant speed: gravity alone
    >>> log = Log(t=t, q=q, motor_torque=(g + 0.01)[:, None], joint_names=("shoulder",))
    >>> left = without_rigid_body(log, rb, window=0.05).motor_torque[100:-100, 0]
    >>> bool(np.allclose(left, 0.01, atol=1e-6))
    True
    """
    import dataclasses

    sig = arm_signals(log, robot, window=window)
    rigid = robot.arm.inverse_dynamics(sig.q, sig.qd, sig.qdd) / sig.gear
    return dataclasses.replace(log, motor_torque=log.motor_torque - rigid)
