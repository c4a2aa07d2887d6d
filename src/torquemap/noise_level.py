"""The white-noise level of a torque signal, measured above the estimate's band.

A log polled slower than the one a model was identified from holds the same noise per sample
over a narrower band: its power spectral density in the estimate's band is higher by the
ratio of the rates (a logger that samples without an anti-alias filter folds everything
above its Nyquist frequency into that band: current noise, amplifier ripple, PDTV the model
misses). The model's residual PSD, measured on its identification logs, then understates the
estimate's noise on such a log (the simulated bench's circle read every 4th sample, 500 Hz:
63 % of the force errors within 2 sigma against 92 % at 2 kHz).

:func:`high_band_psd` measures the level above :data:`HIGH_BAND_SPLIT` (well above any
estimate's cut-off, where the external load has no content) on the samples where the joint
slides, robustly (a median absolute deviation, so that glitches and the odd impact do not
set it). Identification records it for its logs (``uncertainty.noise_high_psd``,
docs/formats.md); estimation measures it on the log it is given and adds what exceeds the
model's to the noise term of its sigmas (:func:`torquemap.uncertainty.joint_sigma`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.filters import lowpass
from torquemap.robust import mad_scale

#: [Hz] The high band starts here: ten times the estimate's default cut-off (2 Hz).
HIGH_BAND_SPLIT = 20.0
#: The band [in units of the split] that ``x`` less its forward-backward 2nd-order Butterworth
#: low-pass loses: ``integral (1 - H)^2`` falls short of the band by ``2 int H - int H^2``,
#: with ``H = 1 / (1 + f^4)``: ``pi / sqrt 2 - 3 pi / (8 sqrt 2) = 5 pi / (8 sqrt 2)``.
HIGH_BAND_LOSS = 5.0 * math.pi / (8.0 * math.sqrt(2.0))
#: Fewest samples the level is measured on (fewer: NaN).
MIN_SAMPLES = 200


def high_band_psd(
    t: NDArray[np.float64],
    x: NDArray[np.float64],
    use: NDArray[np.bool_],
    *,
    split: float = HIGH_BAND_SPLIT,
    step: float | None = None,
) -> float:
    """One-sided PSD [unit^2/Hz] of ``x``'s content above ``split`` [Hz], taken as white.

    ``x`` less its low-pass at ``split``, scaled by 1.4826 times its median absolute
    deviation over the samples ``use``, squared, over the band that difference passes: the
    log's Nyquist frequency (from its median step: ``step`` when the caller has it) less
    :data:`HIGH_BAND_LOSS` ``split``. NaN when the band is narrower than ``split``
    (a log slower than ``4 split``), when fewer than :data:`MIN_SAMPLES` samples are used, or
    when the log is too short for the filter.

    Examples
    --------
    White noise of sd 1 sampled at 1 kHz: a PSD of 1 / 500 per Hz.

    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(20000) / 1000.0
    >>> x = rng.normal(0.0, 1.0, t.size) + np.sin(2 * np.pi * 0.5 * t)
    >>> round(high_band_psd(t, x, np.ones(t.size, bool)) * 500, 1)
    1.0
    """
    if t.size < 2:
        return float("nan")
    fs = 1.0 / (float(np.median(np.diff(t))) if step is None else step)
    band = 0.5 * fs - HIGH_BAND_LOSS * split
    if not 0.5 * fs >= 2.0 * split or int(np.count_nonzero(use)) < MIN_SAMPLES:
        return float("nan")
    try:
        high = x - lowpass(t, x, cutoff=split)
    except InputError:  # too short for the filter
        return float("nan")
    return mad_scale(high[use]) ** 2 / band  # robust_scale's number, sooner
