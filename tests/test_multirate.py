"""The low-pass of the regressor's combinations at a decimated rate, against the full rate.

:func:`torquemap._kernels.decimated_variance` against :func:`torquemap._kernels.lowpassed_variance`
(the full-rate kernel, itself bit for bit scipy's ``sosfiltfilt``: tests/test_kernels.py) and
scipy's ``sosfilt`` over every sample (the multirate plan's steps): sinusoids at every frequency
up to the log's Nyquist frequency, whose error per unit amplitude the module states
(:data:`torquemap.multirate.SINE_BOUND`), and regressors drawn with a seeded generator.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from torquemap import multirate
from torquemap._kernels import decimated_variance, lowpassed_variance
from torquemap.filters import _butter_lowpass, _initial_state, lowpass

REGULAR = (np.empty(0, dtype=np.int64), np.empty(0))  # no resampling grid: the log's samples


def _dense_spec(columns: np.ndarray) -> tuple[object, ...]:
    """A regressor spec whose rows are ``columns`` (r, n) as they are (identity factor)."""
    r, n = columns.shape
    f, i = np.empty(0), np.empty(0, dtype=np.int64)
    return (np.ascontiguousarray(columns), np.arange(r, dtype=np.int64), np.zeros(n), np.ones(n),
            f, i, i, i, i, f, i, i, -1, -1, 1.0, np.eye(r),
            np.arange(1, r + 1, dtype=np.int64), f, f)  # fmt: skip


def _both(spec: tuple[object, ...], fs: float, cutoff: float) -> tuple[np.ndarray, np.ndarray]:
    sos, pad = _butter_lowpass(2, cutoff, fs)
    zi = _initial_state(sos.tobytes())
    m = multirate.decimation_factor(1.0 / fs, cutoff)
    assert m >= 3
    plan = multirate.multirate_plan(sos.tobytes(), m)
    r = spec[15].shape[1]  # type: ignore[attr-defined]
    weights = np.ones(r)
    full = lowpassed_variance(spec, weights, sos.copy(), zi.copy(), pad)
    fast, steps = decimated_variance(spec, weights, sos.copy(), zi.copy(), pad, plan, REGULAR)
    assert steps.size == 0
    return full, fast


def _irregular(t: np.ndarray, columns: np.ndarray, cutoff: float) -> tuple[np.ndarray, np.ndarray]:
    """The variance of ``columns`` (r, n) at irregular stamps ``t``: by ``lowpass`` (linear
    resampling to the median step and back, scipy's filter on the grid: the direct formula's
    path) and by the decimated kernel on the same grid, interpolated back."""
    grid = multirate.resample_grid(t)
    assert grid is not None
    full = np.sum(lowpass(t, columns.T, cutoff=cutoff) ** 2, axis=1)
    sos, pad = _butter_lowpass(2, cutoff, 1.0 / grid.step)
    m = multirate.decimation_factor(grid.step, cutoff)
    plan = multirate.multirate_plan(sos.tobytes(), m)
    zi = _initial_state(sos.tobytes())
    spec = _dense_spec(columns)
    weights = np.ones(columns.shape[0])
    var, steps = decimated_variance(
        spec, weights, sos.copy(), zi.copy(), pad, plan, (grid.index, grid.weight)
    )
    return full, multirate.variance_at(t, grid.times, var, steps)


def _random_combinations(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Five random combinations (5, n) of signals with content at every frequency: a chirp,
    random steps, a slow drift, white noise and a constant."""
    n = t.size
    chirp = np.sin(2 * np.pi * (0.1 + 20.0 * t / t[-1]) * t)
    steps = np.cumsum(rng.random(n) < 2e-4) % 2 - 0.5
    drift = np.cumsum(rng.standard_normal(n)) / np.sqrt(n)
    noise = rng.standard_normal(n)
    columns = np.stack([chirp, steps, drift, noise, 1.0 + 0.0 * t])
    return np.ascontiguousarray(rng.standard_normal((5, 5)) @ columns)


def _jittered(n: int, fs: float, rng: np.random.Generator) -> np.ndarray:
    """Stamps at ``fs`` jittered by up to 3 % of a step, with one sample in 50 dropped."""
    t = (np.arange(n) + rng.uniform(-0.03, 0.03, n)) / fs
    return np.delete(t, np.arange(7, n, 50))


def test_decimation_factor_is_odd_and_keeps_the_rate() -> None:
    for fs, cutoff in ((2000.0, 2.0), (1000.0, 2.0), (10_000.0, 0.5), (250.0, 2.0), (600.0, 1.0)):
        m = multirate.decimation_factor(1.0 / fs, cutoff)
        assert m % 2 == 1
        assert m == 1 or fs / m >= multirate.DECIMATED_RATE * cutoff
        assert fs / (m + 2) < multirate.DECIMATED_RATE * cutoff  # the largest such odd m


def test_plan_steps_equal_the_section_over_a_cubic_input() -> None:
    # closed form: on an input that is a cubic in time the 4-point interpolation is exact, so
    # m steps of the plan are m steps of scipy's section, to rounding
    fs, m = 2000.0, 19
    sos = np.ascontiguousarray(signal.butter(2, 2.0, fs=fs, output="sos"))
    plan = multirate.multirate_plan(sos.tobytes(), m)
    step, inputs, step_short, inputs_short = (np.asarray(plan[k]) for k in (3, 4, 5, 6))
    samples = np.arange(-m, 3 * m + 1, dtype=np.float64)
    x = 0.3 - 0.02 * samples + 1e-3 * samples**2 - 2e-5 * samples**3
    z = np.array([0.7, -0.4])
    y, zf = signal.sosfilt(sos, x[m + 1 : 2 * m + 1], zi=z[None, :])
    nodes = x[[0, m, 2 * m, 3 * m]]  # decimated samples j - 1, j, j + 1, j + 2
    np.testing.assert_allclose(step @ z + inputs.T @ nodes, zf[0], rtol=1e-12, atol=1e-14)
    y_last = sos[0, 0] * nodes[2] + (step_short @ z + inputs_short.T @ nodes)[0]
    np.testing.assert_allclose(y_last, y[-1], rtol=1e-12)


@pytest.mark.parametrize("fs", [2000.0, 1000.0])
def test_sinusoids_within_the_stated_bound(fs: float) -> None:
    # a sine and a cosine of unit amplitude as two combinations: the full-rate variance is
    # |H(f)|^4 between the ends, each one's error adds 2 |H|^2 e to it; the module states
    # |dV| <= SINE_BOUND at every sample and frequency (the ends included: there the odd
    # extension makes the variance large for any frequency)
    cutoff = 2.0
    n = int(40 * fs)
    t = np.arange(n) / fs
    for f in np.geomspace(0.05, 0.499 * fs, 17):
        columns = np.stack([np.sin(2 * np.pi * f * t + 0.3), np.cos(2 * np.pi * f * t + 0.3)])
        full, fast = _both(_dense_spec(columns), fs, cutoff)
        assert np.abs(fast - full).max() <= multirate.SINE_BOUND, f


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_regressor_within_the_stated_accuracy(seed: int) -> None:
    # combinations with content at every frequency (white noise, steps, chirps, slow drift):
    # the relative error of the variance the module states, VARIANCE_RTOL
    rng = np.random.default_rng(seed)
    fs, n = 2000.0, 60_000
    t = np.arange(n) / fs
    full, fast = _both(_dense_spec(_random_combinations(t, rng)), fs, 2.0)
    np.testing.assert_allclose(fast, full, rtol=multirate.VARIANCE_RTOL, atol=0.0)


@pytest.mark.parametrize("fs", [2000.0, 1000.0])
def test_irregular_stamps_sinusoids_within_the_stated_bound(fs: float) -> None:
    # jittered stamps with dropouts: the decimated kernel on the grid lowpass resamples to,
    # against lowpass itself (the direct formula's path). The rows are resampled alike and
    # the variance is interpolated back as the signals are (multirate.variance_at), so what
    # differs is the decimation: SINE_BOUND
    cutoff = 2.0
    t = _jittered(int(40 * fs), fs, np.random.default_rng(int(fs)))
    for f in np.geomspace(0.05, 0.45 * fs, 13):
        columns = np.stack([np.sin(2 * np.pi * f * t + 0.3), np.cos(2 * np.pi * f * t + 0.3)])
        full, fast = _irregular(t, columns, cutoff)
        assert np.abs(fast - full).max() <= multirate.SINE_BOUND, f


@pytest.mark.parametrize("seed", [0, 1])
def test_irregular_stamps_random_regressor_within_the_stated_accuracy(seed: int) -> None:
    rng = np.random.default_rng(seed)
    t = _jittered(60_000, 2000.0, rng)
    full, fast = _irregular(t, _random_combinations(t, rng), 2.0)
    np.testing.assert_allclose(fast, full, rtol=multirate.VARIANCE_RTOL, atol=0.0)


@pytest.mark.parametrize("seed", [0, 1])
def test_boxcar_rows_skip_zeros_bit_for_bit(seed: int) -> None:
    # second algorithm: every regressor row in full (zeros included) through the boxcars,
    # the irregular-grid path's accumulation; the regular log's compact rows must add the
    # same products in the same order, so the decimated rows are identical, not close
    from test_kernels import _regressor_case

    from torquemap._kernels import _boxcar_rows_grid, boxcar_rows

    spec, _, _ = _regressor_case(20_000, seed)
    fs, cutoff = 1000.0, 2.0
    sos, _ = _butter_lowpass(2, cutoff, fs)
    m = multirate.decimation_factor(1.0 / fs, cutoff)
    plan = multirate.multirate_plan(sos.tobytes(), m)
    n = 20_000
    count = (n - 1 - 2 * ((3 * m - 3) // 2)) // m + 1
    want = _boxcar_rows_grid(spec, plan, REGULAR, n, count)
    got = boxcar_rows(spec, plan, n, count)
    assert np.count_nonzero(want) > want.size // 4  # the case has rows to compare
    np.testing.assert_array_equal(got.view(np.int64), want.view(np.int64))
