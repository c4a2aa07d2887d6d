"""The sigma of a friction table between steady passes (stop 44, F69): a table that departs from
the chord between the passes around a speed is uncertain by that departure
(``uncertainty.CHORD_SPREAD``, :func:`torquemap.pass_chord.chord_spread`).

Random robot 453's joint a law (Stribeck, Fc 0.103 / 0.135 N m) swept at 453's passes 0.452,
4.32 and 37.6 rad/s (8.7x apart at the top), identified by the whole fit; the truth is read by
the test only. 453's identified table rose 0.010 N m above the truth at 7.6 rad/s (0.004 at
12.7) where the law is flat, with a sigma of 0.002 there; this simulation's fit does not make
that error by itself, so the test puts 453's departure on the knots between the two upper passes
(the passes' own knots untouched) and measures the sigma against the simulator's law. A sweep
whose passes are at most 1.8x apart has its knots at the passes: there the table between two
passes is its chord and the sigma stays what it was (to rounding).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_identify_whole import robot, simulate

from torquemap import uncertainty
from torquemap.friction_law import SpeedTableFriction, StribeckFriction
from torquemap.identify import identify_model
from torquemap.model import Model
from torquemap.pass_chord import chord_spread

pytestmark = pytest.mark.xdist_group("pass_chord")

LAW = StribeckFriction(
    coulomb_positive=0.10307,
    coulomb_negative=0.13492,
    viscous=0.000945,
    stribeck_positive=0.014375,
    stribeck_negative=0.04848,
    stribeck_velocity=0.2141,
    zero_velocity=0.012,
    stribeck_exponent=2.0,
    transition="linear",
)
FAR = (0.452, 4.32, 37.6)
CLOSE = (0.5, 0.85, 1.45, 2.45, 4.2, 7.1)
HALF = float(np.sqrt(0.5))


def _identified(passes: tuple[float, ...]) -> Model:
    log = simulate(law=LAW, speeds=passes, ramp=0.4, noise=0.005, seed=3)
    return identify_model(robot(), [log], max_order=20, friction="whole").model


def _with_table(model: Model, law: SpeedTableFriction) -> Model:
    joint = dataclasses.replace(model.joints["m"], friction=law)
    return dataclasses.replace(model, joints={**model.joints, "m": joint})


def _steady_sigma(model: Model, velocity: np.ndarray, share: float) -> np.ndarray:
    """The joint's sigma [N m] in the middle of 4 s at each constant ``velocity`` (1 kHz)."""
    t = np.arange(0.0, 4.0, 1e-3)
    saved = uncertainty.CHORD_SPREAD
    out = []
    try:
        uncertainty.CHORD_SPREAD = share
        for v in velocity:
            s = uncertainty.joint_sigma(
                model,
                "m",
                t=t,
                theta=v * t,
                velocity=np.full(t.size, v),
                acceleration=np.zeros(t.size),
                modulation=np.zeros(t.size),
                cutoff=2.0,
            )
            out.append(s[t.size // 2])
    finally:
        uncertainty.CHORD_SPREAD = saved
    return np.array(out)


def _between(passes: tuple[float, ...]) -> np.ndarray:
    return np.geomspace(passes[0], passes[-1], 30)[1:-1]


@pytest.fixture(scope="module")
def bumped() -> Model:
    model = _identified(FAR)
    law = model.joints["m"].friction
    assert isinstance(law, SpeedTableFriction)
    knots = np.asarray(law.speeds)
    # 453's departure: +0.010 N m at the knot near 7.6 rad/s, +0.004 at the next (12.7)
    bump = np.where(
        (knots > 1.02 * FAR[1]) & (knots < FAR[2] / 1.02),
        0.010 * np.clip(1.0 - np.abs(np.log(knots / 7.42)) / np.log(2.5), 0.0, None),
        0.0,
    )
    assert np.count_nonzero(bump) == 2 and bump.max() > 0.0099  # the knots at 7.4 and 12.7
    table = dataclasses.replace(
        law,
        positive=tuple(np.asarray(law.positive) + bump),
        negative=tuple(np.asarray(law.negative) + bump),
    )
    return _with_table(model, table)


def test_chord_spread_in_closed_form() -> None:
    # dry levels 0.2, 0.26, 0.2 at 1, 2, 4 rad/s and passes at 1 and 4: the chord is 0.2, the
    # departure 0.06 at 2 rad/s and half of it at sqrt(2) (linear in log speed); the viscous
    # term (0.01 s) is not part of either; no departure beyond the passes
    law = SpeedTableFriction(
        speeds=(1.0, 2.0, 4.0),
        positive=(0.2, 0.26, 0.2),
        negative=(0.3, 0.3, 0.3),
        viscous=0.01,
        viscous_negative=0.01,
        zero_velocity=1e-3,
    )
    v = np.array([2.0, np.sqrt(2.0), 0.5, 6.0, -2.0])
    got = chord_spread(law, v, 1e-3, [1.0, 4.0, -1.0, -4.0])
    np.testing.assert_allclose(got, [0.06, 0.03, 0.0, 0.0, 0.0], atol=1e-12)
    # "both", a flat dry level: none off the dry chord, but the whole level (0.21 at 1 rad/s,
    # 0.24 at 4) has the chord 0.225 at 2 rad/s, where the table holds 0.22
    flat = dataclasses.replace(law, positive=(0.2, 0.2, 0.2))
    assert chord_spread(flat, v[:1], 1e-3, [1.0, 4.0])[0] == 0.0
    both = chord_spread(flat, v[:1], 1e-3, [1.0, 4.0], chords="both")
    np.testing.assert_allclose(both, [0.005], atol=1e-12)
    # a direction with one pass has no chord
    assert chord_spread(law, np.array([2.0]), 1e-3, [1.0])[0] == 0.0


def test_the_sigma_covers_a_table_off_its_chord_between_passes_far_apart(bumped: Model) -> None:
    v = _between(FAR)
    law = bumped.joints["m"].friction
    for sign in (1.0, -1.0):
        err = np.abs(law.torque(sign * v) - LAW.torque(sign * v))
        before = _steady_sigma(bumped, sign * v, 0.0)
        after = _steady_sigma(bumped, sign * v, HALF)
        # measured: 68 % of the speeds' errors within 2 sigma before, 93 / 100 % after
        assert np.mean(err <= 2.0 * before) < 0.75
        assert np.mean(err <= 2.0 * after) >= 0.9
        # honest, not padded: where the error peaks (the bump, 9.4-9.7 mN m) the sigma is
        # below the error (measured 1.5x and 1.3x the sigma; before 28x)
        peak = int(np.argmax(err))
        assert err[peak] > 0.008
        assert 1.0 < err[peak] / after[peak] < 2.0
        assert err[peak] / before[peak] > 10.0
        # the term only adds: nowhere narrower (below the middle pass the fit's own table
        # departs from its chord a little: the sigma there 1.0-1.9x, measured)
        assert np.all(after >= before)


def test_the_sigma_stays_where_the_knots_are_the_passes() -> None:
    model = _identified(CLOSE)
    law = model.joints["m"].friction
    assert isinstance(law, SpeedTableFriction)
    # passes at most 1.8x apart: every knot above the slowest pass is a pass
    above = np.asarray(law.speeds) >= CLOSE[0] * 0.99
    np.testing.assert_allclose(np.asarray(law.speeds)[above], CLOSE, rtol=0.02)
    v = _between(CLOSE)
    for sign in (1.0, -1.0):
        before = _steady_sigma(model, sign * v, 0.0)
        after = _steady_sigma(model, sign * v, HALF)
        np.testing.assert_allclose(after, before, rtol=1e-9)
        err = np.abs(law.torque(sign * v) - LAW.torque(sign * v))
        # the truth within 2 sigma everywhere (measured: at most 0.59 sigma)
        assert np.all(err <= 2.0 * after)
