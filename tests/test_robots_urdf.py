"""The ``urdf`` robot kind: kinematics and dynamics against independent references."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.errors import InputError
from torquemap.robots.urdf import UrdfArm, arm_from_table, urdf_arm

DATA = Path(__file__).parent / "data" / "arm"
TWO_LINK = DATA / "two_link.urdf"
ERD = Path(sys.prefix).glob(
    "lib/python3*/site-packages/cmeel.prefix/share/example-robot-data/robots"
)
ROBOTS = next(iter(ERD), None)

# two_link.urdf: l1 = 0.4, lc1 = 0.2, m1 = 2.0, I1zz = 0.03; lc2 = 0.12, m2 = 1.2, I2zz = 0.01
L1, LC1, M1, I1 = 0.4, 0.2, 2.0, 0.03
L2, LC2, M2, I2 = 0.3, 0.12, 1.2, 0.01
G = 9.81
XARM7 = [f"joint{i}" for i in range(1, 8)]
Z1 = [f"joint{i}" for i in range(1, 7)]
JACO2 = [f"j2s6s200_joint_{i}" for i in range(1, 7)]
SO100 = ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"]


def _two_link(gravity: tuple[float, float, float] = (0.0, -G, 0.0)) -> UrdfArm:
    return urdf_arm(TWO_LINK, ["shoulder", "elbow"], end_effector="tool", gravity=gravity)


def _closed_form(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """Textbook two-link dynamics (Spong, Hutchinson & Vidyasagar, section 7.3), gravity -y."""
    c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
    m11 = I1 + I2 + M1 * LC1**2 + M2 * (L1**2 + LC2**2 + 2 * L1 * LC2 * c2)
    m12 = I2 + M2 * (LC2**2 + L1 * LC2 * c2)
    m22 = I2 + M2 * LC2**2
    h = M2 * L1 * LC2 * s2
    c1, c12 = np.cos(q[:, 0]), np.cos(q[:, 0] + q[:, 1])
    g1 = (M1 * LC1 + M2 * L1) * G * c1 + M2 * LC2 * G * c12
    g2 = M2 * LC2 * G * c12
    tau1 = m11 * qdd[:, 0] + m12 * qdd[:, 1] - h * (2 * qd[:, 0] * qd[:, 1] + qd[:, 1] ** 2) + g1
    tau2 = m12 * qdd[:, 0] + m22 * qdd[:, 1] + h * qd[:, 0] ** 2 + g2
    return np.stack([tau1, tau2], axis=1)


def _states(n: int, nj: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return (
        rng.uniform(-1.5, 1.5, (n, nj)),
        rng.standard_normal((n, nj)),
        rng.standard_normal((n, nj)),
    )


def test_two_link_dynamics_match_closed_form() -> None:
    arm = _two_link()
    q, qd, qdd = _states(20, 2, 0)
    # both are exact; the tolerance is float rounding
    assert_allclose(arm.inverse_dynamics(q, qd, qdd), _closed_form(q, qd, qdd), atol=1e-12)
    assert_allclose(
        arm.regressor(q, qd, qdd) @ arm.parameters(), _closed_form(q, qd, qdd), atol=1e-12
    )


def test_two_link_kinematics_and_base_parameters() -> None:
    arm = _two_link()
    q = np.array([[0.3, -0.7]])
    x = L1 * np.cos(0.3) + L2 * np.cos(-0.4)
    y = L1 * np.sin(0.3) + L2 * np.sin(-0.4)
    assert_allclose(arm.forward_kinematics(q), [[x, y, 0.0]], atol=1e-14)
    assert arm.wrench_axes == ("fx", "fy", "fz")
    # Khalil & Dombre: a planar 2R arm has 6 base parameters with gravity in its plane
    # (ZZ1R, MX1R, MY1R, ZZ2, MX2, MY2) and 4 without (the first link's moments drop out)
    assert len(arm.parameter_names) == 6
    assert len(_two_link((0.0, 0.0, -G)).parameter_names) == 4
    named = dict(zip(arm.parameter_names, arm.parameters(), strict=True))
    assert_allclose(named["shoulder.mx"], M1 * LC1 + M2 * L1, rtol=1e-12)
    assert_allclose(named["shoulder.Izz"], I1 + M1 * LC1**2 + M2 * L1**2, rtol=1e-12)


def test_two_link_wrench_inverts_jacobian_transpose() -> None:
    arm = _two_link()
    q = np.array([[0.3, 1.1], [1.0, -0.8]])
    force = np.array([[3.0, -2.0, 0.0], [-1.0, 4.0, 0.0]])
    tau = np.einsum("nij,ni->nj", arm.jacobian(q), force)
    w = arm.wrench_from_joint_torque(q, tau, damping=1e-6)
    # a 2-joint arm sees the in-plane force only; the damping biases it by ~damping^2
    assert_allclose(w.wrench, force, atol=1e-8)
    assert not w.singular.any()
    assert arm.wrench_from_joint_torque([[0.3, 0.0]], [[1.0, 1.0]]).singular[0]


@pytest.mark.skipif(ROBOTS is None, reason="example-robot-data not installed")
@pytest.mark.parametrize(
    ("urdf", "joints", "ee", "base_count"),
    [
        # Gaz, Cognetti, Oliva, Robuffo Giordano & De Luca (2019): the Panda has 43 base
        # inertial parameters (without friction)
        (
            "panda_description/urdf/panda.urdf",
            [f"panda_joint{i}" for i in range(1, 8)],
            "panda_hand_tcp",
            43,
        ),
        (
            "ur_description/urdf/ur5_robot.urdf",
            [
                "shoulder_pan_joint",
                "shoulder_lift_joint",
                "elbow_joint",
                "wrist_1_joint",
                "wrist_2_joint",
                "wrist_3_joint",
            ],
            "tool0",
            None,
        ),
        # arms no bench of ours was tuned on: a 7-axis xArm, Unitree's Z1 (its end-effector
        # link shares its name with the fixed joint above it) and Kinova's Jaco2, whose
        # continuous joints Pinocchio stores as (cos, sin)
        ("xarm_description/urdf/xarm7.urdf", XARM7, "link_eef", None),
        ("z1_description/urdf/z1.urdf", Z1, "gripperStator", None),
        ("kinova_description/robots/kinova.urdf", JACO2, "j2s6s200_end_effector", None),
        # five joints, the jaw locked: its joint is named as the link it hangs from
        ("so_arm_description/urdf/so100.urdf", SO100, "gripper", None),
    ],
)
def test_example_arms(urdf: str, joints: list[str], ee: str, base_count: int | None) -> None:
    assert ROBOTS is not None
    arm = urdf_arm(ROBOTS / urdf, joints, end_effector=ee)
    nj = len(joints)
    q, qd, qdd = _states(6, nj, 1)
    tau = arm.inverse_dynamics(q, qd, qdd)
    # regressor linear in the parameters: exact up to rounding
    assert_allclose(arm.full_regressor(q, qd, qdd) @ arm.full_parameters, tau, atol=1e-10)
    assert_allclose(arm.regressor(q, qd, qdd) @ arm.parameters(), tau, atol=1e-9)
    if base_count is not None:
        assert len(arm.parameter_names) == base_count
    # M(q) qdd + (RNEA at zero acceleration) == RNEA, and g(q) == RNEA at rest
    M = arm.mass_matrix(q)
    assert_allclose(
        np.einsum("nij,nj->ni", M, qdd) + arm.inverse_dynamics(q, qd, 0 * qdd), tau, atol=1e-10
    )
    assert_allclose(arm.gravity_torque(q), arm.inverse_dynamics(q, 0 * qd, 0 * qdd), atol=1e-10)
    # C qd + g == RNEA at zero acceleration; dM/dt == C + C^T by central differences
    C = arm.coriolis_matrix(q, qd)
    assert_allclose(
        np.einsum("nij,nj->ni", C, qd) + arm.gravity_torque(q),
        arm.inverse_dynamics(q, qd, 0 * qdd),
        atol=1e-10,
    )
    h = 1e-6
    dM = (arm.mass_matrix(q + h * qd) - arm.mass_matrix(q - h * qd)) / (2 * h)
    # central difference: error O(h^2) plus rounding ~1e-16 / h
    assert_allclose(dM, C + np.swapaxes(C, 1, 2), atol=1e-8)
    # Jacobian: position rows against central differences of forward kinematics
    J = arm.spatial_jacobian(q[:2])
    for k in range(nj):
        e = np.zeros(nj)
        e[k] = h
        fd = (arm.forward_kinematics(q[:2] + e) - arm.forward_kinematics(q[:2] - e)) / (2 * h)
        assert_allclose(J[:, :3, k], fd, atol=1e-8)
        R_plus = arm.end_effector_rotation(q[:2] + e)
        R_minus = arm.end_effector_rotation(q[:2] - e)
        skew = (R_plus - R_minus) @ np.swapaxes(arm.end_effector_rotation(q[:2]), 1, 2) / (2 * h)
        omega = np.stack([skew[:, 2, 1], skew[:, 0, 2], skew[:, 1, 0]], axis=1)
        assert_allclose(J[:, 3:, k], omega, atol=1e-7)


def test_parameters_round_trip_through_the_robot_table(tmp_path: Path) -> None:
    arm = _two_link()
    pi = arm.full_parameters.copy()
    pi[10] += 0.5  # elbow body mass + 0.5 kg
    changed = arm.with_full_parameters(pi)
    q, qd, qdd = _states(5, 2, 2)
    assert not np.allclose(changed.inverse_dynamics(q, qd, qdd), arm.inverse_dynamics(q, qd, qdd))
    table = changed.to_dict()
    assert "inertial" in table
    table["urdf"] = str(TWO_LINK)
    again = arm_from_table(table, ["shoulder", "elbow"], path=None, base_dir=None)
    assert_allclose(again.full_parameters, pi, atol=1e-12)
    beta = arm.parameters() * 1.1
    assert_allclose(arm.with_parameters(beta).parameters(), beta, rtol=1e-12)


def _table(**kw: object) -> dict[str, object]:
    head: dict[str, object] = {
        "kinematics": "urdf",
        "urdf": "two_link.urdf",
        "end_effector": "tool",
    }
    head.update(kw)
    return head


@pytest.mark.parametrize(
    ("head", "joints", "match"),
    [
        (_table(urdf="nope.urdf"), ["shoulder"], "URDF file not found"),
        (_table(end_effector="hand"), ["shoulder"], "end_effector 'hand' is not a link"),
        (_table(), ["shoulder", "wrist"], "joint 'wrist' is not a movable joint"),
        (_table(), ["shoulder", "tool_joint"], "joint 'tool_joint' is fixed"),
        (_table(), ["shoulder", "shoulder"], "listed twice"),
        (_table(gravity=[0, 1]), ["shoulder"], "gravity must be"),
        (_table(colour="red"), ["shoulder"], "unknown key 'colour'"),
    ],
)
def test_bad_robot_table(head: dict[str, object], joints: list[str], match: str) -> None:
    with pytest.raises(InputError, match=match):
        arm_from_table(head, joints, path="robot.toml", base_dir=DATA)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("<robot name='x'><link name='a'/>", "not a valid URDF"),
        ("<model/>", "root element is <model>"),
        (
            "<robot name='x'><link name='a'/><link name='b'/><link name='c'/>"
            "<joint name='j1' type='revolute'><parent link='a'/><child link='b'/></joint>"
            "<joint name='j2' type='revolute'><parent link='b'/><child link='c'/></joint>"
            "<joint name='j3' type='revolute'><parent link='a'/><child link='c'/></joint></robot>",
            "closed chain: link 'c' has two parent joints",
        ),
        (
            "<robot name='x'><link name='w'/><link name='b'/>"
            "<joint name='fl' type='floating'><parent link='w'/><child link='b'/></joint></robot>",
            "'fl' is floating: torquemap needs a fixed-base arm",
        ),
    ],
)
def test_bad_urdf(tmp_path: Path, text: str, match: str) -> None:
    (tmp_path / "arm.urdf").write_text(text)
    with pytest.raises(InputError, match=match) as info:
        arm_from_table(_table(urdf="arm.urdf"), ["j1"], path="robot.toml", base_dir=tmp_path)
    assert info.value.path is not None and info.value.path.endswith("arm.urdf")


ROBOT_TOML = """
[robot]
name = "vertical two-link"
kinematics = "urdf"
urdf = "two_link.urdf"
end_effector = "tool"
gravity = [0.0, -9.81, 0.0]

[joints.elbow]
gear_ratio = 40
torque_constant = 0.1
encoder_counts_per_rev = 0

[joints.shoulder]
gear_ratio = 60
torque_constant = 0.1
"""


def _robot_dir(tmp_path: Path, text: str = ROBOT_TOML) -> Path:
    (tmp_path / "two_link.urdf").write_text(TWO_LINK.read_text())
    (tmp_path / "robot.toml").write_text(text)
    return tmp_path / "robot.toml"


def test_robot_file_round_trip(tmp_path: Path) -> None:
    from torquemap.io import write_toml
    from torquemap.model import load_model, model_to_dict

    model = load_model(_robot_dir(tmp_path))
    arm = model.robot.arm
    assert isinstance(arm, UrdfArm)
    # file order (elbow first), not the URDF's: columns follow the file
    assert arm.joint_names == ("elbow", "shoulder")
    assert model.robot.joints[0].encoder_counts_per_rev is None
    q = np.array([[0.4, 0.2]])  # elbow, shoulder
    ref = _two_link()
    assert_allclose(arm.jacobian(q)[0], ref.jacobian(q[:, ::-1])[0][:, ::-1], atol=1e-14)
    pi = arm.full_parameters.copy()
    pi[10] += 0.25
    changed = arm_from_table(
        {**arm.to_dict(), "urdf": str(TWO_LINK)}, arm.joint_names, path=None, base_dir=None
    ).with_full_parameters(pi)
    doc = model_to_dict(
        type(model)(robot=type(model.robot)(
            name=model.robot.name, kinematics="urdf", link_lengths=(),
            joints=model.robot.joints, arm=changed), joints=model.joints)
    )  # fmt: skip
    doc["robot"]["urdf"] = "two_link.urdf"
    write_toml(tmp_path / "model.toml", doc)
    again = load_model(tmp_path / "model.toml")
    assert isinstance(again.robot.arm, UrdfArm)
    assert_allclose(again.robot.arm.full_parameters, pi, atol=1e-12)


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        ('end_effector = "tool"', 'end_effector = "gripper"', "end_effector 'gripper' is not"),
        ("[joints.elbow]", "[joints.wrist]", "joint 'wrist' is not a movable joint"),
        ('urdf = "two_link.urdf"', 'urdf = "other.urdf"', "URDF file not found"),
        ("[joints.shoulder]", "[joints.elbow]", "not valid TOML"),
    ],
)
def test_bad_robot_file_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], old: str, new: str, match: str
) -> None:
    from torquemap.cli.main import main

    path = _robot_dir(tmp_path, ROBOT_TOML.replace(old, new))
    status = main(["excite", str(path), "-o", str(tmp_path / "traj.csv")])
    err = capsys.readouterr().err
    assert status == 2
    assert err.count("\n") == 1 and match in err, err
    assert str(tmp_path) in err
    assert not (tmp_path / "traj.csv").exists()


def test_excite_cli_within_limits(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from torquemap.cli.main import main
    from torquemap.io import read_table

    path = _robot_dir(tmp_path)
    out = tmp_path / "traj.csv"
    argv = ["excite", str(path), "-o", str(out), "--duration", "10", "--rate", "100"]
    assert main(argv) == 0
    assert "condition number" in capsys.readouterr().out
    cols = read_table(out)
    assert list(cols)[:3] == ["t", "q_elbow", "q_shoulder"]
    arm = _two_link()
    lo, hi = arm.position_limits  # shoulder, elbow
    for name, k in (("shoulder", 0), ("elbow", 1)):
        q = cols[f"q_{name}"]
        assert lo[k] <= q.min() and q.max() <= hi[k]
        assert np.abs(cols[f"qd_{name}"]).max() <= 0.7 * arm.velocity_limits[k] + 1e-9
        # starts and ends at rest at the middle of the range
        assert_allclose([q[0], q[-1]], 0.5 * (lo[k] + hi[k]), atol=1e-12)
        assert_allclose([cols[f"qd_{name}"][0], cols[f"qdd_{name}"][-1]], 0.0, atol=1e-12)
        # velocity is the derivative of position (central differences at 100 Hz, 0.2 Hz motion)
        fd = np.gradient(q, cols["t"])
        assert_allclose(fd[1:-1], cols[f"qd_{name}"][1:-1], atol=2e-3)


def test_excite_centre(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``--centre``: the motion swings about the given pose (starts and ends there at rest),
    still inside the limits; a centre outside them is one line of error."""
    from torquemap.cli.main import main
    from torquemap.io import read_table

    path = _robot_dir(tmp_path)
    arm = _two_link()
    lo, hi = arm.position_limits
    centre = {"elbow": 1.5, "shoulder": -1.0}  # in the robot file's order: elbow, shoulder
    out = tmp_path / "traj.csv"
    argv = ["excite", str(path), "-o", str(out), "--duration", "10", "--rate", "100"]
    assert main([*argv, "--centre", "1.5,-1.0"]) == 0
    assert "elbow=1.5000, shoulder=-1.0000" in capsys.readouterr().out
    cols = read_table(out)
    for name, k in (("shoulder", 0), ("elbow", 1)):
        q = cols[f"q_{name}"]
        assert_allclose([q[0], q[-1]], centre[name], atol=1e-12)
        assert lo[k] <= q.min() and q.max() <= hi[k]
        assert np.ptp(q) > 0.1  # it moves
    assert main([*argv, "--centre", "2.4,0"]) == 2  # beyond the elbow's limit less 10 %
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "centre is outside" in err and "elbow=2.4" in err


def test_excite_speed_schedule() -> None:
    """The path played at each speed of the schedule in turn: the same poses (a quarter speed
    takes four times as long; backwards runs them in reverse), velocity and acceleration the
    path's times the speed and its square, agreeing with central differences of the position
    across the traversals' joins; each traversal starts and ends at rest at the centre."""
    from torquemap.excite import exciting_trajectory

    arm = _two_link()
    rate = 200.0
    tr = exciting_trajectory(
        arm, period=4.0, speeds=(1.0, 0.25, -0.5), rate=rate, iterations=5, rng=1
    )
    assert tr.speeds == (1.0, 0.25, -0.5)
    assert_allclose(tr.t[-1], 4.0 + 16.0 + 8.0)  # one traversal of each by default
    fast = tr.q[: int(4 * rate) + 1]
    slow = tr.q[int(4 * rate) : int(20 * rate) + 1 : 4]  # every 4th sample of the slow one
    back = tr.q[int(20 * rate) :: 2][::-1]
    assert_allclose(slow, fast, atol=1e-12)
    assert_allclose(back, fast, atol=1e-12)
    k = np.arange(int(4 * rate) + 1)
    assert_allclose(tr.qd[int(4 * rate) + 4 * k], 0.25 * tr.qd[k], atol=1e-12)
    assert_allclose(tr.qdd[int(4 * rate) + 4 * k], 0.0625 * tr.qdd[k], atol=1e-12)
    # velocity and acceleration are the derivatives of position everywhere, joins included
    # (central differences at 200 Hz on a 0.25-1.25 Hz motion: errors ~ (w h)^2 / 6 of a few
    # rad/s, below 1e-2)
    scale = np.abs(tr.qd).max()
    assert_allclose(np.gradient(tr.q, tr.t, axis=0)[1:-1], tr.qd[1:-1], atol=2e-3 * scale)
    fd2 = np.gradient(tr.qd, tr.t, axis=0)[1:-1]
    assert_allclose(fd2, tr.qdd[1:-1], atol=1e-2 * np.abs(tr.qdd).max())
    for join in (0.0, 4.0, 20.0, 28.0):
        i = round(join * rate)
        assert_allclose(tr.q[i], tr.centre, atol=1e-12)
        assert_allclose(tr.qd[i], 0.0, atol=1e-12)
    # a duration asks for whole traversals of the schedule in turn, rounded up
    assert_allclose(
        exciting_trajectory(arm, period=4.0, duration=5.0, rate=50.0, iterations=2).t[-1],
        20.0,
    )
    with pytest.raises(InputError, match="speeds must be fractions"):
        exciting_trajectory(arm, speeds=(1.0, 1.5))
    with pytest.raises(InputError, match="speeds must be fractions"):
        exciting_trajectory(arm, speeds=(0.0,))


def test_excite_spans_the_ranges_within_one_turn() -> None:
    """The default path (20 s) swings each joint over most of its range: the two-link's
    joints (+-3 and +-2.5 rad, less 10 % at each end) reach beyond half of what is allowed;
    a joint of wider range than a turn (the UR5's +-2 pi) stays within +-pi of the centre."""
    from torquemap.excite import exciting_trajectory

    arm = _two_link()
    tr = exciting_trajectory(arm, speeds=(1.0,), rate=50.0, iterations=10)
    allowed = np.array([2.4, 2.0])
    reach = np.max(np.abs(tr.q - tr.centre), axis=0)
    assert np.all(reach <= allowed + 1e-9)
    assert np.all(reach > 0.5 * allowed), reach
    if ROBOTS is None:
        return
    ur5 = urdf_arm(
        ROBOTS / "ur_description/urdf/ur5_robot.urdf",
        ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
         "wrist_2_joint", "wrist_3_joint"],
        end_effector="tool0",
    )  # fmt: skip
    tr = exciting_trajectory(ur5, speeds=(1.0,), rate=50.0, iterations=4)
    assert np.all(np.max(np.abs(tr.q - tr.centre), axis=0) <= np.pi + 1e-9)


@pytest.mark.skipif(ROBOTS is None, reason="example-robot-data not installed")
@pytest.mark.parametrize(
    ("urdf", "joints"),
    [
        ("panda_description/urdf/panda.urdf", [f"panda_joint{i}" for i in range(1, 8)]),
        ("ur_description/urdf/ur5_robot.urdf",
         ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
          "wrist_2_joint", "wrist_3_joint"]),
        ("xarm_description/urdf/xarm7.urdf", XARM7[::-1]),  # the robot file's order, not the tree's
        ("z1_description/urdf/z1.urdf", Z1),
        ("kinova_description/robots/kinova.urdf", JACO2),
        ("so_arm_description/urdf/so100.urdf", SO100),
    ],
)  # fmt: skip
def test_inverse_dynamics_matches_mujoco(urdf: str, joints: list[str]) -> None:
    """A second engine: MuJoCo's inverse dynamics of the same URDF (meshes dropped, the URDF's
    joint damping and MuJoCo's constraints switched off)."""
    import re

    mujoco = pytest.importorskip("mujoco")
    assert ROBOTS is not None
    text = (ROBOTS / urdf).read_text()
    text = re.sub(r"<(visual|collision)>.*?</\1>", "", text, flags=re.S)
    text = re.sub(
        r"(<robot[^>]*>)",
        r'\1<mujoco><compiler fusestatic="false" discardvisual="true"/></mujoco>',
        text,
        count=1,
    )
    model = mujoco.MjModel.from_xml_string(text)
    model.dof_damping[:] = 0.0
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    data = mujoco.MjData(model)
    index = [model.joint(j).dofadr[0] for j in joints]
    arm = urdf_arm(ROBOTS / urdf, joints, end_effector=arm_ee(urdf))
    lo, hi = arm.position_limits
    rng = np.random.default_rng(3)
    for _ in range(4):
        q = rng.uniform(np.maximum(lo, -3), np.minimum(hi, 3))
        qd, qdd = rng.standard_normal((2, len(joints)))
        data.qpos[:] = data.qvel[:] = data.qacc[:] = 0.0
        data.qpos[index], data.qvel[index], data.qacc[index] = q, qd, qdd
        mujoco.mj_inverse(model, data)
        # two engines, the same rigid bodies: agreement to rounding (torques of 1-100 N m)
        assert_allclose(arm.inverse_dynamics(q, qd, qdd)[0], data.qfrc_inverse[index], atol=1e-8)


def arm_ee(urdf: str) -> str:
    ends = {"panda": "panda_hand_tcp", "xarm": "link_eef", "z1": "gripperStator"}
    ends |= {"kinova": "j2s6s200_end_effector", "so_arm": "gripper"}
    return next((e for k, e in ends.items() if f"{k}_description" in urdf), "tool0")
