"""The onset law searched on the measured positions (torquemap.linearize.onset.fit_onset's
``search``; not passed by build_tables, docs/linearize.md "stop 38 (L42)"): between measured
positions the forward model interpolates
the measured curves, which at a narrow ramp's cross-fades are not the law at the shares there.
Checked by recovery of a known dead zone and exponent from surfaces written here in closed
form (the law itself: a linear amplifier past its dead zone, torque ~ current or ~ current
squared), measured every 4th position and interpolated linearly between, as the forward model
fills them."""

from __future__ import annotations

import numpy as np
import pytest

from torquemap.linearize.motor import ramp_function
from torquemap.linearize.onset import DEAD_ZONES, fit_onset

A = 255
STEP = float(DEAD_ZONES[1] * A)  # one step of the dead-zone grid [pulse widths]


def _forward(d: float, n: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A 3-phase narrow ramp over 128 positions: sensed = max(sum_k G_k(p) x_k^n - F, 0),
    ``x_k = max(r_k(p) u - d, 0) / (A - d)``, at every 4th pulse width; the positions other
    than every 4th filled by the linear interpolation between the measured ones. Returns the
    forward model, the levels, the ramp and the measured positions (mask)."""
    ramp = ramp_function("narrow", phases=3, positions_per_cycle=128)
    p = np.arange(128)
    g = 8.0 * (1.0 + 0.1 * np.sin(2 * np.pi * p / 128))[:, None] * np.array([0.9, 1.0, 1.1])
    u = np.arange(0, A + 1, 4, dtype=float)
    x = np.maximum(ramp[:, None, :] * u[None, :, None] - d, 0.0) / (A - d)
    truth = np.maximum(np.einsum("pum,pm->pu", x**n, g) - 0.1, 0.0)
    measured = p % 4 == 0
    anchors = np.r_[p[measured], 128]
    forward = np.stack(
        [np.interp(p, anchors, np.r_[truth[measured, j], truth[0, j]]) for j in range(u.size)],
        axis=1,
    )
    return forward, u, ramp, measured


def _fit(d: float, n: float, *, on_measured: bool) -> tuple[float, float]:
    forward, u, ramp, measured = _forward(d, n)
    top = float(np.min(forward.max(axis=1)))
    fit = fit_onset(
        forward,
        u,
        ramp,
        readable=0.03,
        upper=0.3 * top,
        actuation_max=A,
        search=measured if on_measured else None,
    )
    return fit.dead_zone, fit.exponent


@pytest.mark.parametrize("n", [1.0, 2.0])
@pytest.mark.parametrize("d", [10.0, 20.0, 30.0, 40.0])
def test_measured_positions_recover_the_law(d: float, n: float) -> None:
    got_d, got_n = _fit(d, n, on_measured=True)
    assert abs(got_d - d) <= STEP / 2 + 1e-9
    assert got_n == pytest.approx(n)


@pytest.mark.parametrize(("d", "n"), [(30.0, 1.0), (40.0, 1.0), (30.0, 2.0), (40.0, 2.0)])
def test_every_position_misreads_a_large_dead_zone(d: float, n: float) -> None:
    """Why: the interpolated cross-fades, searched with the rest, pull the dead zone two or
    more grid steps short (to 2.6 with n = 0.8 for 30 and 40 at n = 1)."""
    got_d, _ = _fit(d, n, on_measured=False)
    assert d - got_d >= 2 * STEP


def test_search_without_cells_falls_back_to_every_position() -> None:
    forward, u, ramp, _ = _forward(20.0, 1.0)
    top = float(np.min(forward.max(axis=1)))
    kwargs = {"readable": 0.03, "upper": 0.3 * top, "actuation_max": A}
    none = fit_onset(forward, u, ramp, search=np.zeros(128, dtype=bool), **kwargs)
    every = fit_onset(forward, u, ramp, **kwargs)
    assert (none.dead_zone, none.exponent) == (every.dead_zone, every.exponent)
