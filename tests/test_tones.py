"""Fixed-frequency lines (torquemap.tones) against signals built with known lines."""

from __future__ import annotations

import math

import numpy as np
import pytest

from torquemap.tones import Tone, find_tones, folded, folded_sd


def _pieces(seed: int, lines: list[tuple[float, float]], pdtv: float = 0.0) -> list[tuple]:
    """Two jittered pieces (2 kHz, a gap between) of white noise sd 1 with ``lines`` (Hz,
    amplitude) fixed in time and, with ``pdtv``, a 21 CPR position line of that amplitude at
    motor speeds that change from segment to segment (its time frequency 21 v / 2 pi moves)."""
    rng = np.random.default_rng(seed)
    out = []
    for start, duration in ((0.0, 70.0), (75.0, 50.0)):
        n = int(duration * 2000)
        t = start + np.arange(n) / 2000.0 + rng.uniform(-1e-5, 1e-5, n)
        speed = 20.0 + 15.0 * np.sin(2 * np.pi * t / 37.0)  # 5-35 rad/s: 17-117 Hz at 21 CPR
        theta = np.cumsum(speed) / 2000.0
        x = rng.normal(0.0, 1.0, n) + pdtv * np.cos(21.0 * theta)
        for f, a in lines:
            x += a * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi))
        out.append((t, x, speed))
    return out


def test_lines_fixed_in_time_are_found_and_measured() -> None:
    tones = find_tones(_pieces(1, [(300.0, 0.2), (360.0, 0.1)], pdtv=0.5))
    assert [round(x.frequency) for x in tones] == [300, 360]  # the position line is not a tone
    for tone, (f, a) in zip(tones, [(300.0, 0.2), (360.0, 0.1)], strict=True):
        assert abs(tone.frequency - f) < 0.05  # a fifth of the 0.25 Hz bin
        # the line's power over its 7 bins of 0.25 Hz carries the noise floor's scatter:
        # 2e-3 / Hz x 1.75 Hz / sqrt(2 x 119 segments) = 2.3e-4 against a^2 / 2 = 5e-3 (0.1):
        # 5 % of the amplitude is beyond 4 of those
        assert abs(tone.amplitude - a) < 0.05 * a


@pytest.mark.parametrize("seed", range(4))
def test_noise_and_a_moving_position_line_are_not_tones(seed: int) -> None:
    assert find_tones(_pieces(10 + seed, [], pdtv=0.5)) == ()


def test_too_short_or_too_slow_gives_nothing() -> None:
    t = np.arange(400) / 2000.0
    assert find_tones([(t, np.sin(2 * np.pi * 300 * t), t)]) == ()
    t = np.arange(20000) / 60.0  # Nyquist 30 Hz: under twice the 20 Hz split
    assert find_tones([(t, np.sin(2 * np.pi * 25 * t), t)]) == ()


def test_folding_closed_forms() -> None:
    assert folded(300.0, 100.0) == 0.0
    assert math.isclose(folded(300.0, 149.0), 2.0)
    assert math.isclose(folded(60.0, 2000.0), 60.0)
    tone = Tone(300.0, 0.2)
    # on 0 Hz the low-pass passes it whole: a sinusoid of unknown phase, sd A / sqrt 2
    assert math.isclose(folded_sd([tone], 100.0, 2.0), 0.2 / math.sqrt(2.0))
    # folded onto the cut-off, the forward-backward Butterworth passes half of it
    assert math.isclose(folded_sd([tone], 149.0, 2.0), 0.5 * 0.2 / math.sqrt(2.0))
    # two folded lines add in variance
    both = folded_sd([tone, Tone(600.0, 0.1)], 100.0, 2.0)
    assert math.isclose(both, math.hypot(0.2, 0.1) / math.sqrt(2.0))
