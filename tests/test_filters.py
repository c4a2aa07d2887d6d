"""filters: differentiation against closed forms, low-pass gain against the Butterworth formula."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.errors import InputError
from torquemap.filters import (
    MIN_RELATIVE_CUTOFF,
    differentiate,
    lowpass,
    smooth_as_acceleration,
)
from torquemap.friction import fit_inertia


def test_quadratic_is_exact_on_irregular_time() -> None:
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 2000))
    x = 1.0 + 2.0 * t - 3.0 * t**2
    d = differentiate(t, x, window=0.02)
    # a local quadratic fit reproduces a quadratic exactly, ends included (rounding only)
    assert_allclose(d.position, x, atol=1e-9)
    assert_allclose(d.velocity, 2.0 - 6.0 * t, atol=1e-6)
    assert_allclose(d.acceleration, -6.0, atol=1e-3)


def test_noisy_sine_matches_closed_form_derivatives() -> None:
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 4.0, 1e-3)
    w = 2 * np.pi * 0.5
    x = np.sin(w * t) + rng.normal(0.0, 1e-4, t.size)
    d = differentiate(t, x, window=0.1)
    inner = slice(100, -100)
    # window 0.1 s is 1/20 of the period: quadratic-fit bias ~ (w*window)^2/40 ~ 2.5e-3 relative;
    # the noise adds ~ 1e-4*sqrt(12/100)/0.1 = 3.5e-4 to the velocity
    assert_allclose(d.velocity[inner], w * np.cos(w * t[inner]), atol=0.01 * w)
    assert_allclose(d.acceleration[inner], -(w**2) * np.sin(w * t[inner]), atol=0.05 * w**2)


def test_differentiate_errors() -> None:
    t = np.linspace(0.0, 0.01, 11)
    with pytest.raises(InputError, match="shorter than the differentiation window"):
        differentiate(t, t, window=0.1)
    with pytest.raises(InputError, match="at least 5 samples"):
        differentiate(np.array([0.0, 1.0, 2.0, 10.0]), np.zeros(4), window=0.5)
    with pytest.raises(InputError, match="strictly increasing"):
        differentiate(np.array([0.0, 1.0, 1.0]), np.zeros(3), window=0.5)


@pytest.mark.parametrize("f", [2.0, 10.0, 30.0])
def test_lowpass_gain_is_squared_butterworth(f: float) -> None:
    t = np.arange(0.0, 4.0, 1e-3)
    y = lowpass(t, np.sin(2 * np.pi * f * t), cutoff=10.0, order=2)
    inner = slice(1000, -1000)
    gain = np.sqrt(2 * np.mean(y[inner] ** 2))
    # forward-backward Butterworth: |H|^2 = 1 / (1 + (f/fc)^(2n)); 1 % for the bilinear warp
    assert_allclose(gain, 1.0 / (1.0 + (f / 10.0) ** 4), rtol=0.02, atol=1e-3)


def test_lowpass_irregular_time_and_errors() -> None:
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 3000))
    y = lowpass(t, np.sin(2 * np.pi * 1.0 * t), cutoff=20.0)
    # 1 Hz is far below the 20 Hz cut-off: passes with < 1 % change (interpolation error only)
    assert_allclose(y[300:-300], np.sin(2 * np.pi * t[300:-300]), atol=0.01)
    with pytest.raises(InputError, match="Nyquist"):
        lowpass(t, t, cutoff=1e4)
    with pytest.raises(InputError, match="shorter than the low-pass filter"):
        lowpass(np.arange(5) * 1e-3, np.zeros(5), cutoff=10.0)


def test_lowpass_refuses_a_cut_off_float64_cannot_hold() -> None:
    t = np.arange(4000) * 1e-3  # Nyquist 500 Hz
    x = np.full(t.size, 3.0)
    # at the bound the design is still sound: a constant passes with gain 1 (DC gain of a
    # Butterworth; its float64 error there is ~1e-16 / 1e-10 = 1e-6 at most)
    y = lowpass(t, x, cutoff=MIN_RELATIVE_CUTOFF * 500.0)
    assert_allclose(y, 3.0, rtol=1e-6)
    with pytest.raises(InputError, match=r"below 1e-05 of the Nyquist frequency 500 Hz"):
        lowpass(t, x, cutoff=1e-9)  # was numpy.linalg.LinAlgError (a singular initial state)


@pytest.mark.parametrize("irregular", [False, True])
def test_smooth_as_acceleration_is_the_differentiators_kernel(irregular: bool) -> None:
    rng = np.random.default_rng(4)
    if irregular:
        t = np.cumsum(rng.uniform(0.8e-3, 1.2e-3, 3000))
    else:
        t = np.arange(3000) * 1e-3
    w1, w2 = 7.0, 23.0
    theta = np.sin(w1 * t) + 0.2 * np.cos(w2 * t) + t**3
    acc = -(w1**2) * np.sin(w1 * t) - 0.2 * w2**2 * np.cos(w2 * t) + 6.0 * t
    window = 0.1
    got = smooth_as_acceleration(t, acc, window=window)
    ref = differentiate(t, theta, window=window).acceleration
    # the differentiated acceleration of theta is its true acceleration through the kernel:
    # equal up to the trapezoidal rule's O(h^2) error, h^2 / 12 * acc'' ~ 5e-3 from the
    # 23 rad/s term (amplitude 106 rad/s^2); that term loses ~20 % through the window, so the
    # unsmoothed acc is far off
    inner = slice(100, -100)
    assert_allclose(got[inner], ref[inner], atol=1e-2)
    assert np.max(np.abs(ref[inner] - acc[inner])) > 5.0  # the filtering is real
    # unit sum: a constant passes unchanged
    assert_allclose(smooth_as_acceleration(t, np.full(t.size, 3.0), window=window), 3.0)
    with pytest.raises(InputError, match="shorter than the differentiation window"):
        smooth_as_acceleration(t[:50], acc[:50], window=0.2)


def test_matched_smoothing_removes_the_inertia_bias_of_ramps() -> None:
    # a trapezoidal move: acceleration steps at every ramp's start and end, where the local
    # quadratic smears it over the window
    h = 5e-4
    t = np.arange(0.0, 4.0, h)
    a_true = np.select(
        [t < 0.3, t < 1.0, t < 1.3, t < 2.0, t < 2.3, t < 3.0, t < 3.3],
        [40, 0, -40, 0, -40, 0, 40],
        0.0,
    )
    w = np.cumsum(a_true) * h
    theta = np.cumsum(w) * h
    inertia = 2e-4
    torque = inertia * a_true
    d = differentiate(t, theta, window=0.05)
    ramp = np.abs(d.acceleration) > 20.0  # the accelerating samples, as identify picks them
    naive = fit_inertia(d.acceleration[ramp], torque[ramp]).inertia.constant
    matched = smooth_as_acceleration(t, torque, window=0.05)
    fitted = fit_inertia(d.acceleration[ramp], matched[ramp]).inertia.constant
    # both sides through one filter: exact up to rounding and the discrete integration
    assert_allclose(fitted, inertia, rtol=1e-3)
    # the raw torque steps where the smeared acceleration has not yet: a biased fit
    assert abs(naive / inertia - 1.0) > 0.01


def test_window_widens_where_samples_are_sparse() -> None:
    # a quadratic across a 0.3 s gap in a 1 kHz log with a 0.05 s window: the windows next to the
    # gap hold too few samples and widen by samples; a local quadratic fit stays exact
    t = np.arange(0.0, 2.0, 1e-3)
    t = np.concatenate((t[t < 0.8], t[t > 1.1]))
    x = 0.5 - t + 2.0 * t**2
    d = differentiate(t, x, window=0.05)
    assert_allclose(d.velocity, -1.0 + 4.0 * t, atol=1e-6)
    assert_allclose(d.acceleration, 4.0, atol=1e-3)


def test_several_signals_at_once_match_one_by_one() -> None:
    rng = np.random.default_rng(5)
    t = np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 1500))
    x = rng.normal(size=(t.size, 3)).cumsum(axis=0)
    both = differentiate(t, x, window=0.03)
    for k in range(3):
        one = differentiate(t, x[:, k], window=0.03)
        assert_allclose(both.acceleration[:, k], one.acceleration, rtol=1e-9, atol=1e-9)
    sm = smooth_as_acceleration(t, x, window=0.03)
    assert_allclose(sm[:, 1], smooth_as_acceleration(t, x[:, 1], window=0.03), atol=1e-9)


def test_dilate_marks_the_samples_within_reach_of_a_marked_one() -> None:
    from torquemap.filters import dilate

    # the definition, sample by sample (a second algorithm): within reach of a marked sample,
    # on jittered time with repeated stamps (stamps on a 0.01 s grid, the reach between two
    # grid distances: no sample lies at the reach, where rounding would decide)
    rng = np.random.default_rng(11)
    t = np.sort(np.round(rng.uniform(0.0, 10.0, 600), 2))
    for share in (0.0, 0.01, 0.2):
        mask = rng.uniform(size=t.size) < share
        ref = np.array([bool(np.any(mask & (np.abs(t - ti) <= 0.075))) for ti in t])
        np.testing.assert_array_equal(dilate(t, mask, 0.075), ref)
