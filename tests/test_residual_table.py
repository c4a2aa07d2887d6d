"""The residual table's sample selection (stop 34, F40): on a sweep with starts from rest and
reversals, :func:`torquemap.uncertainty.residual_table` with ``selection="representative"``
measures the residual noise set in the simulation (closed form: white noise through the
low-pass's equivalent noise bandwidth), while the default (every steady sample) carries the
misfit at the reversals into its steady bins through the low-pass. The default stays the
identification's (measured, not kept: docs/estimation.md "The residual table (F40)")."""

from __future__ import annotations

import math

import numpy as np
import pytest

import torquemap.uncertainty as unc
from torquemap.filters import dilate
from torquemap.uncertainty import (
    LOWPASS_ENB,
    RESIDUAL_CUTOFF,
    representative_samples,
    residual_table,
)

RATE = 1000.0  # [Hz]
NOISE = 2e-3  # [N m] white noise of the residual, per sample
BURST = 20e-3  # [N m] the misfit near zero speed (the table's prior there)
SPEEDS = (5.0, 12.0, 30.0)  # [rad/s] steady passes, each direction
STICK_SLIP = 1.5  # [rad/s] mean speed of the slow pass in stick-slip
BAND = 0.1  # [rad/s] reversal band


def _sweep(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Time, velocity, acceleration and residual of a sweep: per speed a hold at rest, a
    start, 10 s forwards, a reversal, 10 s backwards, a stop (1 % speed ripple); then a slow
    pass in stick-slip both ways (``STICK_SLIP``: the speed between 5 % and 1.95 times its mean
    at 1.5 Hz, as the slowest passes of random robots 6 and 20). The model's misfit
    (``BURST``) is confined to speeds under 0.3 rad/s: the holds, the reversals and the
    sticking phases."""
    rng = np.random.default_rng(seed)
    h = 1.0 / RATE
    parts = [np.zeros(int(RATE))]
    ramp = np.linspace(0.0, 1.0, int(0.4 * RATE), endpoint=False)
    hold = np.ones(int(10.0 * RATE))
    for s in SPEEDS:
        parts += [s * ramp, s * hold, s * (1.0 - 2.0 * ramp), -s * hold, -s * (1.0 - ramp)]
        parts.append(np.zeros(int(RATE)))
    v = np.concatenate(parts)
    v = v * (1.0 + 0.01 * np.sin(2.0 * math.pi * 0.7 * np.arange(v.size) * h))
    tau = np.arange(int(10.0 * RATE)) * h
    slip = STICK_SLIP * (1.0 - 0.95 * np.cos(2.0 * math.pi * 1.5 * tau))
    v = np.concatenate([v, slip, np.zeros(int(RATE)), -slip, np.zeros(int(RATE))])
    t = np.arange(v.size) * h
    acc = np.gradient(v, h)
    misfit = BURST * np.exp(-((v / 0.3) ** 2))  # what the model leaves near zero speed
    residual = misfit + NOISE * rng.standard_normal(v.size)
    return t, v, acc, residual


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_representative_table_is_the_noise_level(seed: int) -> None:
    t, v, acc, r = _sweep(seed)
    # white noise of variance NOISE^2 at RATE: one-sided PSD 2 NOISE^2 / RATE, through the
    # low-pass's equivalent noise bandwidth
    level = NOISE * math.sqrt(2.0 / RATE * LOWPASS_ENB * RESIDUAL_CUTOFF)
    clean = residual_table([t], [v], [acc], [r], band=BAND, selection="representative")
    assert clean is not None
    # the steady passes' bins only: no sample of the stick-slip pass stands for one speed
    speeds = np.asarray(clean["speeds"])
    assert speeds.size == len(SPEEDS)
    assert np.all(np.min(np.abs(np.log(speeds[:, None] / np.asarray(SPEEDS))), axis=1) < 0.7)
    rms = np.asarray(clean["rms"])
    # ~20 s per bin, about 70 independent low-passed values: the RMS within 25 % (3 sd)
    assert np.all(np.abs(rms / level - 1.0) < 0.25), rms / level
    smeared = residual_table([t], [v], [acc], [r], band=BAND, selection="steady")
    assert smeared is not None
    # the default's bins at the stick-slip pass's speeds hold the sticking phases' misfit,
    # carried into the slipping samples by the low-pass
    assert max(smeared["rms"]) > 3.0 * level, np.asarray(smeared["rms"]) / level
    assert math.isfinite(clean["acceleration_sigma"]) and clean["acceleration_sigma"] >= 0


def test_default_selection_is_the_module_switch(monkeypatch: pytest.MonkeyPatch) -> None:
    t, v, acc, r = _sweep(4)
    steady = residual_table([t], [v], [acc], [r], band=BAND)
    assert steady == residual_table([t], [v], [acc], [r], band=BAND, selection="steady")
    monkeypatch.setattr(unc, "RESIDUAL_SELECTION", "representative")
    assert residual_table([t], [v], [acc], [r], band=BAND) == residual_table(
        [t], [v], [acc], [r], band=BAND, selection="representative"
    )


def test_representative_samples_against_brute_force() -> None:
    """The sparse-table window extremes against a loop over each sample's window, on an
    irregular time axis."""
    rng = np.random.default_rng(5)
    t = np.cumsum(rng.uniform(0.002, 0.02, 3000))
    v = 3.0 * np.sin(2.0 * math.pi * 0.3 * t) + 0.4 * rng.standard_normal(t.size)
    reach, factor = 0.5, 2.0
    got = representative_samples(t, v, reach=reach, factor=factor)
    want = np.zeros(t.size, dtype=bool)
    for i in range(t.size):
        w = v[np.abs(t - t[i]) <= reach]
        if v[i] > 0:
            want[i] = w.min() > 0 and w.min() * factor >= v[i] and w.max() <= factor * v[i]
        elif v[i] < 0:
            want[i] = w.max() < 0 and w.max() * factor <= v[i] and w.min() >= factor * v[i]
    assert np.array_equal(got, want)
    assert 0 < got.sum() < t.size
    # no representative sample lies within the reach of a sign change
    flips = np.r_[False, np.sign(v[1:]) != np.sign(v[:-1])]
    assert not np.any(got & dilate(t, flips, reach * 0.999))
