"""An arm of one joint (a pendulum, a single axis): Pinocchio hands its (1, 10) regressor and
(6, 1) Jacobian back as 1-D arrays, which identification used to read as zeros (a traceback in
``identify``). Checked against the closed form of a rigid pendulum and on a simulated log."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.cli.main import main
from torquemap.estimate_arm import estimate_arm
from torquemap.friction_law import StribeckFriction
from torquemap.identify_arm import identify_arm
from torquemap.io import Log, write_table, write_toml
from torquemap.model import InertiaModel, JointModel, Model
from torquemap.robot import Joint, Robot
from torquemap.robots.urdf import urdf_arm

TWO_LINK = Path(__file__).parent / "data" / "arm" / "two_link.urdf"
# two_link.urdf with the elbow locked at zero: one rigid body about the shoulder (axis z),
# upper arm 2.0 kg at 0.2 m (Izz 0.03), forearm 1.2 kg at 0.4 + 0.12 m (Izz 0.01), tool at 0.7 m
G = 9.81
MASS_MOMENT = 2.0 * 0.2 + 1.2 * 0.52  # [kg m]
INERTIA = 0.03 + 2.0 * 0.2**2 + 0.01 + 1.2 * 0.52**2  # about the shoulder [kg m^2]
REACH = 0.7
GEAR = 50.0
KT = 0.1


def _arm():  # type: ignore[no-untyped-def]
    return urdf_arm(TWO_LINK, ["shoulder"], end_effector="tool", gravity=(0.0, -G, 0.0))


def test_one_joint_dynamics_and_jacobian_match_the_closed_form() -> None:
    arm = _arm()
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-2.0, 2.0, (12, 1)) for _ in range(3))
    closed = INERTIA * qdd[:, 0] + MASS_MOMENT * G * np.cos(q[:, 0])
    assert_allclose(arm.inverse_dynamics(q, qd, qdd)[:, 0], closed, atol=1e-12)
    assert_allclose((arm.regressor(q, qd, qdd) @ arm.parameters())[:, 0], closed, atol=1e-12)
    assert len(arm.parameter_names) == 3  # Izz, mx, my of the one body
    J = arm.spatial_jacobian(q)
    assert J.shape == (12, 6, 1)
    s, c = np.sin(q[:, 0]), np.cos(q[:, 0])
    assert_allclose(J[:, 0, 0], -REACH * s, atol=1e-12)
    assert_allclose(J[:, 1, 0], REACH * c, atol=1e-12)
    assert_allclose(J[:, 5, 0], 1.0, atol=1e-12)


def _log(arm, seed: int, torque_ext: float) -> Log:  # type: ignore[no-untyped-def]
    t = np.arange(0.0, 30.0, 1e-3)
    q = 0.8 * np.sin(2 * np.pi * t / 6.0) + 0.4 * np.sin(2 * np.pi * t / 2.3 + 0.5)
    qd = np.gradient(q, t)
    qdd = np.gradient(qd, t)
    law = StribeckFriction(
        coulomb_positive=0.01,
        coulomb_negative=0.012,
        viscous=2e-5,
        stribeck_positive=0.003,
        stribeck_negative=0.003,
        stribeck_velocity=3.0,
        zero_velocity=1.0,
        transition="smooth",
    )
    rng = np.random.default_rng(seed)
    rigid = arm.inverse_dynamics(q[:, None], qd[:, None], qdd[:, None])[:, 0]
    tau_m = (
        (rigid - torque_ext) / GEAR
        + 3e-5 * GEAR * qdd
        + law.torque(GEAR * qd)
        + KT * 0.01 * rng.standard_normal(t.size)
    )
    return Log(t=t, q=q[:, None], motor_torque=tau_m[:, None], joint_names=("shoulder",))


def _start(arm) -> Model:  # type: ignore[no-untyped-def]
    robot = Robot(
        name="pendulum",
        kinematics="urdf",
        link_lengths=(),
        joints=(Joint(name="shoulder", gear_ratio=GEAR, torque_constant=KT),),
        arm=arm,
    )
    law = StribeckFriction(
        coulomb_positive=0.0,
        coulomb_negative=0.0,
        viscous=0.0,
        stribeck_positive=0.0,
        stribeck_negative=0.0,
        stribeck_velocity=3.0,
        zero_velocity=1.0,
        transition="smooth",
    )
    return Model(robot=robot, joints={"shoulder": JointModel(InertiaModel(0.0), law, ())})


def test_a_one_joint_arm_is_identified_and_its_external_torque_estimated() -> None:
    arm = _arm()
    result = identify_arm(_start(arm), [_log(arm, 1, 0.0)], max_samples=3000, pdtv_max_order=0)
    named = dict(zip(arm.parameter_names, result.model.robot.arm.parameters(), strict=True))
    # the simulated arm is the URDF's: its mass moment along the link comes back
    assert_allclose(named["shoulder.mx"], MASS_MOMENT, rtol=0.02)
    est = estimate_arm(result.model, _log(arm, 2, 1.5))
    inside = slice(1000, -1000)
    assert_allclose(np.median(est.tau_ext[inside, 0]), 1.5, atol=0.05)
    assert not any("times the identification logs'" in w for w in est.warnings)
    # the same log with its torque 1000 times too large (a current in mA): said, not silent
    log = _log(arm, 2, 1.5)
    milli = Log(
        t=log.t, q=log.q, motor_torque=1000.0 * log.motor_torque, joint_names=log.joint_names
    )
    said = [
        w for w in estimate_arm(result.model, milli).warnings if "times the identification" in w
    ]
    assert len(said) == 1 and said[0].startswith("joint shoulder: the motor torque reaches"), said


def _write_robot(folder: Path) -> None:
    """The one-joint arm's URDF and robot file in ``folder``."""
    (folder / "arm.urdf").write_text(TWO_LINK.read_text())
    write_toml(
        folder / "robot.toml",
        {
            "robot": {
                "kinematics": "urdf",
                "urdf": "arm.urdf",
                "end_effector": "tool",
                "gravity": [0.0, -G, 0.0],
            },
            "joints": {"shoulder": {"gear_ratio": GEAR, "torque_constant": KT}},
        },
    )


def test_cli_identifies_a_one_joint_arm(tmp_path: Path) -> None:
    arm = _arm()
    log = _log(arm, 3, 0.0)
    _write_robot(tmp_path)
    write_table(
        tmp_path / "free.csv",
        {"t": log.t, "q_shoulder": log.q[:, 0], "tau_shoulder": log.motor_torque[:, 0]},
    )
    out = tmp_path / "model.toml"
    assert (
        main(["identify", str(tmp_path / "robot.toml"), str(tmp_path / "free.csv"), "-o", str(out)])
        == 0
    )
    assert out.exists()
    forces = tmp_path / "forces.csv"
    assert main(["estimate", str(out), str(tmp_path / "free.csv"), "-o", str(forces)]) == 0


def test_a_tool_on_a_one_joint_arm_is_named_as_a_cause() -> None:
    """With one joint a tool the URDF lacks and a wrong gear ratio both scale its torque: the
    warning names both (it used to blame the robot file alone)."""
    arm = _arm()
    pi = arm.full_parameters.copy()
    tool, at = 1.0, REACH  # 1 kg at the tool: mass moment 1.024 -> 1.724 kg m, 1.68x
    pi[0] += tool
    pi[1] += tool * at
    pi[6] += tool * at**2  # Iyy, Izz of a point mass on the x axis
    pi[9] += tool * at**2
    heavy = arm.with_full_parameters(pi)
    result = identify_arm(_start(arm), [_log(heavy, 4, 0.0)], max_samples=3000, pdtv_max_order=0)
    named = dict(zip(arm.parameter_names, result.model.robot.arm.parameters(), strict=True))
    assert_allclose(named["shoulder.mx"], MASS_MOMENT + tool * at, rtol=0.02)
    line = next(w for w in result.warnings if "times the URDF's" in w)
    assert "a load the URDF lacks" in line


def test_spectrum_of_an_arm_takes_out_gravity(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    """`spectrum` on an arm ran the per-joint pass method on the raw torque: gravity, which
    changes along a pass, read as lines below a few CPR (21 mN m at 1/3 CPR on a UR10, its
    2 CPR ripple doubled). The arm's rigid-body torque is now taken out first."""
    arm = _arm()
    rate, speed, revs, amp, phase = 1000.0, 3.0, 4.0, 0.004, 0.7  # motor side [rad/s], [N m]
    cruise = revs * 2 * np.pi / speed
    ramp = 0.2
    seg = np.arange(0.0, cruise + 2 * ramp, 1 / rate)
    w = speed * np.clip(np.minimum(seg, cruise + 2 * ramp - seg) / ramp, 0.0, 1.0)
    w_all = np.concatenate([w, np.zeros(200), -w, np.zeros(200)])
    t = np.arange(w_all.size) / rate
    motor = -0.3 * GEAR + np.cumsum(w_all) / rate  # starts at q = -0.3 rad
    q = motor / GEAR
    qd = w_all / GEAR
    qdd = np.gradient(qd, t)
    rng = np.random.default_rng(5)
    rigid = arm.inverse_dynamics(q[:, None], qd[:, None], qdd[:, None])[:, 0]
    law = StribeckFriction(
        coulomb_positive=0.01,
        coulomb_negative=0.01,
        viscous=1e-5,
        stribeck_positive=0.0,
        stribeck_negative=0.0,
        stribeck_velocity=3.0,
        zero_velocity=0.05,
    )
    tau_m = (
        rigid / GEAR
        + 3e-5 * GEAR * qdd
        + law.torque(w_all)
        + amp * np.cos(2 * motor + phase)
        + KT * 0.002 * rng.standard_normal(t.size)
    )
    _write_robot(tmp_path)
    write_table(tmp_path / "sweep.csv", {"t": t, "q_shoulder": q, "tau_shoulder": tau_m})
    capsys.readouterr()
    argv = ["spectrum", str(tmp_path / "robot.toml"), str(tmp_path / "sweep.csv")]
    assert main([*argv, "--joint", "shoulder", "--top", "500"]) == 0
    rows = [line.split(",") for line in capsys.readouterr().out.splitlines()[2:]]
    lines = {float(o): float(a) for o, a, _, _ in rows}
    assert lines[2.0] == pytest.approx(amp, rel=0.1)
    assert max(a for o, a in lines.items() if o != 2.0) < 0.25 * amp, sorted(lines.items())[:6]


def test_excite_labels_a_prismatic_joint_in_metres(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    """excite printed 'start pose [rad]' for a slide whose position is in metres."""
    text = TWO_LINK.read_text().replace(
        'name="elbow" type="revolute"', 'name="elbow" type="prismatic"'
    )
    (tmp_path / "slide.urdf").write_text(text)
    joints = {"shoulder": {"gear_ratio": GEAR, "torque_constant": KT}}
    head = {"kinematics": "urdf", "urdf": "slide.urdf", "end_effector": "tool"}
    write_toml(tmp_path / "one.toml", {"robot": head, "joints": joints})
    joints = {**joints, "elbow": {"gear_ratio": 500.0, "torque_constant": KT}}
    write_toml(tmp_path / "two.toml", {"robot": head, "joints": joints})
    for robot, unit in (("one", "[rad]"), ("two", "[rad; m for a prismatic joint]")):
        capsys.readouterr()
        argv = ["excite", str(tmp_path / f"{robot}.toml"), "-o", str(tmp_path / f"{robot}.csv")]
        assert main([*argv, "--duration", "10", "--period", "5"]) == 0
        assert f"start pose {unit}: " in capsys.readouterr().out
