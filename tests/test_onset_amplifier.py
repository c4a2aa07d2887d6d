"""The onset law's ``"amplifier"`` form (torquemap.linearize.onset): recovery of a known dead
zone, amplifier curve and torque exponent from surfaces written here in closed form."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.linearize.motor import motor_spec, ramp_function
from torquemap.linearize.onset import amplifier_shape, fit_onset, onset_curve, onset_psi
from torquemap.linearize.surface import _lift
from torquemap.linearize.tables import build_tables

A = 255


def _law(a: np.ndarray, d: float, c: float, n: float) -> np.ndarray:
    """The closed form, written out: current ``(e^(c x) - 1) / (e^c - 1)`` past the dead zone,
    torque ~ current^n."""
    x = np.maximum(a - d, 0.0) / (A - d)
    if c == 0.0:
        return x**n
    return ((np.exp(c * x) - 1.0) / (np.exp(c) - 1.0)) ** n


def _surface(d: float, c: float, n: float, friction: float) -> tuple[np.ndarray, np.ndarray]:
    """A 3-phase wide ramp over 48 positions (hand-overs with shares 1/6 .. 5/6): sensed =
    max(sum_k G_k(p) psi(r_k(p) u) - F(p), 0) on every pulse width, and the ramp."""
    ramp = ramp_function("wide", phases=3, positions_per_cycle=48)
    p = np.arange(48)
    g = 10.0 * (1.5 + 0.5 * np.cos(2 * np.pi * p / 48))[:, None] * np.array([1.0, 0.9, 1.1])
    f = friction * (1.0 + 0.2 * np.sin(2 * np.pi * 3 * p / 48))
    u = np.arange(A + 1, dtype=float)
    a = ramp[:, None, :] * u[None, :, None]
    torque = np.einsum("pum,pm->pu", _law(a, d, c, n) * (ramp[:, None, :] > 0), g)
    return np.maximum(torque - f[:, None], 0.0), ramp


def test_amplifier_shape_is_the_closed_form() -> None:
    x = np.linspace(0.0, 1.0, 11)
    for c in (-2.0, 0.7, 3.0):
        # the same expression written with exp: agreement to rounding
        assert_allclose(amplifier_shape(x, c), np.expm1(c * x) / np.expm1(c), rtol=1e-12)
        assert_allclose(amplifier_shape(x, c), (np.exp(c * x) - 1) / (np.exp(c) - 1), atol=1e-12)
    assert_allclose(amplifier_shape(x, 0.0), x)
    a = np.array([0.0, 25.5, 100.0, 255.0])
    assert_allclose(onset_psi(a, 25.5, 2.0, A, 1.5), _law(a, 25.5, 1.5, 2.0), rtol=1e-12)


@pytest.mark.parametrize(
    ("d", "c", "n"),
    [(25.5, 1.5, 1.0), (15.3, -1.0, 1.0), (35.7, 1.0, 2.0)],
)
def test_fit_recovers_dead_zone_curve_and_exponent(d: float, c: float, n: float) -> None:
    truth, ramp = _surface(d, c, n, friction=0.4)
    levels = np.arange(0, A + 1, 4, dtype=float)  # the paper's every 4th pulse width
    forward = truth[:, levels.astype(int)]
    top = float(truth.max())
    fit = fit_onset(
        forward, levels, ramp, readable=0.2, upper=0.3 * top, actuation_max=A, form="amplifier"
    )
    # noise-free, and the truth on the grids searched (d every 0.01 A, c every 0.5): exact
    assert fit.exponent == n
    assert abs(fit.dead_zone - d) < 1e-6 * A
    assert abs(fit.curve - c) < 1e-9
    assert fit.fitted.all()
    # the law's curve then holds the friction zone: below the readable torque within 1 %
    # of the largest torque in the window (the window's own fit error)
    law = onset_curve(fit, ramp, np.arange(A + 1, dtype=float), A)
    low = truth < 0.2
    assert np.abs(law[low] - truth[low]).max() < 0.01 * 0.3 * top


def test_fit_with_noise_keeps_the_dead_zone_within_two_steps() -> None:
    # readings with a row's noise of 1 % of the window's top; the dead zone within two grid
    # steps (5.1 pulse widths), where the power form, fitted to the same readings, puts it
    # at least three steps short (it lends the amplifier's convex curve to the dead zone)
    d, c, n = 25.5, 1.5, 1.0
    truth, ramp = _surface(d, c, n, friction=0.4)
    levels = np.arange(0, A + 1, 4, dtype=float)
    top = float(truth.max())
    rng = np.random.default_rng(7)
    forward = truth[:, levels.astype(int)] + rng.normal(0.0, 0.003 * top, (48, levels.size))
    forward = np.maximum.accumulate(forward, axis=1)
    args = dict(readable=0.3, upper=0.3 * top, actuation_max=A)
    amp = fit_onset(forward, levels, ramp, form="amplifier", **args)  # type: ignore[arg-type]
    power = fit_onset(forward, levels, ramp, form="power", **args)  # type: ignore[arg-type]
    assert abs(amp.dead_zone - d) <= 2 * 0.01 * A + 1e-9
    assert power.dead_zone <= d - 3 * 0.01 * A


def test_power_form_is_unchanged_and_form_is_checked() -> None:
    truth, ramp = _surface(25.5, 0.0, 2.0, friction=0.4)
    levels = np.arange(0, A + 1, 4, dtype=float)
    forward = truth[:, levels.astype(int)]
    top = float(truth.max())
    fit = fit_onset(forward, levels, ramp, readable=0.2, upper=0.3 * top, actuation_max=A)
    assert fit.curve == 0.0
    assert abs(fit.dead_zone - 25.5) < 1e-6 and abs(fit.exponent - 2.0) < 1e-9
    with pytest.raises(ValueError, match="form must be"):
        fit_onset(
            forward,
            levels,
            ramp,
            readable=0.2,
            upper=0.3 * top,
            actuation_max=A,
            form="cubic",  # type: ignore[arg-type]
        )


def test_surface_lift_follows_the_curved_law_below_the_join() -> None:
    kx = np.arange(0.0, 256.0, 2.0)
    kx[-1] = 255.0
    join = 60.0
    lift = _lift(kx, 20.0, 1.0, join, 1.5)
    low = kx <= join
    # the first column is the law normalised to 1 at the join (closed form above)
    expected = _law(kx[low], 20.0, 1.5, 1.0) / _law(np.array([join]), 20.0, 1.5, 1.0)
    assert_allclose(lift[low, 0], expected, rtol=1e-12)
    # with no curve, the power law as before
    assert_allclose(_lift(kx, 20.0, 2.0, join)[low, 0], (np.maximum(kx[low] - 20.0, 0) / 40.0) ** 2)


def test_build_tables_amplifier_form_at_the_lowest_commands() -> None:
    # one phase, a convex amplifier (c = 1.5) past a dead zone of 25.5, torque ~ current,
    # friction 0.4 N m, rows every 4th pulse width with noise: through build_tables the
    # amplifier form brings the three lowest commands closer to their targets than the
    # interpolation (measured: mean relative error 10.1 % against 12.2 %; the power form
    # gives 12.2 % here); 0.9 of the interpolation's error: between the two
    n = 24
    spec = motor_spec("m1", phases=1, positions_per_cycle=n, equilibrium_positions=(0,))
    g = 10.0 * (2.0 + np.cos(2 * np.pi * 3 * np.arange(n) / n))
    u = np.arange(A + 1, dtype=float)
    truth = np.maximum(g[:, None] * _law(u, 25.5, 1.5, 1.0)[None, :] - 0.4, 0.0)
    rng = np.random.default_rng(0)
    p, w = np.meshgrid(np.arange(n), np.arange(0, A + 1, 4), indexing="ij")
    p, w = p.ravel(), w.ravel()
    tau = truth[p, w] + 0.01 * rng.standard_normal(p.size)
    err = {}
    for name, kw in (("none", {"onset": False}), ("amplifier", {"onset_form": "amplifier"})):
        tab = build_tables(spec, p, w, tau, **kw)  # type: ignore[arg-type]
        got = truth[np.arange(n)[:, None], tab.phases[0][:, 1:4]]
        target = np.arange(1, 4)[None, :] * tab.torque_per_count
        err[name] = float(np.mean(np.abs(got - target) / target))
    assert err["amplifier"] < 0.9 * err["none"]
