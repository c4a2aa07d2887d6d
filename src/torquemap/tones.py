"""Tones in a torque signal: fixed-frequency lines a slower logger can fold into the estimate.

A drive's current often holds lines at fixed frequencies in time, not locked to the motor's
position: the ripple of the DC bus (300 Hz from a 50 Hz three-phase rectifier, 360 Hz at
60 Hz), the inverter's and the control loop's own frequencies. At the identification logs'
rate they lie far above the estimate's low-pass and do no harm. A log sampled slower, without
an anti-alias filter, folds a tone at ``f`` to ``|f - k fs|`` (``fs`` the log's rate, ``k`` the
nearest whole number): a 300 Hz ripple sampled at 100 Hz lands on 0 Hz and reads as a constant
load, which no filter can take out and no measure on the slow log can see (the paper's bench
at 100 Hz: 58 % force error, 26 % of it within 2 sigma, before this module).

:func:`find_tones` finds the lines of the identification logs' residual (torque less the
model) above :data:`torquemap.noise_level.HIGH_BAND_SPLIT` by Welch's method: a bin is a line
where its power exceeds the running median of the spectrum by the chi-square quantile of its
averaged segments at a false-alarm rate of :data:`FALSE_ALARM` over all the bins; neighbouring
such bins are one tone, whose amplitude is ``sqrt(2 P)`` with ``P`` its power above the floor.
Identification records them (``uncertainty.tones``, docs/formats.md); estimation folds each
to the log's rate and adds what the low-pass passes of it to the sigma
(:func:`folded_sd`), and says so when it matters.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from torquemap.noise_level import HIGH_BAND_SPLIT

#: Probability that noise alone gives a tone anywhere in the spectrum.
FALSE_ALARM = 1e-3
#: Target frequency resolution [s of log per Welch segment]: 0.25 Hz, well inside the
#: estimate's 2 Hz band, so that a fold near 0 Hz is placed to a fraction of that band.
SEGMENT = 4.0
#: Bins of the running median that stands for the noise floor (about 25 Hz at 0.25 Hz).
FLOOR_BINS = 101
#: Speed groups (of Welch's segments) a line fixed in time must stand out in, each.
GROUPS = 3
#: The most Welch segments averaged (spread over the pieces by their lengths): a chi-square of
#: 1024 degrees of freedom, and a cost that stops growing with the log.
MOST_SEGMENTS = 512
#: The most tones kept per joint (the largest).
MOST = 16


@dataclass(frozen=True, slots=True)
class Tone:
    """A fixed-frequency line of a torque signal.

    Attributes
    ----------
    frequency
        [Hz].
    amplitude
        Peak amplitude [unit of the signal, N m for a torque].
    """

    frequency: float
    amplitude: float


def nominal_step(t: NDArray[np.float64]) -> float:
    """The sampling step [s] of increasing stamps ``t``: their span over the whole number of
    median steps it holds (jitter averages out and a dropped sample counts as a step, where the
    median alone is off by up to the jitter, and over a long log the grid drifts by as much).

    >>> t = np.r_[np.arange(10.0), np.arange(11.0, 21.0)] * 0.001  # one sample dropped
    >>> round(nominal_step(t), 12)
    0.001
    """
    steps = np.diff(t)
    median = float(np.median(steps))
    if not median > 0:
        return median
    # each step counted on its own (1, or 2 over a dropped sample): jitter far below a step
    # cannot miscount, where the span over the median would by the median's own error times n
    count = int(np.sum(np.maximum(np.rint(steps / median), 1.0)))
    return float(t[-1] - t[0]) / count


def _regular(
    t: NDArray[np.float64], *xs: NDArray[np.float64]
) -> tuple[list[NDArray[np.float64]], float]:
    """``xs`` on a grid of the nominal step from ``t[0]`` (linear interpolation where
    jittered)."""
    step = nominal_step(t)
    n = round(float(t[-1] - t[0]) / step) + 1
    if np.allclose(np.diff(t), step, rtol=1e-6, atol=0.0):
        return [x[:n] for x in xs], 1.0 / step
    grid = t[0] + step * np.arange(n)
    return [np.interp(grid, t, x) for x in xs], 1.0 / step


def _segments(
    x: NDArray[np.float64], speed: NDArray[np.float64], nper: int, most: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Welch's periodograms of ``x`` (Hann window, half overlap, a line taken out of each
    segment; one-sided, density scaling; at most ``most`` segments, evenly spread) and each
    segment's mean speed."""
    from scipy import signal

    hop = nper // 2
    starts = np.arange(0, x.size - nper + 1, hop)
    if starts.size == 0:
        return np.zeros((0, nper // 2 + 1)), np.zeros(0)
    if starts.size > most:  # evenly spread over the piece: the statistic needs no more
        starts = starts[np.linspace(0, starts.size - 1, most).round().astype(np.int64)]
    frames = np.lib.stride_tricks.sliding_window_view(x, nper)[starts]
    # each segment less its least-squares line (orthonormal mean and ramp)
    ramp = np.arange(nper) - 0.5 * (nper - 1)
    ramp /= math.sqrt(float(np.sum(ramp**2)))
    frames = frames - frames.mean(axis=1, keepdims=True) - np.outer(frames @ ramp, ramp)
    window = signal.windows.hann(nper, sym=False)
    spectra = np.abs(np.fft.rfft(frames * window, axis=1)) ** 2 / float(np.sum(window**2))
    spectra[:, 1:-1] *= 2.0  # one-sided (per sample; divided by the rate by the caller)
    means = np.array([float(np.mean(speed[a : a + nper])) for a in starts])
    return spectra, means


def _lines(
    psd: NDArray[np.float64], f: NDArray[np.float64], segments: int, split: float
) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """The bins of ``psd`` (an average of ``segments`` periodograms) that stand above its
    running median by the chi-square quantile at :data:`FALSE_ALARM` over all bins, and
    that median."""
    from scipy import signal, stats

    floor = signal.medfilt(psd, min(FLOOR_BINS, psd.size - (1 - psd.size % 2)))
    dof = 2 * segments
    above = float(stats.chi2.ppf(1.0 - FALSE_ALARM / psd.size, dof)) / dof
    return (psd > above * floor) & (f > split) & (floor > 0), floor


def find_tones(
    pieces: Sequence[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]],
    *,
    split: float = HIGH_BAND_SPLIT,
) -> tuple[Tone, ...]:
    """The fixed-frequency lines above ``split`` [Hz] of a signal given in pieces.

    A line fixed in time is at the same frequency whatever the motor does; a position-locked
    one (PDTV the model misses, at ``order * speed / 2 pi``) moves with the speed. So the
    segments are ranked by their mean speed into :data:`GROUPS` groups (two when there are
    fewer than four segments a group) and a line is kept only where every group holds it
    (within a bin); its amplitude is measured on every segment.

    Parameters
    ----------
    pieces
        ``(t, x, velocity)`` per piece: time [s], increasing; the signal (a torque residual,
        the model taken out); the motor velocity [rad/s]. Pieces at other rates than the
        longest one's are left out.
    split
        Lowest frequency searched [Hz].

    Returns
    -------
    tuple of Tone
        At most :data:`MOST`, largest first; empty when the pieces are too short (a segment is
        :data:`SEGMENT` s, or a quarter of the longest piece, but not under a quarter of
        :data:`SEGMENT`) or too slow (Nyquist below ``2 split``).

    Examples
    --------
    White noise of sd 1 with a 300 Hz line of amplitude 0.2, 60 s at 2 kHz:

    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(120000) / 2000.0
    >>> x = rng.normal(0.0, 1.0, t.size) + 0.2 * np.sin(2 * np.pi * 300.0 * t + 1.0)
    >>> [(round(s.frequency, 1), round(s.amplitude, 2)) for s in find_tones([(t, x, t)])]
    [(300.0, 0.2)]
    """
    regular = [_regular(t, x, np.abs(v)) for t, x, v in pieces if t.size >= 16]
    if not regular:
        return ()
    fs = max(regular, key=lambda r: r[0][0].size)[1]
    regular = [r for r in regular if abs(r[1] - fs) <= 1e-3 * fs]
    longest = max(r[0][0].size for r in regular)
    nper = min(int(2 ** math.ceil(math.log2(SEGMENT * fs))), 2 ** int(math.log2(longest / 4)))
    if 0.5 * fs < 2.0 * split or 4 * nper < SEGMENT * fs:
        return ()
    total = sum(r[0][0].size for r in regular)
    parts = [
        _segments(x, v, nper, max(2, MOST_SEGMENTS * x.size // total)) for (x, v), _ in regular
    ]
    spectra = np.concatenate([p[0] for p in parts]) / fs
    speeds = np.concatenate([p[1] for p in parts])
    if speeds.size < 4:
        return ()
    f = np.asarray(np.fft.rfftfreq(nper, 1.0 / fs), dtype=np.float64)
    df = float(f[1] - f[0])
    psd = spectra.mean(axis=0)
    hit, floor = _lines(psd, f, speeds.size, split)
    # a line fixed in time is in the slow, the middle and the fast third of the segments alike
    groups = GROUPS if speeds.size >= 4 * GROUPS else 2
    rank = np.argsort(np.argsort(speeds, kind="stable"), kind="stable") * groups // speeds.size
    for g in range(groups):
        part = spectra[rank == g]
        found, _ = _lines(part.mean(axis=0), f, part.shape[0], split)
        hit &= np.convolve(found, np.ones(3), mode="same") > 0
    tones = []
    i = 0
    while i < hit.size:
        if not hit[i]:
            i += 1
            continue
        j = i
        while j + 1 < hit.size and hit[j + 1]:
            j += 1
        # the line's power: its bins and the window's skirt (3 bins each side) above the floor
        lo, hi = max(i - 3, 0), min(j + 4, psd.size)
        excess = np.clip(psd[lo:hi] - floor[lo:hi], 0.0, None)
        power = float(np.sum(excess)) * df
        if power > 0:
            centre = float(np.sum(f[lo:hi] * excess) / np.sum(excess))
            tones.append(Tone(frequency=centre, amplitude=math.sqrt(2.0 * power)))
        i = j + 1
    tones.sort(key=lambda s: -s.amplitude)
    return tuple(tones[:MOST])


def folded(frequency: float, rate: float) -> float:
    """Where a line at ``frequency`` [Hz] lands in a log sampled at ``rate`` [Hz]: ``|f - k
    rate|`` with ``k`` the nearest whole number.

    >>> folded(300.0, 100.0), folded(300.0, 2000.0), round(folded(300.0, 143.0), 6)
    (0.0, 300.0, 14.0)
    """
    return abs(frequency - rate * round(frequency / rate))


def folded_sd(tones: Sequence[Tone], rate: float, cutoff: float) -> float:
    """Standard deviation [unit of the tones] the tones add to an estimate low-passed at
    ``cutoff`` [Hz] (a forward-backward 2nd-order Butterworth: gain ``1 / (1 + (f /
    cutoff)^4)``) on a log sampled at ``rate`` [Hz] without an anti-alias filter: each folded
    line a sinusoid of unknown phase, ``A gain / sqrt 2``, independent of the others.

    >>> round(folded_sd([Tone(300.0, 0.2)], 100.0, 2.0), 4)  # on 0 Hz: 0.2 / sqrt 2
    0.1414
    >>> folded_sd([Tone(300.0, 0.2)], 2000.0, 2.0) < 1e-9
    True
    """
    var = 0.0
    for tone in tones:
        gain = 1.0 / (1.0 + (folded(tone.frequency, rate) / cutoff) ** 4)
        var += 0.5 * (tone.amplitude * gain) ** 2
    return math.sqrt(var)
