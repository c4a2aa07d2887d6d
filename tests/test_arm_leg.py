"""The vertical two-link leg bench (torquemap.sim.leg): identified from its flight phases.

MuJoCo simulates the leg (true masses within 15 % of the URDF, a 0.3 kg mass the URDF lacks,
gears, rotor inertia, friction of another form, ripple, quantisation, current noise); the leg
is identified from free.csv (flight) and from free.csv plus task.csv with the contact samples
found and excluded, and the truth it is compared with is MuJoCo's model (truth.urdf, truth.csv).
"""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import pytest

from torquemap.estimate_arm import estimate_arm
from torquemap.identify_arm import ArmIdentification, identify_arm
from torquemap.io import read_log, read_table
from torquemap.model import load_model
from torquemap.robots.urdf import urdf_arm
from torquemap.sim import arm as sim
from torquemap.sim import leg

# one worker runs the module (pytest -n 2 --dist loadgroup), so its module fixture `bench`
# is built once, not once per worker
pytestmark = pytest.mark.xdist_group("arm_leg")

FREE, TASK = 6.0, 5.0  # [s] of flight (whole traversals of excite's schedule: 14.5 s), stepping


@pytest.fixture(scope="module")
def bench(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    folder = tmp_path_factory.mktemp("leg")
    sim.write_arm_bench(folder, seed=0, arm="leg", free_duration=FREE, task_duration=TASK)
    model = load_model(folder / "robot.toml")
    free = read_log(folder / "free.csv", model.robot)
    task = read_log(folder / "task.csv", model.robot)
    flight = identify_arm(model, [free], max_samples=1500)
    mixed = identify_arm(model, [free, task], max_samples=2000, exclude_contact=True)
    true_arm = urdf_arm(folder / "truth.urdf", leg.LEG.joints, end_effector="foot")
    return {
        "folder": folder,
        "model": model,
        "task": task,
        "free": free,
        "flight": flight,
        "mixed": mixed,
        "true_arm": true_arm,
        "truth": read_table(folder / "truth.csv"),
    }


def test_leg_geometry_matches_pinocchio() -> None:
    model = pin.buildModelFromXML(leg.LEG_URDF)
    data = model.createData()
    foot = model.getFrameId("foot")
    rng = np.random.default_rng(0)
    for _ in range(5):
        x, z = rng.uniform(-0.1, 0.1), rng.uniform(-0.55, -0.4)
        q = leg.leg_angles(np.array([x]), np.array([z]))[0]
        pin.framesForwardKinematics(model, data, q)
        np.testing.assert_allclose(data.oMf[foot].translation, [x, 0.0, z], atol=1e-12)
        np.testing.assert_allclose(leg.foot_position(q), [x, z], atol=1e-12)


def test_leg_bench_files_and_contact(bench: dict[str, Any]) -> None:
    folder: Path = bench["folder"]
    for name in ("robot.toml", "leg.urdf", "free.csv", "task.csv", "truth.csv", "truth.urdf"):
        assert (folder / name).is_file()
    truth = bench["truth"]
    fz = np.asarray(truth["fz"])
    contact = fz > 0
    # a third of each cycle in contact (the loop dips below the ground while sin < -1/2)
    assert 0.2 < contact.mean() < 0.4
    assert 10.0 < fz.max() < 40.0
    assert np.all(np.asarray(truth["fy"]) == 0.0)  # the leg's plane is x-z
    # gravity lies in the plane of motion: the hip's axis is horizontal
    doc = tomllib.loads((folder / "robot.toml").read_text())
    assert doc["robot"]["gravity"] == [0.0, 0.0, -9.81]


def _base(result: ArmIdentification, true_arm: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    arm: Any = result.model.robot.arm
    B = arm.base.matrix(arm.nominal_parameters.size)
    nb = B.shape[0]
    truth = B @ np.asarray(true_arm.nominal_parameters)
    sigma = np.sqrt(np.diag(result.covariance))[:nb]
    return result.parameters[:nb], truth, sigma


@pytest.mark.parametrize("which", ["flight", "mixed"])
def test_identified_leg_recovers_mujocos_gravity_and_inertia(
    bench: dict[str, Any], which: str
) -> None:
    """Against the MuJoCo model (truth.urdf, truth.toml): the base parameters (6 for a planar
    two-link arm with gravity in its plane) within 4 sigma; the gravity torque g(q) within 0.5 %
    and the joint-space inertia M(q) + N^2 J_a (rotor inertia included: the hip's rotor and
    the thigh's inertia about the hip are one parameter) within 2 % at 20 random poses, where
    the URDF as given misses both by more than 10 %."""
    result: ArmIdentification = bench[which]
    beta, truth, sigma = _base(result, bench["true_arm"])
    assert beta.size == 6
    assert np.all(np.abs(beta - truth) < 4 * sigma + 1e-9), (beta, truth, sigma)

    doc = tomllib.loads((bench["folder"] / "truth.toml").read_text())
    gear = np.array(leg.LEG.gear)
    rotor_true = gear**2 * np.array([doc["joints"][j]["armature"] for j in leg.LEG.joints])
    rotor_id = gear**2 * np.array([result.model.joints[j].inertia.constant for j in leg.LEG.joints])
    rotor_urdf = np.zeros(2)
    arm_id: Any = result.model.robot.arm
    arm_urdf: Any = bench["model"].robot.arm
    true_arm: Any = bench["true_arm"]
    rng = np.random.default_rng(1)
    q = np.column_stack([rng.uniform(-1.0, 1.0, 20), rng.uniform(-2.2, -0.2, 20)])
    g_true = true_arm.gravity_torque(q)
    scale_g = np.max(np.abs(g_true), axis=0)

    def inertia(arm: Any, rotor: np.ndarray) -> np.ndarray:
        return np.asarray(arm.mass_matrix(q)) + np.diag(rotor)[None]

    m_true = inertia(true_arm, rotor_true)
    scale_m = np.max(np.abs(m_true), axis=0)
    g_err = np.max(np.abs(arm_id.gravity_torque(q) - g_true), axis=0) / scale_g
    m_err = np.max(np.abs(inertia(arm_id, rotor_id) - m_true), axis=0) / scale_m
    assert np.all(g_err < 0.005), g_err
    assert np.all(m_err < 0.02), m_err
    g_urdf = np.max(np.abs(arm_urdf.gravity_torque(q) - g_true), axis=0) / scale_g
    m_urdf = np.max(np.abs(inertia(arm_urdf, rotor_urdf) - m_true), axis=0) / scale_m
    assert np.all(g_urdf > 0.1) and np.max(m_urdf) > 0.1, (g_urdf, m_urdf)


def test_contact_samples_are_found_and_excluded(bench: dict[str, Any]) -> None:
    result: ArmIdentification = bench["mixed"]
    contact = float(np.mean(np.asarray(bench["truth"]["fz"]) > 0))
    span = [float(log.t[-1] - log.t[0]) for log in (bench["free"], bench["task"])]
    task_share = span[1] / sum(span)  # task.csv's share of the two logs
    # at least every contact sample of task.csv is excluded (plus margins around them)
    assert result.excluded >= 0.9 * contact * task_share * (result.samples + result.excluded)
    assert result.excluded < 0.35 * (result.samples + result.excluded)


@pytest.mark.parametrize("which", ["flight", "mixed"])
def test_estimated_contact_force_tracks_the_truth(bench: dict[str, Any], which: str) -> None:
    """fx, fz in the leg's plane against MuJoCo's, both low-passed at 10 Hz alike: the
    identified model within 1.3x the error with the true bodies (truth.urdf, identified joints)
    and 5x better than the URDF as given."""
    from torquemap.filters import lowpass

    task, truth = bench["task"], bench["truth"]
    t = np.asarray(truth["t"])
    force = np.column_stack([np.asarray(truth[a]) for a in ("fx", "fz")])
    ref = np.column_stack([lowpass(t, force[:, i], cutoff=10.0) for i in range(2)])

    def error(model: Any) -> float:
        est = estimate_arm(model, task, cutoff=10.0)
        assert np.mean(est.flag == 0) > 0.9
        ok = (est.flag == 0) & (t > 1.5) & (t < t[-1] - 0.5)
        got = est.wrench[ok][:, [0, 2]]
        return float(np.sqrt(np.mean(np.sum((got - ref[ok]) ** 2, axis=1))))

    oracle = dataclasses.replace(
        bench[which].model, robot=dataclasses.replace(bench["model"].robot, arm=bench["true_arm"])
    )
    e_id = error(bench[which].model)
    e_urdf = error(bench["model"])
    rms = float(np.sqrt(np.mean(np.sum(ref**2, axis=1))))
    assert e_id < 0.1 * rms, (e_id, rms)
    assert e_id < 1.3 * error(oracle)
    assert e_id < e_urdf / 5.0, (e_id, e_urdf)
