"""New-user QA of arms, stop 37 (Q44; docs/arm.md "New-user QA, stop 37").

A two-link arm simulated here by inverse dynamics (the URDF's links, gears, rotor inertia,
friction, white current noise): a log whose currents lag its angles, and a direct drive whose
friction is too small a share of its torque to be resolved.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from torquemap.errors import InputError
from torquemap.estimate_arm import estimate_arm
from torquemap.excite import exciting_trajectory
from torquemap.filters import lowpass
from torquemap.friction_law import StribeckFriction
from torquemap.identify_arm import ArmIdentification, identify_arm
from torquemap.io import Log
from torquemap.model import InertiaModel, JointModel, Model
from torquemap.robot import Joint, Robot
from torquemap.robots.urdf import UrdfArm, urdf_arm

pytestmark = pytest.mark.xdist_group("arm_qa37")

TWO_LINK = Path(__file__).parent / "data" / "arm" / "two_link.urdf"
KT = 0.1
NOISE = 0.02  # [A] current noise, white per sample


def _law(coulomb: float) -> StribeckFriction:
    return StribeckFriction(
        coulomb_positive=coulomb,
        coulomb_negative=coulomb,
        viscous=2e-4 if coulomb else 0.0,
        stribeck_positive=0.3 * coulomb,
        stribeck_negative=0.3 * coulomb,
        stribeck_velocity=5.0,
        zero_velocity=0.5,
        transition="smooth",
    )


def _arm() -> UrdfArm:
    return urdf_arm(TWO_LINK, ["shoulder", "elbow"], end_effector="tool", gravity=(0, -9.81, 0))


def _robot(arm: UrdfArm, gear: tuple[float, float]) -> Robot:
    joints = tuple(
        Joint(name=n, gear_ratio=g, torque_constant=KT)
        for n, g in zip(arm.joint_names, gear, strict=True)
    )
    return Robot(name="two-link", kinematics="urdf", link_lengths=(), joints=joints, arm=arm)


def _simulate(
    arm: UrdfArm,
    seed: int,
    *,
    gear: tuple[float, float],
    coulomb: tuple[float, float],
    lag: float = 0.0,
    force: bool = False,
    duration: float = 20.0,
) -> tuple[Log, np.ndarray]:
    """A log at 1 kHz whose motor torques are read ``lag`` [s] late, and the external joint
    torque [N m]."""
    traj = exciting_trajectory(
        arm, duration=duration, period=10.0, rate=1000.0, iterations=6, rng=seed
    )
    t, q, qd, qdd = traj.t, traj.q, traj.qd, traj.qdd
    rng = np.random.default_rng(seed)
    F = np.zeros((t.size, 3))
    if force:
        F[:, 0] = 4.0 + 2.0 * np.sin(0.5 * t)
        F[:, 1] = -3.0 + np.cos(0.3 * t)
    tau_ext = np.einsum("nij,ni->nj", arm.jacobian(q), F)
    rigid = arm.inverse_dynamics(q, qd, qdd)
    tau_m = np.empty_like(q)
    for k in range(2):
        n = gear[k]
        exact = (
            (rigid[:, k] - tau_ext[:, k]) / n
            + 2e-5 * n * qdd[:, k]
            + _law(coulomb[k]).torque(n * qd[:, k])
        )
        tau_m[:, k] = np.interp(t - lag, t, exact) + KT * NOISE * rng.standard_normal(t.size)
    return Log(t=t, q=q, motor_torque=tau_m, joint_names=arm.joint_names, path="sim.csv"), tau_ext


def _identified(arm: UrdfArm, gear: tuple[float, float], free: Log) -> ArmIdentification:
    """``identify_arm`` from a zero start on ``arm`` (no PDTV lines) over the free log."""
    start = Model(
        robot=_robot(arm, gear),
        joints={n: JointModel(inertia=InertiaModel(constant=0.0), friction=_law(0.0), pdtv=())
                for n in arm.joint_names},
    )  # fmt: skip
    return identify_arm(start, [free], max_samples=3000, pdtv_max_order=0)


GEAR = (60.0, 40.0)
COULOMB = (0.03, 0.02)


@pytest.fixture(scope="module")
def free_1() -> Log:
    """``_simulate(_arm(), 1, gear=GEAR, coulomb=COULOMB)``: the free log with no lag that three
    tests read (each simulated it alike before: 0.55 s each)."""
    return _simulate(_arm(), 1, gear=GEAR, coulomb=COULOMB)[0]


@pytest.mark.parametrize("lag", [0.0, 0.01])
def test_a_current_lag_is_warned(lag: float, free_1: Log) -> None:
    """Currents read 10 ms after the angles: identify says so, with the lag, and estimate
    repeats it (before: no word; on a UR3 bench a 5 ms lag raised the force error 3-8 times,
    and a 30 ms one was refused blaming the robot file's gravity). Without a lag, no warning."""
    arm = _arm()
    free = free_1 if lag == 0.0 else _simulate(arm, 1, gear=GEAR, coulomb=COULOMB, lag=lag)[0]
    result = _identified(arm, GEAR, free)
    said = [w for w in result.warnings if "their joint angles by about" in w]
    if lag == 0.0:
        assert not said, said
        assert abs(result.model.notes["arm"].get("current_lag", 0.0)) < 0.001
        return
    assert len(said) == 1, result.warnings
    found = re.search(r"lag their joint angles by about (\d+) ms", said[0])
    assert found is not None and 8 <= int(found[1]) <= 12, said[0]
    task, _ = _simulate(arm, 2, gear=GEAR, coulomb=COULOMB, lag=lag, force=True)
    est = estimate_arm(result.model, task)
    assert any("currents lag their angles by about" in w for w in est.warnings), est.warnings


def test_a_direct_drive_without_friction_is_identified_not_refused() -> None:
    """Gear 1 and no friction (a direct drive): the identified Coulomb levels are noise about
    zero, here summing below zero on the elbow (1.9e-5 and -1.2e-4 N m), which was refused as "the
    model does not fit the log; check the robot file's gravity, gear ratios...". Now refitted
    with no band, warned, and the forces are estimated within their sigmas."""
    arm = _arm()
    gear = (1.0, 1.0)
    free, _ = _simulate(arm, 3, gear=gear, coulomb=(0.0, 0.0))
    result = _identified(arm, gear, free)
    assert any("too small to resolve" in w for w in result.warnings), result.warnings
    for joint in result.model.joints.values():
        law = joint.friction
        assert isinstance(law, StribeckFriction)
        assert law.coulomb_positive + law.coulomb_negative > 0  # a model file can hold it
    task, tau_ext = _simulate(arm, 4, gear=gear, coulomb=(0.0, 0.0), force=True)
    est = estimate_arm(result.model, task)
    # the sigmas cover noise and parameters, not the low-pass's attenuation of the force
    target = np.column_stack([lowpass(task.t, tau_ext[:, k], cutoff=est.cutoff) for k in range(2)])
    inner = (task.t > 1.0) & (task.t < task.t[-1] - 1.0) & (est.flag == 0)
    z = np.abs(est.tau_ext[inner] - target[inner]) / est.tau_ext_sigma[inner]
    assert np.mean(z < 2.0) > 0.9


def test_a_large_negative_friction_is_still_refused() -> None:
    """The refit is only for friction too small to resolve: a log whose friction reads
    negative at a material share of the torque (here the currents of another sign of
    friction: a robot file at odds with the log) is still refused."""
    arm = _arm()
    free, _ = _simulate(arm, 1, gear=GEAR, coulomb=(-0.05, 0.02))
    with pytest.raises(InputError, match="negative in both directions"):
        _identified(arm, GEAR, free)


def test_gravity_upside_down_is_named(free_1: Log) -> None:
    """A robot file whose gravity points up (+9.81 where the arm's is -9.81): the rigid-body
    torque is the URDF's times a negative gain, which was warned as "a gear ratio or torque
    constant in the robot file is too small" (a UR3 bench: -1.10 and -1.23, forces 8-11 N off);
    now the warning asks about the gravity's sign, and estimate repeats it."""
    arm, free = _arm(), free_1
    upside = urdf_arm(TWO_LINK, ["shoulder", "elbow"], end_effector="tool", gravity=(0, 9.81, 0))
    result = _identified(upside, GEAR, free)
    said = [w for w in result.warnings if "times the URDF's" in w]
    assert said and all("does the robot file's gravity point up" in w for w in said), said
    assert all(re.search(r"torque is -\d", w) for w in said), said
    task, _ = _simulate(arm, 2, gear=GEAR, coulomb=COULOMB, force=True)
    est = estimate_arm(result.model, task)
    assert any("check the robot file's gravity" in w for w in est.warnings), est.warnings


def test_a_heavier_tool_is_named_as_a_possible_cause() -> None:
    """A 4 kg tool the URDF lacks, at the two-link's tip: the base joint's rigid-body torque is
    more than 1.6 times the URDF's, which was warned only as "a gear ratio or torque constant
    in the robot file is too large" (a 3 kg payload on a UR3: 2.01, forces right); the warning
    now names the load too."""
    nominal = _arm()
    pi = nominal.full_parameters.copy()
    tool, tip = 4.0, np.array([0.3, 0.0, 0.0])
    pi[10] += tool
    pi[11:14] += tool * tip
    pi[16] += tool * tip[0] ** 2
    pi[19] += tool * tip[0] ** 2
    heavy = nominal.with_full_parameters(pi)
    free, _ = _simulate(heavy, 1, gear=GEAR, coulomb=COULOMB)
    result = _identified(nominal, GEAR, free)
    said = [w for w in result.warnings if "times the URDF's" in w]
    assert said, result.warnings
    assert all("or a load the URDF lacks" in w for w in said), said


def test_a_limit_without_velocity_is_named(tmp_path: Path) -> None:
    """A <limit> without velocity (or effort): before, urdfdom's C++ lines on stderr and
    "Pinocchio cannot read the URDF (The XML stream does not contain a valid URDF model.)"."""
    from torquemap.robots.urdf import check_urdf

    path = tmp_path / "arm.urdf"
    path.write_text(
        "<robot name='x'><link name='a'/><link name='b'/>"
        "<joint name='j1' type='revolute'><parent link='a'/><child link='b'/>"
        "<limit lower='-1' upper='1' effort='10'/></joint></robot>"
    )
    with pytest.raises(InputError, match="'j1' has a <limit> without velocity") as info:
        check_urdf(path)
    assert info.value.path is not None and info.value.path.endswith("arm.urdf")


def test_null_space_share_of_a_wrench_and_of_swapped_columns() -> None:
    """Torques of end-effector wrenches plus noise at their sigmas: 0.27 % beyond 3 sigmas
    (the chi-square's tail); the same with two joints' columns swapped: most samples."""
    from torquemap.arm_null import null_space_share

    rng = np.random.default_rng(0)
    n = 4000
    J = rng.standard_normal((n, 6, 7))
    w = rng.standard_normal((n, 6)) * 10.0
    sigma = np.full((n, 7), 0.1)
    tau = np.einsum("nij,ni->nj", J, w) + sigma * rng.standard_normal((n, 7))
    keep = np.ones(n, dtype=bool)
    share = null_space_share(J, tau, sigma, keep)
    assert share is not None and share < 0.01
    swapped = tau[:, [0, 2, 1, 3, 4, 5, 6]]
    share = null_space_share(J, swapped, sigma, keep)
    assert share is not None and share > 0.9
    assert null_space_share(J[:, :, :6], tau[:, :6], sigma[:, :6], keep) is None  # no null space


@pytest.fixture(scope="module")
def panda() -> dict[str, object]:
    """A Panda (example-robot-data) simulated by inverse dynamics with its URDF's own bodies,
    identified from 12 s, and a task log of a varying force on its hand."""
    from torquemap.sim.arm import PANDA, panda_urdf

    arm = urdf_arm(panda_urdf(), list(PANDA.joints), end_effector=PANDA.end_effector)
    gear = tuple(float(g) for g in PANDA.gear)

    def log(seed: int, force: bool, duration: float) -> Log:
        traj = exciting_trajectory(arm, duration=duration, rate=500.0, iterations=2, rng=seed)
        t, q, qd, qdd = traj.t, traj.q, traj.qd, traj.qdd
        rng = np.random.default_rng(seed)
        F = np.zeros((t.size, 6))
        if force:
            F[:, 0] = 4.0 + 2.0 * np.sin(0.5 * t)
            F[:, 2] = -10.0 + 3.0 * np.cos(0.3 * t)
        tau_ext = np.einsum("nij,ni->nj", arm.jacobian(q), F)
        g = np.asarray(gear)
        tau_m = (
            (arm.inverse_dynamics(q, qd, qdd) - tau_ext) / g
            + 3e-5 * g * qdd
            + 0.01 * np.tanh(g * qd / 1.5)
            + KT * NOISE * rng.standard_normal(q.shape)
        )
        return Log(t=t, q=q, motor_torque=tau_m, joint_names=arm.joint_names, path="sim.csv")

    joints = tuple(
        Joint(name=n, gear_ratio=gr, torque_constant=KT)
        for n, gr in zip(arm.joint_names, gear, strict=True)
    )
    robot = Robot(name="panda", kinematics="urdf", link_lengths=(), joints=joints, arm=arm)
    start = Model(
        robot=robot,
        joints={n: JointModel(inertia=InertiaModel(constant=0.0), friction=_law(0.0), pdtv=())
                for n in arm.joint_names},
    )  # fmt: skip
    free = log(1, False, 12.0)
    result = identify_arm(
        start, [free], max_samples=2000, pdtv_max_order=0, fit_friction_shape=False
    )
    return {"model": result.model, "task": log(2, True, 8.0)}


def test_swapped_columns_of_a_seven_axis_arm_are_warned(panda: dict[str, object]) -> None:
    """A 7-axis arm's task log with joints 2 and 3 swapped (angle and current): on the Panda
    bench a 104 N median force against the true 13 N, with no warning; now warned. The log as
    recorded is not."""
    model, task = panda["model"], panda["task"]
    assert isinstance(model, Model) and isinstance(task, Log)
    said = "hold a part no wrench on the end effector gives"
    assert not any(said in w for w in estimate_arm(model, task).warnings)
    order = [0, 2, 1, 3, 4, 5, 6]
    swapped = Log(
        t=task.t,
        q=task.q[:, order],
        motor_torque=task.motor_torque[:, order],
        joint_names=task.joint_names,
        path="sim.csv",
    )
    assert any(said in w for w in estimate_arm(model, swapped).warnings)


def test_a_flipped_current_on_an_arm_is_refused_naming_the_log(free_1: Log) -> None:
    """The elbow's current logged with its sign flipped: refused, naming the log (before, stop
    39: no file named) and the flipped sign as a cause."""
    import dataclasses

    arm, free = _arm(), free_1
    flipped = dataclasses.replace(free, motor_torque=free.motor_torque * np.array([1.0, -1.0]))
    with pytest.raises(InputError, match="negative in both directions") as caught:
        _identified(arm, GEAR, flipped)
    assert str(caught.value).startswith("sim.csv: joint ")
    assert "a current logged with its sign flipped against the joint's angle" in str(caught.value)


def test_a_flipped_current_in_a_task_log_is_warned_as_such(panda: dict[str, object]) -> None:
    """The Panda bench's task log with joint 4's current negated: |F| median 164 N against
    the true 12 N (CLI, `simulate arm`), warned as columns swapped or another robot; now the
    warning names a flipped sign too (before, stop 39: it did not)."""
    model, task = panda["model"], panda["task"]
    assert isinstance(model, Model) and isinstance(task, Log)
    flip = np.ones(task.motor_torque.shape[1])
    flip[3] = -1.0
    flipped = Log(
        t=task.t,
        q=task.q,
        motor_torque=task.motor_torque * flip,
        joint_names=task.joint_names,
        path="sim.csv",
    )
    said = "a joint's current logged with its sign flipped"
    assert any(said in w for w in estimate_arm(model, flipped).warnings)
