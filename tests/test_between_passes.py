"""The friction table between two steady passes far apart (torquemap.between_passes)."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

from torquemap.between_passes import (
    anchor_knots,
    redraw_between_anchors,
    redraw_law,
    redraw_law_by_direction,
)
from torquemap.friction_law import SpeedTableFriction


def test_a_line_in_log_speed_is_kept_by_both_methods() -> None:
    # a friction magnitude linear in log speed: any interpolation that reproduces lines (the
    # chord, a cubic Hermite with Fritsch-Carlson slopes) must give it back between anchors
    s = np.geomspace(0.5, 40.0, 9)
    g = 0.1 - 0.01 * np.log(s)
    wrong = g.copy()
    wrong[[1, 2, 5, 6, 7]] += [0.02, -0.03, 0.01, 0.05, -0.02]
    anchors = np.array([0, 3, 4, 8])
    for method in ("pchip", "linear"):
        out = redraw_between_anchors(s, wrong, anchors, method)  # type: ignore[arg-type]
        assert_allclose(out, g, rtol=0, atol=1e-12)


def test_a_drop_between_anchors_stays_a_drop() -> None:
    # shape preservation (Fritsch-Carlson): anchors falling monotonically give knots that fall
    # monotonically between them and never leave the anchors' range (no overshoot), whatever
    # the fitted knots were
    s = np.geomspace(0.3, 30.0, 12)
    anchors = np.array([0, 2, 7, 11])
    g = np.full(s.size, 0.5)
    g[anchors] = [0.9, 0.85, 0.3, 0.29]
    out = redraw_between_anchors(s, g, anchors, "pchip")
    assert np.all(np.diff(out) <= 1e-15)
    assert out.min() >= 0.29 - 1e-15 and out.max() <= 0.9 + 1e-15
    assert_allclose(out[anchors], g[anchors], rtol=0, atol=0)


def test_knots_outside_the_anchors_are_the_fits() -> None:
    law = SpeedTableFriction(
        speeds=(0.1, 0.2, 0.5, 1.0, 2.0, 4.0, 8.0),
        positive=(0.3, 0.3, 0.28, 0.9, 0.2, 0.21, 0.2),
        negative=(0.4, 0.35, 0.3, -0.5, 0.25, 0.22, 0.2),
        viscous=0.01,
        viscous_negative=0.02,
        zero_velocity=0.01,
    )
    out = redraw_law(law, [0.5, 2.1, 8.0])
    assert anchor_knots(law.speeds, [0.5, 2.1, 8.0]).tolist() == [2, 4, 6]
    keep = [0, 1, 2, 4, 6]
    assert_allclose(np.array(out.positive)[keep], np.array(law.positive)[keep], atol=0)
    assert_allclose(np.array(out.negative)[keep], np.array(law.negative)[keep], atol=0)
    assert (out.viscous, out.viscous_negative) == (law.viscous, law.viscous_negative)
    # the magnitude g = level + viscous * s at the knot between 0.5 and 2 rad/s lies between
    # the anchors' magnitudes (the fit's outlier is gone)
    g_pos = out.levels(np.array([0.5, 1.0, 2.0]))[0]
    assert g_pos[2] <= g_pos[1] <= g_pos[0]


def test_coulomb_and_viscous_above_a_stribeck_drop_are_drawn_exactly() -> None:
    # g(s) = 0.05 + 0.02 exp(-(s / 1.0)^2) + 0.004 s sampled at anchors 0.3, 0.9, 4, 15, 50
    # rad/s: above 4 rad/s the drop is gone (exp(-16)) and g is a line in speed, which the
    # fastest anchors' secant gives exactly; in log speed alone a cubic lies above it
    s = np.geomspace(0.3, 50.0, 12)
    anchors = anchor_knots(s, [0.3, 0.9, 4.0, 15.0, 50.0])
    s[anchors] = [0.3, 0.9, 4.0, 15.0, 50.0]

    def g(v: np.ndarray) -> np.ndarray:
        return 0.05 + 0.02 * np.exp(-(v**2)) + 0.004 * v

    law = SpeedTableFriction(
        speeds=tuple(s),
        positive=tuple(np.where(np.isin(np.arange(12), anchors), g(s), 0.0)),
        negative=tuple(np.where(np.isin(np.arange(12), anchors), g(s), 0.0)),
        zero_velocity=0.01,
    )
    out = redraw_law(law, [0.3, 0.9, 4.0, 15.0, 50.0])
    above = s > 4.0
    assert_allclose(out.levels(s[above])[0], g(s[above]), rtol=1e-6)
    assert_allclose(out.levels(s[above])[1], g(s[above]), rtol=1e-6)
    # without the line taken out the same cubic is percents above the truth there
    plain = redraw_between_anchors(s, g(s), anchors, "pchip")
    assert np.max(plain[above] / g(s[above]) - 1.0) > 0.02


def test_each_direction_is_drawn_between_its_own_passes() -> None:
    # random robot 332 joint b: forward passes at 2, 12, 50 and 64 rad/s, backward at 2, 12
    # and 64 only. g(s) = 0.06 + 0.02 exp(-(s / 3)^2) + 0.001 s in both directions; the fit
    # left the backward knots between 12 and 64 rad/s (50 among them) bowed 3 mN m low. Each
    # direction drawn between its own passes gives the line in speed back there, to the drop's
    # remainder at 11.75 rad/s (0.02 exp(-15) = 6e-9 N m); anchoring the backward table at
    # the forward 50 rad/s pass keeps the bow.
    passes = [1.9, 11.75, 50.4, 64.0, -1.9, -11.75, -64.0]
    s = np.geomspace(0.07, 72.0, 15)
    anchors = anchor_knots(s, [abs(x) for x in passes])
    s[anchors] = [1.9, 11.75, 50.4, 64.0]

    def g(v: np.ndarray) -> np.ndarray:
        return 0.06 + 0.02 * np.exp(-((v / 3.0) ** 2)) + 0.001 * v

    gap = (s > 11.75) & (s < 64.0)
    bowed = g(s) - np.where(gap, 0.003, 0.0)
    law = SpeedTableFriction(
        speeds=tuple(s), positive=tuple(g(s)), negative=tuple(bowed), zero_velocity=0.01
    )
    out = redraw_law_by_direction(law, passes)
    assert_allclose(out.levels(s[gap])[1], g(s[gap]), rtol=0, atol=1e-8)
    old = redraw_law(law, [abs(x) for x in passes])
    # the forward passes are every pass speed here: the forward table is drawn as before
    assert_allclose(out.positive, old.positive, rtol=0, atol=0)
    assert np.max(np.abs(old.levels(s[gap])[1] - g(s[gap]))) > 0.002


def test_a_direction_with_one_pass_is_drawn_at_every_pass_speed() -> None:
    # backward held steady at one speed only (its table the forward one's, say): nothing of its
    # own to draw between, so it is drawn at every pass speed, as redraw_law draws it
    law = SpeedTableFriction(
        speeds=(1.0, 2.0, 4.0, 8.0),
        positive=(1.0, 3.0, 6.0, 8.0),
        negative=(1.0, 3.0, 6.0, 8.0),
        zero_velocity=0.01,
    )
    out = redraw_law_by_direction(law, [1.0, 8.0, -8.0], method="linear")
    old = redraw_law(law, [1.0, 8.0], method="linear")
    assert_allclose(out.linear_parameters(), old.linear_parameters(), rtol=0, atol=0)
    # a line in speed through the anchors (1, 1) and (8, 8)
    assert_allclose(out.negative, [1.0, 2.0, 4.0, 8.0], rtol=0, atol=1e-12)
