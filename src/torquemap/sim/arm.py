"""The simulated arm bench: a Panda in MuJoCo whose truth differs from its URDF (docs/arm.md).

The same bench runs the other arms of :data:`ARMS` (UR5, xArm7, Unitree Z1, Kinova Jaco2;
docs/arm-bench.md).

MuJoCo (an engine independent of the Pinocchio model torquemap fits) simulates the Panda of
``example-robot-data`` with every link's mass and inertia scaled by up to +-15 % and a 0.8 kg
tool the URDF lacks, driven through gears with rotor inertia (``dof_armature``), a motor-side
friction law of another form than the one torquemap fits (Stribeck exponent 1, tanh
transition), a torque ripple in motor angle, encoder quantisation and current noise, under
computed-torque control on the NOMINAL model (so tracking is imperfect). Two runs: ``free``
(an exciting trajectory, no contact) and ``task`` (the end effector pressing on a compliant
horizontal surface with 5-20 N while it moves in a circle; the surface is an explicit
spring-damper with Coulomb sliding friction, applied at the end effector through
``xfrc_applied``). The true force on the end effector is kept for scoring only.
"""

from __future__ import annotations

import math
import os
import sys
import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pinocchio as pin
from numpy.typing import NDArray
from scipy.interpolate import CubicSpline

from torquemap.errors import InputError

TOOL_MASS = 0.8  # [kg]
TOOL_OFFSET = 0.1  # [m] beyond the flange (panda_link8), along its z axis
SURFACE_STIFFNESS = 1000.0  # [N/m]
SURFACE_DAMPING = 20.0  # [N s/m]
SURFACE_FRICTION = 0.3  # sliding friction coefficient


@dataclass(frozen=True, slots=True, eq=False)
class ArmSpec:
    """One arm of ``example-robot-data`` as the bench drives it.

    Attributes
    ----------
    name
        ``"panda"``, ``"ur5"``, ``"xarm7"`` or ``"z1"``.
    urdf
        Path under the ``robots`` folder.
    joints
        Actuated joints, in order.
    end_effector
        The URDF link whose origin is the end effector.
    gear
        Gear ratios.
    armature
        Rotor inertia per joint [kg m^2], motor side.
    ready
        Start pose of the task, end effector pointing down [rad].
    tool_parent
        The link the tool hangs from (``tool_offset`` in its frame).
    tool_mass
        The tool's mass [kg] (a 3 cm ball).
    tool_offset
        The tool's position in ``tool_parent``'s frame [m].
    surface_stiffness, surface_damping, surface_friction
        The compliant surface (or ground) of the task: [N/m], [N s/m], sliding coefficient [-].
    urdf_text
        The URDF itself when it is not a file of ``example-robot-data`` (``urdf`` is then the
        file name written into the bench folder).
    """

    name: str
    urdf: str
    joints: tuple[str, ...]
    end_effector: str
    gear: tuple[float, ...]
    armature: tuple[float, ...]
    ready: tuple[float, ...]
    tool_parent: str
    tool_mass: float = TOOL_MASS
    tool_offset: tuple[float, float, float] = (0.0, 0.0, TOOL_OFFSET)
    surface_stiffness: float = SURFACE_STIFFNESS
    surface_damping: float = SURFACE_DAMPING
    surface_friction: float = SURFACE_FRICTION
    urdf_text: str | None = None


PANDA = ArmSpec(
    name="panda",
    urdf="panda_description/urdf/panda.urdf",
    joints=tuple(f"panda_joint{k}" for k in range(1, 8)),
    end_effector="panda_hand_tcp",
    gear=(100.0, 100.0, 100.0, 100.0, 80.0, 80.0, 80.0),
    armature=(3e-5, 3e-5, 3e-5, 3e-5, 1.5e-5, 1.5e-5, 1.5e-5),
    ready=(0.0, -0.5, 0.0, -2.2, 0.0, 1.7, 0.785),
    tool_parent="panda_link8",
)
UR5 = ArmSpec(
    name="ur5",
    urdf="ur_description/urdf/ur5_robot.urdf",
    joints=(
        "shoulder_pan_joint",
        "shoulder_lift_joint",
        "elbow_joint",
        "wrist_1_joint",
        "wrist_2_joint",
        "wrist_3_joint",
    ),
    end_effector="tool0",
    gear=(100.0, 100.0, 100.0, 80.0, 80.0, 80.0),
    armature=(6e-5, 6e-5, 6e-5, 2e-5, 2e-5, 2e-5),
    ready=(0.0, -1.9, 1.9, -1.57, -1.57, 0.0),
    tool_parent="tool0",
)
XARM7 = ArmSpec(
    name="xarm7",
    urdf="xarm_description/urdf/xarm7.urdf",
    joints=tuple(f"joint{k}" for k in range(1, 8)),
    end_effector="link_eef",
    gear=(100.0, 100.0, 100.0, 100.0, 80.0, 80.0, 80.0),
    armature=(2e-5, 2e-5, 1.5e-5, 1.5e-5, 1e-5, 1e-5, 1e-5),
    ready=(0.0, 0.0, 0.0, 0.7, 0.0, 0.7, 0.0),  # the flange 0.40 m ahead, 0.25 m up
    tool_parent="link_eef",
)
JACO2 = ArmSpec(
    name="jaco2",
    urdf="kinova_description/robots/kinova.urdf",
    joints=tuple(f"j2s6s200_joint_{k}" for k in range(1, 7)),  # 1, 4 and 6 continuous
    end_effector="j2s6s200_end_effector",
    gear=(100.0, 100.0, 100.0, 80.0, 80.0, 80.0),
    armature=(2e-5, 2e-5, 2e-5, 1e-5, 1e-5, 1e-5),
    ready=(0.0, 3.6, 1.45, 0.0, 4.1332, 0.0),  # q2 - q3 + q5 = 2 pi: 0.45 m along -y, 0.2 m up
    tool_parent="j2s6s200_end_effector",
    tool_offset=(0.1, 0.0, 0.0),  # the hand points along the end effector's x axis
)
Z1 = ArmSpec(
    name="z1",
    urdf="z1_description/urdf/z1.urdf",
    joints=tuple(f"joint{k}" for k in range(1, 7)),
    end_effector="gripperStator",  # a link, and the fixed joint above it
    gear=(60.0, 60.0, 60.0, 40.0, 40.0, 40.0),
    armature=(3e-5, 3e-5, 3e-5, 1.5e-5, 1.5e-5, 1.5e-5),
    ready=(0.0, 2.0, -1.3, 0.8708, 0.0, 0.0),  # 0.35 m ahead, 0.15 m up
    tool_parent="gripperStator",
    tool_offset=(0.1, 0.0, 0.0),  # the gripper points along its x axis
)
ARMS = {"panda": PANDA, "ur5": UR5, "xarm7": XARM7, "z1": Z1, "jaco2": JACO2}
JOINTS = PANDA.joints
END_EFFECTOR = PANDA.end_effector
GEAR = PANDA.gear
ARMATURE = PANDA.armature
TORQUE_CONSTANT = 0.1  # [N m / A], motor side
COUNTS = 16384  # encoder counts per motor revolution
CURRENT_NOISE = 0.02  # [A], standard deviation
MASS_SPREAD = 0.15
TIMESTEP = 1e-3  # [s], MuJoCo and the controller


ARM_NAMES = ("panda", "ur5", "xarm7", "z1", "jaco2", "leg")
"""The benches :func:`write_arm_bench` simulates (``leg``: :mod:`torquemap.sim.leg`)."""


def arm_spec(name: str) -> ArmSpec:
    """The bench's :class:`ArmSpec` by name (one of :data:`ARM_NAMES`); InputError otherwise."""
    if name == "leg":
        from torquemap.sim.leg import LEG

        return LEG
    if name not in ARMS:
        raise InputError(f"unknown arm {name!r} (known: {', '.join(ARM_NAMES)})")
    return ARMS[name]


def robots_folder() -> Path:
    """The ``robots`` folder of the installed ``example-robot-data`` (cmeel prefix)."""
    found = next(
        iter(
            Path(sys.prefix).glob(
                "lib/python3*/site-packages/cmeel.prefix/share/example-robot-data/robots"
            )
        ),
        None,
    )
    if found is None:
        raise InputError("example-robot-data is not installed (pip install example-robot-data)")
    return found


def panda_urdf(spec: ArmSpec | None = None) -> Path:
    """The URDF of ``example-robot-data`` for ``spec`` (default the Panda)."""
    return robots_folder() / (spec or PANDA).urdf


@dataclass(frozen=True, slots=True, eq=False)
class ArmTruth:
    """What differs from the URDF (hidden from torquemap; for tests and benchmarks).

    Attributes
    ----------
    mass_scale
        Factor on each link's mass and inertia, by link name.
    coulomb, stribeck, viscous
        Motor-side friction per joint: ``f(w) = (coulomb + stribeck exp(-|w| / STRIBECK_VEL))
        tanh(w / TANH_VEL) + viscous w`` [N m], [N m], [N m s/rad].
    ripple
        Motor-side torque ripple amplitude per joint [N m], order 2 in motor angle.
    ripple_phase
        Its phase per joint [rad].
    """

    mass_scale: dict[str, float]
    coulomb: NDArray[np.float64]
    stribeck: NDArray[np.float64]
    viscous: NDArray[np.float64]
    ripple: NDArray[np.float64]
    ripple_phase: NDArray[np.float64]


STRIBECK_VEL = 3.0  # [rad/s], motor side
TANH_VEL = 1.5  # [rad/s], motor side
RIPPLE_ORDER = 2.0


def random_truth(seed: int, nominal: ET.Element, n: int = 7) -> ArmTruth:
    """Draw the true arm's deviations from the URDF for ``seed``."""
    rng = np.random.default_rng(seed)
    links = [
        link.get("name", "") for link in nominal.iter("link") if link.find("inertial") is not None
    ]
    scale = {name: float(1.0 + rng.uniform(-MASS_SPREAD, MASS_SPREAD)) for name in links}
    return ArmTruth(
        mass_scale=scale,
        coulomb=rng.uniform(0.005, 0.012, n),
        stribeck=rng.uniform(0.002, 0.005, n),
        viscous=rng.uniform(2e-5, 6e-5, n),
        ripple=rng.uniform(0.001, 0.003, n),
        ripple_phase=rng.uniform(0.0, 2.0 * math.pi, n),
    )


def friction(truth: ArmTruth, w: NDArray[np.float64]) -> NDArray[np.float64]:
    """The true motor-side friction [N m] at motor velocities ``w`` [rad/s], shape (..., nj)."""
    level = truth.coulomb + truth.stribeck * np.exp(-np.abs(w) / STRIBECK_VEL)
    out: NDArray[np.float64] = level * np.tanh(w / TANH_VEL) + truth.viscous * w
    return out


def ripple(truth: ArmTruth, motor_angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """The true motor-side torque ripple [N m] at motor angles [rad]."""
    out: NDArray[np.float64] = truth.ripple * np.cos(
        RIPPLE_ORDER * motor_angle + truth.ripple_phase
    )
    return out


def source_text(spec: ArmSpec) -> str:
    """The nominal URDF's text: ``spec.urdf_text`` or the file of ``example-robot-data``."""
    return spec.urdf_text if spec.urdf_text is not None else panda_urdf(spec).read_text()


def _stripped(urdf: Path | str, spec: ArmSpec = PANDA) -> ET.Element:
    root = ET.parse(urdf).getroot() if isinstance(urdf, Path) else ET.fromstring(urdf)
    for parent in list(root.iter()):
        for child in list(parent):
            if child.tag in ("visual", "collision", "dynamics", "transmission", "gazebo"):
                parent.remove(child)
    for joint in root.findall("joint"):
        if joint.get("name") not in spec.joints and joint.get("type") != "fixed":
            joint.set("type", "fixed")  # the fingers: locked at zero, as torquemap does
            for tag in ("limit", "axis", "mimic"):
                for e in joint.findall(tag):
                    joint.remove(e)
    return root


def true_urdf(nominal: ET.Element, truth: ArmTruth, spec: ArmSpec = PANDA) -> str:
    """The true arm's URDF text: scaled links, the tool, no meshes, fingers fixed."""
    root = ET.fromstring(ET.tostring(nominal))
    for link in root.iter("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        s = truth.mass_scale[link.get("name", "")]
        mass = inertial.find("mass")
        inertia = inertial.find("inertia")
        if mass is not None:
            mass.set("value", repr(s * float(mass.get("value", "0"))))
        if inertia is not None:
            for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
                inertia.set(key, repr(s * float(inertia.get(key, "0"))))
    tool = ET.SubElement(root, "link", name="tool")
    inertial = ET.SubElement(tool, "inertial")
    ET.SubElement(inertial, "origin", xyz="0 0 0", rpy="0 0 0")
    ET.SubElement(inertial, "mass", value=repr(spec.tool_mass))
    r2 = 2.0 / 5.0 * spec.tool_mass * 0.03**2  # a 3 cm radius ball
    ET.SubElement(
        inertial, "inertia", ixx=repr(r2), ixy="0", ixz="0", iyy=repr(r2), iyz="0", izz=repr(r2)
    )
    joint = ET.SubElement(root, "joint", name="tool_joint", type="fixed")
    ET.SubElement(joint, "parent", link=spec.tool_parent)
    ET.SubElement(joint, "child", link="tool")
    ET.SubElement(joint, "origin", xyz=" ".join(repr(v) for v in spec.tool_offset), rpy="0 0 0")
    return ET.tostring(root, encoding="unicode")


def _mujoco_model(
    urdf_text: str, armature: NDArray[np.float64], spec: ArmSpec = PANDA
) -> mujoco.MjModel:
    root = ET.fromstring(urdf_text)
    mj = ET.SubElement(root, "mujoco")
    ET.SubElement(
        mj,
        "compiler",
        discardvisual="true",
        fusestatic="false",
        balanceinertia="false",
        inertiafromgeom="false",
        angle="radian",
    )
    model = mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))
    model.opt.timestep = TIMESTEP
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    names = [model.joint(k).name for k in range(model.njnt)]
    if tuple(names) != spec.joints:
        raise InputError(f"unexpected MuJoCo joints {names}")
    model.dof_armature[:] = armature
    return model


@dataclass(frozen=True, slots=True, eq=False)
class ArmRun:
    """One simulated run at 1 kHz.

    Attributes
    ----------
    t
        Time [s], shape (n,).
    q, qd, qdd
        True joint position [rad], velocity [rad/s] and MuJoCo's acceleration [rad/s^2] over
        each step, shape (n, 7).
    counts
        Measured motor encoder counts (quantised, unwrapped), shape (n, 7).
    current
        Measured motor current [A] (noise included), shape (n, 7).
    drive
        Joint-side torque of the drive [N m]: ``N (Kt i - friction - ripple)``, noise-free.
    wrench
        Wrench by the environment on the end effector [N, N m] (base frame, moments about the
        end effector), shape (n, 6).
    reference
        The controller's reference joint position [rad], shape (n, 7).
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    qd: NDArray[np.float64]
    qdd: NDArray[np.float64]
    counts: NDArray[np.int64]
    current: NDArray[np.float64]
    drive: NDArray[np.float64]
    wrench: NDArray[np.float64]
    reference: NDArray[np.float64]


def _pin_model(urdf_text: str) -> tuple[Any, Any]:
    model = pin.buildModelFromXML(urdf_text)
    return model, model.createData()


def _configuration(
    model: Any, joints: Sequence[str]
) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """A function from joint angles (nj,) [rad], ``joints``' order, to Pinocchio's
    configuration of ``model``: a continuous joint (the Jaco2's) is stored as (cos, sin)."""
    kinds = []
    for k, name in enumerate(joints):
        joint = model.joints[model.getJointId(name)]
        if joint.idx_v != k:  # Pinocchio's velocities must be in the spec's order
            raise InputError(f"joint {name!r} is not the {k + 1}th of the chain")
        kinds.append((joint.nq == 2, joint.idx_q))
    if model.nq == len(joints):
        return lambda q: q
    index = np.array([i for _, i in kinds], dtype=np.intp)
    pair = np.array([p for p, _ in kinds], dtype=bool)
    neutral = np.asarray(pin.neutral(model), dtype=np.float64)

    def configuration(q: NDArray[np.float64]) -> NDArray[np.float64]:
        out = neutral.copy()
        out[index[~pair]] = q[~pair]
        out[index[pair]] = np.cos(q[pair])
        out[index[pair] + 1] = np.sin(q[pair])
        return out

    return configuration


def run_arm(
    true_text: str,
    nominal_text: str,
    truth: ArmTruth,
    reference: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    *,
    surface: float | None,
    seed: int,
    noise: bool = True,
    spec: ArmSpec = PANDA,
) -> ArmRun:
    """Simulate the true arm tracking ``reference`` = (q, qd, qdd) sampled at 1 kHz.

    ``surface`` is the height [m] of a compliant horizontal surface, or None.
    """
    gear = np.asarray(spec.gear)
    armature = np.asarray(spec.armature) * gear**2  # joint side
    model = _mujoco_model(true_text, armature, spec)
    data = mujoco.MjData(model)
    nominal, ndata = _pin_model(nominal_text)
    configuration = _configuration(nominal, spec.joints)
    q_ref, qd_ref, qdd_ref = reference
    n, nj = q_ref.shape
    rng = np.random.default_rng(seed + 1000)
    tcp = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, spec.end_effector)
    kp, kd = 50.0**2, 2.0 * 50.0
    data.qpos[:] = q_ref[0]
    data.qvel[:] = qd_ref[0]
    out = {k: np.empty((n, nj)) for k in ("q", "qd", "qdd", "drive", "current")}
    wrench = np.zeros((n, 6))
    velocity = np.zeros(6)
    for k in range(n):
        mujoco.mj_step1(model, data)  # kinematics at the current state, then the forces
        q = data.qpos.copy()
        qd = data.qvel.copy()
        a = qdd_ref[k] + kp * (q_ref[k] - q) + kd * (qd_ref[k] - qd)
        tau = pin.rnea(nominal, ndata, configuration(q), qd, a) + armature * a  # nominal
        i_cmd = tau / gear / TORQUE_CONSTANT
        drive = gear * (
            TORQUE_CONSTANT * i_cmd - friction(truth, gear * qd) - ripple(truth, gear * q)
        )
        data.qfrc_applied[:] = drive
        data.xfrc_applied[:] = 0.0
        if surface is not None:
            p = data.xpos[tcp].copy()
            mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, tcp, velocity, 0)
            v = velocity[3:]
            depth = surface - p[2]
            if depth > 0.0:
                normal = max(spec.surface_stiffness * depth - spec.surface_damping * v[2], 0.0)
                slide = v[:2] / math.sqrt(v[0] ** 2 + v[1] ** 2 + 1e-4)
                force = np.array([*(-spec.surface_friction * normal * slide), normal])
                wrench[k, :3] = force
                data.xfrc_applied[tcp, :3] = force
                data.xfrc_applied[tcp, 3:] = np.cross(p - data.xipos[tcp], force)
        mujoco.mj_step2(model, data)
        out["q"][k], out["qd"][k], out["qdd"][k] = q, qd, data.qacc
        out["drive"][k] = drive
        out["current"][k] = i_cmd
    motor = gear * out["q"]
    current = out["current"]
    if noise:
        current = current + CURRENT_NOISE * rng.standard_normal(current.shape)
        counts = np.floor(motor * COUNTS / (2.0 * math.pi)).astype(np.int64)
    else:
        counts = np.round(motor * COUNTS / (2.0 * math.pi)).astype(np.int64)
    t = np.arange(n, dtype=np.float64) * TIMESTEP
    return ArmRun(
        t=t,
        q=out["q"],
        qd=out["qd"],
        qdd=out["qdd"],
        counts=counts,
        current=current,
        drive=out["drive"],
        wrench=wrench,
        reference=q_ref,
    )


def _spline(
    t_knots: NDArray[np.float64], q_knots: NDArray[np.float64], t: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    s = CubicSpline(t_knots, q_knots, axis=0, bc_type="clamped")
    return s(t), s(t, 1), s(t, 2)


def task_reference(
    nominal_text: str, duration: float, seed: int, spec: ArmSpec = PANDA
) -> tuple[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]], float]:
    """A reference pressing the end effector 5-20 mm into a surface along a circle.

    Returns the reference (q, qd, qdd) at 1 kHz and the surface height [m].
    """
    model, data = _pin_model(nominal_text)
    frame = model.getFrameId(spec.end_effector, pin.FrameType.BODY)  # a link (see Z1)
    configuration = _configuration(model, spec.joints)
    q0 = np.asarray(spec.ready)
    pin.framesForwardKinematics(model, data, configuration(q0))
    start = data.oMf[frame].copy()
    surface = float(start.translation[2]) - 0.01
    rng = np.random.default_rng(seed + 2000)
    radius = rng.uniform(0.05, 0.08)
    period = rng.uniform(4.0, 6.0)
    t_knots = np.arange(0.0, duration + 1e-9, 0.05)
    q = q0.copy()
    knots = []
    for tk in t_knots:
        ramp = min(tk / 1.5, 1.0)  # descend over 1.5 s
        depth = ramp * (0.0125 + 0.0075 * math.sin(2.0 * math.pi * tk / 3.7))
        angle = 2.0 * math.pi * max(tk - 1.5, 0.0) / period
        target = start.copy()
        target.translation = start.translation + np.array(
            [radius * (math.cos(angle) - 1.0), radius * math.sin(angle), -0.01 - depth]
        )
        for _ in range(30):
            pin.framesForwardKinematics(model, data, configuration(q))
            err = pin.log6(data.oMf[frame].actInv(target)).vector
            if np.linalg.norm(err) < 1e-10:
                break
            J = pin.computeFrameJacobian(model, data, configuration(q), frame, pin.LOCAL)
            q = q + J.T @ np.linalg.solve(J @ J.T + 1e-8 * np.eye(6), err)
        knots.append(q.copy())
    t = np.arange(round(duration / TIMESTEP), dtype=np.float64) * TIMESTEP
    return _spline(t_knots, np.array(knots), t), surface


def free_reference(
    nominal_path: Path,
    duration: float,
    seed: int,
    *,
    iterations: int = 8,
    spec: ArmSpec = PANDA,
    centre: NDArray[np.float64] | None = None,
    period: float | None = None,
    speeds: Sequence[float] = (1.0, 0.25),
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """An exciting trajectory (``torquemap.excite``) at 1 kHz on the nominal arm, about
    ``centre`` (default the middle of the joints' ranges): the path of ``period`` (default
    excite's, from the limits; at most ``duration``) played at each of ``speeds`` in turn,
    whole traversals up to ``duration``."""
    from torquemap.excite import exciting_trajectory
    from torquemap.robots.urdf import urdf_arm

    arm: Any = urdf_arm(nominal_path, spec.joints, end_effector=spec.end_effector)
    traj = exciting_trajectory(
        arm,
        duration=duration,
        period=None if period is None else min(period, duration),
        rate=1.0 / TIMESTEP,
        iterations=iterations,
        centre=centre,
        rng=seed,
        speeds=speeds,
    )
    return traj.q, traj.qd, traj.qdd


def _log_columns(run: ArmRun, spec: ArmSpec = PANDA) -> dict[str, NDArray[Any]]:
    cols: dict[str, NDArray[Any]] = {"t": run.t}
    for k, name in enumerate(spec.joints):
        cols[f"q_{name}"] = run.counts[:, k]
        cols[f"i_{name}"] = run.current[:, k]
    return cols


def robot_toml(urdf_name: str, spec: ArmSpec = PANDA) -> dict[str, Any]:
    """The robot file (kind ``urdf``) of the simulated arm."""
    joints: dict[str, Any] = {}
    for name, g in zip(spec.joints, spec.gear, strict=True):
        joints[name] = {
            "gear_ratio": g,
            "torque_constant": TORQUE_CONSTANT,
            "encoder_counts_per_rev": COUNTS,
            "position_unit": "counts",
        }
    return {
        "robot": {
            "name": f"{spec.name} (simulated)",
            "kinematics": "urdf",
            "urdf": urdf_name,
            "end_effector": spec.end_effector,
            "gravity": [0.0, 0.0, -9.81],
        },
        "joints": joints,
    }


def write_arm_bench(
    out: str | os.PathLike[str],
    *,
    seed: int = 0,
    free_duration: float = 100.0,
    task_duration: float = 15.0,
    iterations: int = 8,
    arm: str = "panda",
    free_centre: str = "middle",
    free_period: float | None = None,
    free_speeds: Sequence[float] = (1.0, 0.25),
) -> list[Path]:
    """Simulate the Panda bench and write its files into ``out``.

    Files: ``robot.toml``, ``panda.urdf`` (the nominal URDF, copied), ``free.csv``,
    ``task.csv`` (logs ``t, q_<j>`` [counts], ``i_<j>`` [A]), ``truth.csv`` (``t, fx, fy, fz,
    mx, my, mz``: the wrench by the surface on the end effector during the task, base frame),
    ``truth.toml`` (the hidden deviations) and ``truth.urdf`` (the true arm, tool included).
    ``arm`` is ``"panda"``, ``"ur5"``, ``"xarm7"``, ``"z1"``, ``"jaco2"`` (the URDF is then
    ``<arm>.urdf``; :data:`ARMS`) or ``"leg"`` (the
    vertical two-link leg of :mod:`torquemap.sim.leg`, ``leg.urdf``, stepping on a compliant
    ground in ``task.csv``; ``free.csv`` is its motion in the air). ``iterations`` is the
    exciting trajectory's random search (``torquemap.excite``); ``free_centre`` the pose it
    swings about: ``"middle"`` of the joints' ranges (the default of ``torquemap excite``) or
    ``"task"``, the task's start pose (``excite --centre``: excite where the robot works);
    ``free_period`` and ``free_speeds`` its path's period [s] and speed schedule (the
    defaults of ``torquemap excite``: twice the slowest joint's swing over its range at its
    speed limit, 19.2 s for the Panda, 18 s for the UR5 and the xArm7, 12.8 s for the Z1,
    71.9 s for the slow Jaco2 (0.63-0.84 rad/s) and 2.9 s for the leg; full speed then
    a quarter; whole traversals up to ``free_duration``).

    Returns
    -------
    list of Path
        The files written.
    """
    from torquemap.io import write_table, write_toml

    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    spec = arm_spec(arm)
    if free_centre not in ("middle", "task"):
        raise InputError(f"free_centre must be 'middle' or 'task', got {free_centre!r}")
    source = source_text(spec)
    nominal = _stripped(source, spec)
    nominal_text = ET.tostring(nominal, encoding="unicode")
    truth = random_truth(seed, nominal, len(spec.joints))
    true_text = true_urdf(nominal, truth, spec)
    urdf_name = f"{spec.name}.urdf"
    urdf_copy = folder / urdf_name
    urdf_copy.write_text(source)
    free = run_arm(
        true_text,
        nominal_text,
        truth,
        free_reference(
            urdf_copy,
            free_duration,
            seed,
            iterations=iterations,
            spec=spec,
            centre=np.asarray(spec.ready) if free_centre == "task" else None,
            period=free_period,
            speeds=free_speeds,
        ),
        surface=None,
        seed=seed,
        spec=spec,
    )
    if spec.name == "leg":
        from torquemap.sim.leg import leg_task_reference

        reference, surface = leg_task_reference(task_duration, seed)
    else:
        reference, surface = task_reference(nominal_text, task_duration, seed, spec)
    task = run_arm(
        true_text, nominal_text, truth, reference, surface=surface, seed=seed + 1, spec=spec
    )
    write_table(folder / "free.csv", _log_columns(free, spec))
    write_table(folder / "task.csv", _log_columns(task, spec))
    truth_cols: dict[str, NDArray[Any]] = {"t": task.t}
    for k, axis in enumerate(("fx", "fy", "fz", "mx", "my", "mz")):
        truth_cols[axis] = task.wrench[:, k]
    write_table(folder / "truth.csv", truth_cols)
    (folder / "truth.urdf").write_text(true_text)
    write_toml(folder / "robot.toml", robot_toml(urdf_name, spec))
    write_toml(
        folder / "truth.toml",
        {
            "seed": seed,
            "arm": spec.name,
            "tool": {
                "mass": spec.tool_mass,
                "offset": list(spec.tool_offset),
                "parent": spec.tool_parent,
            },
            "mass_scale": truth.mass_scale,
            "surface": {
                "height": surface,
                "stiffness": spec.surface_stiffness,
                "damping": spec.surface_damping,
                "friction": spec.surface_friction,
            },
            "joints": {
                name: {
                    "armature": spec.armature[k],
                    "coulomb": float(truth.coulomb[k]),
                    "stribeck": float(truth.stribeck[k]),
                    "stribeck_velocity": STRIBECK_VEL,
                    "tanh_velocity": TANH_VEL,
                    "viscous": float(truth.viscous[k]),
                    "ripple": float(truth.ripple[k]),
                    "ripple_order": RIPPLE_ORDER,
                    "ripple_phase": float(truth.ripple_phase[k]),
                }
                for k, name in enumerate(spec.joints)
            },
        },
    )
    names = ("robot.toml", urdf_name, "free.csv", "task.csv", "truth.csv", "truth.toml")
    return [folder / n for n in (*names, "truth.urdf")]


def oracle_model(robot_path: str | os.PathLike[str], folder: str | os.PathLike[str]) -> Any:
    """The model of a bench's TRUE arm (for scoring only): ``truth.urdf`` (tool included), the
    true rotor inertia, friction law (``StribeckFriction`` with exponent 1 and a ``tanh``
    blend is the truth's form) and ripple, from ``truth.toml``; the robot file ``robot_path``
    gives the joints.

    Returns
    -------
    torquemap.model.Model
    """
    import dataclasses
    import tomllib

    from torquemap.friction_law import StribeckFriction
    from torquemap.model import InertiaModel, JointModel, Model, PdtvLine
    from torquemap.robot import load_robot
    from torquemap.robots.urdf import urdf_arm

    robot = load_robot(robot_path)
    bench = Path(folder)
    truth = tomllib.loads((bench / "truth.toml").read_text())
    spec = arm_spec(truth["arm"])
    arm: Any = urdf_arm(bench / "truth.urdf", spec.joints, end_effector=spec.end_effector)
    joints = {}
    for name in spec.joints:
        j = truth["joints"][name]
        law = StribeckFriction(
            coulomb_positive=j["coulomb"],
            coulomb_negative=j["coulomb"],
            viscous=j["viscous"],
            stribeck_positive=j["stribeck"],
            stribeck_negative=j["stribeck"],
            stribeck_velocity=j["stribeck_velocity"],
            zero_velocity=j["tanh_velocity"],
            stribeck_exponent=1.0,
            transition="smooth",
        )
        line = PdtvLine(order=j["ripple_order"], amplitude=j["ripple"], phase=j["ripple_phase"])
        joints[name] = JointModel(
            inertia=InertiaModel(constant=j["armature"]), friction=law, pdtv=(line,)
        )
    return Model(robot=dataclasses.replace(robot, arm=arm), joints=joints)
