"""The onset law's ``"choose"`` form (torquemap.linearize.onset, docs/linearize.md "stop 43
(L61)"): the amplifier's curve taken where it predicts held-out readings better, the power law
kept on a straight onset. Truth written here in closed form."""

from __future__ import annotations

import numpy as np
import pytest

from torquemap.linearize.motor import motor_spec
from torquemap.linearize.onset import fit_onset
from torquemap.linearize.tables import build_tables

A = 255
N = 24


def _law(a: np.ndarray, d: float, c: float, n: float) -> np.ndarray:
    """Current ``(e^(c x) - 1) / (e^c - 1)`` past the dead zone ``d`` (``x`` linear for
    ``c = 0``), torque ~ current^n."""
    x = np.maximum(a - d, 0.0) / (A - d)
    if c == 0.0:
        return x**n
    return ((np.exp(c * x) - 1.0) / (np.exp(c) - 1.0)) ** n


def _rows(c: float, n: float, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One phase over 24 positions, dead zone 25.5, friction 0.4 N m, rows every 4th pulse
    width with 0.01 N m of noise: the truth on every pulse width (P, A + 1) and the rows."""
    g = 10.0 * (2.0 + np.cos(2 * np.pi * 3 * np.arange(N) / N))
    u = np.arange(A + 1, dtype=float)
    truth = np.maximum(g[:, None] * _law(u, 25.5, c, n)[None, :] - 0.4, 0.0)
    p, w = np.meshgrid(np.arange(N), np.arange(0, A + 1, 4), indexing="ij")
    p, w = p.ravel(), w.ravel()
    tau = truth[p, w] + 0.01 * np.random.default_rng(seed).standard_normal(p.size)
    return truth, p, w, tau


def _low_error(truth: np.ndarray, phases: np.ndarray, per_count: float) -> float:
    """Mean relative error of the torque the tables give at commands 1 to 3."""
    got = truth[np.arange(N)[:, None], phases[0][:, 1:4]]
    target = np.arange(1, 4)[None, :] * per_count
    return float(np.mean(np.abs(got - target) / target))


@pytest.mark.parametrize("seed", [0, 1])
def test_choose_takes_the_convex_amplifier_at_the_lowest_commands(seed: int) -> None:
    # a convex amplifier (c = 1.5), torque ~ current: the power law bends through its dead
    # zone (fitted 10.2 for 25.5, n 1.4) and the choice takes the amplifier's curve; the
    # three lowest commands' mean relative error 10.1 / 10.7 % against the power law's
    # 12.2 / 12.1 % (measured, seeds 0 / 1)
    spec = motor_spec("m1", phases=1, positions_per_cycle=N, equilibrium_positions=(0,))
    truth, p, w, tau = _rows(1.5, 1.0, seed)
    power = build_tables(spec, p, w, tau)
    chosen = build_tables(spec, p, w, tau, onset_form="choose")
    amplifier = build_tables(spec, p, w, tau, onset_form="amplifier")
    assert np.array_equal(chosen.phases, amplifier.phases)
    e_power = _low_error(truth, power.phases, power.torque_per_count)
    e_chosen = _low_error(truth, chosen.phases, chosen.torque_per_count)
    assert e_chosen < 0.9 * e_power


@pytest.mark.parametrize(("n", "seed"), [(1.4, 0), (1.4, 1), (1.6, 0), (1.6, 1)])
def test_choose_keeps_the_power_law_on_a_straight_amplifier(n: float, seed: int) -> None:
    # a linear amplifier past its dead zone, torque ~ current^1.4 or ^1.6 (the power law
    # exactly, on its grid): the amplifier's form alone reads another law (measured: d 5.1,
    # n 2, c -1.0 for 1.4; d 10.2, n 2, c -0.5 for 1.6), and the choice keeps the power law
    # and its tables
    spec = motor_spec("m1", phases=1, positions_per_cycle=N, equilibrium_positions=(0,))
    truth, p, w, tau = _rows(0.0, n, seed)
    levels = np.arange(0, A + 1, 4, dtype=float)
    forward = truth[:, levels.astype(int)]
    laws = {}
    for form in ("power", "amplifier", "choose"):
        fit = fit_onset(
            forward + 0.01 * np.random.default_rng(seed).standard_normal(forward.shape),
            levels,
            np.ones((N, 1)),
            readable=0.03,
            upper=0.3 * float(truth.max(axis=1).min()),
            actuation_max=A,
            form=form,  # type: ignore[arg-type]
        )
        laws[form] = (fit.dead_zone, fit.exponent, fit.curve)
    assert laws["choose"] == laws["power"] and laws["power"][2] == 0.0
    assert laws["amplifier"] != laws["power"]
    power = build_tables(spec, p, w, tau)
    chosen = build_tables(spec, p, w, tau, onset_form="choose")
    assert np.array_equal(chosen.phases, power.phases)


def test_choose_fit_law_on_a_straight_and_a_convex_onset() -> None:
    # fit_onset directly, noise-free, every 4th pulse width: a straight onset keeps the power
    # law's curve 0; a convex one (c = 1.5) reads the amplifier's curve within a grid step
    levels = np.arange(0, A + 1, 4, dtype=float)
    ramp = np.ones((N, 1))
    for c, want in ((0.0, 0.0), (1.5, 1.5)):
        truth, *_ = _rows(c, 1.0, 0)
        fit = fit_onset(
            truth[:, levels.astype(int)],
            levels,
            ramp,
            readable=0.03,
            upper=0.3 * float(truth.max(axis=1).min()),
            actuation_max=A,
            form="choose",
        )
        assert abs(fit.curve - want) <= 0.5 and fit.fitted.all()
