"""Whole-log identification (issue 12) on a 1-DoF motor simulated here from a known law."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.errors import InputError
from torquemap.estimate import estimate_forces
from torquemap.friction_law import StribeckFriction
from torquemap.identify import identify_model
from torquemap.io import Log
from torquemap.model import PdtvLine, pdtv_torque
from torquemap.robot import robot_from_dict

LAW = StribeckFriction(
    coulomb_positive=0.05,
    coulomb_negative=0.06,
    viscous=0.004,
    stribeck_positive=0.02,
    stribeck_negative=0.015,
    stribeck_velocity=0.8,
    zero_velocity=0.05,
    transition="smooth",
)
LINES = (
    PdtvLine(order=2.0, amplitude=0.02, phase=0.3),
    PdtvLine(order=7.0, amplitude=0.01, phase=-1),
)
J = 2e-4


def robot(gear: float = 1.0, counts: int = 8000) -> object:
    return robot_from_dict(
        {
            "robot": {"name": "motor", "kinematics": "none"},
            "joints": {
                "m": {"gear_ratio": gear, "torque_constant": 0.1, "encoder_counts_per_rev": counts}
            },
        }
    )


def simulate(
    *,
    delay: float = 0.0,
    gravity: float = 0.0,
    gear: float = 1.0,
    counts: int = 8000,
    seed: int = 3,
    law: object = LAW,
) -> Log:
    """Passes at 0.5-8 rad/s both ways with raised-cosine ramps through rest; the torque read
    ``delay`` late; ``gravity`` [N m, motor side] times cos of the joint angle."""
    rng = np.random.default_rng(seed)
    rate, ramp = 1000.0, 0.4
    h = 1.0 / rate
    vel = [np.zeros(200)]
    for v in (0.5, 2.0, 8.0):
        for s in (1, -1):
            tr = np.arange(0.0, ramp, h)
            up = 0.5 * (1 - np.cos(np.pi * tr / ramp)) * v * s
            hold = np.full(int(2.5 * 2 * np.pi / v * rate), v * s)
            vel += [up, hold, up[::-1], np.zeros(150)]
    w = np.concatenate(vel)
    t = np.arange(w.size) * h
    acc = np.gradient(w, h)
    theta = np.concatenate(([0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * h)))
    tau = J * acc + law.torque(w) + pdtv_torque(theta, LINES)  # type: ignore[attr-defined]
    tau += gravity * np.cos(theta / gear)
    tau = np.interp(t - delay, t, tau) + rng.normal(0.0, 0.005, t.size)
    q = np.round(theta * counts / (2 * np.pi)) * (2 * np.pi / counts) / gear
    return Log(t=t, q=q[:, None], motor_torque=tau[:, None], joint_names=("m",), path="m.csv")


@pytest.fixture(scope="module")
def delayed() -> object:
    return identify_model(robot(), [simulate(delay=0.02)], max_order=20, friction="whole")  # type: ignore[arg-type]


def test_recovers_the_law_through_zero_and_the_delay(delayed) -> None:  # type: ignore[no-untyped-def]
    m = delayed.model.joints["m"]
    f = m.friction
    assert f.transition == "smooth"
    # one viscous slope: the directions do not differ
    assert isinstance(f, StribeckFriction)
    # 10^4 samples per pass of 5 mN m noise: the linear terms within 2 %, the Stribeck
    # velocity (searched outside the linear fit) within 10 %, the inertia within 5 %
    assert_allclose([f.coulomb_positive, f.coulomb_negative], [0.05, 0.06], rtol=0.02)
    assert_allclose(f.viscous, 0.004, rtol=0.02)
    assert_allclose([f.stribeck_positive, f.stribeck_negative], [0.02, 0.015], rtol=0.1)
    assert_allclose(f.stribeck_velocity, 0.8, rtol=0.1)
    assert_allclose(m.inertia.constant, J, rtol=0.05)
    # the 20 ms delay, searched outside the fit (grid and parabola): within 2 ms
    assert abs(delayed.model.notes["joints"]["m"]["channel_delay"] - 0.02) < 2e-3
    got = {ln.order: ln.amplitude for ln in m.pdtv}
    assert_allclose([got[2.0], got[7.0]], [0.02, 0.01], rtol=0.05)


def test_covariance_and_noise_recorded(delayed) -> None:  # type: ignore[no-untyped-def]
    u = delayed.model.notes["joints"]["m"]["uncertainty"]
    cov = np.array(u["covariance"])
    assert cov.shape == (len(u["parameters"]),) * 2
    assert "friction.coulomb_positive" in u["parameters"]
    # white noise of 5 mN m at 1 kHz: PSD 2 * 0.005^2 / 1000 = 5e-8 N^2 m^2 / Hz (one-sided)
    assert 2e-8 < u["residual_psd"] < 2e-7


def test_a_vertical_arm_is_refused() -> None:
    # gravity on the joint (gear 10, 90 degrees of joint travel): cos of the JOINT angle, which no PDTV line of the motor
    # angle explains; as large as the Coulomb friction here
    log = simulate(gravity=0.06, gear=10.0)
    with pytest.raises(InputError, match="vertical arm"):
        identify_model(robot(gear=10.0), [log], max_order=20, friction="whole")  # type: ignore[arg-type]
    res = identify_model(robot(gear=10.0), [simulate(gear=10.0)], max_order=20, friction="whole")  # type: ignore[arg-type]
    assert not any("vertical" in w for w in res.warnings)


def test_a_log_from_another_robot_is_refused(delayed) -> None:  # type: ignore[no-untyped-def]
    other = simulate(counts=4096)
    with pytest.raises(InputError, match="another robot"):
        estimate_forces(delayed.model, other)
    same = simulate(seed=4)
    assert estimate_forces(delayed.model, same).tau_ext.shape == (same.t.size, 1)


@pytest.mark.parametrize("jitter", [0.0, 0.3])
def test_row_smoother_matches_the_full_smoothing(jitter: float) -> None:
    # the search's smoothing at a subset of rows against filters.smooth_as_acceleration on
    # every sample (a second implementation: savgol on a uniform grid, normal equations else)
    from torquemap.filters import smooth_as_acceleration
    from torquemap.identify_whole import RowSmoother

    rng = np.random.default_rng(1)
    h = 1.0 / 900.0
    t = np.cumsum(h * (1.0 + jitter * rng.uniform(-1.0, 1.0, 6000)))
    x = np.c_[np.tanh(20.0 * np.sin(3.0 * t)), rng.normal(size=t.size), 5.0 + t]
    rows = np.arange(0, t.size, 7)
    full = smooth_as_acceleration(t, x, window=0.05)[rows]
    assert_allclose(RowSmoother.build(t, rows, 0.05)(x), full, atol=1e-7)


def test_an_ambiguous_delay_is_reported() -> None:
    from torquemap.identify_whole import delay_profile

    # two equally deep minima, at -0.1 and +0.1 s: both are candidates
    def cost(d: float) -> float:
        return 100.0 + 1e5 * min((d - 0.1) ** 2, (d + 0.1) ** 2)

    p = delay_profile(cost, 0.25, dof=100.0)
    assert len(p.candidates) == 2
    assert sorted(round(c, 2) for c in p.candidates) == [-0.1, 0.1]


def test_a_viscous_slope_per_direction() -> None:
    import dataclasses

    from torquemap.friction_law import DirectionalViscousFriction

    fields = {f.name: getattr(LAW, f.name) for f in dataclasses.fields(LAW)}
    law = DirectionalViscousFriction(**fields, viscous_negative=0.006)
    res = identify_model(robot(), [simulate(law=law)], max_order=20, friction="whole")  # type: ignore[arg-type]
    f = res.model.joints["m"].friction
    assert isinstance(f, DirectionalViscousFriction)
    # 0.004 and 0.006 N m s/rad, from 10^4 samples per pass of 5 mN m noise
    assert_allclose([f.viscous, f.viscous_negative], [0.004, 0.006], rtol=0.03)
    # the model file's table reads back as the same law
    from torquemap.friction_law import friction_law_from_dict

    assert friction_law_from_dict(f.to_dict()).to_dict() == f.to_dict()
