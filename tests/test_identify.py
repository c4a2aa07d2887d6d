"""identify_model on a 1-DoF motor simulated here (inverse dynamics from a known motion)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.errors import InputError
from torquemap.identify import identify_model
from torquemap.io import Log, write_toml
from torquemap.model import FrictionModel, PdtvLine, friction_torque, load_model, model_to_dict
from torquemap.robot import robot_from_dict

# one worker runs the module (pytest -n 2 --dist loadgroup), so its module fixture `result`
# is built once, not once per worker
pytestmark = pytest.mark.xdist_group("identify")

J_TRUE = 2e-4
FRICTION = FrictionModel(coulomb_positive=0.05, coulomb_negative=0.06, viscous=0.004)
LINES = (
    PdtvLine(order=2.0, amplitude=0.02, phase=0.3),
    PdtvLine(order=7.0, amplitude=0.008, phase=-1.0),
    PdtvLine(order=36.0, amplitude=0.005, phase=2.0),
)
ROBOT = {
    "robot": {"name": "motor", "kinematics": "none"},
    "joints": {"m": {"gear_ratio": 1.0, "torque_constant": 0.1}},
}


def simulate(
    rng: np.random.Generator,
    *,
    speeds: tuple[float, ...] = (1.0, 2.0, 4.0, 8.0),
    directions: tuple[int, ...] = (1, -1),
    revolutions: float = 3.0,
    noise: float = 0.01,
    rate: float = 1000.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time, quantised motor angle and torque of back-and-forth passes with smooth ramps."""
    ramp = 0.4  # s, raised-cosine speed change
    h = 1.0 / rate
    vel: list[np.ndarray] = [np.zeros(int(0.3 * rate))]
    for v in speeds:
        for s in directions:
            tr = np.arange(0.0, ramp, h)
            up = 0.5 * (1 - np.cos(np.pi * tr / ramp)) * v * s
            hold = np.full(int(revolutions * 2 * np.pi / v * rate), v * s)
            vel += [up, hold, up[::-1], np.zeros(int(0.3 * rate))]
    w = np.concatenate(vel)
    t = np.arange(w.size) * h
    acc = np.gradient(w, h)
    theta = np.concatenate(([0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * h)))
    pd = sum(ln.amplitude * np.cos(ln.order * theta + ln.phase) for ln in LINES)
    moving = np.abs(w) > 1e-9
    tau = J_TRUE * acc + np.where(moving, friction_torque(w, FRICTION) + pd, 0.0)
    tau = tau + rng.normal(0.0, noise, t.size)
    counts = 8000
    q = np.round(theta * counts / (2 * np.pi)) * (2 * np.pi / counts)
    return t, q, tau


def as_log(t: np.ndarray, q: np.ndarray, tau: np.ndarray) -> Log:
    return Log(t=t, q=q[:, None], motor_torque=tau[:, None], joint_names=("m",), path="sim.csv")


@pytest.fixture(scope="module")
def result():  # type: ignore[no-untyped-def]
    t, q, tau = simulate(np.random.default_rng(7))
    return identify_model(
        robot_from_dict(ROBOT), [as_log(t, q, tau)], max_order=100, friction="passes"
    )


def test_recovers_friction(result) -> None:  # type: ignore[no-untyped-def]
    f = result.model.joints["m"].friction
    # pass means average ~5000+ samples of 0.01 N m noise and whole PDTV revolutions:
    # 1 mN m on Coulomb (2 %) and 3 % on viscous are several standard errors
    assert_allclose(f.coulomb_positive, 0.05, atol=1e-3)
    assert_allclose(f.coulomb_negative, 0.06, atol=1e-3)
    assert_allclose(f.viscous, 0.004, rtol=0.03)
    assert f.stribeck_positive == 0.0  # no Stribeck in the data: the F test must refuse it
    assert not result.warnings


def test_recovers_inertia(result) -> None:  # type: ignore[no-untyped-def]
    # ramps peak at pi*v/(2*0.4) rad/s^2: J*acc up to 6 mN m against 10 mN m noise, over
    # ~6000 ramp samples: 10 % is about 5 standard errors
    assert_allclose(result.model.joints["m"].inertia.constant, J_TRUE, rtol=0.1)


def test_recovers_pdtv_lines(result) -> None:  # type: ignore[no-untyped-def]
    lines = result.model.joints["m"].pdtv
    assert sorted(ln.order for ln in lines) == [2.0, 7.0, 36.0]
    assert all(ln.direction == "both" for ln in lines)
    got = {ln.order: ln for ln in lines}
    for ln in LINES:
        # harmonic fit on ~10^4 samples: amplitude SE ~ 0.01*sqrt(2/1e4) = 1.4e-4 N m
        assert_allclose(got[ln.order].amplitude, ln.amplitude, atol=1e-3)
        assert_allclose(got[ln.order].phase, ln.phase, atol=0.2)


def test_one_direction_and_one_speed_warn_not_fail() -> None:
    t, q, tau = simulate(np.random.default_rng(8), speeds=(2.0,), directions=(1,))
    res = identify_model(
        robot_from_dict(ROBOT), [as_log(t, q, tau)], max_order=50, friction="passes"
    )
    f = res.model.joints["m"].friction
    assert f.coulomb_negative == f.coulomb_positive
    assert any("never moves in the negative direction" in w for w in res.warnings)
    assert any("one speed only" in w for w in res.warnings)


def test_errors() -> None:
    rb = robot_from_dict(ROBOT)
    t = np.arange(0.0, 2.0, 1e-3)
    still = as_log(t, np.zeros_like(t), np.zeros_like(t))
    with pytest.raises(InputError, match="no joint moves"):
        identify_model(rb, [still])
    short = as_log(t[:20], t[:20], t[:20])
    with pytest.raises(InputError, match="shorter than the differentiation window"):
        identify_model(rb, [short])
    tt, q, tau = simulate(np.random.default_rng(9), speeds=(8.0,))
    with pytest.raises(InputError, match="needs a slower sweep"):
        identify_model(rb, [as_log(tt, q, tau)], max_order=2000)
    with pytest.raises(InputError, match="unknown joint"):
        identify_model(rb, [still], joints=["x"])


def test_model_file_reloads(result, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "model.toml"
    write_toml(path, model_to_dict(result.model))
    back = load_model(path)
    assert [ln.order for ln in back.joints["m"].pdtv] == [
        ln.order for ln in result.model.joints["m"].pdtv
    ]
    assert back.joints["m"].friction.viscous == result.model.joints["m"].friction.viscous
    assert back.notes["joints"]["m"]["passes"] == 8


def test_smoothing_only_around_the_ramps_equals_smoothing_the_whole_log() -> None:
    # the inertia fit smooths the torque only around its ramp samples (_stretches): the
    # filter sees half a window either side, so the answers there are the whole log's, to
    # rounding (its double integral carries in a constant and a slope, which it annihilates)
    from torquemap.filters import smooth_as_acceleration
    from torquemap.identify import _stretches

    rng = np.random.default_rng(8)
    t = np.arange(40000) * 5e-4
    x = 0.05 * np.sin(3.0 * t) + 0.02 * np.sign(np.sin(0.5 * t)) + rng.normal(0, 0.01, t.size)
    mask = np.zeros(t.size, dtype=bool)
    for a in (3, 5000, 17000, 39990):  # at the log's two ends too
        mask[a : a + 7] = True
    whole = smooth_as_acceleration(t, x, window=0.05)
    for a, b in _stretches(t, mask, 0.05):
        part = smooth_as_acceleration(t[a:b], x[a:b], window=0.05)
        m = mask[a:b]
        # measured 3.4e-10: the whole log's double integral (20 s) rounds at that level after
        # the differentiator's 1 / h^2; the signal is 0.07, so 1e-9 is rounding, a missed
        # half window (an edge inside the stretch) would be of the signal's own size
        np.testing.assert_allclose(part[m], whole[a:b][m], rtol=0, atol=1e-9)


def test_inertia_from_ramps_when_fast_passes_are_mostly_ramp() -> None:
    # constant-acceleration ramps (300 rad/s^2, as random SCARA 214's sweep) into passes of
    # 2 revolutions: at 50 rad/s the ramps take 0.17 s and 0.66 revolution each, so the pass
    # (where the revolution-averaged speed is within 20 % of the run's) holds ramp samples.
    # Before, their acceleration entered the passes' speed ripple as an RMS (121 rad/s^2 here,
    # the ramps 300): no ramp stood out of 3 ripples, "no accelerating segment: inertia set
    # to 0" (random SCARA 209 and 214; 214's model then looked like a vertical arm). The
    # ripple is now, when no ramp clears the plain RMS, the RMS of the pass samples within 5
    # robust standard deviations (identify.pass_ripple).
    rng = np.random.default_rng(3)
    h, accel = 1e-3, 300.0
    vel: list[np.ndarray] = [np.zeros(300)]
    for v in (5.0, 50.0, 50.0, 50.0):
        for s in (1.0, -1.0):
            up = np.arange(0.0, v, accel * h) * s
            ramp_angle = v * v / (2 * accel)
            hold = np.full(max(int((4 * np.pi - 2 * ramp_angle) / v / h), 0), v * s)
            vel += [up, hold, up[::-1], np.zeros(300)]
    w = np.concatenate(vel)
    t = np.arange(w.size) * h
    theta = np.concatenate(([0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * h)))
    moving = np.abs(w) > 1e-9
    tau = J_TRUE * np.gradient(w, h) + np.where(moving, friction_torque(w, FRICTION), 0.0)
    tau = tau + rng.normal(0.0, 0.002, t.size)
    q = np.round(theta * 8000 / (2 * np.pi)) * (2 * np.pi / 8000)
    res = identify_model(robot_from_dict(ROBOT), [as_log(t, q, tau)], friction="passes")
    assert not any("no accelerating segment" in w for w in res.warnings)
    # recovery of the simulated inertia; 10 %: the ramps hold thousands of samples at 300
    # rad/s^2, the torque noise 0.002 N m against J a = 0.06 N m
    assert_allclose(res.model.joints["m"].inertia.constant, J_TRUE, rtol=0.1)
