"""New-user QA of arms, stop 38 (Q46; docs/arm.md "New-user QA, stop 38 (Q46)").

A Coulomb level the logs never reach: a two-link arm simulated here by inverse dynamics (the
URDF's links, rotor inertia, a friction law of the test's own, white current noise). Where the
identified Stribeck velocity lies above the speeds the joint reaches, the fit may split the
friction into a large negative Coulomb level and a Stribeck level of the opposite sign whose
curve over the speeds reached is right; that was refused as "friction negative in both
directions: check the robot file's gravity...". The references are the simulated friction
laws, which the estimators never read.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_arm_qa37 import KT, TWO_LINK  # the same two-link arm
from test_arm_qa37 import _law as _stribeck_law

from torquemap.arm_coarse import coarse_angle_note
from torquemap.arm_stribeck import refit_without_stribeck
from torquemap.errors import InputError
from torquemap.excite import exciting_trajectory
from torquemap.friction_law import StribeckFriction, coulomb_levels_valid
from torquemap.identify_arm import ArmIdentification, identify_arm
from torquemap.io import Log
from torquemap.model import InertiaModel, JointModel, Model
from torquemap.robot import Joint, Robot
from torquemap.robots.urdf import UrdfArm, urdf_arm

pytestmark = pytest.mark.xdist_group("arm_qa38b")

BEYOND = "lies beyond the speeds the logs reach"


def _bench_friction(w: np.ndarray, coulomb: float, stribeck: float) -> np.ndarray:
    """The MuJoCo arm bench's law (torquemap.sim.arm.friction), written out: a tanh of width
    1.5 rad/s and a Stribeck term decaying over 3 rad/s [N m at motor speeds w, rad/s]."""
    out: np.ndarray = (coulomb + stribeck * np.exp(-np.abs(w) / 3.0)) * np.tanh(w / 1.5) + 4e-5 * w
    return out


def _free(
    arm: UrdfArm, gear: tuple[float, float], friction: list, noise: float, seed: int
) -> tuple[Log, np.ndarray]:
    """A free log at 1 kHz (white current noise ``noise`` [A]) and the motor speeds [rad/s];
    ``friction[k](w)`` is joint k's true motor-side friction [N m]."""
    traj = exciting_trajectory(arm, duration=20.0, period=10.0, rate=1000.0, iterations=6, rng=seed)
    t, q, qd, qdd = traj.t, traj.q, traj.qd, traj.qdd
    rng = np.random.default_rng(seed)
    rigid = arm.inverse_dynamics(q, qd, qdd)
    tau_m = np.empty_like(q)
    for k, n in enumerate(gear):
        exact = rigid[:, k] / n + 2e-5 * n * qdd[:, k] + friction[k](n * qd[:, k])
        tau_m[:, k] = exact + KT * noise * rng.standard_normal(t.size)
    log = Log(t=t, q=q, motor_torque=tau_m, joint_names=arm.joint_names, path="sim.csv")
    return log, qd * np.asarray(gear)


def _identified(arm: UrdfArm, gear: tuple[float, float], free: Log) -> ArmIdentification:
    joints = tuple(
        Joint(name=n, gear_ratio=g, torque_constant=KT)
        for n, g in zip(arm.joint_names, gear, strict=True)
    )
    start = Model(
        robot=Robot(name="two-link", kinematics="urdf", link_lengths=(), joints=joints, arm=arm),
        joints={n: JointModel(inertia=InertiaModel(constant=0.0), friction=_stribeck_law(0.0),
                              pdtv=()) for n in arm.joint_names},
    )  # fmt: skip
    return identify_arm(start, [free], max_samples=3000, pdtv_max_order=0)


def _curve_error(law: object, truth: object, speeds: np.ndarray) -> float:
    """RMS of the identified law's friction against the true one over the motor speeds the
    log holds (5th to 95th percentile of |w|, both directions), over the true one's RMS."""
    lo, hi = np.percentile(np.abs(speeds), [5, 95])
    w = np.concatenate([-np.linspace(lo, hi, 50), np.linspace(lo, hi, 50)])
    got = np.asarray(law.torque(w))  # type: ignore[attr-defined]
    want = np.asarray(truth(w))  # type: ignore[operator]
    return float(np.sqrt(np.mean((got - want) ** 2)) / np.sqrt(np.mean(want**2)))


def test_a_direct_drive_whose_stribeck_term_outlasts_the_motion_is_kept() -> None:
    """A direct drive in a horizontal plane (no gravity torque) with the MuJoCo bench's
    smooth friction: motor speeds up to 2.4 rad/s, the fitted Stribeck velocity above them.
    Before: refused ("the identified friction is negative in both directions (Coulomb -0.0506,
    -0.0518 N m) ... check the robot file's gravity"), as a UR3 at gear 1 was on its wrist_3.
    Now kept, warned, and the elbow's friction over the speeds reached is the simulated one."""
    arm = urdf_arm(TWO_LINK, ["shoulder", "elbow"], end_effector="tool", gravity=(0, 0, -9.81))
    truth = [lambda w: _bench_friction(w, 0.01, 0.004), lambda w: _bench_friction(w, 0.008, 0.003)]
    free, speeds = _free(arm, (1.0, 1.0), truth, 0.02, seed=2)
    result = _identified(arm, (1.0, 1.0), free)
    said = [w for w in result.warnings if w.startswith("joint elbow:") and BEYOND in w]
    assert len(said) == 1, result.warnings
    assert "refitted with no Stribeck term" in said[0] and "torquemap excite" in said[0]
    law = result.model.joints["elbow"].friction
    assert coulomb_levels_valid(law.coulomb_positive, law.coulomb_negative)  # type: ignore[attr-defined]
    assert _curve_error(law, truth[1], speeds[:, 1]) < 0.15  # 0.063 measured


def test_current_noise_on_a_geared_joint_is_kept() -> None:
    """Gears 60 / 40, the test's Stribeck law, 1 A of white current noise: the elbow's Coulomb
    level was fitted at -0.27 N m against a Stribeck level of +0.30 N m at 166 rad/s (motor
    speeds up to 84 rad/s) and refused. Now kept with no Stribeck term, its Coulomb level
    within 30 % of the simulated 0.02 N m."""
    arm = urdf_arm(TWO_LINK, ["shoulder", "elbow"], end_effector="tool", gravity=(0, -9.81, 0))
    laws = [_stribeck_law(0.03), _stribeck_law(0.02)]
    free, speeds = _free(arm, (60.0, 40.0), [law.torque for law in laws], 1.0, seed=1)
    result = _identified(arm, (60.0, 40.0), free)
    said = [w for w in result.warnings if w.startswith("joint elbow:") and BEYOND in w]
    assert len(said) == 1, result.warnings
    law = result.model.joints["elbow"].friction
    assert isinstance(law, StribeckFriction)
    for level in (law.coulomb_positive, law.coulomb_negative):
        assert abs(level - 0.02) < 0.3 * 0.02, law
    assert _curve_error(law, laws[1].torque, speeds[:, 1]) < 0.15  # 0.057 measured


def test_a_friction_that_injects_energy_is_still_refused() -> None:
    """The same direct drive, its elbow's true friction negative (-0.03 N m both ways: the
    currents of a robot file at odds with the log): refused as before."""
    arm = urdf_arm(TWO_LINK, ["shoulder", "elbow"], end_effector="tool", gravity=(0, 0, -9.81))
    truth = [lambda w: _bench_friction(w, 0.01, 0.004), lambda w: _bench_friction(w, -0.03, 0.0)]
    free, _ = _free(arm, (1.0, 1.0), truth, 0.02, seed=2)
    with pytest.raises(InputError, match="negative in both directions"):
        _identified(arm, (1.0, 1.0), free)


# --- the cause named when the angles are too coarse or read too small (torquemap.arm_coarse) ---


def _robot(arm: UrdfArm, gear: tuple[float, float], unit: str = "rad") -> Robot:
    joints = tuple(
        Joint(
            name=n,
            gear_ratio=g,
            torque_constant=KT,
            encoder_counts_per_rev=4096 if unit == "counts" else None,
            position_unit=unit,  # type: ignore[arg-type]
        )
        for n, g in zip(arm.joint_names, gear, strict=True)
    )
    return Robot(name="two-link", kinematics="urdf", link_lengths=(), joints=joints, arm=arm)


def test_an_output_encoders_step_is_named_at_the_motor() -> None:
    """Angles from a servo's output encoder (4096 counts per joint turn) at gear 345 step by
    345 x 2 pi / 4096 = 0.529 rad at the motor, which the clause names; the same motion from a
    16384-count motor encoder is not named."""
    arm = urdf_arm(TWO_LINK, ["shoulder", "elbow"], end_effector="tool", gravity=(0, -9.81, 0))
    gear = (345.0, 345.0)
    traj = exciting_trajectory(arm, duration=20.0, period=10.0, rate=1000.0, iterations=6, rng=1)
    speeds = [gear[k] * traj.qd[:, k] for k in range(2)]
    robot = _robot(arm, gear)
    for counts, at_motor, named in ((4096, False, True), (16384, True, False)):
        step = 2 * np.pi / counts / (gear[0] if at_motor else 1.0)
        q = np.floor(traj.q / step) * step
        log = Log(t=traj.t, q=q, motor_torque=np.zeros_like(q), joint_names=arm.joint_names)
        note = coarse_angle_note(robot, [log], speeds, 0.05)
        assert (note is not None) == named, note
        if note is not None:
            assert "0.529 rad at the motor" in note and "2 pi / 4096 of the joint" in note
            assert "log the motor's encoder" in note


def test_output_counts_read_as_motor_counts_are_named() -> None:
    """A servo's output counts read as motor counts: every joint spans 1/400 of its motion (a harmonic drive's servo) and
    the refusal "only jitters about a held pose" now names the likely cause; one joint held
    still (a brake) is refused as before, without it."""
    arm = urdf_arm(TWO_LINK, ["shoulder", "elbow"], end_effector="tool", gravity=(0, -9.81, 0))
    gear = (400.0, 400.0)
    traj = exciting_trajectory(arm, duration=20.0, period=10.0, rate=1000.0, iterations=6, rng=1)
    start = Model(
        robot=_robot(arm, gear, "counts"),
        joints={n: JointModel(inertia=InertiaModel(constant=0.0), friction=_stribeck_law(0.0),
                              pdtv=()) for n in arm.joint_names},
    )  # fmt: skip
    torque = np.ones_like(traj.q)
    read_small = Log(t=traj.t, q=traj.q / 400.0, motor_torque=torque, joint_names=arm.joint_names)
    with pytest.raises(InputError, match="only jitters") as err:
        identify_arm(start, [read_small], max_samples=3000, pdtv_max_order=0)
    assert "encoder on the joint's output" in str(err.value), err.value
    assert "400 times too small" in str(err.value)
    held = traj.q.copy()
    held[:, 1] = 0.3 + 0.002 * np.sin(traj.t)
    one_held = Log(t=traj.t, q=held, motor_torque=torque, joint_names=arm.joint_names)
    with pytest.raises(InputError, match="only jitters") as err:
        identify_arm(start, [one_held], max_samples=3000, pdtv_max_order=0)
    assert "encoder on the joint's output" not in str(err.value), err.value


def test_the_refits_band_sigma_is_its_spread_over_noise_draws() -> None:
    """The refit with no Stribeck term on a law whose Stribeck velocity (50 rad/s) lies above
    the speeds (up to 10 rad/s): the Coulomb levels come back (0.02, 0.03 N m), and the band's
    sigma is the spread of the band over 200 draws of the noise (a second method)."""
    law = dataclasses.replace(_stribeck_law(0.0), stribeck_velocity=50.0)
    rng = np.random.default_rng(3)
    w = 10.0 * np.sin(np.linspace(0.0, 20.0 * np.pi, 2000))
    block = np.column_stack([rng.standard_normal(w.size), law.basis(w)])
    exact = (
        law.with_linear_parameters(np.array([0.02, 0.03, 1e-3, 0.0, 0.0])).torque(w)
        + 1e-4 * block[:, 0]
    )
    noise = 0.005
    bands = []
    for _ in range(200):
        refit = refit_without_stribeck(
            law, block, exact + noise * rng.standard_normal(w.size), w, noise**2
        )
        assert refit is not None and refit.remaining > 0.9
        bands.append(refit.band)
    assert abs(np.mean(bands) - 0.05) < 3 * refit.band_sigma / np.sqrt(200)
    assert 0.85 < np.std(bands) / refit.band_sigma < 1.15  # 0.99 measured
    assert refit.parameters[4] == 0.0 and refit.parameters[5] == 0.0  # no Stribeck term
