"""The compiled kernels against the numpy/scipy code they replace (a second algorithm each)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.lib.stride_tricks import sliding_window_view
from scipy import signal

from torquemap import _kernels as K
from torquemap.filters import _savgol_lags, differentiate, differentiate_rates, lowpass
from torquemap.kinematics import force_and_sigma, force_map
from torquemap.model import PdtvLine, pdtv_torque

pytestmark = pytest.mark.xdist_group("kernels")


@pytest.mark.parametrize("m", [1, 3, 4, 5, 9])
@pytest.mark.parametrize("n", [40, 1001])
def test_sosfiltfilt_is_scipy_bit_for_bit(m: int, n: int) -> None:
    # the same recurrence in the same order of operations: equal, not close
    rng = np.random.default_rng(m * 1000 + n)
    sos = signal.butter(2, 3.0, fs=1000.0, output="sos")
    x = np.ascontiguousarray(rng.standard_normal((m, n)).cumsum(axis=1))
    y = K.sosfiltfilt_odd(sos, np.ascontiguousarray(signal.sosfilt_zi(sos)), x, 9)
    np.testing.assert_array_equal(y, signal.sosfiltfilt(sos, x, axis=1))


def test_lowpass_takes_scipy_for_higher_orders() -> None:
    # several sections are not the kernel's: scipy's own filter, to rounding of the resampling
    t = np.arange(3000) * 1e-3
    x = np.sin(7.0 * t) + 0.1 * np.random.default_rng(0).standard_normal(t.size)
    sos = signal.butter(4, 20.0, fs=1000.0, output="sos")
    np.testing.assert_array_equal(lowpass(t, x, cutoff=20.0, order=4), signal.sosfiltfilt(sos, x))


@pytest.mark.parametrize("length", [5, 11, 101])
def test_savgol_fit_matches_scipy(length: int) -> None:
    # scipy designs the weights by least squares (a pseudo-inverse of the Vandermonde matrix,
    # condition ~ half^4 = 6e6 at 101 taps): its second-derivative weights carry ~1e-10 of
    # relative error, and sum to zero only to that (a constant leaks through). Compared after
    # removing the offset, to 2e-9 of the derivative's range; exactness is the next test's
    # (extended precision)
    rng = np.random.default_rng(length)
    h = 5e-4
    t = np.arange(4000) * h
    x = 3.0 * np.sin(2.0 * t) + np.cumsum(rng.standard_normal(t.size)) * 1e-4
    r = differentiate_rates(t, x, window=(length - 1) * h)
    d = differentiate(t, x, window=(length - 1) * h)
    np.testing.assert_array_equal(d.velocity, r.velocity)  # with or without the position
    ref = signal.savgol_filter(x, length, 2, mode="interp")
    # the smoothing weights' design error in scipy: ~1e-13 at 101 taps (exactness: next test)
    np.testing.assert_allclose(d.position, ref, rtol=0, atol=1e-12 * np.ptp(x))
    for deriv, got in ((1, r.velocity), (2, r.acceleration)):
        ref = signal.savgol_filter(x - x[0], length, 2, deriv=deriv, delta=h, mode="interp")
        np.testing.assert_allclose(got, ref, rtol=0, atol=2e-9 * np.ptp(ref))


def test_savgol_fit_exact_against_long_double() -> None:
    # the closed-form weights applied in extended precision to an angle far from zero: the
    # kernel's sums of local differences lose nothing to the angle's size (1e-14 relative)
    rng = np.random.default_rng(7)
    h, half = 5e-4, 50
    x = 4000.0 + np.cumsum(rng.uniform(0.0, 0.01, 3000))
    smooth, odd, even = _savgol_lags(2 * half + 1, h)
    p, v, a = np.empty(x.size), np.empty(x.size), np.empty(x.size)
    K.savgol_fit(x, smooth, odd, even, p, v, a, True)
    k = np.arange(-half, half + 1).astype(np.longdouble)
    s2, s4, n = np.sum(k**2), np.sum(k**4), np.longdouble(2 * half + 1)
    e1 = k / (np.longdouble(h) * s2)
    e2 = 2 * (k**2 - s2 / n) / (np.longdouble(h) ** 2 * (s4 - s2**2 / n))
    xl = x.astype(np.longdouble)
    idx = rng.integers(half, x.size - half, 300)
    rv = np.array([np.sum(e1 * xl[i - half : i + half + 1]) for i in idx], dtype=np.float64)
    ra = np.array(
        [np.sum(e2 * (xl[i - half : i + half + 1] - xl[i])) for i in idx], dtype=np.float64
    )
    e0 = (3 * (3 * half**2 + 3 * half - 1) - 15 * k**2) / (
        np.longdouble((2 * half - 1) * (2 * half + 1) * (2 * half + 3))
    )
    rp = np.array([np.sum(e0 * xl[i - half : i + half + 1]) for i in idx], dtype=np.float64)
    np.testing.assert_allclose(p[idx], rp, rtol=1e-15)
    np.testing.assert_allclose(v[idx], rv, rtol=0, atol=1e-14 * np.abs(rv).max())
    np.testing.assert_allclose(a[idx], ra, rtol=0, atol=1e-12 * np.abs(ra).max())


def test_phasor_lines_match_cosines() -> None:
    # powers of exp(i theta) against one cosine per line; directional lines masked by the
    # velocity's sign. Theta up to 6000 rad: the cosines' own product k theta rounds to
    # ~48 * 6000 * 1.1e-16 = 3e-11 rad, times an amplitude of 4e-3 N m: 1e-13 N m
    rng = np.random.default_rng(3)
    n = 5000
    theta = np.cumsum(rng.uniform(0.0, 1.2, n))
    w = rng.standard_normal(n)
    lines = (
        PdtvLine(order=1, amplitude=1e-3, phase=0.3),
        PdtvLine(order=2, amplitude=4e-3, phase=-1.2),
        PdtvLine(order=21, amplitude=1.5e-3, phase=3.0, direction="negative"),
        PdtvLine(order=48, amplitude=3e-4, phase=-2.5),
        PdtvLine(order=7, amplitude=2e-3, phase=0.7, direction="positive"),
        PdtvLine(order=2.5, amplitude=1e-3, phase=0.2),
    )
    ref = np.zeros(n)
    for line in lines:
        keep = {"both": np.ones(n, bool), "positive": w > 0, "negative": w < 0}[line.direction]
        ref += np.where(keep, line.amplitude * np.cos(line.order * theta + line.phase), 0.0)
    np.testing.assert_allclose(pdtv_torque(theta, lines, velocity=w), ref, rtol=0, atol=2e-13)


def test_median_reach_suspects_match_running_extremes() -> None:
    rng = np.random.default_rng(5)
    x = np.cumsum(rng.standard_normal(3000))
    x[[0, 700, 2999]] += [50.0, -80.0, 60.0]
    big = float(np.max(np.abs(x)))
    u = x / big
    padded = np.concatenate((np.full(2, u[0]), u, np.full(2, u[-1])))
    win = sliding_window_view(padded, 5)
    reach = np.maximum(win.max(axis=1) - u, u - win.min(axis=1))
    for bound in (1e-9, 2.0 / big, 10.0 / big, 1.0):
        np.testing.assert_array_equal(
            K.median_reach_suspects(x, big, bound), np.flatnonzero(reach > bound)
        )


def test_step_kernels_match_numpy() -> None:
    rng = np.random.default_rng(11)
    x = np.round(np.cumsum(rng.standard_normal(2000)), 1)
    t = np.arange(x.size) * 1e-3
    d = np.abs(np.diff(x / 3.0))
    guess = float(np.median(d[d > 0]))
    assert K.step_counts(x, 3.0, guess) == (np.count_nonzero(d), np.count_nonzero(d >= guess))
    assert K.max_abs(x) == np.max(np.abs(x))
    assert np.isnan(K.max_abs(np.array([1.0, np.nan, 2.0])))
    dq = np.abs(np.diff(x))
    assert K.angle_step_summary(t, x) == (True, dq.max())
    assert not K.angle_step_summary(t[::-1].copy(), x)[0]
    assert K.count_at_least(x, 1.0) == np.count_nonzero(dq >= 1.0)


def test_step_range_matches_numpy() -> None:
    # the smallest and largest step and finiteness, as numpy.diff/min/max/isfinite give them
    # (NaN steps propagate as numpy's min and max do); jittered and epoch-stamped times
    rng = np.random.default_rng(12)
    for t in (
        np.cumsum(rng.uniform(0.5, 1.5, 5000)) * 1e-3,
        1.7e9 + 5e-4 * np.arange(3000),
        np.array([0.0, 1.0, 1.0, 0.5]),
    ):
        d = np.diff(t)
        assert K.step_range(t) == (True, d.min(), d.max())
    for bad in (np.inf, np.nan):
        t = np.arange(10.0)
        t[4] = bad
        finite, lo, hi = K.step_range(t)
        d = np.diff(t)
        assert not finite
        np.testing.assert_array_equal([lo, hi], [d.min(), d.max()])


def test_planar_force_matches_force_map() -> None:
    # the kernel against force_map's matrices applied by numpy; NaN torques taken as 0, NaN
    # sigmas give NaN sigmas, singular rows NaN
    rng = np.random.default_rng(2)
    n = 500
    q = np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-3, 3, n)])
    q[:5, 1] = 0.01  # singular with the default guard
    tau = rng.standard_normal((n, 2))
    sig = rng.uniform(0.0, 0.1, (n, 2))
    tau[7, 0], sig[9, 1] = np.nan, np.nan
    force, singular, sigma = force_and_sigma(q, tau, sig, (0.3, 0.2))
    a, sing_ref = force_map(q, (0.3, 0.2))
    np.testing.assert_array_equal(singular, sing_ref)
    # 1e-15 relative: the same products, the sines from another library
    np.testing.assert_allclose(
        force, np.einsum("nij,nj->ni", a, np.nan_to_num(tau)), rtol=1e-12, atol=0
    )
    np.testing.assert_allclose(sigma, np.sqrt(np.einsum("nij,nj->ni", a**2, sig**2)), rtol=1e-12)
    assert np.isnan(force[:5]).all() and np.isnan(sigma[9]).all()


def _regressor_case(n: int, seed: int) -> tuple[tuple[object, ...], np.ndarray, list[str]]:
    """A regressor spec for :func:`K.regressor_directions` and the columns it stands for."""
    from torquemap.friction_law import SpeedTableFriction
    from torquemap.uncertainty import regressor_columns

    rng = np.random.default_rng(seed)
    h = 1e-3
    velocity = 20.0 * np.sin(np.arange(n) * h * 3.0) + 0.05 * rng.standard_normal(n)
    theta = np.cumsum(velocity) * h
    acceleration = rng.standard_normal(n)
    law = SpeedTableFriction(speeds=(0.1, 1.0, 10.0), positive=(0.1, 0.08, 0.09),
                             negative=(0.1, 0.07, 0.1), viscous=1e-3, zero_velocity=0.05)  # fmt: skip
    names = ["inertia.constant", "pdtv.3.both.a", "pdtv.3.both.b", "pdtv.0.5.positive.a",
             "pdtv.7.negative.b", *(f"friction.{k}" for k in law.linear_parameter_names)]  # fmt: skip
    columns = regressor_columns(names, law=law, theta=theta, velocity=velocity,
                                acceleration=acceleration, modulation=np.ones(n))  # fmt: skip
    p = len(names)
    i64 = np.int64
    spec = (
        np.ascontiguousarray(acceleration[None, :]), np.array([0], dtype=i64), theta, velocity,
        np.array([3.0, 0.5, 7.0]), np.array([3, -1, 7], dtype=i64), np.array([1, 3, -1], dtype=i64),
        np.array([2, -1, 4], dtype=i64), np.array([0, 1, -1], dtype=i64),
        np.log(np.array(law.speeds)), np.array([5, 6, 7], dtype=i64), np.array([8, 9, 10], dtype=i64),
        11, 12, law.zero_velocity, np.ascontiguousarray(rng.standard_normal((p, p))),
        np.full(p, p, dtype=i64), np.empty(0), np.empty(0),
    )  # fmt: skip
    return spec, columns, names


def test_regressor_directions_match_regressor_columns() -> None:
    # second algorithm: the (n, p) regressor by numpy, times the directions; the kernel's
    # powers of exp(i theta) and sums in another order: rounding of the largest column
    spec, columns, _ = _regressor_case(3000, 0)
    directions = spec[15]
    assert isinstance(directions, np.ndarray)
    got = K.regressor_directions(spec)
    want = columns @ directions
    scale = np.abs(columns).max() * np.abs(directions).sum(axis=0)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * scale.max())
    # the caller's cos and sin of theta (numpy's, libm's as the kernel's own): the same rows
    theta = spec[2]
    assert isinstance(theta, np.ndarray)
    given = (*spec[:17], np.cos(theta), np.sin(theta))
    np.testing.assert_array_equal(K.regressor_directions(given), got)


def test_lowpassed_variance_matches_sosfiltfilt() -> None:
    # second algorithm: scipy's sosfiltfilt of each combination, weighted squares summed; the
    # filter's recurrences are the same operations (exact), the weighted sum in another order
    spec, columns, _ = _regressor_case(2500, 1)
    directions = spec[15]
    assert isinstance(directions, np.ndarray)
    sos = signal.butter(2, 2.0, fs=1000.0, output="sos")
    weights = np.random.default_rng(5).random(directions.shape[1])
    zi = np.ascontiguousarray(signal.sosfilt_zi(sos))
    got = K.lowpassed_variance(spec, weights, sos, zi, 9)
    y = signal.sosfiltfilt(sos, columns @ directions, axis=0)
    want = (y**2) @ weights
    np.testing.assert_allclose(got, want, rtol=1e-12)
