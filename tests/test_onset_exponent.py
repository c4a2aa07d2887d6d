"""The onset law's exponents searched from 1 (torquemap.linearize.onset.fit_onset's
``exponents``; not the default, docs/linearize.md "stop 38 (L42)"): on a concave amplifier an
exponent below 1 (an infinite slope at the dead zone) trades with the dead zone and puts it near
0, so a phase at a small share switches on many pulse widths early. Checked on surfaces written
here in closed form (the amplifier's dead zone, smooth onset and concave current curve; torque ~
current, a brushless DC motor), against the default grid from 0.8."""

from __future__ import annotations

import numpy as np
import pytest

import torquemap.linearize.onset as onset
from torquemap.linearize.motor import ramp_function
from torquemap.linearize.onset import fit_onset, onset_curve

A = 255
STEP = float(onset.DEAD_ZONES[1] * A)  # one step of the dead-zone grid [pulse widths]


def _current(a: np.ndarray, d: float, c: float, w: float) -> np.ndarray:
    """The amplifier written out: a dead zone ``d``, a quadratic onset over ``w`` pulse widths
    past it, then the concave curve ``(1 - e^(-c x)) / (1 - e^(-c))`` of ``x`` the drive past
    the dead zone as a fraction of the range above it."""
    x = np.maximum(a - d, 0.0)
    if w > 0:
        x = np.where(x < w, x * x / (2.0 * w), x - w / 2.0)
    x = np.clip(x / (A - d), 0.0, 1.0)
    return (1.0 - np.exp(-c * x)) / (1.0 - np.exp(-c))


def _sensed(d: float, c: float, w: float, noise: float = 0.0) -> tuple[np.ndarray, ...]:
    """A 3-phase narrow ramp over 128 positions (cross-fades), gains varying over the cycle,
    friction 0.1 N m: sensed = max(sum_k G_k(p) i(r_k(p) u) - F, 0) at every 4th pulse width
    (monotone, as the forward model is), the levels, the ramp and the sensed torque on every
    pulse width (noise-free)."""
    ramp = ramp_function("narrow", phases=3, positions_per_cycle=128)
    p = np.arange(128)
    g = 8.0 * (1.0 + 0.1 * np.sin(2 * np.pi * p / 128))[:, None] * np.array([1.0, 1.07, 0.87])
    u = np.arange(A + 1, dtype=float)
    a = ramp[:, None, :] * u[None, :, None]
    fine = np.maximum(np.einsum("pum,pm->pu", _current(a, d, c, w), g) - 0.1, 0.0)
    levels = np.arange(0, A + 1, 4, dtype=float)
    rows = fine[:, levels.astype(int)]
    if noise:
        rows = rows + np.random.default_rng(3).normal(0.0, noise, rows.shape)
    return np.maximum.accumulate(rows, axis=1), levels, ramp, fine


#: The grid from 1.
FROM_ONE = np.linspace(1.0, 3.2, 12)


def _fit(
    forward: np.ndarray, levels: np.ndarray, ramp: np.ndarray, exponents: np.ndarray | None
) -> onset.OnsetFit:
    top = float(np.min(forward.max(axis=1)))
    return fit_onset(
        forward,
        levels,
        ramp,
        readable=0.03,
        upper=0.3 * top,
        actuation_max=A,
        exponents=exponents,
    )


CASES = [(36.0, 0.9, 7.4), (36.0, 0.9, 0.0), (15.0, 0.92, 0.0), (20.0, 1.0, 0.0)]


def test_default_grid_from_0_8() -> None:
    assert onset.EXPONENTS.min() == pytest.approx(0.8)
    assert onset.EXPONENTS.max() == pytest.approx(3.2)


@pytest.mark.parametrize(("d", "c", "w"), CASES)
def test_concave_amplifier_dead_zone_recovered(d: float, c: float, w: float) -> None:
    forward, levels, ramp, _ = _sensed(d, c, w)
    fit = _fit(forward, levels, ramp, FROM_ONE)
    # the dead zone where the current leaves zero's straight part begins (d + w / 2), within
    # two steps of the grid; torque ~ current
    assert abs(fit.dead_zone - (d + w / 2)) <= 2 * STEP
    assert fit.exponent == pytest.approx(1.0)


@pytest.mark.parametrize(("d", "c", "w"), [(36.0, 0.9, 7.4), (20.0, 1.0, 0.0)])
def test_grid_from_0_8_puts_the_dead_zone_near_zero(d: float, c: float, w: float) -> None:
    """Why: on two of the four surfaces (the other two it fitted as the new
    grid does) the grid from 0.8 picks 0.8 and a dead zone of at most two grid steps, where
    the amplifier's is 20 and 36 pulse widths."""
    forward, levels, ramp, _ = _sensed(d, c, w)
    fit = _fit(forward, levels, ramp, None)
    assert fit.exponent == pytest.approx(0.8)
    assert fit.dead_zone <= 2 * STEP


@pytest.mark.parametrize(("d", "c"), [(15.0, 0.92), (20.0, 1.0)])
def test_with_row_noise(d: float, c: float) -> None:
    forward, levels, ramp, _ = _sensed(d, c, 0.0, noise=0.01)
    fit = _fit(forward, levels, ramp, FROM_ONE)
    assert abs(fit.dead_zone - d) <= 2 * STEP
    assert fit.exponent == pytest.approx(1.0)


def test_knee_at_the_cross_fades_closer() -> None:
    """Where the law is used: the pulse width at which the sensed torque leaves zero, at the
    positions where two phases share the drive (every position, the measured ones and those
    between, as the law is evaluated), against the closed form's."""
    forward, levels, ramp, fine = _sensed(36.0, 0.9, 7.4)
    shared = ((ramp > 0.05) & (ramp < 0.95)).sum(axis=1) == 2
    u = np.arange(A + 1, dtype=float)

    def knee(curve: np.ndarray) -> np.ndarray:
        on = curve > 1e-9
        return np.where(on.any(axis=1), np.argmax(on, axis=1), A + 1)[shared]

    truth = knee(fine)
    new = np.abs(knee(onset_curve(_fit(forward, levels, ramp, FROM_ONE), ramp, u, A)) - truth)
    old = np.abs(knee(onset_curve(_fit(forward, levels, ramp, None), ramp, u, A)) - truth)
    assert shared.sum() >= 40
    assert np.median(new) <= 3.0  # pulse widths
    assert np.median(old) >= 3 * np.median(new) + 5.0
