"""The compiled bridges (:func:`torquemap._estimate_kernels.bridge_runs`) against the numpy loop
they replace, bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray

from torquemap._estimate_kernels import _mean
from torquemap.estimate import _gap_runs, _run_sides, bridge_gaps


def _numpy_bridges(
    t: NDArray[np.float64],
    values: NDArray[np.float64],
    gaps: NDArray[np.bool_],
    *,
    longest: float,
    support: float = 0.0,
    ends: bool = False,
) -> NDArray[np.float64]:
    """``bridge_gaps`` as it was before the kernel (stop 42): a Python loop over the runs."""
    out = values.copy()
    if gaps.all():
        return out
    tie = 0.01 * float(t[-1] - t[0]) / max(t.size - 1, 1)
    for a, b in _gap_runs(gaps):
        if t[b - 1] - t[a] > longest or ((a == 0 or b == gaps.size) and not ends):
            continue
        origin = t[a]
        sides_t, sides_v = [], []
        for side in _run_sides(t, a, b, support=support, tie=tie):
            keep = ~gaps[side]
            sides_t.append((t[side][keep] - origin).mean())
            sides_v.append(values[side][keep].mean())
        out[a:b] = np.interp(t[a:b] - origin, sides_t, sides_v)
    return out


def test_mean_is_numpys_bit_for_bit() -> None:
    # sequential below 8 values, eight accumulators to 128, halves above; a sum of -0.0 is 0.0
    rng = np.random.default_rng(0)
    for n in [*range(1, 300), 511, 1000, 4097]:
        for a in (rng.normal(size=n) * 10 ** rng.uniform(-8, 8, n), -np.zeros(n)):
            got, want = _mean(a.copy(), n), a.mean()
            assert got == want and math.copysign(1, got) == math.copysign(1, want), n


@pytest.mark.parametrize("seed", range(12))
def test_bridges_are_the_numpy_loops_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(50, 5000))
    h = 1e-3
    # regular, jittered and Unix-epoch stamps
    t = np.arange(n) * h
    if seed % 3 == 1:
        t = t + rng.uniform(-0.3, 0.3, n) * h
    if seed % 3 == 2:
        t = t + 1.7e9
    values = np.cumsum(rng.normal(size=n)) * 10 ** rng.uniform(-3, 3)
    if seed % 4 == 3:
        values[rng.integers(0, n, 3)] = np.nan
    # runs of every length, at the ends too, from one sample to hundreds
    gaps = np.zeros(n, dtype=bool)
    for _ in range(int(rng.integers(1, 60))):
        a = int(rng.integers(0, n))
        gaps[a : a + int(rng.geometric(0.05 if seed % 2 else 0.3))] = True
    gaps[: int(rng.integers(0, 3))] = True
    for support in (0.0, 3 * h, 0.02, 0.3):
        for longest in (math.inf, 0.01, 0.1):
            for ends in (False, True):
                want = _numpy_bridges(t, values, gaps, longest=longest, support=support, ends=ends)
                got = bridge_gaps(t, values, gaps, longest=longest, support=support, ends=ends)
                np.testing.assert_array_equal(got, want)
                runs = _gap_runs(gaps)
                again = bridge_gaps(
                    t, values, gaps, longest=longest, support=support, ends=ends, runs=runs
                )
                np.testing.assert_array_equal(again, want)
    # the test can fail: bridged samples differ from the values
    assert not np.array_equal(want, values)


def test_bridges_of_no_runs_and_all_gaps() -> None:
    t = np.arange(10.0)
    v = np.arange(10.0) ** 2
    np.testing.assert_array_equal(bridge_gaps(t, v, np.zeros(10, bool), longest=5.0), v)
    np.testing.assert_array_equal(bridge_gaps(t, v, np.ones(10, bool), longest=5.0), v)
