"""The robots seam: kinds none and planar2r against independent references."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.errors import InputError
from torquemap.io import log_from_columns
from torquemap.robot import Joint, Robot, robot_from_dict
from torquemap.robots import Arm, arm_from_kind, arm_from_table
from torquemap.robots.planar2r import Planar2R

L1, L2 = 0.3, 0.2
M1, M2 = 2.0, 1.5  # point masses at the link ends


def _point_mass_inertia(q: np.ndarray) -> np.ndarray:
    """M(q) of two point masses from their own Jacobians: sum m_i J_i^T J_i (independent)."""
    q1, q2 = q
    j1 = np.array([[-L1 * np.sin(q1), 0.0], [L1 * np.cos(q1), 0.0]])
    j2 = np.array(
        [
            [-L1 * np.sin(q1) - L2 * np.sin(q1 + q2), -L2 * np.sin(q1 + q2)],
            [L1 * np.cos(q1) + L2 * np.cos(q1 + q2), L2 * np.cos(q1 + q2)],
        ]
    )
    return M1 * j1.T @ j1 + M2 * j2.T @ j2


def _arm() -> Planar2R:
    a1 = M1 * L1**2 + M2 * (L1**2 + L2**2)
    return Planar2R(("a", "b"), (L1, L2), base_parameters=(a1, M2 * L1 * L2, M2 * L2**2))


def test_planar2r_inertia_matrix_matches_point_masses() -> None:
    arm = _arm()
    rng = np.random.default_rng(0)
    for q in rng.uniform(-3, 3, (5, 2)):
        # columns of M: inverse dynamics at zero velocity and unit accelerations
        m = np.stack([arm.inverse_dynamics(q, [0.0, 0.0], e)[0] for e in np.eye(2)], axis=1)
        assert_allclose(m, _point_mass_inertia(q), rtol=1e-12)


def test_planar2r_power_balance() -> None:
    """tau . qd = dT/dt along any motion (no gravity, no friction): Coriolis terms included."""
    arm = _arm()
    t = np.linspace(0.0, 2.0, 20001)
    q = np.stack([0.7 * np.sin(2.1 * t), 1.0 + 0.9 * np.cos(1.3 * t)], axis=1)
    qd = np.gradient(q, t, axis=0)
    qdd = np.gradient(qd, t, axis=0)
    tau = arm.inverse_dynamics(q, qd, qdd)
    energy = 0.5 * np.einsum("ni,nij,nj->n", qd, np.stack([_point_mass_inertia(x) for x in q]), qd)
    power = np.sum(tau * qd, axis=1)
    inner = slice(10, -10)  # np.gradient is first order at the ends
    # central differences of smooth signals at h = 1e-4 s: error ~ h^2 * derivative ~ 1e-6
    assert_allclose(power[inner], np.gradient(energy, t)[inner], atol=1e-5)


def test_regressor_is_linear_in_parameters() -> None:
    arm = _arm()
    rng = np.random.default_rng(1)
    q, qd, qdd = (rng.normal(size=(7, 2)) for _ in range(3))
    y = arm.regressor(q, qd, qdd)
    assert_allclose(y @ arm.parameters(), arm.inverse_dynamics(q, qd, qdd), rtol=1e-13)
    other = arm.with_parameters([1.0, 2.0, 3.0])
    assert_allclose(other.inverse_dynamics(q, qd, qdd), y @ np.array([1.0, 2.0, 3.0]))


def test_planar2r_wrench_inverts_jacobian_transpose() -> None:
    arm = _arm()
    q = np.array([[0.3, 1.1], [0.1, 0.01]])
    force = np.array([[2.0, -3.5], [1.0, 1.0]])
    tau = np.einsum("nji,nj->ni", arm.jacobian(q), force)  # tau = J^T F
    w = arm.wrench_from_joint_torque(q, tau)
    assert_allclose(w.wrench[0], force[0], rtol=1e-12)
    assert w.singular.tolist() == [False, True]  # |sin 0.01| < 0.05
    assert np.isnan(w.wrench[1]).all()


def test_kinds_from_tables_and_robot_files() -> None:
    arm = arm_from_table({"kinematics": "planar2r", "link_lengths": [0.3, 0.2]}, ["a", "b"])
    assert isinstance(arm, Arm) and arm.wrench_axes == ("fx", "fy")
    none = arm_from_kind("none", ["m"])
    assert isinstance(none, Arm) and none.wrench_axes == () and not none.has_dynamics
    assert_allclose(none.inverse_dynamics([[1.0]], [[2.0]], [[3.0]]), [[0.0]])
    robot = Robot("r", "planar2r", (0.3, 0.2), (Joint("a", 50.0, 0.1), Joint("b", 30.0, 0.1)))
    assert robot.arm.kind == "planar2r"
    assert_allclose(robot.arm.inertia_modulation([[0.0, np.pi]]), [[-1.0, 0.0]], atol=1e-15)


def test_unknown_kind_and_keys_of_other_kinds() -> None:
    base = {"joints": {"m": {"gear_ratio": 1, "torque_constant": 1}}}
    with pytest.raises(InputError, match="kinematics must be one of"):
        robot_from_dict({"robot": {"kinematics": "delta"}, **base}, path="r.toml")
    with pytest.raises(InputError, match="link_lengths is only for kinematics = 'planar2r'"):
        robot_from_dict({"robot": {"link_lengths": [1, 1]}, **base}, path="r.toml")


def test_light_kinds_do_not_load_the_urdf_engine() -> None:
    # a planar or plain robot file does not import Pinocchio (a fifth of a second of every
    # command); an unknown kind still lists the URDF kind, and a URDF key on a planar robot
    # still names its kind (every kind loaded for the messages)
    import subprocess
    import sys

    code = """
import sys
from torquemap.errors import InputError
from torquemap.robot import robot_from_dict
base = {"joints": {"a": {"gear_ratio": 1, "torque_constant": 1},
                   "b": {"gear_ratio": 1, "torque_constant": 1}}}
robot_from_dict({"robot": {"kinematics": "planar2r", "link_lengths": [0.3, 0.2]}, **base})
robot_from_dict({"robot": {"kinematics": "none"}, **base})
print("loaded" if "pinocchio" in sys.modules else "light")
for head in ({"kinematics": "delta"}, {"kinematics": "none", "urdf": "arm.urdf"}):
    try:
        robot_from_dict({"robot": head, **base})
    except InputError as exc:
        print(exc)
"""
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.splitlines()
    assert out[0] == "light"
    try:
        import pinocchio  # noqa: F401
    except ImportError:
        return
    assert "'urdf'" in out[1] and "kinematics must be one of" in out[1]
    assert "urdf is only for kinematics = 'urdf'" in out[2]


@pytest.mark.parametrize(
    ("joint", "message"),
    [
        ({"gear_ratio": -1.0}, "gear_ratio must be positive"),
        ({"torque_constant": 1e-320}, r"torque_constant must lie in"),
        ({"gear_ratio": 1e9}, r"gear_ratio must lie in"),
        ({"encoder_counts_per_rev": 2**63}, "encoder_counts_per_rev must be an integer"),
    ],
)
def test_joint_ranges(joint: dict[str, float], message: str) -> None:
    spec = {"gear_ratio": 10.0, "torque_constant": 0.1, **joint}
    with pytest.raises(InputError, match=message):
        robot_from_dict({"robot": {}, "joints": {"m": spec}}, path="r.toml")
    with pytest.raises(InputError, match=message.replace("must be positive", "must")):
        Joint(
            "m",
            float(spec["gear_ratio"]),
            float(spec["torque_constant"]),
            joint.get("encoder_counts_per_rev"),
        )  # type: ignore[arg-type]


def test_position_unit_turns() -> None:
    robot = robot_from_dict(
        {
            "robot": {},
            "joints": {"m": {"gear_ratio": 4.0, "torque_constant": 0.1, "position_unit": "turns"}},
        }
    )
    t = np.arange(3.0)
    log = log_from_columns(
        {"t": t, "q_m": np.array([0.0, 1.0, 2.5]), "i_m": np.zeros(3)}, robot, path="x.csv"
    )
    # motor turns -> joint radians: 2 pi / gear ratio per turn
    assert_allclose(log.q[:, 0], [0.0, 2 * np.pi / 4, 2.5 * 2 * np.pi / 4])
