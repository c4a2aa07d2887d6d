"""Estimating a direction the identification logs never moved in: warned, with its cost."""

from __future__ import annotations

import numpy as np

import torquemap

ROBOT = {
    "robot": {"name": "one motor", "kinematics": "none"},
    "joints": {"m": {"gear_ratio": 1.0, "torque_constant": 0.1, "encoder_counts_per_rev": 8000}},
}


def _log(robot: torquemap.Robot, speeds: tuple[float, ...], seed: int) -> torquemap.Log:
    # Coulomb friction 0.03 N m forward, 0.05 N m backward (an asymmetric seal), viscous
    # 0.0005 N m s/rad, a 2 CPR cogging line, 0.1 A (10 mN m) current noise at 1 kHz
    rng = np.random.default_rng(seed)
    parts, start = [], 0.0
    for v in speeds:
        t = np.arange(0.0, 3 * 2 * np.pi / abs(v), 1e-3)
        parts.append(start + v * t)
        start = parts[-1][-1]
    theta = np.concatenate(parts)
    vel = np.gradient(theta) * 1e3
    dry = np.where(vel > 0, 0.03, -0.05)
    torque = dry + 0.0005 * vel + 0.004 * np.cos(2 * theta + 0.3)
    current = torque / 0.1 + rng.normal(0.0, 0.01, theta.size)
    counts = np.floor(theta / (2 * np.pi / 8000)) * (2 * np.pi / 8000)
    t = np.arange(theta.size) * 1e-3
    return torquemap.log_from_columns({"t": t, "q_m": counts, "i_m": current}, robot)


def test_a_direction_never_identified_is_warned_when_estimated() -> None:
    robot = torquemap.robot_from_dict(ROBOT)
    model = torquemap.identify(robot, _log(robot, (1.0, 2.0, 4.0), seed=0)).model
    assert any("never moved in the negative direction" in w for w in model.notes["warnings"])
    forward = torquemap.estimate(model, _log(robot, (2.0,), seed=1))
    backward = torquemap.estimate(model, _log(robot, (-2.0,), seed=2))
    said = "of the samples move in the negative direction, which the identification logs never"
    assert not any(said in w for w in forward.warnings)
    (line,) = [w for w in backward.warnings if said in w]
    assert line.startswith("joint m: 100% of the samples")
    # no load on either log: forward the estimate is ~0; backward it is the friction the
    # model copied from the forward direction, 0.03 instead of 0.05 N m: 0.02 N m off, while
    # every sample is called sound -- what the warning is for
    sound_f, sound_b = forward.flag == 0, backward.flag == 0
    assert abs(float(np.mean(forward.tau_ext[sound_f, 0]))) < 0.002
    assert abs(abs(float(np.mean(backward.tau_ext[sound_b, 0]))) - 0.02) < 0.002
