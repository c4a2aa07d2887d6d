"""New-user QA of arms, stop 38 (Q45; docs/arm.md "New-user QA, stop 38").

A two-link arm simulated here by inverse dynamics (the URDF's links, gears, rotor inertia,
friction, white current noise) under an end-effector force that is made and broken as a
contact would be: the estimate is the force through its low-pass, and the sigmas must hold the
part the filter removed, against the true (unfiltered) force.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_arm_qa37 import KT, NOISE, TWO_LINK, _arm, _law  # the same two-link arm and law

import torquemap.estimate_arm as estimate_arm_module
from torquemap.arm_fast import fast_torque_variance
from torquemap.estimate_arm import estimate_arm
from torquemap.excite import exciting_trajectory
from torquemap.filters import lowpass
from torquemap.identify_arm import identify_arm
from torquemap.io import Log
from torquemap.model import InertiaModel, JointModel, Model
from torquemap.robot import Joint, Robot
from torquemap.robots.urdf import UrdfArm, urdf_arm

pytestmark = pytest.mark.xdist_group("arm_qa38")

GEAR = (1.0, 1.0)  # a direct drive


def _robot(arm: UrdfArm) -> Robot:
    joints = tuple(
        Joint(name=n, gear_ratio=g, torque_constant=KT)
        for n, g in zip(arm.joint_names, GEAR, strict=True)
    )
    return Robot(name="two-link", kinematics="urdf", link_lengths=(), joints=joints, arm=arm)


def _force(t: np.ndarray, kind: str) -> np.ndarray:
    """The end-effector force [N], shape (n, 3): none, a slow smooth one, or a contact made
    and broken every 1.5 s (20 ms edges) whose friction chatters at 6 Hz while it holds."""
    F = np.zeros((t.size, 3))
    if kind == "smooth":
        F[:, 0] = 4.0 + 2.0 * np.sin(0.5 * t)
        F[:, 1] = -3.0 + np.cos(0.3 * t)
    elif kind == "contact":
        phase = np.mod(t, 3.0)
        on = np.clip(phase / 0.02, 0.0, 1.0) * np.clip((1.5 - phase) / 0.02, 0.0, 1.0)
        F[:, 1] = -5.0 * on
        F[:, 0] = on * (1.5 + 0.5 * np.sin(2.0 * np.pi * 6.0 * t))
    return F


def _simulate(arm: UrdfArm, seed: int, kind: str) -> tuple[Log, np.ndarray]:
    """A log at 1 kHz and the true external joint torque [N m]."""
    traj = exciting_trajectory(arm, duration=20.0, period=10.0, rate=1000.0, iterations=6, rng=seed)
    t, q, qd, qdd = traj.t, traj.q, traj.qd, traj.qdd
    rng = np.random.default_rng(seed)
    tau_ext = np.einsum("nij,ni->nj", arm.jacobian(q), _force(t, kind))
    rigid = arm.inverse_dynamics(q, qd, qdd)
    tau_m = np.empty_like(q)
    for k in range(2):
        n = GEAR[k]
        exact = (
            (rigid[:, k] - tau_ext[:, k]) / n
            + 2e-5 * n * qdd[:, k]
            + _law(0.01).torque(n * qd[:, k])
        )
        tau_m[:, k] = exact + KT * NOISE * rng.standard_normal(t.size)
    return Log(t=t, q=q, motor_torque=tau_m, joint_names=arm.joint_names, path="sim.csv"), tau_ext


@pytest.fixture(scope="module")
def direct_drive() -> Model:
    """``identify_arm`` of the direct drive from a zero start over a free log."""
    arm = _arm()
    free, _ = _simulate(arm, 11, "none")
    start = Model(
        robot=_robot(arm),
        joints={n: JointModel(inertia=InertiaModel(constant=0.0), friction=_law(0.0), pdtv=())
                for n in arm.joint_names},
    )  # fmt: skip
    return identify_arm(start, [free], max_samples=3000, pdtv_max_order=0).model


def _shares(model: Model, kind: str) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """Per joint, the share of the errors against the true and against the low-passed true
    external torque within 2 sigma, and the estimate's warnings."""
    task, tau_ext = _simulate(_arm(), 12, kind)
    est = estimate_arm(model, task)
    inner = (task.t > 1.0) & (task.t < task.t[-1] - 1.0) & (est.flag == 0)
    smooth = np.column_stack([lowpass(task.t, tau_ext[:, k], cutoff=est.cutoff) for k in range(2)])
    s = est.tau_ext_sigma[inner]
    true = np.mean(np.abs(est.tau_ext[inner] - tau_ext[inner]) <= 2.0 * s, axis=0)
    filtered = np.mean(np.abs(est.tau_ext[inner] - smooth[inner]) <= 2.0 * s, axis=0)
    return true, filtered, est.warnings


def test_a_contact_made_and_broken_is_within_the_sigmas(direct_drive: Model) -> None:
    """A contact made and broken on a direct drive: against the true force, the share of the
    errors within 2 sigma was 31 / 32 % (the sigmas held the noise and parameters, 0.002 N m,
    while the low-pass removes up to half the 5 N step at each edge); now 90-99.5 % (98-99 %),
    with a warning naming both joints."""
    true, _, warnings = _shares(direct_drive, "contact")
    assert np.all(true >= 0.9) and np.all(true <= 0.995), true
    said = [w for w in warnings if "change faster than the 2 Hz cut-off" in w]
    assert len(said) == 1 and "shoulder" in said[0] and "elbow" in said[0], warnings


def test_a_slow_force_on_a_fast_motion_is_covered(direct_drive: Model) -> None:
    """A slow force on a fast motion (``J(q)^T F`` follows the motion above the cut-off): 92 /
    89 % of the errors were within 2 sigma, now all of them (the term is the removed part's
    local mean square, which an oscillation never leaves: loose, not wrong), with no warning:
    the removed part stays below the model's uncertainty over the log."""
    true, filtered, warnings = _shares(direct_drive, "smooth")
    assert np.all(true > 0.95), true
    assert np.all(filtered > 0.95), filtered
    assert not any("cut-off follows" in w for w in warnings), warnings


def test_no_force_keeps_its_sigmas(direct_drive: Model, monkeypatch: pytest.MonkeyPatch) -> None:
    """No external force: the unfiltered estimate holds the noise only, the term stays
    (nearly) out: 99.0 / 99.6 % within 2 sigma against 98.4 / 99.6 % without it, and no
    warning."""
    true, _, warnings = _shares(direct_drive, "none")
    assert not any("cut-off follows" in w for w in warnings), warnings
    monkeypatch.setattr(estimate_arm_module, "fast_torque_variance", _nothing)
    without, _, _ = _shares(direct_drive, "none")
    assert np.all(without > 0.95), without
    assert np.all(true - without < 0.01), (true, without)


def _nothing(t: np.ndarray, unfiltered: np.ndarray, *_: object) -> np.ndarray:
    return np.zeros_like(unfiltered)


def test_the_fast_term_is_what_the_filter_removed() -> None:
    """A 5 Hz swing of 0.1 N m on top of white noise of 0.01 N m at 1 kHz, a 2 Hz cut-off: the
    term holds the removed swing's mean square (0.005 N^2 m^2, the swing passes the
    Butterworth at -21 dB) where the swing is on, and nothing where only the noise is."""
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 20.0, 1e-3)
    swing = np.where((t > 8.0) & (t < 12.0), 0.1 * np.sin(2.0 * np.pi * 5.0 * t), 0.0)
    unfiltered = (swing + 0.01 * rng.standard_normal(t.size))[:, None]
    reported = lowpass(t, unfiltered, cutoff=2.0)
    removed = unfiltered - reported
    floor = np.array([float(np.var(removed[t < 6.0]))])
    var = fast_torque_variance(t, unfiltered, reported, 2.0, floor)[:, 0]
    on = (t > 9.0) & (t < 11.0)
    assert np.median(var[on]) == pytest.approx(0.005, rel=0.1)
    off = (t < 6.0) | (t > 14.0)
    assert np.mean(var[off] > 0) < 0.01


# --- the misfit's cause: the log's noise, or a robot file at odds (torquemap.arm_misfit) ---

NOISY_GEAR = (60.0, 40.0)


def _geared_free(arm_truth: UrdfArm, noise: float, oscillation: float = 0.0) -> Log:
    """A free log of the geared two-link arm at 1 kHz: white current noise ``noise`` [A], and
    a 35 Hz oscillation of ``oscillation`` [N m] in the elbow's motor torque (a controller
    ringing)."""
    traj = exciting_trajectory(
        arm_truth, duration=20.0, period=10.0, rate=1000.0, iterations=6, rng=1
    )
    t, q, qd, qdd = traj.t, traj.q, traj.qd, traj.qdd
    rng = np.random.default_rng(1)
    rigid = arm_truth.inverse_dynamics(q, qd, qdd)
    tau_m = np.empty_like(q)
    for k, coulomb in enumerate((0.03, 0.02)):
        n = NOISY_GEAR[k]
        exact = rigid[:, k] / n + 2e-5 * n * qdd[:, k] + _law(coulomb).torque(n * qd[:, k])
        tau_m[:, k] = exact + KT * noise * rng.standard_normal(t.size)
    tau_m[:, 1] += oscillation * np.sin(2.0 * np.pi * 35.0 * t)
    return Log(t=t, q=q, motor_torque=tau_m, joint_names=arm_truth.joint_names, path="sim.csv")


def _identify_geared(arm: UrdfArm, free: Log) -> tuple[str, ...]:
    joints = tuple(
        Joint(name=n, gear_ratio=g, torque_constant=KT)
        for n, g in zip(arm.joint_names, NOISY_GEAR, strict=True)
    )
    start = Model(
        robot=Robot(name="two-link", kinematics="urdf", link_lengths=(), joints=joints, arm=arm),
        joints={n: JointModel(inertia=InertiaModel(constant=0.0), friction=_law(0.0), pdtv=())
                for n in arm.joint_names},
    )  # fmt: skip
    return identify_arm(start, [free], max_samples=3000, pdtv_max_order=0).warnings


def test_a_misfit_of_noise_names_the_noise_not_the_robot_file() -> None:
    """35 times the current noise (0.7 A): the elbow's model explains 86 % of its torque, the
    rest white noise. Before: "explains only 86 % ...; check the robot file's gravity, gear
    ratios and torque constants" (as on a UR3 bench with 0.2 A, which estimate repeated); now
    the warning names the noise and what to record, and estimate does not repeat it."""
    arm = _arm()
    warnings = _identify_geared(arm, _geared_free(arm, 0.7))
    elbow = [w for w in warnings if w.startswith("joint elbow: the identified model explains")]
    assert len(elbow) == 1, warnings
    assert "the log's torque noise" in elbow[0] and "robot file's gravity" not in elbow[0]
    assert "not the robot file" in elbow[0] and "torquemap excite" in elbow[0]


@pytest.mark.parametrize("case", ["wall", "ringing"])
def test_a_misfit_that_is_not_noise_still_blames_the_robot_file(case: str) -> None:
    """A robot file whose gravity is perpendicular to the arm's plane (the arm on a wall; 39 /
    59 % explained: the residual is far above the noise), or a controller ringing at 35 Hz in
    the elbow's torque (as the Solo leg's bench; 52 % explained, and the residual is within the
    high band's level, so that only the high band's whiteness tells it from noise): the
    warning stands as before."""
    arm = _arm()
    if case == "wall":
        free = _geared_free(arm, 0.02)
        model_arm = urdf_arm(
            TWO_LINK, ["shoulder", "elbow"], end_effector="tool", gravity=(0, 0, -9.81)
        )
    else:
        free = _geared_free(arm, 0.02, oscillation=3.0)
        model_arm = arm
    warnings = _identify_geared(model_arm, free)
    blamed = [w for w in warnings if "explains only" in w and "robot file's gravity" in w]
    assert blamed, warnings
    assert not any("the log's torque noise" in w for w in warnings), warnings
