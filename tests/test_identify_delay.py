"""The pass method's torque-channel delay, on a 1-DoF motor simulated here with a known delay.

A slow log (333 Hz), short fast passes and steep ramps: a delay of 118 ms lets the ramps'
torque into the passes' means. The pass method must still find the delay (scored on every
moving sample, ramps included) and, with it, the friction and inertia.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.identify import identify_model
from torquemap.io import Log
from torquemap.model import FrictionModel, PdtvLine, friction_torque
from torquemap.robot import robot_from_dict

J_TRUE = 2.15e-4
DELAY = 0.1185
# a Stribeck law (exponent 1), small PDTV lines against 2.5 mN m of noise: random bench 31's
# joint b (torquemap.sim.scara_family), where the pass method found 68 ms
FRICTION = FrictionModel(
    coulomb_positive=0.034,
    coulomb_negative=0.028,
    viscous=3.3e-4,
    stribeck_positive=0.019,
    stribeck_negative=0.008,
    stribeck_velocity=1.8,
    stribeck_exponent=1.0,
    zero_velocity=0.05,
)
LINES = (
    PdtvLine(order=1.0, amplitude=0.0013, phase=-0.46),
    PdtvLine(order=2.0, amplitude=0.0013, phase=1.96),
    PdtvLine(order=4.0, amplitude=0.0028, phase=2.62),
    PdtvLine(order=37.0, amplitude=0.0017, phase=-1.41),
)
ROBOT = {
    "robot": {"name": "motor", "kinematics": "none"},
    "joints": {"m": {"gear_ratio": 1.0, "torque_constant": 0.1}},
}
SPEEDS = (1.36, 3.28, 7.94, 19.2, 46.5, 112.4)


def simulate(
    rng: np.random.Generator,
    *,
    delay: float,
    rate: float = 340.0,
    noise: float = 0.0025,
    friction: FrictionModel = FRICTION,
) -> Log:
    """Back-and-forth passes of 2.6 revolutions at ``SPEEDS`` [rad/s], ramps at a constant
    1000 rad/s^2, logged at ``rate`` [Hz] with 17 % jitter, the torque channel reporting what
    happened ``delay`` [s] earlier."""
    h = 1e-4  # the motion on a fine grid; the log samples it
    accel = 1000.0
    vel: list[np.ndarray] = [np.zeros(int(0.5 / h))]
    for v in SPEEDS:
        for s in (1, -1):
            up = np.arange(0.0, v, accel * h) * s
            hold = np.full(int(2.6 * 2 * np.pi / v / h), v * s)
            vel += [up, hold, up[::-1], np.zeros(int(0.25 / h))]
    w = np.concatenate(vel)
    tf = np.arange(w.size) * h
    acc = np.gradient(w, h)
    theta = np.concatenate(([0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * h)))
    pd = sum(ln.amplitude * np.cos(ln.order * theta + ln.phase) for ln in LINES)
    moving = np.abs(w) > 1e-9
    tau = J_TRUE * acc + np.where(moving, friction_torque(w, friction) + pd, 0.0)
    step = (1.0 + 0.17 * rng.uniform(-1.0, 1.0, int(tf[-1] * rate) + 2)) / rate
    t = np.cumsum(step)
    t = t[t < tf[-1]]
    # the channel reports the torque of ``delay`` earlier (held at the start)
    recorded = np.interp(t - delay, tf, tau) + rng.normal(0.0, noise, t.size)
    counts = 2**20
    q = np.round(np.interp(t, tf, theta) * counts / (2 * np.pi)) * (2 * np.pi / counts)
    return Log(t=t, q=q[:, None], motor_torque=recorded[:, None], joint_names=("m",), path="s")


@pytest.fixture(scope="module")
def delayed():  # type: ignore[no-untyped-def]
    log = simulate(np.random.default_rng(3), delay=DELAY)
    return identify_model(robot_from_dict(ROBOT), [log], friction="passes")


@pytest.mark.xdist_group("delayed")  # delayed, built once
def test_pass_method_recovers_a_long_delay(delayed) -> None:  # type: ignore[no-untyped-def]
    d = delayed.model.notes["joints"]["m"]["channel_delay"]
    # the log's period is 3 ms; the trial grid's step 12.5 ms is refined by a parabola: two
    # log periods
    assert_allclose(d, DELAY, atol=0.006)


@pytest.mark.xdist_group("delayed")  # delayed, built once
def test_pass_method_with_a_long_delay_recovers_friction_and_inertia(delayed) -> None:  # type: ignore[no-untyped-def]
    jm = delayed.model.joints["m"]
    v = np.array([-46.5, -7.94, -1.36, 1.36, 7.94, 46.5])
    # the law at the pass speeds: each pass mean averages 2.6 revolutions of 2.5 mN m noise,
    # so 1 mN m (3 % of Coulomb) is several standard errors; a delay 50 ms short leaves the
    # ramps' torque in the fast passes' means (+17 mN m at 46.5 rad/s on bench 31)
    assert_allclose(friction_torque(v, jm.friction), friction_torque(v, FRICTION), atol=1e-3)
    # the inertia from 12 ramps: 5 % (measured 1.5 %)
    assert_allclose(jm.inertia.constant, J_TRUE, rtol=0.05)


def test_no_delay_is_found_where_there_is_none() -> None:
    log = simulate(np.random.default_rng(4), delay=0.0)
    ident = identify_model(robot_from_dict(ROBOT), [log], friction="passes")
    # the F test at 1 - 1e-6 keeps a delay only when it explains more than noise; a kept
    # delay must still be within a sample period or two of zero
    assert abs(ident.model.notes["joints"]["m"]["channel_delay"]) < 0.006


@pytest.fixture(scope="module")
def bench31():  # type: ignore[no-untyped-def]
    """Random bench 31 (torquemap.sim: closed-loop servo, 340 Hz log with jitter and gaps,
    118.5 ms current delay), its sweep cut to five speeds at two elbow angles (~10 s to
    simulate)."""
    import dataclasses

    from torquemap.io import log_from_columns
    from torquemap.model import model_from_dict
    from torquemap.sim.bench import simulate_bench
    from torquemap.sim.scara_family import random_bench

    b = random_bench(31)
    sweep = dataclasses.replace(
        b.sweep,
        speeds=b.sweep.speeds[:5],
        elbow_angles=b.sweep.elbow_angles[:2],
        fast_speeds=0,
    )
    files = simulate_bench(dataclasses.replace(b, sweep=sweep), seed=31)
    truth = model_from_dict(files.truth)
    log = log_from_columns(files.sweep, truth.robot, path="s")
    return b, truth, identify_model(truth.robot, [log], friction="passes")


@pytest.mark.xdist_group("bench31")
def test_pass_method_finds_the_delay_of_a_simulated_servo(bench31) -> None:  # type: ignore[no-untyped-def]
    b, truth, ident = bench31
    d = ident.model.notes["joints"]["b"]["channel_delay"]
    # before scoring the delay on the ramps too, joint b's came out 30 ms (68 ms on the full
    # sweep) and its inertia negative; 10 ms is three log periods
    assert_allclose(d, b.logging.current_delay, atol=0.01)
    # the inertia from the ramps, with the delay right: within 10 % (the servo's speed ripple
    # and the jittered 340 Hz log; measured 6 %)
    assert_allclose(
        ident.model.joints["b"].inertia.constant, truth.joints["b"].inertia.constant, rtol=0.1
    )


MISFIT = "the pass model does not explain the sweep"
# Coulomb and viscous only: a law the pass method fits exactly
PLAIN = FrictionModel(coulomb_positive=0.034, coulomb_negative=0.028, viscous=3.3e-4)


def test_pass_check_is_silent_when_the_pass_model_holds() -> None:
    log = simulate(np.random.default_rng(5), delay=DELAY, friction=PLAIN)
    ident = identify_model(robot_from_dict(ROBOT), [log], friction="passes")
    # the F test at 1 - 1e-6: a true model warns once in a million logs
    assert not [w for w in ident.warnings if MISFIT in w]


def test_pass_check_warns_when_the_delay_is_wrong() -> None:
    log = simulate(np.random.default_rng(5), delay=DELAY, friction=PLAIN)
    ident = identify_model(robot_from_dict(ROBOT), [log], friction="passes", channel_delay=0.0)
    # told there is no delay, the pass means carry the ramps' torque and the ramps lead the
    # torque by 118 ms: the free law fitted to every sample explains far more
    assert [w for w in ident.warnings if MISFIT in w]


def test_whole_fit_does_not_judge_the_pass_model(monkeypatch: pytest.MonkeyPatch) -> None:
    # the default whole-log fit replaces the pass model: the pass check (and its advice to use
    # the whole fit) is for --friction passes only, also when the pass method found a channel
    # delay and re-identified (where it used to run regardless and cost 1 s on a 1 M-sample log)
    import torquemap.pass_check

    calls: list[int] = []

    def counted(*args: object, **kwargs: object) -> object:
        calls.append(1)
        return original(*args, **kwargs)

    original = torquemap.pass_check.check_pass_model
    monkeypatch.setattr(torquemap.pass_check, "check_pass_model", counted)
    log = simulate(np.random.default_rng(3), delay=DELAY)
    whole = identify_model(robot_from_dict(ROBOT), [log])
    assert whole.model.notes["joints"]["m"]["channel_delay"] > 0.05  # the delay path was taken
    assert calls == []
    identify_model(robot_from_dict(ROBOT), [log], friction="passes")
    assert calls == [1]  # after the delay, on the shifted log
