"""The bridges' departure in one compiled pass (:func:`torquemap._estimate_kernels.departure_runs`)
against the exact least-squares slope (rational arithmetic) and against ``np.polyfit`` per
side, the path it replaces (stop 44, E70)."""

from __future__ import annotations

import math
import warnings
from fractions import Fraction

import numpy as np
import pytest
from numpy.typing import NDArray

from torquemap._estimate_kernels import _side_slope
from torquemap.estimate import _gap_runs
from torquemap.uncertainty import _bridge_departure_polyfit, bridge_departure


def _exact_slope(x: NDArray[np.float64], y: NDArray[np.float64]) -> float:
    """The least-squares slope of ``y`` on ``x`` in rational arithmetic, rounded once."""
    xs = [Fraction(float(v)) for v in x]
    ys = [Fraction(float(v)) for v in y]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    sxy = sum((a - mx) * (b - my) for a, b in zip(xs, ys, strict=True))
    return float(sxy / sum((a - mx) ** 2 for a in xs))


def _case(seed: int) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Regular, jittered and Unix-epoch stamps; a random walk with or without noise and an
    offset; runs from one sample to hundreds, at the ends too."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(200, 8000))
    h = 1.0 / float(rng.choice([500.0, 1000.0, 2000.0]))
    t = np.arange(n) * h + float(rng.choice([0.0, 5000.0, 1.7e9]))
    if seed % 3 == 1:
        t = t + rng.uniform(-0.2, 0.2, n) * h
    noise = float(rng.choice([0.0, 1e-3, 1.0]))
    y = np.cumsum(rng.normal(size=n)) * 0.01 + rng.normal(size=n) * noise + rng.normal() * 10
    bridged = np.zeros(n, dtype=bool)
    for _ in range(int(rng.integers(1, 30))):
        a = int(rng.integers(0, n))
        bridged[a : a + int(rng.integers(1, 600))] = True
    bridged[: int(rng.integers(0, 3))] = True
    bridged[n // 2 : n // 2 + 20] = True  # one run inside at least
    return t, y, bridged


@pytest.mark.parametrize("seed", range(40))
def test_side_slopes_are_the_exact_least_squares(seed: int) -> None:
    rng = np.random.default_rng(seed)
    k = int(rng.integers(3, 400))
    h = 1 / 2000
    t = float(rng.choice([0.0, 5000.0, 1.7e9])) + np.arange(k) * h
    if seed % 2:
        t = t + rng.uniform(-0.2, 0.2, k) * h
    lo, hi = float(t[0] - rng.uniform(0, h)), float(t[-1])
    x = t - lo
    # a line with a large offset and a small slope (np.polyfit's weak case) or noise
    y = rng.normal() * x * float(rng.choice([1.0, 1e-6])) + rng.normal() * 10
    y = y + rng.normal(size=k) * float(rng.choice([0.0, 1e-3, 1.0]))
    bridged = np.zeros(k, dtype=bool)
    status, slope = _side_slope(t, y, bridged, lo, hi, np.empty(k), np.empty(k))
    assert status == 1
    exact = _exact_slope(x, y)
    scale = abs(exact) + float(np.std(y) / np.std(x))
    assert abs(slope - exact) <= 1e-14 * scale, (slope, exact)


def test_side_slope_needs_three_samples_that_are_not_bridged() -> None:
    t = np.arange(10) * 0.1
    y = 2.0 * t
    bridged = np.array([1, 1, 0, 1, 0, 1, 0, 1, 1, 1], dtype=bool)
    status, slope = _side_slope(t, y, bridged, 0.0, 0.9, np.empty(10), np.empty(10))
    assert status == 1 and slope == pytest.approx(2.0, rel=1e-15)
    bridged[4] = True
    status, slope = _side_slope(t, y, bridged, 0.0, 0.9, np.empty(10), np.empty(10))
    assert status == 0 and math.isnan(slope)


@pytest.mark.parametrize("seed", range(30))
def test_departure_is_polyfits(seed: int) -> None:
    t, y, bridged = _case(seed)
    runs = _gap_runs(bridged)
    answered = 0
    for cutoff in (0.5, 2.0, 20.0):
        span = 1.0 / cutoff
        got = bridge_departure(t, y, bridged, cutoff=cutoff)
        want = _bridge_departure_polyfit(t, y, bridged, span=span, runs=runs)
        np.testing.assert_array_equal(got == 0.0, want == 0.0)
        np.testing.assert_array_equal(
            got, bridge_departure(t, y, bridged, cutoff=cutoff, runs=runs)
        )
        # elsewhere np.polyfit's to its own rounding: LAPACK's SVD of the scaled Vandermonde
        # matrix solves to the values' rounding, a slope error of about eps max|y| / reach over
        # a side of ``reach = min(D / 2, span)``, so the departure's (at most the slopes'
        # errors times D) is about eps max|y| max(2, D / span)
        for a, b in runs:
            ta = t[a - 1] if a > 0 else t[a]
            tb = t[b] if b < t.size else t[b - 1]
            bound = 1e-13 * float(np.max(np.abs(y))) * max(2.0, (tb - ta) / span)
            assert float(np.max(np.abs(got[a:b] - want[a:b]))) <= bound
        answered += int(np.count_nonzero(want))
    assert answered > 0  # the test can fail: departures were computed


def test_a_value_that_is_not_finite_or_equal_times_take_polyfits_path() -> None:
    t, y, bridged = _case(3)
    runs = _gap_runs(bridged)
    a, b = next((a, b) for a, b in runs if a > 10 and b < t.size - 10)
    y[a - 2] = np.nan  # inside the run's left side
    with np.errstate(invalid="ignore"):
        want = _bridge_departure_polyfit(t, y, bridged, span=0.5, runs=runs)
        np.testing.assert_array_equal(bridge_departure(t, y, bridged, cutoff=2.0), want)
    assert np.isnan(want[a:b]).all()
    # a side whose stamps are all equal: np.polyfit's minimum-norm answer (and its warning)
    t = np.array([0.0, 0.5, 1.0, 3.0, 3.0, 3.0, 4.0, 5.0, 6.0, 6.5, 7.0, 8.0])
    y = np.array([0.0, 0.5, 1.0, 3.0, 5.0, 7.0, 4.0, 5.0, 6.0, 6.0, 7.5, 8.0])
    bridged = np.array([0, 0, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0], dtype=bool)
    assert _side_slope(t, y, bridged, 1.5, 3.0, np.empty(12), np.empty(12))[0] == -1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", np.exceptions.RankWarning)
        want = _bridge_departure_polyfit(t, y, bridged, span=10.0, runs=_gap_runs(bridged))
        got = bridge_departure(t, y, bridged, cutoff=0.1)
    np.testing.assert_array_equal(got, want)
    assert np.isfinite(want).all() and want[6:8].min() > 0
