"""The white-noise level above the estimate's band (torquemap.noise_level)."""

from __future__ import annotations

import math

import numpy as np

from torquemap.noise_level import high_band_psd


def test_white_noise_psd_scales_with_the_rate_and_ignores_the_load() -> None:
    # sd 0.01 white noise on a 0.5 Hz load, at 2 kHz and read every 4th sample (500 Hz):
    # the one-sided PSD is sd^2 / (fs / 2), four times higher at the slower rate
    rng = np.random.default_rng(1)
    t = np.arange(200_000) / 2000.0
    x = 0.3 * np.sin(2 * np.pi * 0.5 * t) + rng.normal(0.0, 0.01, t.size)
    use = np.ones(t.size, dtype=bool)
    fast = high_band_psd(t, x, use)
    slow = high_band_psd(t[::4], x[::4], use[::4])
    # the median absolute deviation of 2e5 (5e4) Gaussian samples: a relative sd of about
    # 0.5 % (1 %) on the variance; within 2 % (4 %), measured -1.3 % and +0.7 %
    assert math.isclose(fast, 1e-4 / 1000.0, rel_tol=0.02)
    assert math.isclose(slow, 1e-4 / 250.0, rel_tol=0.04)


def test_a_log_too_slow_or_too_short_has_no_level() -> None:
    t = np.arange(5000) / 60.0  # 60 Hz: Nyquist 30 Hz, no band above 20 Hz worth the name
    assert math.isnan(high_band_psd(t, np.sin(t), np.ones(t.size, dtype=bool)))
    t = np.arange(5000) / 1000.0
    few = np.zeros(t.size, dtype=bool)
    few[:100] = True
    assert math.isnan(high_band_psd(t, np.sin(t), few))
