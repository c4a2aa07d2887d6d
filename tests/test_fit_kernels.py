"""Identification's compiled kernels against the numpy code they replaced (a second algorithm
each, run here as written before): equal, not close, since they perform the same operations in
the same order."""

from __future__ import annotations

import math

import numpy as np
import pytest

from torquemap._fit_kernels import (
    column_centres,
    cos_sin,
    curvature_weights,
    delayed_columns,
    delayed_columns_at,
    double_integral,
    group_sums,
    interp_increasing,
    run_starts,
    savgol_acceleration,
    search_increasing,
    smooth_at_rows,
    speed_table_block,
    window_sums,
)
from torquemap._kernels import savgol_fit
from torquemap.filters import (
    _acceleration_rate,
    _savgol_lags,
    _smooth_as_acceleration_at_step,
    _windows,
    differentiate_rates,
    regular_step,
)
from torquemap.identify_whole import gravity_basis, pdtv_basis
from torquemap.smooth_rows import RowSmoother

pytestmark = pytest.mark.xdist_group("kernels")


def _window_sums_numpy(
    tt: np.ndarray, x: np.ndarray, lo: np.ndarray, hi: np.ndarray, scale: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The loop over lags that :func:`torquemap.filters.differentiate` ran on irregular time."""
    n = tt.size
    idx = np.arange(n)
    s_sum = np.zeros((5, n))
    sx_sum = np.zeros((3, n, x.shape[1]))
    for k in range(int((lo - idx).min()), int((hi - 1 - idx).max()) + 1):
        j = idx + k
        inside = (j >= lo) & (j < hi)
        jj = np.clip(j, 0, n - 1)
        s = np.where(inside, (tt[jj] - tt) / scale, 0.0)
        m = inside.astype(np.float64)
        xs = np.where(inside[:, None], x[jj] - x, 0.0)
        p = m.copy()
        for power in range(5):
            s_sum[power] += p
            if power < 3:
                sx_sum[power] += p[:, None] * xs
            p = p * s
    return s_sum, sx_sum


@pytest.mark.parametrize("m", [1, 3])
def test_window_sums_equal_the_loop_over_lags(m: int) -> None:
    # jittered time with a gap (windows widened by samples there) and a slow stretch
    rng = np.random.default_rng(m)
    step = rng.uniform(2e-4, 8e-4, 3000)
    step[1500] = 0.2
    step[2000:2100] = 5e-3
    tt = 7.0 + np.cumsum(step)
    x = np.ascontiguousarray(rng.standard_normal((tt.size, m)).cumsum(axis=0))
    lo, hi = _windows(tt, 0.05)
    scale = np.maximum(0.5 * (tt[hi - 1] - tt[lo]), 1e-300)
    got = window_sums(tt, x, lo, hi, scale)
    ref = _window_sums_numpy(tt, x, lo, hi, scale)
    np.testing.assert_array_equal(got[0], ref[0])
    np.testing.assert_array_equal(got[1], ref[1])


def _double_integral_numpy(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Twice the cumulative trapezoidal integral, as :mod:`torquemap.smooth_rows` computed it."""
    dt = np.diff(t)[:, None]
    out = np.zeros_like(x)
    out[1:] = np.cumsum(0.5 * (x[1:] + x[:-1]) * dt, axis=0)
    second = np.zeros_like(x)
    second[1:] = np.cumsum(0.5 * (out[1:] + out[:-1]) * dt, axis=0)
    return second


@pytest.mark.parametrize("m", [1, 2, 4])
@pytest.mark.parametrize("uniform", [True, False])
def test_smooth_at_rows_equals_sparse_product(m: int, uniform: bool) -> None:
    rng = np.random.default_rng(10 * m + uniform)
    n = 4001
    t = 3.0 + (np.arange(n) * 5e-4 if uniform else np.cumsum(rng.uniform(2e-4, 8e-4, n)))
    rows = np.sort(rng.choice(n, n // 12, replace=False)).astype(np.intp)
    smoother = RowSmoother.build(t, rows, 0.05)
    x = np.ascontiguousarray(rng.standard_normal((n, m)).cumsum(axis=0) + 7.0)
    mean = np.mean(x, axis=0)
    op = smoother.operator
    ref = np.asarray(op @ _double_integral_numpy(t, x - mean))
    got = smooth_at_rows(t, x, mean, op.indptr, op.indices, op.data, smoother.starts)
    np.testing.assert_array_equal(got, ref)
    # the rows read by position (consecutive samples) and those read through their indices
    # (every row so, with no run marked): both the sparse product's numbers
    assert (smoother.starts >= 0).any()
    none = np.full(rows.size, -1, dtype=np.intp)
    np.testing.assert_array_equal(
        smooth_at_rows(t, x, mean, op.indptr, op.indices, op.data, none), ref
    )
    centre = column_centres(x)
    ref_centred = np.asarray(op @ _double_integral_numpy(t, x - centre))
    np.testing.assert_array_equal(smoother(x), ref_centred + centre)
    # the centre only sets the rounding (the smoothing is exact for a constant): the two
    # centres agree to the rounding of the double integral (values up to ~1e2 over 2 s, so
    # 2e-14 absolute) carried through a row's weights (~100 of them, each up to 2 / 0.025^2):
    # a bound of ~1e-8; measured 2e-10
    np.testing.assert_allclose(smoother(x), ref + mean, rtol=0, atol=1e-8)


def test_column_centres_is_the_mean_of_every_step_th_sample() -> None:
    rng = np.random.default_rng(5)
    for n in (1, 7, 1023, 1024, 5000, 300_001):
        x = np.ascontiguousarray(rng.standard_normal((n, 3)) + np.array([1.0, -2e3, 5e6]))
        step = max(1, n // 1024)
        # numpy's mean of the same samples: the same sum in another order (1e-15 relative)
        np.testing.assert_allclose(column_centres(x), x[::step].mean(axis=0), rtol=1e-13)


def test_a_column_smooths_to_the_same_bits_alone_or_beside_others() -> None:
    # the whole fit caches a column however it was smoothed (the torque per delay four at a
    # time, or alone): every chunk must give the column the same numbers
    rng = np.random.default_rng(3)
    n = 6001
    t = 1.0 + np.arange(n) * 5e-4
    rows = np.arange(3, n, 7).astype(np.intp)
    smoother = RowSmoother.build(t, rows, 0.05)
    x = np.ascontiguousarray(rng.standard_normal((n, 6)).cumsum(axis=0))
    together = smoother(x)
    for c in range(6):
        np.testing.assert_array_equal(smoother(x[:, c : c + 1]), together[:, c : c + 1])
    np.testing.assert_array_equal(smoother(x[:, 2:5]), together[:, 2:5])


@pytest.mark.parametrize("uniform", [True, False])
def test_both_ways_columns_smooth_as_the_numpy_columns(uniform: bool) -> None:
    # the six PDTV columns of a line formed inside the smoother against pdtv_basis's columns
    # (numpy's cos, sin and masks) through the smoother: rests (v = 0), a NaN velocity, and an
    # irregular log with a gap (rows read through their indices)
    rng = np.random.default_rng(20 + uniform)
    n = 12001
    step = np.full(n, 5e-4) if uniform else rng.uniform(2e-4, 8e-4, n)
    if not uniform:
        step[7000] = 0.03
    t = 3.0 + np.cumsum(step)
    theta = 40.0 * np.sin(t) + np.cumsum(rng.standard_normal(n)) * 0.01
    velocity = np.gradient(theta, t)
    velocity[100:130] = 0.0
    velocity[200] = np.nan
    # an encoder's angle: repeated values (the kernel reuses their cosine and sine), zeros of
    # both signs among them (a zero's sine keeps its sign) and a NaN
    theta[3000:6000] = np.round(theta[3000:6000] * 20.0) / 20.0
    theta[500:520] = 0.0
    theta[520:530] = -0.0
    theta[530:535] = theta[529]
    theta[11990] = theta[11991] = np.nan
    rows = np.arange(0, n, 7).astype(np.intp)
    smoother = RowSmoother.build(t, rows, 0.05)
    for order in (0.5, 1.0, 21.0):
        both, _ = pdtv_basis(theta, velocity, [(order, False)])
        split, _ = pdtv_basis(theta, velocity, [(order, True)])
        ref = smoother(np.hstack((both, split)))
        got = smoother.both_ways(theta, velocity, order)
        x = order * theta
        if np.array_equal(np.cos(x), [math.cos(v) for v in x], equal_nan=True) and np.array_equal(
            np.sin(x), [math.sin(v) for v in x], equal_nan=True
        ):
            np.testing.assert_array_equal(got, ref)
        else:  # numpy's own SIMD cos and sin (an ulp off the C library's): the columns agree
            # to the smoother's rounding (the bound of test_smooth_at_rows_equals_sparse_product)
            np.testing.assert_allclose(got, ref, rtol=0, atol=1e-8)


def test_both_ways_cached_cosines_are_those_of_every_sample() -> None:
    # the kernel's kept cosines and sines (slots by the encoder count) against math.cos and
    # math.sin of every sample (the C library's, as the kernel's), through the smoother, bit
    # for bit: a quantised sweep back and forth over the same counts (slots reused), a range
    # wider than the slots (slots overwritten), zeros of both signs, a NaN, and slot widths
    # from one slot (0) to one per bit pattern (1e30)
    from torquemap._fit_kernels import TRIG_SLOTS, smooth_both_ways_at_rows
    from torquemap.smooth_rows import slots_per_radian

    rng = np.random.default_rng(41)
    n = 40001
    t = np.arange(n) * 5e-4
    count = 2.0 * np.pi / 8000.0 * 80.0  # an 8000-count encoder behind an 80:1 gear
    turns = 40.0 * np.sin(2.0 * np.pi * t / 4.0) + rng.standard_normal(n) * 0.3
    theta = np.round(turns / count) * count
    theta[15000:20000] += 1.5 * TRIG_SLOTS * count  # beyond the slots: the same slots again
    theta[700:720] = 0.0
    theta[720:730] = -0.0
    theta[33333] = np.nan
    velocity = np.gradient(theta, t)
    velocity[100:130] = 0.0
    rows = np.arange(0, n, 7).astype(np.intp)
    smoother = RowSmoother.build(t, rows, 0.05)
    op = smoother.operator
    assert slots_per_radian(theta) == pytest.approx(1.0 / count, rel=1e-9)
    for order in (1.0, 21.0, 41.9091):
        x = order * theta
        c = np.array([math.cos(v) for v in x])
        s = np.array([math.sin(v) for v in x])
        up = (velocity > 0).astype(np.float64)
        down = (velocity < 0).astype(np.float64)
        ref = smoother(np.column_stack((c, s, c * up, s * up, c * down, s * down)))
        for per_slot in (0.0, slots_per_radian(theta), 0.37 / count, 1e30):
            got = smooth_both_ways_at_rows(
                t, theta, velocity, order, per_slot, op.indptr, op.indices, op.data, smoother.starts
            )
            np.testing.assert_array_equal(got, ref)
        np.testing.assert_array_equal(smoother.both_ways(theta, velocity, order), ref)


@pytest.mark.parametrize("uniform", [True, False])
def test_speed_table_columns_smooth_as_the_block(uniform: bool) -> None:
    # the friction table's columns formed inside the smoother against speed_table_block's
    # columns through the smoother, four at a time as the fit formed them: every column, a
    # few (a width trial's), one, none
    rng = np.random.default_rng(30 + uniform)
    n = 12001
    step = np.full(n, 5e-4) if uniform else rng.uniform(2e-4, 8e-4, n)
    if not uniform:
        step[7000] = 0.03
    t = 3.0 + np.cumsum(step)
    v = 3.0 * np.sin(3.0 * t) + 0.01 * rng.standard_normal(n)
    v[50:80] = 0.0
    logs = np.log(np.geomspace(0.01, 5.0, 11))
    k = logs.size
    s = np.abs(v)
    b = 0.5 * (1.0 + np.tanh(v / 0.02))
    x = np.log(np.maximum(s, 1e-300))
    i = np.clip(np.searchsorted(logs, x, side="right") - 1, 0, k - 2).astype(np.int64)
    u = np.clip((x - logs[i]) / (logs[i + 1] - logs[i]), 0.0, 1.0)
    args = (s, b, -(1.0 - b), i, u)
    smoother = RowSmoother.build(t, np.arange(0, n, 9).astype(np.intp), 0.05)
    for which in (list(range(2 * k + 2)), [0, 1, 11, 12, 22, 23], [3], []):
        w = np.array(which, dtype=np.int64)
        parts = [smoother(speed_table_block(*args, w[j : j + 4], k)) for j in range(0, w.size, 4)]
        ref = np.hstack(parts) if parts else np.zeros((smoother.operator.shape[0], 0))
        np.testing.assert_array_equal(smoother.speed_table(*args, w, k), ref)


@pytest.mark.parametrize("uniform", [True, False])
def test_interp_increasing_is_numpy_interp(uniform: bool) -> None:
    # numpy's own formula per sample: equal, not close, for delays on and between samples and
    # beyond both ends
    rng = np.random.default_rng(uniform)
    n = 20001
    t = 3.0 + (np.arange(n) * 5e-4 if uniform else np.cumsum(rng.uniform(1e-4, 1e-3, n)))
    y = rng.standard_normal(n).cumsum()
    for delay in (-0.25, -0.0104, 0.0, 1e-3 / 3, 5e-4, 0.02, 20.0):
        np.testing.assert_array_equal(
            interp_increasing(t + delay, t, y), np.interp(t + delay, t, y)
        )


@pytest.mark.parametrize("uniform", [True, False])
def test_delayed_columns_are_numpy_interp_per_delay(uniform: bool) -> None:
    # every delay in one walk: each column numpy's interpolation of its own delay (the signal
    # itself at 0), equal, not close, whatever the delays beside it
    rng = np.random.default_rng(7 + uniform)
    n = 20001
    t = 3.0 + (np.arange(n) * 5e-4 if uniform else np.cumsum(rng.uniform(1e-4, 1e-3, n)))
    y = rng.standard_normal(n).cumsum()
    delays = np.array([-0.25, -0.0104, 0.0, 1e-3 / 3, 5e-4, 0.02, 20.0])
    got = delayed_columns(t, y, delays)
    for c, delay in enumerate(delays):
        expected = y if delay == 0 else np.interp(t + delay, t, y)
        np.testing.assert_array_equal(got[:, c], expected)
    np.testing.assert_array_equal(delayed_columns(t, y, delays[3:5]), got[:, 3:5])


@pytest.mark.parametrize("uniform", [True, False])
def test_delayed_columns_at_are_numpy_interp_at_those_samples(uniform: bool) -> None:
    # stretches of samples with gaps between (a bisection at each stretch's start, the walk
    # within), the first and last samples among them: numpy's interpolation there, equal
    rng = np.random.default_rng(11 + uniform)
    n = 20001
    t = 3.0 + (np.arange(n) * 5e-4 if uniform else np.cumsum(rng.uniform(1e-4, 1e-3, n)))
    y = rng.standard_normal(n).cumsum()
    starts = np.sort(rng.choice(n - 300, 40, replace=False))
    at = np.unique(np.r_[0, *(np.arange(a, a + rng.integers(1, 300)) for a in starts), n - 1])
    delays = np.array([-0.25, -0.0104, 0.0, 1e-3 / 3, 5e-4, 0.02, 20.0, -20.0])
    got = delayed_columns_at(t, y, at, delays)
    for c, delay in enumerate(delays):
        expected = y[at] if delay == 0 else np.interp(t[at] + delay, t, y)
        np.testing.assert_array_equal(got[:, c], expected)
    np.testing.assert_array_equal(got, delayed_columns(t, y, delays)[at])


def test_speed_table_block_equals_numpy_columns() -> None:
    # the friction table's basis as identify_whole built it with numpy, column by column
    rng = np.random.default_rng(5)
    k = 6
    logs = np.log(np.geomspace(0.05, 20.0, k))
    v = np.concatenate([rng.normal(0.0, 3.0, 5000), [0.0, -0.0, 20.0, -25.0, 0.05, 1e-9]])
    s = np.abs(v)
    b = 0.5 * (1.0 + np.tanh(v / 0.01))
    x = np.log(np.maximum(s, 1e-300))
    i = np.clip(np.searchsorted(logs, x, side="right") - 1, 0, k - 2)
    u = np.clip((x - logs[i]) / (logs[i + 1] - logs[i]), 0.0, 1.0)
    which = np.array([0, 3, 5, 6, 8, 11, 12, 13], dtype=np.int64)
    got = speed_table_block(s, b, -(1.0 - b), i.astype(np.int64), u, which, k)
    for c, j in enumerate(which):
        if j >= 2 * k:
            ref = s * (b if j == 2 * k else -(1.0 - b))
        else:
            hat = np.where(i == j % k, 1.0 - u, 0.0) + np.where(i + 1 == j % k, u, 0.0)
            ref = hat * (b if j < k else -(1.0 - b))
        np.testing.assert_array_equal(got[:, c], ref)


def _curvature_weights_numpy(
    t: np.ndarray, rows: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> np.ndarray:
    """The rows' weights as :mod:`torquemap.smooth_rows` built them with numpy (rows, width):
    each row's 3x3 normal equations of the local quadratic solved by LU."""
    n = t.size
    width = int((hi - lo).max())
    offsets = np.arange(width)
    index = np.minimum(lo[:, None] + offsets, n - 1)
    inside = (lo[:, None] + offsets) < hi[:, None]
    scale = np.maximum(0.5 * (t[hi - 1] - t[lo]), 1e-300)
    sc = np.where(inside, (t[index] - t[rows][:, None]) / scale[:, None], 0.0)
    m = inside.astype(np.float64)
    basis = np.stack([m, m * sc, m * sc * sc], axis=-1)
    normal = np.einsum("rli,rlj->rij", basis, basis)
    unit = np.broadcast_to(np.array([0.0, 0.0, 1.0]), (rows.size, 3))[:, :, None]
    e = np.linalg.solve(normal, unit)[:, :, 0]
    return np.asarray(2.0 * np.einsum("rlj,rj->rl", basis, e) / (scale**2)[:, None])


@pytest.mark.parametrize("uniform", [True, False])
def test_curvature_weights_equal_the_lu_solution(uniform: bool) -> None:
    # centred windows, windows clipped at both ends (the row at its window's edge) and, on
    # jittered time, windows of different lengths: the cofactor formula and numpy's LU solve
    # of the same 3x3 systems agree to rounding, 1e-12 of a row's largest weight (the systems'
    # condition numbers are below ~1e2 for abscissae in [-2, 2])
    rng = np.random.default_rng(7 + uniform)
    n = 3001
    t = 1e3 + (np.arange(n) * 5e-4 if uniform else np.cumsum(rng.uniform(2e-4, 8e-4, n)))
    rows = np.r_[0, 1, np.sort(rng.choice(n, 200, replace=False)), n - 2, n - 1]
    half = 50
    lo = np.clip(rows - half + rng.integers(-10, 10, rows.size) * (not uniform), 0, n - 101)
    hi = lo + 101 - rng.integers(0, 30, rows.size) * (not uniform)
    ref = _curvature_weights_numpy(t, rows, lo, hi)
    width = ref.shape[1]
    data, index = curvature_weights(t, rows, lo, hi, width)
    got = data.reshape(rows.size, width)
    big = np.max(np.abs(ref), axis=1, keepdims=True)
    assert np.all(np.abs(got - ref) <= 1e-12 * big)
    np.testing.assert_array_equal(
        index.reshape(rows.size, width), np.minimum(lo[:, None] + np.arange(width), n - 1)
    )


def test_group_sums_equal_numpy_add_at() -> None:
    # add.at adds each row into its group in the rows' order; values spread over 16 orders of
    # magnitude with mixed signs make any other order of the additions round differently
    rng = np.random.default_rng(11)
    n, m, count = 5000, 7, 37
    groups = rng.integers(0, count, n).astype(np.intp)
    x = rng.standard_normal((n, m)) * 10.0 ** rng.integers(-8, 8, (n, m))
    expected = np.zeros((count, m))
    np.add.at(expected, groups, x)
    got = group_sums(groups, x, count)
    assert np.array_equal(got, expected)
    # a sum in another order differs somewhere (the check above can tell orders apart)
    other = np.zeros((count, m))
    np.add.at(other, groups[::-1], x[::-1])
    assert not np.array_equal(other, expected)
    # no rows: zeros of the groups' shape
    assert np.array_equal(group_sums(groups[:0], x[:0], 3), np.zeros((3, m)))


def test_run_starts_marks_consecutive_rows_only() -> None:
    # by hand: a run, a run of one, a gap, a repeated index (a clipped window), an empty row
    indptr = np.array([0, 3, 4, 6, 9, 9], dtype=np.int32)
    indices = np.array([5, 6, 7, 2, 1, 3, 8, 9, 9, 4], dtype=np.int32)[:9]
    assert run_starts(indptr, indices).tolist() == [5, 2, -1, -1, -1]


def test_search_increasing_is_numpy_searchsorted() -> None:
    # keys on the samples (ties), between them, before the first and past the last
    rng = np.random.default_rng(12)
    a = np.cumsum(rng.uniform(1e-4, 1e-3, 5000))
    keys = np.sort(np.r_[a[::7], a[::5] + 3e-4, a[0] - 1.0, a[-1] + 1.0, a[10:12]])
    for right in (False, True):
        expected = np.searchsorted(a, keys, side="right" if right else "left")
        np.testing.assert_array_equal(search_increasing(a, keys, right), expected)


def test_cluster_medians_in_order_equal_the_sorting_path() -> None:
    # clusters in order take the per-segment sort; the same clusters shuffled (the general
    # lexsort path) must give each value the same median, even and odd counts, ties included
    from torquemap.robust import cluster_medians

    rng = np.random.default_rng(13)
    clusters = np.sort(rng.integers(0, 300, 20000))
    values = np.round(rng.standard_normal(clusters.size), 2)  # ties
    perm = rng.permutation(clusters.size)
    shuffled = np.empty(clusters.size)
    shuffled[perm] = cluster_medians(values[perm], clusters[perm])
    np.testing.assert_array_equal(cluster_medians(values, clusters), shuffled)


@pytest.mark.parametrize("length", [5, 7, 9, 11, 13, 101, 1201])
def test_savgol_acceleration_is_savgol_fits_acceleration(length: int) -> None:
    # the second algorithm: savgol_fit, which also sums the velocity (and the position); four
    # lags per pass and a remainder of 0-3, over several 512-sample stretches and a short one
    y = np.cumsum(np.random.default_rng(length).normal(size=1700))
    smooth, odd, even = _savgol_lags(length, 1e-3)
    p, v, a = np.empty(0), np.full(y.size, np.nan), np.full(y.size, np.nan)
    savgol_fit(y, smooth, odd, even, p, v, a, False)
    got = np.full(y.size, np.nan)
    savgol_acceleration(y, even, got)
    half = length // 2
    np.testing.assert_array_equal(got[half:-half], a[half:-half])


@pytest.mark.parametrize("uniform", [True, False])
@pytest.mark.parametrize("two_d", [True, False])
def test_acceleration_rate_is_differentiate_rates_acceleration(uniform: bool, two_d: bool) -> None:
    # the same path (the Savitzky-Golay filter on a regular grid, the local fits otherwise)
    # and the same bits, the ends included
    rng = np.random.default_rng(3)
    n = 3000
    t = np.arange(n) * 5e-4 if uniform else np.cumsum(rng.uniform(3e-4, 7e-4, n))
    x = np.cumsum(rng.normal(size=(n, 3)), axis=0)
    x = x if two_d else x[:, 1]
    want = differentiate_rates(t, x, window=0.05).acceleration
    np.testing.assert_array_equal(_acceleration_rate(t, x, 0.05), want)


def test_smooth_at_step_equals_the_rates_path() -> None:
    # _smooth_as_acceleration_at_step as it was (differentiate_rates' uniform acceleration of
    # the double integral) against the acceleration-only filter it now calls
    from scipy import integrate

    rng = np.random.default_rng(4)
    t = np.arange(2500) * 5e-4
    x = rng.normal(size=(t.size, 4))
    step = regular_step(t)
    mean = np.mean(x, axis=0)
    first = integrate.cumulative_trapezoid(x - mean, t, initial=0.0, axis=0)
    second = integrate.cumulative_trapezoid(first, t, initial=0.0, axis=0)
    want = differentiate_rates(t, second, window=0.04).acceleration + mean
    np.testing.assert_array_equal(_smooth_as_acceleration_at_step(t, x, 0.04, step), want)


@pytest.mark.parametrize("uniform", [True, False])
@pytest.mark.parametrize("n", [1, 2, 3, 1000])
def test_double_integral_is_scipys_cumulative_trapezoid_twice(uniform: bool, n: int) -> None:
    # the second algorithm: scipy's cumulative_trapezoid, twice, as smooth_as_acceleration
    # called it; a column of zeros of both signs included (sign of zero kept)
    from scipy import integrate

    rng = np.random.default_rng(n)
    t = np.arange(n) * 5e-4 if uniform else np.cumsum(rng.uniform(3e-4, 7e-4, n))
    x = rng.normal(size=(n, 3)) * np.array([1.0, 1e6, 0.0])
    x[::2, 2] = -0.0
    mean = np.mean(x, axis=0)
    first = integrate.cumulative_trapezoid(x - mean, t, initial=0.0, axis=0)
    want = integrate.cumulative_trapezoid(first, t, initial=0.0, axis=0)
    got = double_integral(t, x, mean)
    np.testing.assert_array_equal(got, want)
    assert (np.signbit(got) == np.signbit(want)).all()


@pytest.mark.parametrize("uniform", [True, False])
def test_smooth_as_acceleration_as_before(uniform: bool) -> None:
    # smooth_as_acceleration as it was written (scipy's double integral, differentiate_rates'
    # acceleration) against the compiled integral and the acceleration-only filter, 1-D and 2-D
    from scipy import integrate

    from torquemap.filters import smooth_as_acceleration

    rng = np.random.default_rng(5)
    n = 2000
    t = np.arange(n) * 5e-4 if uniform else np.cumsum(rng.uniform(3e-4, 7e-4, n))
    for x in (rng.normal(size=n), rng.normal(size=(n, 3))):
        mean = np.mean(x, axis=0)
        first = integrate.cumulative_trapezoid(x - mean, t, initial=0.0, axis=0)
        second = integrate.cumulative_trapezoid(first, t, initial=0.0, axis=0)
        want = differentiate_rates(t, second, window=0.03).acceleration + mean
        np.testing.assert_array_equal(smooth_as_acceleration(t, x, window=0.03), want)


@pytest.mark.parametrize("uniform", [True, False])
def test_angle_harmonics_smooth_as_the_gravity_columns(uniform: bool) -> None:
    # the gravity test's joint-angle columns formed inside the smoother against
    # gravity_basis's numpy columns (cumsum, cos, sin) through the smoother: planar chains of
    # two and three joints from each joint, a joint alone; encoder angles that repeat, zeros
    # of both signs, an irregular log with a gap (rows read through their indices)
    rng = np.random.default_rng(40 + uniform)
    n = 12001
    step = np.full(n, 5e-4) if uniform else rng.uniform(2e-4, 8e-4, n)
    if not uniform:
        step[7000] = 0.03
    t = 3.0 + np.cumsum(step)
    q = np.column_stack([np.sin(t * (j + 1)) + 0.3 * j for j in range(3)])
    q[2000:8000] = np.round(q[2000:8000] * 200.0) / 200.0
    q[500:520, 0] = 0.0
    q[520:530, 0] = -0.0
    q[500:540, 1] = -0.0
    smoother = RowSmoother.build(t, np.arange(0, n, 7).astype(np.intp), 0.05)
    for joints, k, planar in (
        (2, 0, True),
        (2, 1, True),
        (3, 1, True),
        (2, 0, False),
        (3, 2, False),
    ):
        qq = np.ascontiguousarray(q[:, :joints])
        basis = gravity_basis(qq, k, planar)
        ref = np.hstack([smoother(basis[:, j : j + 4]) for j in range(0, basis.shape[1], 4)])
        got = smoother.angle_harmonics(qq, k, planar)
        angles = np.concatenate((np.cumsum(qq, axis=1).ravel(), qq.ravel()))
        if np.array_equal(np.cos(angles), [math.cos(v) for v in angles]) and np.array_equal(
            np.sin(angles), [math.sin(v) for v in angles]
        ):
            np.testing.assert_array_equal(got, ref)
        else:  # numpy's own SIMD cos and sin (an ulp off the C library's)
            np.testing.assert_allclose(got, ref, rtol=0, atol=1e-8)


def test_cos_sin_is_numpys_with_repeated_values() -> None:
    # repeated values (their cosine and sine reused), zeros of both signs, NaN
    rng = np.random.default_rng(50)
    x = np.repeat(rng.uniform(-200.0, 200.0, 3000), rng.integers(1, 6, 3000))
    x[10:20] = 0.0
    x[15:18] = -0.0
    x[30:33] = np.nan
    c, s = cos_sin(x)
    libm = np.array_equal(np.cos(x), [math.cos(v) for v in x], equal_nan=True)
    libm &= np.array_equal(np.sin(x), [math.sin(v) for v in x], equal_nan=True)
    if libm:
        np.testing.assert_array_equal(c, np.cos(x))
        np.testing.assert_array_equal(s, np.sin(x))
        np.testing.assert_array_equal(np.signbit(s), np.signbit(np.sin(x)))
    else:  # numpy's own SIMD cos and sin: within an ulp of the C library's
        np.testing.assert_allclose(c, np.cos(x), rtol=0, atol=1e-15)
        np.testing.assert_allclose(s, np.sin(x), rtol=0, atol=1e-15)
