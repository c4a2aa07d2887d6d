"""The knee per position (torquemap.linearize.knee_track).

Checked on a closed-form friction zone whose knee moves across the cycle: two phases handing
over (phase 2's share ``0.5 + 0.5 sin(2 pi p / P)``), each torque growing with the square of its
actuation past a dead zone or linearly with it (a variable-reluctance or a brushless motor), the
sensor reading ``max(torque - friction, 0)``, optionally with seeded noise, every 4th position
and pulse width measured. The true knee at every position is the root of ``torque = friction``,
in closed form.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from torquemap.linearize.knee_track import cut_below_knee, knee_at, knee_between

P = 64
TOP = 200
LEVELS = np.arange(0.0, TOP + 1.0, 4.0)
FINE = np.arange(0.0, TOP + 1.0)
ANCHORS = np.arange(0, P, 4)
FRICTION = 0.4  # N m
DEAD_ZONE = 20.0


def _shares(p: NDArray[np.float64]) -> NDArray[np.float64]:
    """Both phases' shares of the base pulse width, shape (P, 2)."""
    two = 0.5 + 0.5 * np.sin(2 * np.pi * p / P)
    return np.c_[1.0 - two, two]


def _drive(u: NDArray[np.float64], exponent: float) -> NDArray[np.float64]:
    """``sum_k G max(r_k(p) u - d, 0)^n`` [N m] on the (P, U) grid; G puts the knee of a phase
    alone 40 pulse widths past the dead zone."""
    gain = FRICTION / 40.0**exponent
    r = _shares(np.arange(P, dtype=np.float64))
    a = r[:, None, :] * u[None, :, None]
    out: NDArray[np.float64] = np.sum(gain * np.maximum(a - DEAD_ZONE, 0.0) ** exponent, axis=2)
    return out


def _true_knee(exponent: float) -> NDArray[np.float64]:
    """Where the drive reaches the friction at every position, by bisection [pulse width]."""
    lo, hi = np.zeros(P), np.full(P, float(TOP))
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        up = np.array([_drive(np.array([m]), exponent)[p, 0] for p, m in enumerate(mid)])
        above = up >= FRICTION
        hi, lo = np.where(above, mid, hi), np.where(above, lo, mid)
    return 0.5 * (lo + hi)


def _readings(exponent: float, noise: float, rng: int) -> NDArray[np.float64]:
    """Sensed torque at the measured cells (NaN elsewhere), shape (P, J)."""
    truth = np.maximum(_drive(LEVELS, exponent) - FRICTION, 0.0)
    out = np.full(truth.shape, np.nan)
    draw = np.random.default_rng(rng).normal(0.0, noise, truth.shape)
    out[ANCHORS] = np.maximum(truth[ANCHORS] + draw[ANCHORS], 0.0)
    return out


def test_the_knee_moves_across_the_cycle() -> None:
    # the case is one whose knee moves by far more than a level step between measured
    # positions (what the surface's torque at rest cannot follow)
    knee = _true_knee(2.0)
    assert np.max(np.abs(np.diff(knee))) > 4.0
    assert knee.max() - knee.min() > 30.0


def test_a_hinge_is_recovered_to_the_search_grid() -> None:
    # the sensed torque rising linearly from its knee: the hinge is the model, the search grid
    # is a tenth of the level step (0.4 pulse width), so the knee is found within 0.2
    knee = np.linspace(21.0, 57.0, P)
    sensed = np.maximum(0.05 * (LEVELS[None, :] - knee[:, None]), 0.0)
    np.testing.assert_allclose(knee_at(sensed, LEVELS, noise=0.001), knee, atol=0.2 + 1e-9)


def test_the_knee_at_the_measured_positions() -> None:
    truth = _true_knee(2.0)[ANCHORS]
    # noise-free, a torque growing with the square of the actuation past the knee: the
    # straight hinge through the first readings is late by the curve's bend, within one level
    # step (4 pulse widths) and never early by more than the search grid
    found = knee_at(_readings(2.0, 0.0, 0), LEVELS, noise=0.0)[ANCHORS]
    assert np.all(found - truth < 4.0)
    assert np.all(found - truth > -0.4)
    # linear past the knee (a brushless motor): the hinge is the law, within the search grid
    # once both phases' knees are out of the window (here everywhere: one leads at the knee)
    truth1 = _true_knee(1.0)[ANCHORS]
    found1 = knee_at(_readings(1.0, 0.0, 0), LEVELS, noise=0.0)[ANCHORS]
    np.testing.assert_allclose(found1, truth1, atol=0.4 + 1e-9)
    # with a row's noise of 1 % of the friction (seeded, 5 draws): within one level step in
    # root mean square
    for rng in range(5):
        noisy = knee_at(_readings(2.0, 0.004, rng), LEVELS, noise=0.004)[ANCHORS]
        assert np.sqrt(np.mean((noisy - truth) ** 2)) < 4.0


def test_the_knee_between_measured_positions_follows_the_drive() -> None:
    # the friction is the same everywhere, so the drive at the knee is the friction at every
    # position: given the true knees at the measured positions and the true drive, the knee
    # between them is exact up to the drive's linear interpolation between whole pulse widths
    # (a parabola of curvature 2 G r^2 over one pulse width: under 0.01 pulse width here)
    for exponent in (1.0, 2.0):
        truth = _true_knee(exponent)
        given = np.where(np.isin(np.arange(P), ANCHORS), truth, np.nan)
        found = knee_between(given, ANCHORS, _drive(FINE, exponent))
        np.testing.assert_allclose(found, truth, atol=0.01)
        # the knee linear between measured positions (what the drive adds): far off
        linear = np.interp(np.arange(P), ANCHORS, truth[ANCHORS], period=P)
        assert np.max(np.abs(linear - truth)) > 2.0


def test_the_leading_actuation_is_a_drive() -> None:
    # without a surface, the leading phase's actuation: a knee at a fixed leading actuation is
    # carried exactly
    lead = _shares(np.arange(P, dtype=np.float64)).max(axis=1)
    truth = 40.0 / lead
    given = np.where(np.isin(np.arange(P), ANCHORS), truth, np.nan)
    found = knee_between(given, ANCHORS, lead[:, None] * FINE[None, :])
    np.testing.assert_allclose(found, truth, atol=1e-9)


def test_no_knee_leaves_its_block_alone() -> None:
    # a measured position without a knee (the rest torque loads the contact): nothing on the
    # positions between it and its neighbours, which keep their own; fewer than two knees:
    # nothing anywhere
    truth = _true_knee(2.0)
    given = np.where(np.isin(np.arange(P), ANCHORS), truth, np.nan)
    given[8] = np.nan
    found = knee_between(given, ANCHORS, _drive(FINE, 2.0))
    assert np.isnan(found[5:12]).all()
    assert found[4] == truth[4] and found[12] == truth[12]
    assert np.isfinite(found[12:]).all() and np.isfinite(found[:5]).all()
    one = np.full(P, np.nan)
    one[0] = 40.0
    assert np.isnan(knee_between(one, ANCHORS, _drive(FINE, 2.0))).all()
    # a level below the first reading above the noise not measured, or the first level
    # already above it: no knee
    sensed = _readings(2.0, 0.0, 0)
    sensed[0, 2] = np.nan
    sensed[4] = sensed[4] + 1.0
    found = knee_at(sensed, LEVELS, noise=0.0)
    assert np.isnan(found[0]) and np.isnan(found[4]) and np.isfinite(found[8])


def test_the_cut_holds_zero_below_the_knee_and_the_model_above() -> None:
    # a model whose knee is early by 10 pulse widths everywhere (the surface's torque at rest
    # too high): cut at the true knee it is zero below it, unchanged above, non-decreasing
    truth = _true_knee(2.0)
    model = np.maximum(_drive(FINE + 10.0, 2.0) - FRICTION, 0.0)
    out = cut_below_knee(model, truth)
    below = FINE[None, :] < truth[:, None]
    assert np.all(out[below] == 0.0)
    np.testing.assert_array_equal(out[~below], model[~below])
    assert np.all(np.diff(out, axis=1) >= 0.0)
    # a model whose own knee is later is left as it is
    late = np.maximum(_drive(FINE - 10.0, 2.0) - FRICTION, 0.0)
    np.testing.assert_array_equal(cut_below_knee(late, truth), late)
