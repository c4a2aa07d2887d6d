"""The onset law with the amplifier's curve, searched on the measured positions
(``build_tables(onset_form="amplifier", onset_search="measured")``, docs/linearize.md "stop 40
(L44)"). Checked by recovery of the simulator's own amplifier (dead zone, curve's direction,
torque ~ current) from the sensed torque the simulator computes, noise-free, measured every 4th
position and pulse width and interpolated linearly between the measured positions as the
forward model fills them: nothing of the table builder is used to make the surface."""

from __future__ import annotations

import numpy as np
import pytest

from torquemap.linearize.onset import CURVES, DEAD_ZONES, OnsetFit, OnsetForm, fit_onset
from torquemap.sim.motors import Amplifier
from torquemap.sim.rig import SimRig, brushless_dc_rig, variable_reluctance_rig

A = 255
STEP = float(DEAD_ZONES[1] * A)  # one step of the dead-zone grid [pulse widths]
CURVE_STEP = float(CURVES[1] - CURVES[0])  # one step of the curve grid
FRICTION = 0.1  # [N m]


def _sensed(rig: SimRig) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The simulator's sensed torque ``max(true - friction, 0)`` on a narrow ramp at every 4th
    pulse width and position, the other positions the linear interpolation between those.
    Returns the forward model, the levels, the ramp and the measured positions (mask)."""
    spec = rig.motor_spec(ramping="narrow")
    ramp = np.asarray(spec.ramp, dtype=np.float64)
    n = spec.positions_per_cycle
    p = np.arange(n)
    u = np.arange(0, A + 1, 4, dtype=np.float64)
    act = np.rint(ramp[:, None, :] * u[None, :, None])
    truth = np.maximum(rig.true_torque(p[:, None], act) - FRICTION, 0.0)
    measured = p % 4 == 0
    anchors = np.r_[p[measured], n]
    forward = np.stack(
        [np.interp(p, anchors, np.r_[truth[measured, j], truth[0, j]]) for j in range(u.size)],
        axis=1,
    )
    return forward, u, ramp, measured


def _fit(rig: SimRig, *, form: OnsetForm, on_measured: bool = False) -> OnsetFit:
    forward, u, ramp, measured = _sensed(rig)
    top = float(np.min(forward.max(axis=1)))
    return fit_onset(
        forward,
        u,
        ramp,
        readable=0.02 * top,
        upper=0.3 * top,
        actuation_max=A,
        form=form,
        search=measured if on_measured else None,
    )


@pytest.mark.parametrize("dead_band", [20.0, 36.0])
def test_a_concave_amplifier_s_dead_zone_is_recovered(dead_band: float) -> None:
    rig = brushless_dc_rig(rng=0, amplifier=Amplifier(dead_band=dead_band, curve=0.9))
    fit = _fit(rig, form="amplifier", on_measured=True)
    assert abs(fit.dead_zone - dead_band) <= STEP + 1e-9
    assert fit.exponent == 1.0  # brushless DC: torque ~ current
    # the simulator's curve ``a`` is the law's ``c = -a`` (> 0 concave there, < 0 here)
    assert abs(fit.curve + 0.9) <= CURVE_STEP


def test_every_position_or_the_power_law_misreads_it() -> None:
    """Why both parts: over every position (the interpolated cross-fades searched with the
    rest) the amplifier form, and the power law on the measured positions, put the same
    amplifier's dead zone at least two grid steps short."""
    rig = brushless_dc_rig(rng=0, amplifier=Amplifier(dead_band=36.0, curve=0.9))
    every = _fit(rig, form="amplifier")
    power = _fit(rig, form="power", on_measured=True)
    assert 36.0 - every.dead_zone >= 2 * STEP
    assert 36.0 - power.dead_zone >= 2 * STEP


def test_a_reluctance_motor_s_exponent_and_dead_zone() -> None:
    """Torque ~ current squared: the exponent 2 and the dead zone within a grid step."""
    rig = variable_reluctance_rig(rng=0, amplifier=Amplifier(dead_band=20.0, curve=0.6))
    fit = _fit(rig, form="amplifier", on_measured=True)
    assert fit.exponent == 2.0
    assert abs(fit.dead_zone - 20.0) <= STEP + 1e-9
    assert abs(fit.curve + 0.6) <= CURVE_STEP


def test_build_tables_refuses_an_unknown_search() -> None:
    from torquemap.linearize.motor import motor_spec
    from torquemap.linearize.tables import build_tables

    spec = motor_spec("m", phases=1, positions_per_cycle=8, equilibrium_positions=(0,))
    with pytest.raises(ValueError, match="onset_search"):
        build_tables(spec, [0], [0], [0.0], onset_search="every")  # type: ignore[arg-type]
