"""The sigma's calibration (stop 34): the coupling torque Eq 7 leaves in a planar arm's answer
(:func:`torquemap.uncertainty.coupling_level`) and the leave-one-pass-out scale of the friction
table's covariance (:func:`torquemap.uncertainty.covariance_scale`).

Checked against a second algorithm (the arm's own rigid-body regressor,
:meth:`torquemap.robots.planar2r.Planar2R.regressor`, less the terms Eq 7 takes), against the
simulator's mass matrix and Coriolis torques, and against closed forms (chi-square coverage of
the scale's upper bound; a Gaussian's 95.4 % within 2 sigma).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.stats import chi2

from torquemap.filters import lowpass
from torquemap.model import InertiaModel, JointModel, Model
from torquemap.robot import robot_from_dict
from torquemap.uncertainty import coupling_level, covariance_scale

GEARS = (80.0, 50.0)
CUTOFF = 2.0


def _robot(kinematics: str = "planar2r") -> object:
    head: dict[str, object] = {"name": "arm", "kinematics": kinematics}
    if kinematics == "planar2r":
        head["link_lengths"] = [0.3, 0.25]
    return robot_from_dict(
        {
            "robot": head,
            "joints": {
                name: {"gear_ratio": g, "torque_constant": 0.1, "encoder_counts_per_rev": 8192}
                for name, g in zip(("a", "b"), GEARS, strict=True)
            },
        }
    )


def _motion() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A smooth two-joint motion: time [s], joint angles, velocities, accelerations (n, 2)."""
    t = np.arange(0.0, 12.0, 1e-3)
    w = np.array([2.1, 3.3])
    amp = np.array([0.8, 1.1])
    phase = np.array([0.0, 0.7])
    arg = t[:, None] * w + phase
    q = amp * np.sin(arg) + np.array([0.2, 1.2])
    qd = amp * w * np.cos(arg)
    qdd = -amp * w**2 * np.sin(arg)
    return t, q, qd, qdd


def _model(robot: object, cos_elbow: float) -> Model:
    joints = {
        "a": JointModel(inertia=InertiaModel(constant=3e-4, cos_elbow=cos_elbow)),
        "b": JointModel(inertia=InertiaModel(constant=2e-4)),
    }
    return Model(robot=robot, joints=joints, notes={})  # type: ignore[arg-type]


def _level(model: Model, motion: tuple[np.ndarray, ...]) -> np.ndarray | None:
    """:func:`coupling_level` of ``model`` on ``motion`` (joint side, from :func:`_motion`)."""
    t, q, qd, qdd = motion
    gears = np.array(GEARS)
    return coupling_level(
        model, t=t, q=q, velocity=qd * gears, acceleration=qdd * gears, cutoff=CUTOFF
    )


def test_coupling_is_the_arms_dynamics_less_what_eq7_takes() -> None:
    # second algorithm: the planar arm's regressor Y (n, 2, 3) times (a1, a2, a3) is M qdd +
    # C qd; Eq 7 takes each joint's own inertia (joint a: a1 + 2 a2 cos q2 on qdd1; joint b:
    # a3 on qdd2), the rest is the coupling, low-passed like the estimate and motor side
    a = (0.9, 0.12, 0.07)
    base = _robot()
    robot = dataclasses.replace(base, arm=base.arm.with_parameters(a))  # type: ignore[attr-defined]
    t, q, qd, qdd = _motion()
    gears = np.array(GEARS)
    y = robot.arm.regressor(q, qd, qdd)
    c = np.cos(q[:, 1])
    own = np.c_[(a[0] + 2.0 * a[1] * c) * qdd[:, 0], a[2] * qdd[:, 1]]
    coupling = y @ np.array(a) - own
    expected = np.abs(lowpass(t, coupling, cutoff=CUTOFF)) / gears
    got = _level(_model(robot, cos_elbow=0.0), (t, q, qd, qdd))
    assert got is not None
    # the same operations in another order: rounding only
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12 * float(np.max(expected)))


def test_coupling_from_the_identified_modulation_matches_the_simulators() -> None:
    # without base parameters, a2 comes from joint a's identified modulation (motor side
    # cos_elbow = 2 a2 / n_a^2) and a3 is taken as 0: the level is the simulator's coupling
    # torque (off-diagonal mass times the other joint's acceleration, plus Coriolis) less the
    # second link's own inertia delta on the other joint's acceleration, exactly
    from torquemap.sim.scara import coriolis_torque, default_bench, dynamics_constants, mass_matrix

    bench = default_bench()
    dc = dynamics_constants(bench)
    t, q, qd, qdd = _motion()
    mass = mass_matrix(bench, q)
    coupling = np.c_[(mass[:, 0, 1] - dc.delta) * qdd[:, 1], (mass[:, 1, 0] - dc.delta) * qdd[:, 0]]
    coupling = coupling + coriolis_torque(bench, q, qd)
    gears = np.array(GEARS)
    got = _level(_model(_robot(), cos_elbow=2.0 * dc.beta / GEARS[0] ** 2), (t, q, qd, qdd))
    assert got is not None
    expected = np.abs(lowpass(t, coupling, cutoff=CUTOFF)) / gears
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12 * float(np.max(expected)))


def test_no_coupling_without_a_planar_arm_or_a_modulation() -> None:
    t, q, qd, qdd = _motion()
    kwargs = {"t": t, "q": q, "velocity": qd, "acceleration": qdd, "cutoff": CUTOFF}
    assert coupling_level(_model(_robot(), cos_elbow=0.0), **kwargs) is None  # type: ignore[arg-type]
    assert coupling_level(_model(_robot("none"), cos_elbow=1e-4), **kwargs) is None  # type: ignore[arg-type]


def _record(errors: np.ndarray, sds: np.ndarray) -> dict[str, object]:
    return {"interpolation": {"errors": errors.tolist(), "sigmas": sds.tolist()}}


@pytest.mark.parametrize("true_scale", [0.05, 0.3])
def test_the_scales_upper_bound_covers_95_percent(true_scale: float) -> None:
    # left-out errors drawn with sd true_scale * sigma: n mean(z^2) / true_scale^2 is chi-square
    # with n degrees, so the one-sided 95 % upper bound lies above true_scale^2 in 95 % of draws
    rng = np.random.default_rng(7)
    n, trials = 8, 4000
    covered = 0
    for _ in range(trials):
        sds = rng.uniform(0.5e-3, 3e-3, n)
        errors = true_scale * sds * rng.standard_normal(n)
        covered += covariance_scale(_record(errors, sds)) >= true_scale**2
    # binomial sd of the share over 4000 draws: sqrt(0.95 * 0.05 / 4000) = 0.0034; 4 of them
    assert abs(covered / trials - 0.95) < 4 * math.sqrt(0.95 * 0.05 / trials)


def test_a_sigma_scaled_by_the_left_out_ratio_covers_95_percent() -> None:
    # a sigma 10x too wide, calibrated by the mean z^2 of many left-out errors, holds 95.4 %
    # of fresh errors within 2 sigma (a Gaussian's share)
    rng = np.random.default_rng(11)
    sds = rng.uniform(1e-3, 4e-3, 4000)
    errors = 0.1 * sds * rng.standard_normal(sds.size)
    ratio = covariance_scale(_record(errors, sds), bound=False)
    np.testing.assert_allclose(ratio, 0.01, rtol=0.05)  # sd of mean z^2 over 4000: 2.2 %
    fresh = 0.1 * sds * rng.standard_normal(sds.size)
    share = float(np.mean(np.abs(fresh) <= 2.0 * math.sqrt(ratio) * sds))
    # 95.45 % in closed form; binomial sd over 4000 samples 0.33 %
    assert abs(share - 0.9545) < 0.015


def test_the_scale_never_widens_and_needs_two_passes() -> None:
    sds = np.full(6, 1e-3)
    assert covariance_scale(_record(5.0 * sds, sds)) == 1.0
    assert covariance_scale(_record(sds[:1], sds[:1])) == 1.0
    assert covariance_scale({}) == 1.0
    # the bound: n mean(z^2) / chi2_0.05(n)
    errors = 0.1 * sds
    bound = covariance_scale(_record(errors, sds))
    np.testing.assert_allclose(bound, 6 * 0.01 / chi2.ppf(0.05, 6), rtol=1e-12)
