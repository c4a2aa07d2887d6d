"""A current ripple of fixed time frequency is not taken for PDTV (issue 12: unseen robots).

Random SCARA 101 and 103 (``torquemap simulate scara --random``) put a ripple of 305 and 138 Hz
on the current; the passes at 4.55 and 5.68 rad/s showed it at 422 and 153 CPR, and identify
kept it as a PDTV line, which ``pdtv-map`` turned into anti-cogging feed-forward the motor does
not need. Logs are simulated here with known lines and a known ripple frequency.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray

from torquemap.identify import identify_model
from torquemap.io import Log
from torquemap.model import model_from_dict
from torquemap.time_lines import time_frequency_lines

GEAR = 40.0
KT = 0.05
RATE = 2000.0  # [Hz]
SPEEDS = (3.0, 4.0)  # motor [rad/s]: 4189 and 3142 samples per revolution, both used for PDTV
LINES = ((3.0, 0.004, 0.3), (11.0, 0.002, -1.0))  # order [CPR], amplitude [N m], phase [rad]
RIPPLE = 40.0 * SPEEDS[1] / (2 * math.pi)  # [Hz]: at 40 CPR in the 4 rad/s passes, 53.3 at 3
COULOMB = 0.02


def _levels_signal(seed: int) -> tuple[NDArray[np.float64], ...]:
    """Two steady speeds; the PDTV lines' amplitude 20 % apart between them (a real motor's
    lines vary with speed through the speed ripple they cause), plus the time ripple."""
    rng = np.random.default_rng(seed)
    theta, y, v = [], [], []
    for level, speed in enumerate(SPEEDS):
        t = np.arange(0.0, 8.0, 1.0 / RATE)
        th = speed * t + rng.uniform(0, 2 * math.pi)
        scale = 1.0 + 0.2 * level
        sig = sum(scale * a * np.cos(o * th + p) for o, a, p in LINES)
        sig = sig + 0.002 * np.cos(2 * math.pi * RIPPLE * t + rng.uniform(0, 2 * math.pi))
        theta.append(th)
        y.append(sig + rng.normal(0.0, 0.003, t.size))
        v.append(np.full(t.size, speed))
    return np.concatenate(theta), np.concatenate(y), np.concatenate(v)


@pytest.mark.parametrize("seed", range(4))
def test_the_time_ripple_and_only_it_is_named(seed: int) -> None:
    theta, y, v = _levels_signal(seed)
    ripple_order = 2 * math.pi * RIPPLE / SPEEDS[1]  # 40 CPR at 4 rad/s (closed form)
    orders = [3.0, 11.0, ripple_order]
    found = time_frequency_lines(theta, y, orders=orders, groups=v > 3.5, speed=v)
    assert [ln.order for ln in found] == [ripple_order]
    # its frequency back from the order and the level's speed: exact up to rounding
    assert found[0].frequency == pytest.approx(RIPPLE, rel=1e-9)
    assert found[0].speed == SPEEDS[1]


def test_a_line_that_fades_with_speed_is_not_a_ripple() -> None:
    # a PDTV line whose amplitude in the identification signal falls to a fifth at the faster
    # level (the differentiator smooths the acceleration that carries it at high frequency;
    # random SCARA 7's true 39 CPR line): absent there, but no line at its time frequency
    # either, so it is the motor angle's
    rng = np.random.default_rng(5)
    theta, y, v = [], [], []
    for speed, scale in ((SPEEDS[0], 1.0), (SPEEDS[1], 0.2)):
        t = np.arange(0.0, 8.0, 1.0 / RATE)
        th = speed * t + rng.uniform(0, 2 * math.pi)
        theta.append(th)
        y.append(scale * 0.004 * np.cos(39.0 * th) + rng.normal(0.0, 0.003, t.size))
        v.append(np.full(t.size, speed))
    th_all, y_all, v_all = np.concatenate(theta), np.concatenate(y), np.concatenate(v)
    assert time_frequency_lines(th_all, y_all, orders=[39.0], groups=v_all > 3.5, speed=v_all) == ()


def test_one_speed_tells_nothing() -> None:
    theta, y, v = _levels_signal(0)
    one = v == SPEEDS[1]
    assert (
        time_frequency_lines(theta[one], y[one], orders=[40.0], groups=v[one], speed=v[one]) == ()
    )


def _sweep_log(seed: int) -> Log:
    """Joint a alone at each speed both ways, 2.5 motor revolutions per pass, raised-cosine
    ramps; joint b still. Coulomb friction, the PDTV lines and the current ripple."""
    rng = np.random.default_rng(seed)
    h = 1.0 / RATE
    vm = []
    for speed in SPEEDS:
        for s in (1.0, -1.0):
            ramp = 0.5 * (1 - np.cos(np.pi * np.arange(0.0, 0.2, h) / 0.2)) * speed * s
            hold = np.full(int(2.5 * 2 * math.pi / speed * RATE), speed * s)
            vm.append(np.concatenate((ramp, hold, ramp[::-1], np.zeros(100))))
    v = np.concatenate(vm)
    t = np.arange(v.size) * h
    theta = np.cumsum(v) * h
    tau = COULOMB * np.tanh(v / 0.05) + sum(a * np.cos(o * theta + p) for o, a, p in LINES)
    tau = tau + 0.002 * np.cos(2 * math.pi * RIPPLE * t)
    current = tau / KT + rng.normal(0.0, 0.02, t.size)
    q = np.c_[theta / GEAR, np.full(t.size, 1.2)]
    return Log(
        t=t,
        q=q,
        motor_torque=np.c_[current * KT, np.zeros(t.size)],
        joint_names=("a", "b"),
        path="sweep.csv",
    )


def test_identify_leaves_the_ripple_out_and_keeps_the_lines() -> None:
    robot = model_from_dict(
        {
            "robot": {"name": "r", "kinematics": "planar2r", "link_lengths": [0.3, 0.2]},
            "joints": {
                j: {"gear_ratio": GEAR, "torque_constant": KT, "encoder_counts_per_rev": 65536}
                for j in ("a", "b")
            },
        }
    ).robot
    res = identify_model(robot, [_sweep_log(0)], joints=["a"], friction="passes")
    lines = {ln.order: ln.amplitude for ln in res.model.joints["a"].pdtv}
    # the ripple sits at 40 CPR in the 4 rad/s passes and 53.3 CPR in the 3 rad/s ones
    assert not any(39 < o < 41 or 53 < o < 54 for o in lines), lines
    # the true lines: amplitudes within 5 % (noise 1 mN m per sample over ~30000 samples
    # gives ~1e-5 N m; the pass friction law's error and leakage dominate)
    for order, amplitude, _ in LINES:
        assert lines[order] == pytest.approx(amplitude, rel=0.05)
    said = [w for w in res.warnings if "in time" in w]
    assert said and f"{RIPPLE:.4g} Hz" in said[0]
