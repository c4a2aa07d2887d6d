"""The log's noise beyond the model's, counted where it is white (torquemap.uncertainty,
stop 39): the sigma's noise part against its closed form and against noise realisations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from torquemap.filters import lowpass
from torquemap.friction_law import SpeedTableFriction
from torquemap.model import JointModel, Model
from torquemap.robot import robot_from_dict
from torquemap.uncertainty import joint_sigma, noise_excess, white_noise_excess

#: One-sided PSD [N^2 m^2/Hz] of the identification logs' white noise (their residual's, above
#: 20 Hz and in the estimate's band alike).
OWN = 1e-8
#: This log's white noise: 4 times the model's.
LOUDER = 4e-8
TABLE = SpeedTableFriction(
    speeds=(0.1, 1.0, 10.0),
    positive=(0.05, 0.05, 0.05),
    negative=(0.05, 0.05, 0.05),
    viscous=0.0,
    viscous_negative=0.0,
    zero_velocity=0.01,
)
SPEED = 5.0  # rad/s: steady, far from the friction's sign change


def _model() -> Model:
    rb = robot_from_dict(
        {
            "robot": {"name": "motor", "kinematics": "none"},
            "joints": {
                "m": {"gear_ratio": 1.0, "torque_constant": 0.1, "encoder_counts_per_rev": 8000}
            },
        }
    )
    # no parameter covariance and a flat table swept at the log's speed: the sigma is the
    # noise term alone, sqrt((residual_psd + excess) * ENB * cutoff)
    notes = {
        "joints": {
            "m": {
                "speeds": [1.0, -1.0],
                "uncertainty": {
                    "parameters": ["inertia.constant"],
                    "covariance": [[0.0]],
                    "residual_psd": OWN,
                    "noise_high_psd": OWN,
                },
            }
        }
    }
    return Model(robot=rb, joints={"m": JointModel(friction=TABLE)}, notes=notes)


def _log(
    rng: np.random.Generator, rate: float, tone: float, seconds: float = 20.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time, residual (white noise of PSD LOUDER, plus a 100 Hz tone of amplitude ``tone``
    [N m]) and the steady velocity of a log at ``rate`` [Hz]. The tone lies between 20 Hz and
    an eighth of 2 kHz: far above the estimate's 2 Hz band."""
    t = np.arange(int(seconds * rate)) / rate
    noise = rng.normal(0.0, math.sqrt(LOUDER * rate / 2.0), t.size)
    residual = noise + tone * np.sin(2.0 * np.pi * 100.0 * t)
    return t, residual, np.full(t.size, SPEED)


def _sigma(model: Model, t: np.ndarray, v: np.ndarray, extra: float) -> np.ndarray:
    return joint_sigma(
        model,
        "m",
        t=t,
        theta=SPEED * t,
        velocity=v,
        acceleration=np.zeros(t.size),
        modulation=np.zeros(t.size),
        cutoff=2.0,
        extra_psd=extra,
    )


def test_a_tone_between_the_splits_is_not_white_noise() -> None:
    # white noise 4x the model's plus a 100 Hz tone of 0.01 N m: the white excess is the
    # closed form LOUDER - OWN = 3e-8, measured +4.4, +7.5, +8.9 % on seeds 1-3 (the level
    # above 250 Hz, a quarter of the Nyquist frequency, is biased up by a few % by the
    # band's closed form, which takes the filter's response to reach far beyond the split;
    # the median absolute deviation of 30 000 samples adds about 1 %); the whole level above
    # 20 Hz takes the tone for noise: 3.2-3.3 times the excess (robust, but not to a tone
    # 1.2 times the noise's sd)
    model = _model()
    for seed in (1, 2, 3):
        t, residual, v = _log(np.random.default_rng(seed), 2000.0, tone=0.01)
        white = white_noise_excess(model, "m", t=t, residual=residual, velocity=v)
        whole = noise_excess(model, "m", t=t, residual=residual, velocity=v)
        assert white == pytest.approx(LOUDER - OWN, rel=0.12)
        assert whole > 2.5 * white


def test_white_noise_from_a_slower_logger_is_counted_as_before() -> None:
    # the same white noise read at 500 Hz (an eighth: 62.5 Hz, above 20 Hz) reads the same
    # level above both splits: the excess is the closed form and noise_excess's to within the
    # two levels' sampling spread (a few %); at 143 Hz (an eighth below 20 Hz) there is no
    # upper band and the excess is noise_excess's exactly
    model = _model()
    for rate in (500.0, 143.0):
        t, residual, v = _log(np.random.default_rng(7), rate, tone=0.0, seconds=200.0)
        white = white_noise_excess(model, "m", t=t, residual=residual, velocity=v)
        whole = noise_excess(model, "m", t=t, residual=residual, velocity=v)
        assert white == pytest.approx(LOUDER - OWN, rel=0.1)
        if rate < 160.0:
            assert white == whole
        else:
            assert white == pytest.approx(whole, rel=0.1)
            assert white <= whole


def test_the_noise_sigma_covers_95_percent_of_realisations() -> None:
    # the estimate's noise error is the residual through the 2 Hz low-pass (the tone does not
    # pass it). Over 40 logs of 20 s (about 40 x 20 x 2 x 0.833 x 2 = 2700 independent
    # samples of the low-passed noise: a binomial sd of 0.4 %), the share within 2 sigma of a
    # Gaussian sd is 95.4 %: with the white excess it is that (measured 95.4 %); with the
    # whole level above 20 Hz the sigma is 1.6 times too wide: 99.9 % inside
    model = _model()
    inside_white = inside_whole = total = 0
    for seed in range(40):
        t, residual, v = _log(np.random.default_rng(100 + seed), 2000.0, tone=0.01)
        error = lowpass(t, residual, cutoff=2.0)
        middle = slice(2000, t.size - 2000)  # the filter's edges: 1 s each side
        white = white_noise_excess(model, "m", t=t, residual=residual, velocity=v)
        whole = noise_excess(model, "m", t=t, residual=residual, velocity=v)
        s_white = _sigma(model, t, v, white)[middle]
        s_whole = _sigma(model, t, v, whole)[middle]
        # the closed form: sqrt(PSD * ENB * cutoff) with ENB = 3 pi / (8 sqrt 2)
        enb = 3.0 * math.pi / (8.0 * math.sqrt(2.0))
        assert np.median(s_white) == pytest.approx(math.sqrt(LOUDER * enb * 2.0), rel=0.05)
        e = np.abs(error[middle])
        inside_white += int(np.count_nonzero(e <= 2.0 * s_white))
        inside_whole += int(np.count_nonzero(e <= 2.0 * s_whole))
        total += e.size
    share_white = inside_white / total
    share_whole = inside_whole / total
    assert 0.93 <= share_white <= 0.975
    assert 0.90 <= share_white <= 0.99  # issue 12's band
    assert share_whole > 0.99
