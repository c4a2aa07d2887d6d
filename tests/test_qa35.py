"""A new user's robots and logs (stop 35 probe): cases that gave a silent wrong answer, a
traceback or an unclear message, each refused or warned in one line now."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from torquemap.cli.main import main
from torquemap.errors import InputError
from torquemap.io import read_log, write_table, write_toml
from torquemap.robot import robot_from_dict

TWO_LINK = Path(__file__).parent / "data" / "arm" / "two_link.urdf"


def _two_link_robot(folder: Path, urdf_text: str, joints: dict[str, dict[str, float]]) -> Path:
    (folder / "arm.urdf").write_text(urdf_text)
    write_toml(
        folder / "robot.toml",
        {
            "robot": {"kinematics": "urdf", "urdf": "arm.urdf", "end_effector": "tool"},
            "joints": joints,
        },
    )
    return folder / "robot.toml"


JOINTS = {
    "shoulder": {"gear_ratio": 50.0, "torque_constant": 0.05},
    "elbow": {"gear_ratio": 50.0, "torque_constant": 0.05},
}


def test_excite_refuses_a_joint_with_zero_width_limits(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # example-robot-data's double pendulum: <limit lower="0" upper="0" velocity="0"/> (MuJoCo
    # reads it as no limit); before, excite wrote a trajectory that stood still (+-1e-6 rad)
    # with "condition number of the regressor inf" and exit 0
    text = TWO_LINK.read_text().replace('lower="-2.5" upper="2.5"', 'lower="0" upper="0"')
    robot = _two_link_robot(tmp_path, text, JOINTS)
    out = tmp_path / "excite.csv"
    assert main(["--quiet", "excite", str(robot), "-o", str(out), "--duration", "5"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "arm.urdf: joint 'elbow' has no range in the URDF (lower = upper = 0)" in err
    assert not out.exists()


def test_a_mimic_joint_listed_as_actuated_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the Panda's panda_finger_joint2 mimics panda_finger_joint1; Pinocchio reads it as a free
    # joint, so listed in the robot file it was driven on its own (excite moved it alone)
    text = TWO_LINK.read_text().replace(
        '<limit lower="-2.5" upper="2.5" effort="30" velocity="4.0"/>',
        '<limit lower="-2.5" upper="2.5" effort="30" velocity="4.0"/>\n'
        '    <mimic joint="shoulder" multiplier="1" offset="0"/>',
    )
    robot = _two_link_robot(tmp_path, text, JOINTS)
    out = tmp_path / "excite.csv"
    assert main(["--quiet", "excite", str(robot), "-o", str(out), "--duration", "5"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "robot.toml: joint 'elbow' follows 'shoulder' in arm.urdf (<mimic>)" in err
    assert not out.exists()
    # left out, it is locked at zero and the arm is built
    robot = _two_link_robot(tmp_path, text, {"shoulder": JOINTS["shoulder"]})
    assert main(["--quiet", "excite", str(robot), "-o", str(out), "--duration", "5"]) == 0
    assert out.exists()


def test_a_joint_that_never_moves_the_end_effector_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # example-robot-data's double pendulum has no tip link: its end effector "link2" sits on
    # joint2's axis, every pose was "near-singular" (0 of 8000 samples sound) with no reason
    robot = _two_link_robot(tmp_path, TWO_LINK.read_text(), JOINTS)
    text = robot.read_text().replace('end_effector = "tool"', 'end_effector = "fore"')
    robot.write_text(text)
    t = np.arange(2000) * 1e-3
    cols = {
        "t": t,
        "q_shoulder": 0.5 * np.sin(t),
        "tau_shoulder": np.zeros_like(t),
        "q_elbow": 1.0 + 0.5 * np.sin(2 * t),
        "tau_elbow": np.zeros_like(t),
    }
    write_table(tmp_path / "task.csv", cols)
    out = tmp_path / "forces.csv"
    assert (
        main(["--quiet", "estimate", str(robot), str(tmp_path / "task.csv"), "-o", str(out)]) == 0
    )
    err = capsys.readouterr().err
    assert "2000 of 2000 samples at near-singular poses" in err
    assert "joint 'elbow' does not move the end effector 'fore'" in err
    # with the tool beyond the elbow no joint is named
    robot.write_text(text.replace('end_effector = "fore"', 'end_effector = "tool"'))
    assert (
        main(["--quiet", "estimate", str(robot), str(tmp_path / "task.csv"), "-o", str(out)]) == 0
    )
    assert "does not move the end effector" not in capsys.readouterr().err


def test_fleet_fails_a_urdf_arms_days_with_the_reason(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a UR5 in a fleet: each day failed with "a vertical arm? The model has no gravity term; ...
    # use a robot file that models gravity", of a robot file that does (the pass method ran)
    robot = _two_link_robot(tmp_path, TWO_LINK.read_text(), JOINTS)
    t = np.arange(3000) * 1e-3
    cols = {"t": t}
    for k, name in enumerate(JOINTS):
        cols[f"q_{name}"] = (k + 1) * 0.5 * np.sin(2 * t)
        cols[f"tau_{name}"] = 0.01 * np.sign(np.cos(2 * t))
    write_table(tmp_path / "free.csv", cols)
    (tmp_path / "FLEET.toml").write_text(
        '[[robots]]\nname = "arm"\nrobot = "robot.toml"\n'
        '[[robots.days]]\ndate = 2026-11-02\nlogs = ["free.csv"]\n'
    )
    out = tmp_path / "out"
    argv = ["--quiet", "fleet", "identify", str(tmp_path / "FLEET.toml"), "-o", str(out)]
    assert main([*argv, "--workers", "1"]) == 1
    text = capsys.readouterr()
    assert f"{robot}: fleet identify reads robots of kinematics 'none' or 'planar2r'" in (
        text.out + text.err
    )
    assert not (out / "arm" / "2026-11-02.toml").exists()


def test_a_padded_current_column_is_named(tmp_path: Path) -> None:
    # a writer that pads its columns ("i_a   "): the angle's near miss was named, the
    # current's was not ("missing column 'i_a' or 'tau_a' for joint 'a'" alone)
    robot = robot_from_dict(
        {"robot": {}, "joints": {"a": {"gear_ratio": 1.0, "torque_constant": 0.04}}}
    )
    rows = [f"{k * 1e-3:.3f},{k * 1e-3:.3f},0.1   " for k in range(100)]
    (tmp_path / "log.csv").write_text("t,q_a,i_a   \n" + "\n".join(rows) + "\n")
    with pytest.raises(
        InputError,
        match=r"log.csv: missing column 'i_a' or 'tau_a' for joint "
        r"'a' \(the file has 'i_a   ': names are exact",
    ):
        read_log(tmp_path / "log.csv", robot)
    write_table(
        tmp_path / "log.parquet",
        {"t": np.arange(100) * 1e-3, "q_a": np.zeros(100), "Tau_A [N m]": np.zeros(100)},
    )
    with pytest.raises(InputError, match=r"\(the file has 'Tau_A \[N m\]'"):
        read_log(tmp_path / "log.parquet", robot)


def test_a_second_header_inside_a_log_is_named(tmp_path: Path) -> None:
    # two logs joined with `cat`: "column 't' is not numeric (data row 4: 't')" alone
    robot = robot_from_dict(
        {"robot": {}, "joints": {"a": {"gear_ratio": 1.0, "torque_constant": 0.04}}}
    )
    part = "t,q_a,i_a\n" + "".join(f"{k * 1e-3:.3f},{k * 1e-3:.3f},0.1\n" for k in range(3))
    (tmp_path / "joined.csv").write_text(part + part)
    with pytest.raises(InputError, match=r"data row 4: 't'\): the header again"):
        read_log(tmp_path / "joined.csv", robot)


def test_a_position_step_build_cannot_bridge_is_warned_before_collecting(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # --position-step 1000 on a 384-position motor: one position measured, no word, and
    # `linearize build` refused the data afterwards ("phase 2 was never energised")
    rig = tmp_path / "rig"
    argv = ["--quiet", "simulate", "rig", "--random", "3", "--out", str(rig)]
    assert main([*argv, "--position-step", "24", "--readings", "1"]) == 0
    assert "position step" not in capsys.readouterr().err  # 24 <= 384 // (4 x 4) + 1
    out = tmp_path / "c.csv"
    argv = ["--quiet", "linearize", "collect", str(rig / "motor.toml"), "--random", "3"]
    assert main([*argv, "--position-step", "1000", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "a position step of 1000 leaves gaps of up to 383 positions" in err
    assert "interpolates across at most 24" in err and "a step of at most 25" in err
    assert (
        main(
            [
                "--quiet",
                "linearize",
                "build",
                str(rig / "motor.toml"),
                str(out),
                "-o",
                str(tmp_path / "t.npz"),
            ]
        )
        == 2
    )


def test_a_revolute_joint_without_limit_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # urdfdom printed C++ "Error: Joint [elbow] is of type REVOLUTE but it does not specify
    # limits / at line 607 in .../joint.cpp" lines and torquemap "Pinocchio cannot read the
    # URDF (The XML stream does not contain a valid URDF model.)"
    text = TWO_LINK.read_text().replace(
        '<limit lower="-2.5" upper="2.5" effort="30" velocity="4.0"/>', ""
    )
    robot = _two_link_robot(tmp_path, text, JOINTS)
    out = tmp_path / "excite.csv"
    assert main(["--quiet", "excite", str(robot), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        f"torquemap: error: {tmp_path / 'arm.urdf'}: URDF joint 'elbow' is revolute but has no "
        "<limit> (lower, upper, effort, velocity); one that turns without limits is type "
        '"continuous"'
    )


def test_unix_time_in_float32_is_named(tmp_path: Path) -> None:
    # a controller that logs Unix time as float32: every stamp of a 30 s log is 1.7e9 s
    # (float32 steps by 128 s there); "time 't' never advances" alone before
    import pyarrow as pa
    import pyarrow.parquet as pq

    robot = robot_from_dict(
        {"robot": {}, "joints": {"a": {"gear_ratio": 1.0, "torque_constant": 0.04}}}
    )
    t = 1.7e9 + np.arange(3000) * 0.01
    table = {"t": t.astype(np.float32), "q_a": np.sin(t - t[0]), "i_a": np.zeros(t.size)}
    pq.write_table(pa.table(table), tmp_path / "f32.parquet")
    with pytest.raises(
        InputError,
        match=r"never advances \(every row holds 1700000000 s, a "
        r"float32 value: float32 holds such times only to 128 s",
    ):
        read_log(tmp_path / "f32.parquet", robot)
    # the same times from zero are kept (float32 resolves 30 s to 2 us)
    table["t"] = (t - t[0]).astype(np.float32)
    pq.write_table(pa.table(table), tmp_path / "f32.parquet")
    assert read_log(tmp_path / "f32.parquet", robot).t.size == 3000


def test_report_of_an_unnamed_robot_names_its_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a robot file without [robot] name: "warning: Model: : the model holds no PDTV line" and
    # "2 joint(s) of ; 1 log(s)" in the page
    robot = tmp_path / "robot.toml"
    write_toml(robot, {"robot": {}, "joints": {"a": {"gear_ratio": 1.0, "torque_constant": 0.1}}})
    t = np.arange(4000) * 1e-3
    write_table(tmp_path / "log.csv", {"t": t, "q_a": np.sin(t), "i_a": 0.01 * np.cos(t)})
    out = tmp_path / "report.html"
    assert main(["--quiet", "report", str(robot), str(tmp_path / "log.csv"), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "Model: robot.toml: the model holds no PDTV line" in err and "Model: :" not in err
    page = out.read_text()
    assert "1 joint(s); 1 log(s)" in page and "joint(s) of ;" not in page
    assert "<title>torquemap report: robot.toml" in page


def test_an_arm_joint_held_still_is_refused_with_the_cause(tmp_path: Path) -> None:
    # a two-link arm whose elbow is held (a brake, a disabled drive) throughout the free log:
    # refused "the identified friction is negative in both directions ... check the robot
    # file's gravity, gear ratios and torque constants" (or, by the rounding of a friction the
    # joint cannot show, kept with "explains only 0% of its torque's variation")
    from torquemap.identify_arm import identify_arm
    from torquemap.io import Log
    from torquemap.model import load_model

    robot = _two_link_robot(tmp_path, TWO_LINK.read_text(), JOINTS)
    model = load_model(robot)
    arm = model.robot.arm
    t = np.arange(0.0, 12.0, 2e-3)
    q = np.c_[0.8 * np.sin(2 * np.pi * t / 4.0) + 0.3 * np.sin(2 * np.pi * t / 1.7), 0.3 + 0 * t]
    qd = np.gradient(q, t, axis=0)
    qdd = np.gradient(qd, t, axis=0)
    rng = np.random.default_rng(0)
    tau = arm.inverse_dynamics(q, qd, qdd) / 50.0 + 0.01 * np.tanh(50.0 * qd / 0.1)
    tau += 1e-3 * rng.standard_normal(tau.shape)
    log = Log(t=t, q=q, motor_torque=tau, joint_names=("shoulder", "elbow"), path="free.csv")
    with pytest.raises(
        InputError,
        match=r"free.csv: joint elbow never moves in the logs \(its "
        r"motor angle spans 0 rad\): its friction and rotor inertia cannot",
    ):
        identify_arm(model, [log])
    # moving, the same arm is identified
    q[:, 1] = 0.3 + 0.6 * np.sin(2 * np.pi * t / 3.1)
    qd = np.gradient(q, t, axis=0)
    qdd = np.gradient(qd, t, axis=0)
    tau = arm.inverse_dynamics(q, qd, qdd) / 50.0 + 0.01 * np.tanh(50.0 * qd / 0.1)
    tau += 1e-3 * rng.standard_normal(tau.shape)
    log = Log(t=t, q=q, motor_torque=tau, joint_names=("shoulder", "elbow"), path="free.csv")
    assert identify_arm(model, [log]).model.joints["elbow"].friction is not None
