"""The onset law's censored term (torquemap.linearize.onset.fit_onset(censored="score")): the
readings below each position's first reliable one bound the law from above. Checked by
recovery of a known dead zone and exponent from surfaces written here in closed form."""

from __future__ import annotations

import numpy as np
import pytest

from torquemap.linearize.motor import ramp_function
from torquemap.linearize.onset import fit_onset

A = 255
STEP = 0.01 * A  # the search's dead-zone grid step [pulse widths]


def _surface(d: float, c: float, n: float) -> tuple[np.ndarray, np.ndarray]:
    """A 3-phase wide ramp over 48 positions (hand-overs with shares 1/6 .. 5/6): sensed =
    max(sum_k G_k(p) i(r_k(p) u)^n - F(p), 0) on every pulse width, with the amplifier's
    current ``i`` past the dead zone ``d`` written out as ``(e^(c x) - 1) / (e^c - 1)`` (``x``
    for ``c = 0``), and the ramp. The rig reads zero where the torque is below the friction."""
    ramp = ramp_function("wide", phases=3, positions_per_cycle=48)
    p = np.arange(48)
    g = 10.0 * (1.5 + 0.5 * np.cos(2 * np.pi * p / 48))[:, None] * np.array([1.0, 0.9, 1.1])
    f = 0.4 * (1.0 + 0.2 * np.sin(2 * np.pi * 3 * p / 48))
    u = np.arange(A + 1, dtype=float)
    x = np.maximum(ramp[:, None, :] * u[None, :, None] - d, 0.0) / (A - d)
    i = x if c == 0.0 else (np.exp(c * x) - 1.0) / (np.exp(c) - 1.0)
    torque = np.einsum("pum,pm->pu", i**n * (ramp[:, None, :] > 0), g)
    return np.maximum(torque - f[:, None], 0.0), ramp


def _fit(d: float, c: float, n: float, censored: str) -> tuple[float, float]:
    truth, ramp = _surface(d, c, n)
    levels = np.arange(0, A + 1, 4, dtype=float)  # the paper's every 4th pulse width
    top = float(truth.max())
    fit = fit_onset(
        truth[:, levels.astype(int)],
        levels,
        ramp,
        readable=0.2,
        upper=0.3 * top,
        actuation_max=A,
        censored=censored,
    )
    return fit.dead_zone, fit.exponent


@pytest.mark.parametrize(("d", "n"), [(30.6, 1.0), (30.6, 2.0), (12.75, 1.6)])
def test_censored_keeps_the_exact_law(d: float, n: float) -> None:
    # the power law itself, on the grids searched: the truth scores zero in the window and
    # zero on the censored readings (it never rises above a reading of the rig), so it stays
    # the pick, to rounding
    got_d, got_n = _fit(d, 0.0, n, censored="score")
    assert abs(got_d - d) < 1e-6 * A
    assert abs(got_n - n) < 1e-9


def test_censored_moves_a_concave_amplifiers_dead_zone_toward_the_truth() -> None:
    # a concave amplifier (c = -1) the power law cannot follow: fitted on the window alone the
    # law puts the dead zone 3 grid steps past the truth (22.95 for 15.3) and rises above the
    # rig's zero readings below the window; the censored term brings it within one step
    d = 15.3
    plain, _ = _fit(d, -1.0, 1.0, censored="none")
    censored, _ = _fit(d, -1.0, 1.0, censored="score")
    assert abs(plain - d) > 2.5 * STEP
    assert abs(censored - d) <= 1.0 * STEP + 1e-9


@pytest.mark.parametrize(("d", "n"), [(30.6, 1.0), (12.75, 1.6)])
def test_ties_keep_the_exact_law(d: float, n: float) -> None:
    # the truth has the least window residual (zero) and no censored excess: still the pick
    got_d, got_n = _fit(d, 0.0, n, censored="ties")
    assert abs(got_d - d) < 1e-6 * A
    assert abs(got_n - n) < 1e-9


def test_unknown_censored_use_is_refused() -> None:
    truth, ramp = _surface(30.6, 0.0, 1.0)
    levels = np.arange(0, A + 1, 4, dtype=float)
    with pytest.raises(ValueError, match="censored must be"):
        fit_onset(
            truth[:, levels.astype(int)],
            levels,
            ramp,
            readable=0.2,
            upper=10.0,
            actuation_max=A,
            censored="yes",  # type: ignore[arg-type]
        )


def test_ties_read_the_dead_zone_closer_with_a_rows_noise() -> None:
    # a linear law (d = 30.6, n = 1) read with a row's noise of 0.05 N m (the readable torque
    # three times that), three seeded draws: the window alone fits laws two grid steps past
    # the dead zone about as well (its residual flat there), and the smallest of those within
    # 0.1 % is 35.7; the censored readings break the tie within one step on every draw
    d = 30.6
    truth, ramp = _surface(d, 0.0, 1.0)
    levels = np.arange(0, A + 1, 4, dtype=float)
    top = float(truth.max())
    rng = np.random.default_rng(1)
    plain, ties = [], []
    for _ in range(3):
        rows = truth[:, levels.astype(int)] + 0.05 * rng.standard_normal((48, levels.size))
        rows = np.maximum.accumulate(rows, axis=1)  # the forward model is monotone
        for use, out in (("none", plain), ("ties", ties)):
            fit = fit_onset(
                rows,
                levels,
                ramp,
                readable=0.15,
                upper=0.3 * top,
                actuation_max=A,
                censored=use,  # type: ignore[arg-type]
            )
            out.append(abs(fit.dead_zone - d))
    assert max(ties) <= 1.0 * STEP + 1e-9
    assert max(plain) >= 2.0 * STEP - 1e-9
    assert all(t <= p + 1e-9 for t, p in zip(ties, plain, strict=True))
