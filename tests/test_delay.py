"""Channel delay: recovered where speed varies, refused where it is only an angle offset."""

from __future__ import annotations

import numpy as np

from torquemap.delay import estimate_delay, shift_channel


def _pass(speed_ripple: float, delay: float, seed: int = 0):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 20.0, 2e-3)
    # motor angle: 1 rad/s mean, speed ripple at 7 CPR (as cogging makes it)
    theta = t.copy()
    for _ in range(3):
        theta = t + speed_ripple / 7.0 * np.sin(7.0 * theta)
    pdtv = 0.3 * np.cos(7.0 * theta + 0.2) + 0.1 * np.cos(14.0 * theta - 1.0)
    # the torque channel reports what happened ``delay`` earlier
    recorded = np.interp(t - delay, t, pdtv) + rng.normal(0.0, 0.01, t.size)
    return t, theta, recorded


def test_delay_is_recovered_when_speed_varies() -> None:
    t, theta, y = _pass(speed_ripple=0.5, delay=0.06)
    est = estimate_delay([t], [theta], [y], [(0, 500, t.size - 500)], [7.0, 14.0])
    assert est.significant
    assert abs(est.delay - 0.06) < 0.004  # a fifth of the 12.5 ms grid step, after refinement
    # undoing it makes the torque a function of the angle again
    fixed = shift_channel(t, y, est.delay)
    clean = 0.3 * np.cos(7.0 * theta + 0.2) + 0.1 * np.cos(14.0 * theta - 1.0)
    inner = slice(500, t.size - 500)
    assert np.std(fixed[inner] - clean[inner]) < 0.02


def test_constant_speed_delay_is_only_an_angle_offset() -> None:
    t, theta, y = _pass(speed_ripple=0.0, delay=0.06)
    est = estimate_delay([t], [theta], [y], [(0, 500, t.size - 500)], [7.0, 14.0])
    assert not est.significant
    assert est.delay == 0.0


def test_no_orders_no_delay() -> None:
    t, theta, y = _pass(speed_ripple=0.5, delay=0.06)
    assert estimate_delay([t], [theta], [y], [(0, 0, t.size)], []).delay == 0.0
