"""The friction zone's onset law (torquemap.linearize.onset): recovery of known parameters."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.linearize.motor import motor_spec
from torquemap.linearize.onset import extend_below, fit_onset
from torquemap.linearize.tables import build_tables

A = 255


def _surface(n: int, d: float, exponent: float, friction: float):  # type: ignore[no-untyped-def]
    """One phase: sensed = max(G(p) psi(u) - F, 0), psi = ((u - d) / (A - d))^n."""
    p = np.arange(n)
    g = 10.0 * (2.0 + np.cos(2 * np.pi * 3 * p / n))
    u = np.arange(A + 1, dtype=float)
    psi = (np.maximum(u - d, 0.0) / (A - d)) ** exponent
    return np.maximum(g[:, None] * psi[None, :] - friction, 0.0), g


@pytest.mark.parametrize(("d", "exponent"), [(20.0, 2.0), (35.0, 1.0)])
def test_fit_recovers_dead_zone_exponent_gain_and_friction(d: float, exponent: float) -> None:
    n = 24
    truth, g = _surface(n, d, exponent, friction=0.3)
    levels = np.arange(0, A + 1, 4, dtype=float)  # the paper's every 4th pulse width
    forward = truth[:, levels.astype(int)]
    ramp = np.ones((n, 1))
    fit = fit_onset(forward, levels, ramp, readable=0.5, upper=6.0, actuation_max=A)
    # the grids searched hold the truth within a step: d every 0.01 A, n every 0.2
    assert abs(fit.exponent - exponent) <= 0.2
    assert fit.fitted.all()
    if exponent != 1.0:  # a linear law's dead zone trades with the friction: not identifiable
        assert abs(fit.dead_zone - d) <= 0.01 * A
        assert_allclose(fit.gain[:, 0], g, rtol=0.1)
        assert_allclose(fit.friction, 0.3, atol=0.1)
    # below the first readable reading the rows are lost (zero); the law restores them
    seen = np.where(truth >= 0.5, truth, 0.0)
    restored, replaced = extend_below(seen, fit, ramp, readable=0.5, actuation_max=A)
    low = (truth > 0) & (truth < 0.5)
    assert replaced > 0
    assert np.abs(restored[low] - truth[low]).max() < 0.05  # of a 0.5 N m gap
    assert np.abs(seen[low] - truth[low]).max() > 0.2  # what linear interpolation had lost


def test_tables_at_the_lowest_commands_follow_the_law() -> None:
    # a surface with friction, sampled at every 4th pulse width, rows with noise: the onset
    # extension brings the three lowest commands closer to their targets (measured here: mean
    # relative error 7.7 % against 10.0 %, 8.5 % before the law reached up to the first
    # reliable measured pulse width; the censored low-rank denoising already recovers much of
    # the knee)
    n = 24
    spec = motor_spec("m1", phases=1, positions_per_cycle=n, equilibrium_positions=(0,))
    truth, _ = _surface(n, 30.0, 2.0, friction=0.4)
    rng = np.random.default_rng(0)
    p, w = np.meshgrid(np.arange(n), np.arange(0, A + 1, 4), indexing="ij")
    p, w = p.ravel(), w.ravel()
    tau = truth[p, w] + 0.03 * rng.standard_normal(p.size)
    err = {}
    for onset in (False, True):
        tab = build_tables(spec, p, w, tau, onset=onset)
        entries = tab.phases[0][:, 1:4]
        got = truth[np.arange(n)[:, None], entries]
        target = np.arange(1, 4)[None, :] * tab.torque_per_count
        err[onset] = float(np.mean(np.abs(got - target) / target))
    assert err[True] < 0.9 * err[False]


def test_the_knee_between_two_measured_pulse_widths_follows_the_law() -> None:
    # torque ~ current past a dead zone (brushless DC), friction large enough that the sensed
    # torque leaves zero between two measured pulse widths (every 4th): the rows read about
    # zero at one and well above the noise at the next, and the linear interpolation between
    # them puts torque below the knee. The law, fitted to the readings above, places the knee.
    n = 24
    spec = motor_spec("m1", phases=1, positions_per_cycle=n, equilibrium_positions=(0,))
    d, friction = 20.0, 0.37
    truth, _ = _surface(n, d, 1.0, friction=friction)
    rng = np.random.default_rng(1)
    p, w = np.meshgrid(np.arange(n), np.arange(0, A + 1, 4), indexing="ij")
    p, w = p.ravel(), w.ravel()
    tau = truth[p, w] + 0.002 * rng.standard_normal(p.size)
    tab = build_tables(spec, p, w, tau)
    entries = tab.phases[0][:, 1:4]
    got = truth[np.arange(n)[:, None], entries]
    target = np.arange(1, 4)[None, :] * tab.torque_per_count
    # the best integer pulse width: the exhaustive search over every pulse width
    best = np.abs(truth[:, :, None] - target[:, None, :]).argmin(axis=1)
    floor = truth[np.arange(n)[:, None], best]
    err = float(np.mean(np.abs(got - target) / target))
    err_floor = float(np.mean(np.abs(floor - target) / target))
    # the torque grows by 0.6 to 1.7 commands a pulse width here, so the integer pulse width
    # alone leaves the floor's error (16.4 %); measured: the law 16.8 %, the linear
    # interpolation across the knee 23.9 % (a knee misplaced by a few tenths of a pulse width).
    # 5 points: well above the law's 0.4, below the interpolation's 7.5
    assert err < err_floor + 0.05
