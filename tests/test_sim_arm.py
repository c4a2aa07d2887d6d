"""The MuJoCo arm bench (torquemap.sim.arm) against Pinocchio, the surface law and the readers."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from torquemap.sim import arm as sim

pytestmark = [
    pytest.mark.skipif(
        next(iter(Path(sim.sys.prefix).glob("lib/python3*/site-packages/cmeel.prefix")), None)
        is None,
        reason="example-robot-data not installed",
    ),
    # one worker runs the module, so its module fixture (the simulated Panda) is built once
    pytest.mark.xdist_group("sim_arm"),
]


class _Pin:
    """Pinocchio on a URDF text: RNEA, end-effector position and translational Jacobian."""

    def __init__(self, text: str, frame: str) -> None:
        self.model = pin.buildModelFromXML(text)
        self.data = self.model.createData()
        self.frame = self.model.getFrameId(frame, pin.FrameType.BODY)

    def config(self, q: np.ndarray) -> np.ndarray:
        """Joint angles (tree order) to Pinocchio's configuration: (cos, sin) when continuous."""
        parts = []
        for joint, angle in zip(list(self.model.joints)[1:], q, strict=True):
            parts.append([np.cos(angle), np.sin(angle)] if joint.nq == 2 else [angle])
        return np.concatenate(parts)

    def inverse_dynamics(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        m, d = self.model, self.data
        rows = zip(q, qd, qdd, strict=True)
        return np.array([pin.rnea(m, d, self.config(x), v, a).copy() for x, v, a in rows])

    def position(self, q: np.ndarray) -> np.ndarray:
        out = []
        for x in q:
            pin.framesForwardKinematics(self.model, self.data, self.config(x))
            out.append(self.data.oMf[self.frame].translation.copy())
        return np.array(out)

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        world = pin.LOCAL_WORLD_ALIGNED
        m, d, f = self.model, self.data, self.frame
        return np.array([pin.computeFrameJacobian(m, d, self.config(x), f, world)[:3] for x in q])


@pytest.fixture(scope="module")
def panda() -> dict[str, object]:
    nominal = sim._stripped(sim.panda_urdf())
    truth = sim.random_truth(3, nominal)
    true_text = sim.true_urdf(nominal, truth)
    nominal_text = ET.tostring(nominal, encoding="unicode")
    reference, surface = sim.task_reference(nominal_text, 2.5, 3)
    run = sim.run_arm(
        true_text, nominal_text, truth, reference, surface=surface, seed=3, noise=False
    )
    arm = _Pin(true_text, sim.END_EFFECTOR)
    return {"run": run, "arm": arm, "surface": surface, "texts": (true_text, nominal_text),
            "truth": truth, "reference": reference}  # fmt: skip


def test_mujoco_obeys_pinocchio_on_the_true_arm(panda: dict[str, object]) -> None:
    """Drive + J^T F = M qdd + C qd + g + rotor inertia: MuJoCo against Pinocchio's RNEA."""
    run, arm = panda["run"], panda["arm"]
    assert isinstance(run, sim.ArmRun) and isinstance(arm, _Pin)
    armature = np.asarray(sim.ARMATURE) * np.asarray(sim.GEAR) ** 2
    rigid = arm.inverse_dynamics(run.q, run.qd, run.qdd) + armature * run.qdd
    contact = np.einsum("nij,ni->nj", arm.jacobian(run.q), run.wrench[:, :3])
    scale = np.abs(run.drive).max()
    assert np.abs(contact).max() > 0.5  # the surface is touched
    assert_allclose(run.drive + contact, rigid, atol=1e-9 * scale)
    # without the tool and the mass changes the same check fails by newtons-metres
    model, data = sim._pin_model(panda["texts"][1])  # type: ignore[index]
    off = armature * run.qdd + np.array(
        [pin.rnea(model, data, q, qd, a) for q, qd, a in zip(run.q, run.qd, run.qdd, strict=True)]
    )
    assert np.abs(run.drive + contact - off).max() > 1.0


def test_contact_force_is_the_surface_law(panda: dict[str, object]) -> None:
    run, arm, surface = panda["run"], panda["arm"], panda["surface"]
    assert isinstance(run, sim.ArmRun) and isinstance(arm, _Pin)
    assert isinstance(surface, float)
    p = arm.position(run.q)
    v = np.einsum("nij,nj->ni", arm.jacobian(run.q), run.qd)
    depth = surface - p[:, 2]
    normal = np.where(
        depth > 0, np.maximum(sim.SURFACE_STIFFNESS * depth - sim.SURFACE_DAMPING * v[:, 2], 0), 0
    )
    slide = v[:, :2] / np.sqrt((v[:, :2] ** 2).sum(axis=1) + 1e-4)[:, None]
    expected = np.column_stack([-sim.SURFACE_FRICTION * normal[:, None] * slide, normal])
    assert_allclose(run.wrench[:, :3], expected, atol=1e-9)
    assert_array_equal(run.wrench[:, 3:], 0.0)
    late = run.t > 2.0
    assert 4.0 < run.wrench[late, 2].min() and run.wrench[late, 2].max() < 25.0


def test_deterministic_per_seed(panda: dict[str, object]) -> None:
    true_text, nominal_text = panda["texts"]  # type: ignore[misc]
    reference = tuple(x[:1000] for x in panda["reference"])  # type: ignore[attr-defined]
    runs = [
        sim.run_arm(true_text, nominal_text, panda["truth"], reference, surface=0.3, seed=s)  # type: ignore[arg-type]
        for s in (7, 7, 8)
    ]
    assert_array_equal(runs[0].current, runs[1].current)
    assert_array_equal(runs[0].counts, runs[1].counts)
    assert np.abs(runs[0].current - runs[2].current).max() > 0.01  # another noise draw


def test_files_parse(panda: dict[str, object], tmp_path: Path) -> None:
    from torquemap.io import read_log, write_table, write_toml
    from torquemap.robot import load_robot

    run = panda["run"]
    assert isinstance(run, sim.ArmRun)
    (tmp_path / "panda.urdf").write_text(sim.panda_urdf().read_text())
    write_toml(tmp_path / "robot.toml", sim.robot_toml("panda.urdf"))
    write_table(tmp_path / "task.csv", sim._log_columns(run))
    robot = load_robot(tmp_path / "robot.toml")
    assert robot.joint_names == sim.JOINTS
    log = read_log(tmp_path / "task.csv", robot)
    # counts back to radians: within one count of the true angle
    step = 2.0 * np.pi / sim.COUNTS / np.asarray(sim.GEAR)
    assert np.all(np.abs(log.q - run.q) <= 1.01 * step)
    kt = sim.TORQUE_CONSTANT
    assert_allclose(log.motor_torque, kt * run.current)


def test_cli_refuses_a_negative_seed(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from torquemap.cli.main import main

    assert main(["simulate", "arm", "--out", str(tmp_path / "b"), "--random", "-1"]) == 2
    assert "--random" in capsys.readouterr().err
    assert not (tmp_path / "b").exists()


@pytest.mark.parametrize("spec", [sim.UR5, sim.XARM7, sim.Z1, sim.JACO2], ids=lambda s: s.name)
def test_arm_obeys_pinocchio(spec: sim.ArmSpec) -> None:
    """Each bench arm: MuJoCo's drive torque plus J^T F equals Pinocchio's RNEA on truth.urdf
    plus the rotor inertia (two engines on the same bodies: rounding), and the task presses."""
    nominal = sim._stripped(sim.panda_urdf(spec), spec)
    truth = sim.random_truth(4, nominal, len(spec.joints))
    true_text = sim.true_urdf(nominal, truth, spec)
    nominal_text = ET.tostring(nominal, encoding="unicode")
    reference, surface = sim.task_reference(nominal_text, 2.2, 4, spec)
    run = sim.run_arm(
        true_text, nominal_text, truth, reference, surface=surface, seed=4, noise=False, spec=spec
    )
    arm = _Pin(true_text, spec.end_effector)
    armature = np.asarray(spec.armature) * np.asarray(spec.gear) ** 2
    rigid = arm.inverse_dynamics(run.q, run.qd, run.qdd) + armature * run.qdd
    contact = np.einsum("nij,ni->nj", arm.jacobian(run.q), run.wrench[:, :3])
    assert run.wrench[run.t > 2.0, 2].min() > 4.0
    assert_allclose(run.drive + contact, rigid, atol=1e-9 * np.abs(run.drive).max())
    # the ready pose points the tool down: it hangs its offset straight below the end effector
    tool = _Pin(true_text, "tool")
    ready = np.asarray([spec.ready])
    below = arm.position(ready)[0] - tool.position(ready)[0]
    # the ready poses are rounded to 1e-4 rad: the tool sits within 0.1 mm of the vertical
    assert_allclose(below, [0.0, 0.0, np.linalg.norm(spec.tool_offset)], atol=1e-4)


def test_cli_offers_every_bench_arm() -> None:
    """``simulate arm --arm`` lists its choices without importing MuJoCo: the same as the sim's."""
    from torquemap.cli.main import build_parser, subparsers

    command = subparsers(subparsers(build_parser())["simulate"])["arm"]
    arm = command._option_string_actions["--arm"]
    assert arm.choices is not None
    assert tuple(arm.choices) == sim.ARM_NAMES
