"""Is the torque at rest sampled finely enough? Cogging at the measured positions' Nyquist limit.

The collection measures a position every ``s`` table positions (the paper: every 4th). A torque
at rest (cogging, detent) that repeats every ``2 s`` table positions or faster is then sampled at
most twice a period: its samples alternate from one measured position to the next (exactly at
two samples a period) or alias to a slower ripple near that limit, and no interpolation between
measured positions can restore it. At the lowest commands that ripple is the whole torque asked
for (docs/linearize.md: a VR motor with 16 cogging periods over 128 positions measured every 4th
position lost 1.8 times the floor's APMD). The data cannot fix this; the user can, by measuring
every ``s / 2``-th position.

The check reads the torque at rest of every measured position (``o(p)`` of the structured
surface, :mod:`torquemap.linearize.surface`: the intercept each position's curve needs beyond
the phases' torque) and its spectrum over the evenly spaced measured positions. Undersampled
cogging puts its power at the two highest frequencies (the Nyquist frequency, two samples a
period, and the one below it, where a cogging slightly faster than the limit aliases); a phase
pattern or cogging sampled three or more times a period puts it lower. It warns when the
amplitude at the top stands out of the noise (four times the median amplitude of the lower
frequencies, which the noise of ``o`` sets or a few strong harmonics raise) and matters to the
tables (at least a fifth of the torque of command 1, a 20 % deviation there).

This module never imports the simulator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Warn when the top frequencies' amplitude is at least this many times the median amplitude of
#: the lower ones (the noise level: for noise alone an amplitude is Rayleigh distributed, and
#: exceeds 4 times its median with probability exp(-(4 * 1.177)**2 / 2) = 1.5e-5) ...
SIGNIFICANT = 4.0
#: ... and at least this fraction of the torque of command 1 (a 20 % deviation there).
MATTERS = 0.2
#: Fewest measured positions for a spectrum.
MIN_POSITIONS = 8


@dataclass(frozen=True, slots=True, eq=False)
class SamplingCheck:
    """The torque at rest's spectrum over the measured positions.

    Attributes
    ----------
    position_step
        Table positions between consecutive measured positions (0: not evenly spaced, not
        checked).
    top_amplitude
        Amplitude of the torque at rest at the two highest frequencies [N m].
    noise_amplitude
        The median amplitude at the lower frequencies [N m] (the noise level, or above it).
    undersampled
        Whether the torque at rest varies faster than the measured positions can hold.
    """

    position_step: int
    top_amplitude: float
    noise_amplitude: float
    undersampled: bool

    def advice(self) -> str:
        """What to collect instead (empty when nothing is undersampled)."""
        if not self.undersampled:
            return ""
        s = self.position_step
        if s < 2:
            return (
                "the torque at rest alternates between neighbouring table positions: cogging "
                "with a period under two table positions, which no table can hold"
            )
        return (
            f"the torque at rest alternates between neighbouring measured positions "
            f"({self.top_amplitude:.3g} N m): cogging with a period of about {2 * s} table "
            f"positions or less, which data measured every {_nth(s)} position cannot hold; "
            f"collect again measuring every {_nth(max(s // 2, 1))} position "
            f"(position step {max(s // 2, 1)})"
        )


def _nth(k: int) -> str:
    if k == 1:
        return "single"
    suffix = "th" if 10 <= k % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(k % 10, "th")
    return f"{k}{suffix}"


def check_position_sampling(
    rest: ArrayLike,
    anchors: ArrayLike,
    positions_per_cycle: int,
    *,
    torque_per_count: float,
) -> SamplingCheck:
    """Whether the torque at rest of the measured positions shows undersampled cogging.

    Parameters
    ----------
    rest
        Torque at rest of every table position [N m], shape (P,); only the measured positions
        are read.
    anchors
        The measured positions (the collection's targets), ascending, shape (K,).
    positions_per_cycle
        ``P``.
    torque_per_count
        Torque of command 1 [N m].

    Returns
    -------
    SamplingCheck
        The amplitudes and the verdict; not checked (``position_step`` 0) when the measured
        positions are not evenly spaced over the cycle or fewer than ``MIN_POSITIONS``.

    Notes
    -----
    With ``K`` measured positions every ``s``, the amplitude at frequency ``h`` (periods per
    cycle of the measured series) is ``2 |X_h| / K`` (``|X_h| / K`` at ``h = K / 2``), ``X`` the
    discrete Fourier transform of ``rest`` at the measured positions less its mean. The top
    frequencies are ``h >= K / 2 - 1``.

    Examples
    --------
    Cogging of 16 periods over 128 positions, measured every 4th (two samples a period):

    >>> p = np.arange(128)
    >>> slow = 0.05 * np.sin(2 * np.pi * 3 * p / 128)
    >>> fast = 0.05 * np.cos(2 * np.pi * 16 * p / 128)
    >>> check_position_sampling(slow + fast, p[::4], 128, torque_per_count=0.1).undersampled
    True
    >>> check_position_sampling(slow + fast, p[::2], 128, torque_per_count=0.1).undersampled
    False
    """
    a = np.asarray(anchors, dtype=np.int64)
    y = np.asarray(rest, dtype=np.float64)
    n = int(positions_per_cycle)
    k = a.size
    steps = np.diff(np.concatenate([a, a[:1] + n]))
    if k < MIN_POSITIONS or np.any(steps != steps[0]) or not np.isfinite(y[a]).all():
        return SamplingCheck(0, 0.0, 0.0, False)
    values = y[a] - np.mean(y[a])
    amplitude: NDArray[np.float64] = 2.0 * np.abs(np.fft.rfft(values)) / k
    if k % 2 == 0:
        amplitude[-1] /= 2.0  # the Nyquist bin is not doubled
    top_bins = amplitude[max(k // 2 - 1, 1) :]
    other_bins = amplitude[1 : max(k // 2 - 1, 1)]
    top = float(top_bins.max())
    noise = float(np.median(other_bins)) if other_bins.size else np.inf
    undersampled = top >= SIGNIFICANT * noise and top >= MATTERS * torque_per_count and top > 0
    return SamplingCheck(int(steps[0]), top, noise, bool(undersampled))


def hidden_wave_advice(amplitude: float, anchors: ArrayLike, positions_per_cycle: int) -> str:
    """What to collect when the rows between the measured positions read a ripple of two
    measured positions a period that the measured positions themselves sit on the zeros of
    (:func:`torquemap.linearize.surface.hidden_wave`).

    Parameters
    ----------
    amplitude
        The ripple's amplitude between the measured positions [N m].
    anchors
        The measured positions, evenly spaced, ascending, shape (K,).
    positions_per_cycle
        ``P``.

    Returns
    -------
    str
        One line.

    Examples
    --------
    >>> hidden_wave_advice(0.16, np.arange(0, 128, 4), 128)[:60]
    'the rows between measured positions read a torque at rest of'
    """
    a = np.asarray(anchors, dtype=np.int64)
    s = int(positions_per_cycle) // max(a.size, 1)
    return (
        f"the rows between measured positions read a torque at rest of {amplitude:.3g} N m "
        f"repeating every {2 * s} table positions that the measured positions do not see "
        f"(they sit at its zeros; cogging sampled twice a period, or what the model misses "
        f"between them), read from the rows the rig's compliance moved there; collect again "
        f"measuring every "
        f"{_nth(max(s // 2, 1))} position (position step {max(s // 2, 1)})"
    )


def check_stated_cogging(cogging_periods: int, anchors: ArrayLike, positions_per_cycle: int) -> str:
    """What to collect when the motor file's cogging is sampled at most twice a period.

    Parameters
    ----------
    cogging_periods
        Cogging periods per actuation cycle (the motor file's ``cogging_periods``).
    anchors
        The measured positions, ascending, shape (K,).
    positions_per_cycle
        ``P``.

    Returns
    -------
    str
        One line naming the largest position step that samples the cogging more than twice a
        period (a divisor of ``P``, so the targets stay evenly spaced); empty when the measured
        positions do so already, or are not evenly spaced.

    Examples
    --------
    >>> check_stated_cogging(16, np.arange(0, 128, 4), 128)[:38]
    'the motor file states 16 cogging perio'
    >>> check_stated_cogging(8, np.arange(0, 128, 4), 128)
    ''
    """
    a = np.asarray(anchors, dtype=np.int64)
    n = int(positions_per_cycle)
    if a.size < 2:
        return ""
    steps = np.diff(np.concatenate([a, a[:1] + n]))
    if np.any(steps != steps[0]):
        return ""
    s = int(steps[0])
    if n / (s * cogging_periods) > 2.0:
        return ""
    good = [d for d in range(1, s) if n % d == 0 and n / (d * cogging_periods) > 2.0]
    if not good:
        return (
            f"the motor file states {cogging_periods} cogging periods per cycle of {n} "
            "positions: under two table positions a period, which no table can hold"
        )
    d = max(good)
    return (
        f"the motor file states {cogging_periods} cogging periods per cycle of {n} positions, "
        f"{n / (s * cogging_periods):.3g} measured positions a period: data measured every "
        f"{_nth(s)} position cannot hold it; collect again measuring every {_nth(d)} position "
        f"(position step {d})"
    )


def unheld_gap_advice(
    unheld: ArrayLike, anchors: ArrayLike, positions_per_cycle: int, *, period: float
) -> str:
    """One line naming the gaps between measured positions where the torque at rest's ripple
    is not held by the data, and the positions to collect.

    Parameters
    ----------
    unheld
        True at the table positions where the fitted ripple is not determined by the measured
        positions, shape (P,).
    anchors
        The measured positions, ascending, shape (K,).
    positions_per_cycle
        ``P``.
    period
        The ripple's period [table positions].

    Returns
    -------
    str
        Empty when no position is unheld; otherwise the gaps (first and last unmeasured
        position), their widest span and the midpoint of each, to measure.

    Examples
    --------
    >>> a = np.array([0, 4, 8, 16, 20, 24, 28])
    >>> bad = np.zeros(32, dtype=bool)
    >>> bad[10:15] = True
    >>> unheld_gap_advice(bad, a, 32, period=6.4)[-47:]
    'only the slower ripple; collect position 12 too'
    """
    mask = np.asarray(unheld, dtype=bool)
    a = np.asarray(anchors, dtype=np.int64)
    n = int(positions_per_cycle)
    if not mask.any() or a.size < 2:
        return ""
    width = (np.roll(a, -1) - a) % n
    width[width == 0] = n
    gaps: list[str] = []
    collect: list[int] = []
    widest = 0
    for start, d in zip(a.tolist(), width.tolist(), strict=True):
        inside = (start + np.arange(1, d)) % n
        if d < 2 or not mask[inside].any():
            continue
        gaps.append(f"{int(inside[0])} .. {int(inside[-1])}")
        collect.append(int((start + d // 2) % n))
        widest = max(widest, int(d))
    if not gaps:
        return ""
    shown = ", ".join(gaps[:6]) + (f" and {len(gaps) - 6} more gaps" if len(gaps) > 6 else "")
    wanted = ", ".join(map(str, collect[:12])) + (
        f" and {len(collect) - 12} more" if len(collect) > 12 else ""
    )
    plural = "s" if len(collect) > 1 else ""
    return (
        f"the torque at rest ripples with a period of {period:.3g} table positions that the "
        f"measured positions cannot hold at positions {shown} (measured positions up to "
        f"{widest} apart): the tables there carry only the slower ripple; collect position{plural} {wanted} too"
    )
