"""A new user's robots and logs (stop 35 probe): cases that gave a silent wrong answer, a
traceback or an unclear message, each refused or warned in one line now."""

from __future__ import annotations

from pathlib import Path

import pytest

from torquemap.cli.main import main
from torquemap.io import write_toml

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
