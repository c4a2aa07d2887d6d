"""New-user QA of arms, stop 38 (Q45; docs/arm.md "New-user QA, stop 38").

A two-link arm simulated here by inverse dynamics (the URDF's links, gears, rotor inertia,
friction, white current noise) under an end-effector force that is made and broken as a
contact would be: the estimate is the force through its low-pass, and the sigmas must hold the
part the filter removed, against the true (unfiltered) force.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import torquemap.estimate_arm as estimate_arm_module
from torquemap.arm_fast import fast_torque_variance
from torquemap.estimate_arm import estimate_arm
from torquemap.excite import exciting_trajectory
from torquemap.filters import lowpass
from torquemap.friction_law import StribeckFriction
from torquemap.identify_arm import identify_arm
from torquemap.io import Log
from torquemap.model import InertiaModel, JointModel, Model
from torquemap.robot import Joint, Robot
from torquemap.robots.urdf import UrdfArm, urdf_arm

pytestmark = pytest.mark.xdist_group("arm_qa38")

TWO_LINK = Path(__file__).parent / "data" / "arm" / "two_link.urdf"
KT = 0.1
NOISE = 0.02  # [A] current noise, white per sample
GEAR = (1.0, 1.0)  # a direct drive


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
