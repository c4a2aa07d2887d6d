"""The friction table's leave-one-pass-out interpolation error (``uncertainty.interpolation``).

Between two steady passes a whole fit's friction table is held by the ramps and its smoothness
prior only. :func:`torquemap.identify_whole.pass_interpolation_error` leaves each pass out in
turn and measures how far the table moves at its speed; estimation turns the curvature that
implies into a model-form sigma at any speed (:func:`torquemap.uncertainty.interpolation_sigma`).
Checked against a closed form (a parabola in log speed and its chord) and against a second,
independent measurement: a sweep simulated without the pass at all, identified, and its table
compared with the true law at the left-out speed.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray
from test_identify_whole import robot, simulate

from torquemap.friction_law import StribeckFriction
from torquemap.identify import identify_model
from torquemap.identify_whole import interpolation_gap
from torquemap.uncertainty import interpolation_sigma

# a Stribeck drop (exponent 2.7 at 3 rad/s) across the passes at 1.2 to 5.55 rad/s; 20 ms
# ramps: between passes only the ramps and the prior hold the table
LAW = StribeckFriction(
    coulomb_positive=0.036,
    coulomb_negative=0.046,
    viscous=0.00027,
    stribeck_positive=0.017,
    stribeck_negative=0.010,
    stribeck_velocity=3.0,
    stribeck_exponent=2.7,
    zero_velocity=0.05,
    transition="smooth",
)
PASSES = (1.2, 2.25, 3.53, 5.55, 8.72)


def test_the_sigma_is_a_parabolas_departure_from_its_chord() -> None:
    # f(x) = c x^2 / 2 in x = log s departs from its chord between x_a and x_b by exactly
    # c / 2 (x - x_a)(x_b - x): the sigma with curvature c at passes s_a, s_b is that departure
    c = 0.004
    sa, sb = 1.5, 6.0
    s = np.geomspace(sa, sb, 9)
    x, xa, xb = np.log(s), math.log(sa), math.log(sb)
    f = 0.5 * c * x**2
    chord = f[0] + (f[-1] - f[0]) * (x - xa) / (xb - xa)
    # each direction its own passes; a velocity well above the transition width is one branch
    passes = [sa, sb, -sa, -sb]
    for sign in (1.0, -1.0):
        sigma = interpolation_sigma(sign * s, 1e-3, passes, c)
        np.testing.assert_allclose(sigma, np.abs(f - chord), rtol=1e-9, atol=1e-15)
    # beyond the outer pass, the departure from the line through the two nearest
    beyond = 12.0
    line = f[0] + (f[-1] - f[0]) * (math.log(beyond) - xa) / (xb - xa)
    np.testing.assert_allclose(
        interpolation_sigma(np.array([beyond]), 1e-3, passes, c),
        [abs(0.5 * c * math.log(beyond) ** 2 - line)],
        rtol=1e-9,
    )
    assert interpolation_gap(math.log(beyond), [xa, xb]) > 0


@pytest.mark.parametrize("prior", [False, True])
@pytest.mark.parametrize("held", [0, 1, 2])
def test_leave_one_pass_out_matches_a_sweep_without_the_pass(held: int, prior: bool) -> None:
    # both fits with the same prior: the smoothness prior (False) or the one centred on a
    # Stribeck curve (True). Not the default choice between them ("select"): the sweep without
    # its slowest pass chooses by its next-slowest and so need not choose as the full one does
    full = identify_model(
        robot(),
        [simulate(law=LAW, ramp=0.02, speeds=PASSES)],
        max_order=20,
        friction="whole",
        stribeck_prior=prior,
    )
    record = full.model.notes["joints"]["m"]["uncertainty"]["interpolation"]
    speeds = np.asarray(record["speeds"])
    errors = np.asarray(record["errors"])
    at = np.abs(np.abs(speeds) - PASSES[held]) < 1e-3 * PASSES[held]
    assert at.sum() == 2  # both directions left out
    loo = float(np.sqrt(np.mean(errors[at] ** 2)))
    # the second measurement: the sweep without that pass, its table at that speed
    others = tuple(s for i, s in enumerate(PASSES) if i != held)
    part = identify_model(
        robot(),
        [simulate(law=LAW, ramp=0.02, speeds=others)],
        max_order=20,
        friction="whole",
        stribeck_prior=prior,
    )
    v = np.array([PASSES[held], -PASSES[held]])
    error = part.model.joints["m"].friction.torque(v) - LAW.torque(v)
    measured = float(np.sqrt(np.mean(error**2)))
    assert measured > 0.01 * 0.04  # a real error: 1 % of the friction level
    # measured 4.6, 2.2, 0.9 mN m; the leave-one-pass-out error 6.2, 2.2, 1.2 (the two sweeps
    # differ in their noise and in the ramps beside the left-out pass); with the curve-centred
    # prior 2.9, 1.8, 0.45 against 2.3, 1.1, 0.4
    assert 0.5 < loo / measured < 2.0
    # the full fit, with its pass, is much closer there: the error is the interpolation's
    full_error = full.model.joints["m"].friction.torque(v) - LAW.torque(v)
    assert float(np.sqrt(np.mean(full_error**2))) < 0.3 * measured
    # and the curvature reproduces it at the pass's gap
    c = float(record["curvature"])
    gap = interpolation_gap(math.log(PASSES[held]), [math.log(s) for s in others])
    assert c > 0 and 0.5 * c * gap > 0.2 * measured


def test_joint_sigma_adds_the_interpolation_error_between_passes(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    import torquemap.uncertainty as unc

    model = identify_model(
        robot(), [simulate(law=LAW, ramp=0.02, speeds=PASSES)], max_order=20, friction="whole"
    ).model
    t = np.arange(0.0, 4.0, 1e-3)

    def sigma(speed: float, on: bool) -> NDArray[np.float64]:
        monkeypatch.setattr(unc, "INTERPOLATION", on)
        v = np.full(t.size, speed)
        return unc.joint_sigma(
            model,
            "m",
            t=t,
            theta=speed * t,
            velocity=v,
            acceleration=np.zeros(t.size),
            modulation=np.zeros(t.size),
            cutoff=2.0,
        )

    # at a pass (the speed the notes record) the interpolation error is 0: main's sigma to
    # the bit
    recorded = [float(x) for x in model.notes["joints"]["m"]["speeds"] if x > 0]
    at = min(recorded, key=lambda x: abs(math.log(x / PASSES[2])))
    np.testing.assert_array_equal(sigma(at, True), sigma(at, False))
    # halfway between two passes (log speed) it adds c q / 2 to the friction's level
    mid = math.sqrt(PASSES[2] * PASSES[3])
    on, off = sigma(mid, True), sigma(mid, False)
    c = float(model.notes["joints"]["m"]["uncertainty"]["interpolation"]["curvature"])
    form = 0.5 * c * math.log(mid / PASSES[2]) * math.log(PASSES[3] / mid)
    inside = slice(1000, 3000)  # away from the low-pass's ends
    assert np.all(on[inside] > off[inside])
    # independent parts add in quadrature: the rise is at most the form level itself
    rise = np.sqrt(on[inside] ** 2 - off[inside] ** 2)
    np.testing.assert_array_less(rise, form * (1 + 1e-9))
    assert float(np.median(rise)) > 0.5 * form
