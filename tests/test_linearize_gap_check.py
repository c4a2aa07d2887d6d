"""The held-out gap test (torquemap.linearize.gaps): its false-alarm rate and its power, on a
closed-form torque at rest with Gaussian noise, and through build_tables on a simulated motor."""

from __future__ import annotations

import numpy as np

from torquemap.linearize.gaps import ALPHA, check_gaps, predict_across

N = 192
#: Uneven measured positions as an adaptive collection leaves them: every 2nd position near
#: the hand-overs, gaps of 4 and 8 elsewhere.
ANCHORS = np.array(
    [0, 2, 4, 6, 8, 16, 24, 32, 36, 40, 44, 48, 50, 52, 54, 56, 58, 60, 62, 64, 68, 72, 80, 88,
     96, 100, 104, 106, 108, 112, 114, 116, 118, 120, 122, 124, 126, 128, 132, 136, 144, 152,
     160, 164, 168, 170, 172, 174, 176, 178, 180, 184, 186, 188, 190]
)  # fmt: skip
P = np.arange(N)


def test_predict_across_reproduces_the_series_and_interpolates_the_rest() -> None:
    # a pure harmonic the series holds is predicted exactly across any gap (closed form)
    o = 0.3 * np.cos(2 * np.pi * 12 * P / N) + 0.1
    kept = np.setdiff1d(ANCHORS, [76, 80, 84])
    np.testing.assert_allclose(predict_across(o[kept], kept, (12,), N, 80), o[80], atol=1e-12)
    # without the series the prediction is the straight line between the neighbours
    line = predict_across(o[kept], kept, (), N, 80)
    expected = np.interp(80, [72, 88], [o[72], o[88]])
    np.testing.assert_allclose(line, expected, atol=1e-12)


def test_the_false_alarm_rate_is_at_most_alpha_when_the_series_holds_the_ripple() -> None:
    # null hypothesis: the torque at rest is the series (held across every gap) plus noise
    # of 0.05 N m, as large as what matters, so that the noise alone would warn under an
    # uncalibrated rule (the excess error of the widest gaps over a single position left out
    # is then the prediction's own noise, about 0.02 N m RMS); 400 draws: the rate's standard
    # error at ALPHA = 0.05 is 0.011, so 3 of them bound what a calibrated test shows by chance
    rng = np.random.default_rng(0)
    o = 0.3 * np.cos(2 * np.pi * 12 * P / N) + 0.1 * np.sin(2 * np.pi * 3 * P / N)
    fired = 0
    draws = 400
    for _ in range(draws):
        noisy = o + 0.05 * rng.standard_normal(N)
        fired += check_gaps(noisy, ANCHORS, (3, 12), N, matters=0.05).fired
    rate = fired / draws
    assert rate <= ALPHA + 3 * np.sqrt(ALPHA * (1 - ALPHA) / draws), rate


def test_it_fires_on_a_ripple_the_gaps_cannot_hold() -> None:
    # the series lacks the 16-position ripple (12 periods): across the gaps of 8 (half its
    # period) linear interpolation misses up to its whole amplitude, 0.1 N m, ten times what
    # matters; the noise (0.01 N m) is small beside it
    rng = np.random.default_rng(1)
    o = 0.1 * np.cos(2 * np.pi * 12 * P / N + 0.4)
    hits = sum(
        check_gaps(o + 0.01 * rng.standard_normal(N), ANCHORS, (), N, matters=0.01).fired
        for _ in range(50)
    )
    assert hits >= 48  # power: the excess error is 5 times what matters
    test = check_gaps(o, ANCHORS, (), N, matters=0.01)
    # the gaps named are the widest (8): 9 .. 15 and the others of 8, not the gaps of 4
    assert test.width == 8 and test.unheld[9:16].all() and not test.unheld[33:36].any()


def test_evenly_spaced_positions_are_not_tested() -> None:
    o = 0.1 * np.cos(2 * np.pi * 12 * P / N)
    test = check_gaps(o, np.arange(0, N, 4), (), N, matters=0.001)
    assert test.width == 0 and not test.fired
