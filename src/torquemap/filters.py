"""Time-domain signal tools: noise-aware differentiation and zero-phase low-pass filtering.

Both accept irregular time stamps, as logs polled by a host often have.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError


@dataclass(frozen=True, slots=True, eq=False)
class Derivatives:
    """A signal smoothed and differentiated by :func:`differentiate`.

    Attributes
    ----------
    position
        The smoothed signal, shape (n,) [unit].
    velocity
        Its first derivative, shape (n,) [unit/s].
    acceleration
        Its second derivative, shape (n,) [unit/s^2].
    """

    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]


def _time_and_values(t: ArrayLike, x: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    tt, xx, _, _ = _time_values_and_steps(t, x)
    return tt, xx


def _time_values_and_steps(
    t: ArrayLike, x: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64], float, float]:
    """:func:`_time_and_values` and the smallest and largest step of the time [s] it checked
    (for :func:`_regular_step_within`: one pass over the time, not two)."""
    from torquemap._kernels import max_abs, step_range

    tt = np.asarray(t, dtype=np.float64)
    xx = np.asarray(x, dtype=np.float64)
    if tt.ndim != 1 or xx.ndim not in (1, 2) or xx.shape[0] != tt.size:
        raise InputError(f"time and values must be of equal length, got {tt.shape} and {xx.shape}")
    if tt.size < 3:
        raise InputError(f"need at least 3 samples to filter, got {tt.size}")
    finite, smallest, largest = step_range(np.ascontiguousarray(tt))
    values = xx if xx.flags.c_contiguous or xx.flags.f_contiguous else np.ascontiguousarray(xx)
    if not (finite and math.isfinite(max_abs(values.reshape(-1, order="A")))):
        raise InputError("time or values hold NaN or inf")
    if not smallest > 0:
        raise InputError("time is not strictly increasing")
    return tt, xx, smallest, largest


#: Fewest samples a differentiator window holds: where the sampling is sparser (a gap, a slow
#: host poll) the window of that sample widens to hold this many (local adaptation).
MIN_WINDOW_SAMPLES = 5


def differentiate(t: ArrayLike, x: ArrayLike, *, window: float) -> Derivatives:
    """Smooth a signal and its first two derivatives by local quadratic least squares.

    Around every sample a parabola is fitted, by least squares, to the samples in a window of
    ``window`` seconds; its value, slope and curvature at the sample are the smoothed signal,
    velocity and acceleration. This is the Savitzky-Golay filter generalised to irregular
    time. Near the ends the window keeps its length and is shifted to stay inside the log.
    Where the sampling is too sparse for the window to hold ``MIN_WINDOW_SAMPLES`` samples
    (a gap, jitter, a slow poll) that sample's window widens, by samples, until it does: the
    differentiation adapts to the local sample spacing.

    Parameters
    ----------
    t
        Time [s], strictly increasing, shape (n,).
    x
        Signal [unit], shape (n,), or several signals sharing ``t``, shape (n, m).
    window
        Window length [s]. Longer windows reduce noise but attenuate fast motion: a sine of
        period P loses less than 1 % of its velocity when ``window < P / 5``.

    Returns
    -------
    Derivatives
        Smoothed position [unit], velocity [unit/s] and acceleration [unit/s^2], each shaped
        like ``x``.

    Raises
    ------
    InputError
        If the log is shorter than the window or holds fewer than ``MIN_WINDOW_SAMPLES``
        samples, or the time is not strictly increasing.

    Notes
    -----
    For sample ``i`` with ``s = t_j - t_i`` over the window, the fit minimises
    ``sum_j (x_j - a - b s - c s^2)^2``; then position ``a``, velocity ``b`` and acceleration
    ``2 c``. For white noise of standard deviation sigma on uniform samples at step h and a
    window holding m samples, the velocity noise is about ``sigma * sqrt(12 / m) / (m h)``.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 101)
    >>> d = differentiate(t, 3.0 * t**2, window=0.1)
    >>> round(float(d.velocity[50]), 9), round(float(d.acceleration[0]), 9)
    (3.0, 6.0)
    """
    tt, xx = _time_and_values(t, x)
    w = float(window)
    if not np.isfinite(w) or w <= 0:
        raise InputError(f"differentiation window must be positive, got {window!r} s")
    span = tt[-1] - tt[0]
    if span < w:
        raise InputError(
            f"log lasts {span:.6g} s, shorter than the differentiation window {w:.6g} s"
        )
    n = tt.size
    if n < MIN_WINDOW_SAMPLES:
        raise InputError(
            f"{n} samples: differentiation needs at least {MIN_WINDOW_SAMPLES} samples"
        )
    h = regular_step(tt, rtol=1e-9)
    if h is not None:
        half = math.floor(w / (2 * h) + 1e-9)
        if half >= 2 and 2 * half + 1 <= n:
            return _differentiate_uniform(xx, h, 2 * half + 1)
    return _differentiate_irregular(tt, xx, w)


def _differentiate_irregular(
    tt: NDArray[np.float64], xx: NDArray[np.float64], w: float
) -> Derivatives:
    """:func:`differentiate` by per-sample normal equations (any time axis)."""
    lo, hi = _windows(tt, w)
    two_d = xx.ndim == 2
    x2 = xx if two_d else xx[:, None]
    scale = np.maximum(0.5 * (tt[hi - 1] - tt[lo]), 1e-300)
    from torquemap._fit_kernels import window_sums

    s_sum, sx_sum = window_sums(tt, np.ascontiguousarray(x2, dtype=np.float64), lo, hi, scale)
    # Normal equations (3x3 per sample), solved in scaled time for conditioning.
    a = np.stack(
        [
            np.stack([s_sum[0], s_sum[1], s_sum[2]], axis=-1),
            np.stack([s_sum[1], s_sum[2], s_sum[3]], axis=-1),
            np.stack([s_sum[2], s_sum[3], s_sum[4]], axis=-1),
        ],
        axis=-2,
    )
    # one right-hand side per call: LAPACK's solve with several differs in the last bit
    rhs = np.moveaxis(sx_sum, 0, 1)  # (n, 3, m)
    coef = np.concatenate(
        [np.linalg.solve(a, rhs[:, :, c : c + 1]) for c in range(rhs.shape[2])], axis=2
    )
    position = x2 + coef[:, 0]
    velocity = coef[:, 1] / scale[:, None]
    acceleration = 2.0 * coef[:, 2] / (scale**2)[:, None]
    if not two_d:
        position, velocity, acceleration = position[:, 0], velocity[:, 0], acceleration[:, 0]
    return Derivatives(position=position, velocity=velocity, acceleration=acceleration)


def _windows(tt: NDArray[np.float64], w: float) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Per sample, the slice ``lo:hi`` of its differentiator window (widened where sparse)."""
    from torquemap._fit_kernels import search_increasing

    n = tt.size
    start = np.clip(tt - w / 2, tt[0], tt[-1] - w)
    # numpy.searchsorted's indices by one forward walk: the keys increase with the time
    ta = np.ascontiguousarray(tt)
    lo = search_increasing(ta, start, False)
    hi = search_increasing(ta, start + w * (1 + 1e-12), True)
    need = MIN_WINDOW_SAMPLES
    short = (hi - lo) < need
    if short.any():
        # widen by samples, keeping the sample as central as the log's ends allow
        i = np.flatnonzero(short)
        left = np.clip(i - need // 2, 0, n - need)
        lo[i] = np.minimum(lo[i], left)
        hi[i] = np.maximum(hi[i], left + need)
    return lo, hi


def _differentiate_uniform(x: NDArray[np.float64], h: float, length: int) -> Derivatives:
    """:func:`differentiate` on a uniform grid: the Savitzky-Golay filter of ``length`` samples.

    The same local quadratic fit (centred windows, and at the ends the first and last window,
    scipy's ``mode="interp"``), computed by convolution instead of per-sample normal equations
    (:func:`_savgol_columns`).
    """
    position, velocity, acceleration = _savgol_columns(x, h, length, with_position=True)
    return Derivatives(position=position, velocity=velocity, acceleration=acceleration)


@dataclass(frozen=True, slots=True, eq=False)
class Rates:
    """The velocity and acceleration of a signal, from :func:`differentiate_rates`.

    Attributes
    ----------
    velocity
        First derivative, shaped like the signal [unit/s].
    acceleration
        Second derivative, shaped like the signal [unit/s^2].
    """

    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]


def differentiate_rates(t: ArrayLike, x: ArrayLike, *, window: float) -> Rates:
    """:func:`differentiate` for its two derivatives only, at about a third of its cost.

    The same local quadratic fit. On a uniform grid the two Savitzky-Golay kernels are applied
    by direct (not FFT) convolution and the smoothed position is not computed; the results
    equal :func:`differentiate`'s to floating-point rounding (the sums run in another order).
    Irregular time takes :func:`differentiate` itself.

    Parameters
    ----------
    t
        Time [s], strictly increasing, shape (n,).
    x
        Signal [unit], shape (n,) or (n, m).
    window
        Window length [s] (:func:`differentiate`).

    Returns
    -------
    Rates
        Velocity [unit/s] and acceleration [unit/s^2], each shaped like ``x``.

    Raises
    ------
    InputError
        As :func:`differentiate`.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 101)
    >>> r = differentiate_rates(t, 3.0 * t**2, window=0.1)
    >>> round(float(r.velocity[50]), 9), round(float(r.acceleration[0]), 9)
    (3.0, 6.0)
    """
    tt, xx = _time_and_values(t, x)
    uniform = _uniform_window(tt, float(window))
    if uniform is not None:
        return _rates_uniform(xx, *uniform)
    d = differentiate(tt, xx, window=float(window))
    return Rates(velocity=d.velocity, acceleration=d.acceleration)


def _uniform_window(tt: NDArray[np.float64], w: float) -> tuple[float, int] | None:
    """The regular step [s] of ``tt`` and the odd window length [samples] of ``w`` [s] when
    the uniform-grid path applies (a regular log at least a window long, the window 5 samples
    or more, the log at least ``MIN_WINDOW_SAMPLES``), else None."""
    n = tt.size
    h = regular_step(tt, rtol=1e-9)
    if h is not None and np.isfinite(w) and w > 0 and tt[-1] - tt[0] >= w:
        half = math.floor(w / (2 * h) + 1e-9)
        if half >= 2 and 2 * half + 1 <= n and n >= MIN_WINDOW_SAMPLES:
            return h, 2 * half + 1
    return None


def _rates_uniform(x: NDArray[np.float64], h: float, length: int) -> Rates:
    """Savitzky-Golay velocity and acceleration of ``length`` samples (``mode="interp"``)."""
    _, velocity, acceleration = _savgol_columns(x, h, length, with_position=False)
    return Rates(velocity=velocity, acceleration=acceleration)


def _acceleration_uniform(x: NDArray[np.float64], h: float, length: int) -> NDArray[np.float64]:
    """The acceleration of :func:`_rates_uniform` alone (``x`` (n,) or (n, m), shaped like
    it): the same numbers, without the velocity's sums
    (:func:`torquemap._fit_kernels.savgol_acceleration`, the ends as
    :func:`_savgol_columns` does them)."""
    from torquemap._fit_kernels import savgol_acceleration

    half = length // 2
    even = _savgol_lags(length, h)[2]
    heads = _savgol_ends(length, 2, h)
    columns = x[:, None] if x.ndim == 1 else x
    outputs = []
    for k in range(columns.shape[1]):
        y = np.ascontiguousarray(columns[:, k], dtype=np.float64)
        out = np.empty(y.size)
        savgol_acceleration(y, even, out)
        out[:half] = heads[0] @ (y[:length] - y[0]) + 0.0
        out[-half:] = heads[1] @ (y[-length:] - y[0]) + 0.0
        outputs.append(out)
    if x.ndim == 1:
        return outputs[0]
    return np.stack(outputs, axis=1) if outputs else np.empty((0, x.shape[1]))


def _savgol_columns(
    x: NDArray[np.float64], h: float, length: int, *, with_position: bool
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Savitzky-Golay position (else an empty array), velocity and acceleration of each column.

    The centred windows by the compiled kernel (:func:`torquemap._kernels.savgol_fit`: every
    output in one pass, from the local differences of samples ``k`` either side, closed-form
    weights :func:`_savgol_lags`); the first and last windows' fits evaluated at their outer
    halves (:func:`_savgol_ends`, scipy's ``mode="interp"``).
    """
    from torquemap._kernels import savgol_fit

    half = length // 2
    smooth, odd, even = _savgol_lags(length, h)
    heads = [_savgol_ends(length, d, h) for d in (0, 1, 2)]
    columns = x[:, None] if x.ndim == 1 else x
    outputs: list[list[NDArray[np.float64]]] = [[], [], []]
    for k in range(columns.shape[1]):
        y = np.ascontiguousarray(columns[:, k], dtype=np.float64)
        pk = np.empty(y.size if with_position else 0)
        vk, ak = np.empty(y.size), np.empty(y.size)
        savgol_fit(y, smooth, odd, even, pk, vk, ak, with_position)
        head, tail = y[:length] - y[0], y[-length:] - y[0]
        for d, out in enumerate((pk, vk, ak)):
            if d == 0 and not with_position:
                continue
            out[:half] = heads[d][0] @ head + (y[0] if d == 0 else 0.0)
            out[-half:] = heads[d][1] @ tail + (y[0] if d == 0 else 0.0)
            outputs[d].append(out)
    if x.ndim == 1:
        empty = np.empty(0)
        return (outputs[0][0] if with_position else empty), outputs[1][0], outputs[2][0]
    stacked = [np.stack(o, axis=1) if o else np.empty((0, x.shape[1])) for o in outputs]
    return stacked[0], stacked[1], stacked[2]


@functools.lru_cache(maxsize=64)
def _savgol_lags(
    length: int, h: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The position's, velocity's and acceleration's Savitzky-Golay correlation weights by lag
    ``k = 0..M`` (``length = 2 M + 1``), in closed form.

    A quadratic fit's value is ``(3 (3 M^2 + 3 M - 1) - 15 k^2) / ((2 M - 1) (2 M + 1)
    (2 M + 3))``, its velocity the linear fit's slope ``k / (h S2)``, and its acceleration
    ``2 (k^2 - S2 / N) / (h^2 (S4 - S2^2 / N))`` with ``N = 2 M + 1``, ``S2 = sum k^2`` and
    ``S4 = sum k^4`` over ``-M..M`` (integers, exact): exactly symmetric and antisymmetric
    (scipy's least-squares design is so to rounding only, which lets a constant through the
    acceleration at 1e-13 of its size).
    """
    half = length // 2
    k = np.arange(half + 1, dtype=np.float64)
    lags = np.arange(-half, half + 1, dtype=np.float64)
    s2, s4 = float(np.sum(lags**2)), float(np.sum(lags**4))
    n = float(length)
    m = float(half)
    smooth = (3.0 * (3.0 * m * m + 3.0 * m - 1.0) - 15.0 * k**2) / (
        (2.0 * m - 1.0) * (2.0 * m + 1.0) * (2.0 * m + 3.0)
    )
    odd = k / (h * s2)
    even = 2.0 * (k**2 - s2 / n) / (h * h * (s4 - s2 * s2 / n))
    return smooth, odd, even


@functools.lru_cache(maxsize=64)
def _savgol_ends(
    length: int, deriv: int, h: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The first and last windows' rows of a quadratic Savitzky-Golay fit (designed once per
    length, derivative and step: the inertia fit smooths hundreds of short stretches with the
    same filter)."""
    half = length // 2
    s = np.arange(length, dtype=np.float64) - half
    fit = np.linalg.pinv(np.vander(s, 3, increasing=True))  # (3, length): 1, s, s^2 from x
    head_s, tail_s = s[:half], s[half + 1 :]
    if deriv == 0:
        head = fit[0][None, :] + head_s[:, None] * fit[1] + head_s[:, None] ** 2 * fit[2]
        tail = fit[0][None, :] + tail_s[:, None] * fit[1] + tail_s[:, None] ** 2 * fit[2]
    elif deriv == 1:
        head = (fit[1][None, :] + 2.0 * head_s[:, None] * fit[2][None, :]) / h
        tail = (fit[1][None, :] + 2.0 * tail_s[:, None] * fit[2][None, :]) / h
    else:
        head = tail = np.repeat(2.0 * fit[2][None, :] / h**2, half, axis=0)
    for a in (head, tail):
        a.setflags(write=False)
    return head, tail


def smooth_as_acceleration(t: ArrayLike, x: ArrayLike, *, window: float) -> NDArray[np.float64]:
    """Smooth a signal with the kernel through which :func:`differentiate` sees acceleration.

    The acceleration of :func:`differentiate` is a linear filter ``D`` of the position that
    passes quadratics exactly; summing by parts twice, ``D theta = K * theta''`` with ``K`` a
    kernel of unit sum spanning the window (on a uniform grid, the Savitzky-Golay coefficients
    summed twice: a parabola). So the differentiated acceleration is the true one smoothed by
    ``K``. Smoothing a torque by the same ``K`` before regressing it on that acceleration gives
    both sides one filter, and an inertia fit is not biased where the acceleration changes
    within a window (the start and end of every ramp). Computed as ``D`` applied to the
    signal's double integral (trapezoidal rule), so irregular time is handled exactly as
    :func:`differentiate` handles it.

    Parameters
    ----------
    t
        Time [s], strictly increasing, shape (n,).
    x
        Signal [unit], shape (n,), or several, shape (n, m).
    window
        The differentiator's window [s] (:func:`differentiate`).

    Returns
    -------
    ndarray
        The smoothed signal [unit], shape (n,).

    Raises
    ------
    InputError
        As :func:`differentiate`: a log shorter than the window or with too few samples.

    Examples
    --------
    >>> t = np.arange(2001) * 1e-3
    >>> acc = differentiate(t, np.sin(5.0 * t), window=0.2).acceleration
    >>> smoothed = smooth_as_acceleration(t, -25.0 * np.sin(5.0 * t), window=0.2)
    >>> bool(np.allclose(acc, smoothed, atol=1e-4))
    True
    """
    tt, xx = _time_and_values(t, x)
    mean = np.mean(xx, axis=0)  # a constant passes a unit-sum kernel unchanged
    second = _double_integral(tt, xx, mean)
    out: NDArray[np.float64] = _acceleration_rate(tt, second, window) + mean
    return out


def _double_integral(
    tt: NDArray[np.float64], xx: NDArray[np.float64], mean: NDArray[np.float64] | np.float64
) -> NDArray[np.float64]:
    """``cumulative_trapezoid`` (scipy's, ``initial=0.0``, along time) applied twice to ``xx
    - mean`` over ``tt`` [s], shaped like ``xx`` ((n,) or (n, m)): the same numbers
    (:func:`torquemap._fit_kernels.double_integral`), without five temporaries of the log's
    size."""
    from torquemap._fit_kernels import double_integral

    columns = np.ascontiguousarray(xx.reshape(xx.shape[0], -1), dtype=np.float64)
    centre = np.ascontiguousarray(np.reshape(mean, -1), dtype=np.float64)
    out = double_integral(np.ascontiguousarray(tt, dtype=np.float64), columns, centre)
    return out.reshape(xx.shape)


def _acceleration_rate(t: ArrayLike, x: ArrayLike, window: float) -> NDArray[np.float64]:
    """:func:`differentiate_rates`'s acceleration alone: the same checks, path and numbers
    (:func:`_acceleration_uniform` on a regular grid), without the velocity."""
    tt, xx = _time_and_values(t, x)
    uniform = _uniform_window(tt, float(window))
    if uniform is not None:
        return _acceleration_uniform(xx, *uniform)
    return differentiate(tt, xx, window=float(window)).acceleration


def _smooth_as_acceleration_at_step(
    tt: NDArray[np.float64], xx: NDArray[np.float64], window: float, step: float | None
) -> NDArray[np.float64]:
    """:func:`smooth_as_acceleration` of a piece of a log, by the filter the whole log takes.

    ``step`` is the whole log's :func:`regular_step` (None when irregular): a piece of an
    irregular log may itself be regular, and the two paths' windows can differ by a sample
    where the window is a whole number of steps. Validated input (a piece of a log that
    :func:`smooth_as_acceleration` accepts, at least a window long and ``MIN_WINDOW_SAMPLES``
    samples).
    """
    mean = np.mean(xx, axis=0)
    second = _double_integral(tt, xx, mean)
    half = math.floor(window / (2 * step) + 1e-9) if step is not None else 0
    if step is not None and half >= 2 and 2 * half + 1 <= tt.size:
        acc = _acceleration_uniform(second, step, 2 * half + 1)
    else:
        acc = _differentiate_irregular(tt, second, window).acceleration
    out: NDArray[np.float64] = acc + mean
    return out


def dilate(t: NDArray[np.float64], mask: NDArray[np.bool_], reach: float) -> NDArray[np.bool_]:
    """Samples within ``reach`` [s] of a sample of ``mask`` (``t`` [s] increasing).

    Examples
    --------
    >>> t = np.arange(10.0)
    >>> dilate(t, t == 4.0, 1.5).astype(int).tolist()
    [0, 0, 0, 1, 1, 1, 0, 0, 0, 0]
    """
    if reach >= 0:  # one compiled walk: the same samples (tests/test_whole_speed_i63.py)
        from torquemap._fit_kernels import dilate_mask

        return dilate_mask(
            np.ascontiguousarray(t, dtype=np.float64),
            np.ascontiguousarray(mask, dtype=np.bool_),
            float(reach),
        )
    bad = np.flatnonzero(mask)
    if bad.size == 0:
        return np.asarray(mask, dtype=bool).copy()
    from torquemap._fit_kernels import search_increasing

    tb = np.ascontiguousarray(t[bad], dtype=np.float64)
    ta = np.ascontiguousarray(t, dtype=np.float64)
    lo = search_increasing(ta, tb - reach, False)  # numpy.searchsorted's, by a forward walk
    hi = search_increasing(ta, tb + reach, True)
    edges = np.bincount(lo, minlength=t.size + 1) - np.bincount(hi, minlength=t.size + 1)
    out: NDArray[np.bool_] = np.cumsum(edges[:-1]) > 0
    return out


def uniform_step(t: NDArray[np.float64]) -> float:
    """Median sampling step [s] of ``t`` (the grid :func:`lowpass` resamples to)."""
    return float(np.median(np.diff(t)))


def regular_step(t: NDArray[np.float64], *, rtol: float = 1e-9) -> float | None:
    """The step [s] of ``t`` if it is uniform, else None.

    Uniform means every step equals the mean step ``(t[-1] - t[0]) / (n - 1)`` within ``rtol``
    of it plus the resolution of the stamps themselves: a stamp is a float64 and holds its
    value to half a unit in the last place (2.4e-7 s at Unix-epoch seconds, 4.5e-13 s past
    4096 s), so the difference of two stamps of a perfectly regular log is off by up to one
    unit in the last place of the largest stamp. Testing against ``rtol`` alone would call a
    log stamped in Unix-epoch seconds irregular on its rounding alone. The mean step is
    returned (:func:`round_step`): it is exact to that resolution divided by ``n - 1``, while
    a single step (or the median) carries the full rounding of two stamps.

    Parameters
    ----------
    t
        Time [s], shape (n,), n >= 2.
    rtol
        Relative tolerance on each step.

    Returns
    -------
    float or None
        The step [s], or None when the steps differ by more than the tolerance.

    Examples
    --------
    >>> regular_step(1.7e9 + 5e-4 * np.arange(1000))
    0.0005
    >>> regular_step(np.array([0.0, 1.0, 2.5])) is None
    True
    """
    n = t.size
    if n < 2:
        return None
    h = float(t[-1] - t[0]) / (n - 1)
    if not h > 0:
        return None
    from torquemap._kernels import step_range

    _, smallest, largest = step_range(np.ascontiguousarray(t, dtype=np.float64))
    return _regular_step_within(t, smallest, largest, rtol=rtol)


def _regular_step_within(
    t: NDArray[np.float64], smallest: float, largest: float, *, rtol: float
) -> float | None:
    """:func:`regular_step` of ``t`` (n >= 2) whose smallest and largest steps [s] the caller
    has (:func:`_time_values_and_steps`)."""
    n = t.size
    h = float(t[-1] - t[0]) / (n - 1)
    if not h > 0:
        return None
    resolution = float(np.spacing(max(abs(float(t[0])), abs(float(t[-1])))))
    tol = rtol * h + 2.0 * resolution
    if largest - h > tol or h - smallest > tol:
        return None
    return round_step(h, resolution=resolution, n=n)


def round_step(h: float, *, resolution: float, n: int) -> float:
    """The shortest decimal within the error of a mean step ``h`` [s] of ``n`` stamps.

    Stamps are held to ``resolution`` [s], so their mean step to about
    ``2 resolution / (n - 1)``: a log stamped at 2 kHz from 1.7e9 s has a mean step of
    0.0005 give or take 1e-13 s. Any value within that error is as good as ``h``; the
    shortest decimal among them is what a zero-based log of the same rate yields too, so the
    two are processed with the same step, to the bit.

    Examples
    --------
    >>> round_step(0.000500000000009, resolution=2.4e-7, n=4_000_000)
    0.0005
    """
    tol = 2.0 * resolution / max(n - 1, 1)
    for digits in range(1, 18):
        rounded = float(f"{h:.{digits}g}")
        if abs(rounded - h) <= tol:
            return rounded
    return h


def lowpass(t: ArrayLike, x: ArrayLike, *, cutoff: float, order: int = 2) -> NDArray[np.float64]:
    """Zero-phase Butterworth low-pass filter.

    The signal is filtered forwards and backwards (``scipy.signal.sosfiltfilt``), so the
    magnitude response is the Butterworth's squared, ``1 / (1 + (f / cutoff)^(2 order))``, and
    there is no phase lag. Irregular time is handled by linear resampling to a uniform grid
    at the median step and back.

    Parameters
    ----------
    t
        Time [s], strictly increasing, shape (n,).
    x
        Signal, shape (n,), or several, shape (n, m) (filtered along time).
    cutoff
        Cut-off frequency [Hz] of the single-pass Butterworth (-3 dB; -6 dB after the
        forward-backward pass). Must be below the Nyquist frequency of the median step.
    order
        Butterworth order (of the single pass).

    Returns
    -------
    ndarray
        The filtered signal at the original times, shape (n,).

    Raises
    ------
    InputError
        If the cut-off is not below Nyquist or below :data:`MIN_RELATIVE_CUTOFF` of it, or the
        log is shorter than the filter's padding.

    Examples
    --------
    >>> t = np.arange(1000) * 1e-3
    >>> y = lowpass(t, np.ones(1000), cutoff=10.0)
    >>> bool(np.allclose(y, 1.0))
    True
    """
    tt, xx, smallest, largest = _time_values_and_steps(t, x)
    if order < 1:
        raise InputError(f"filter order must be >= 1, got {order}")
    step = _regular_step_within(tt, smallest, largest, rtol=1e-6)  # regular_step's
    regular = step is not None
    h = uniform_step(tt) if step is None else step
    nyquist = 0.5 / h
    if not (0 < cutoff < nyquist):
        raise InputError(
            f"low-pass cut-off {cutoff:.6g} Hz must be in (0, {nyquist:.6g}) Hz (Nyquist of the "
            "median sampling step)"
        )
    if cutoff < MIN_RELATIVE_CUTOFF * nyquist:
        raise InputError(
            f"low-pass cut-off {cutoff:.6g} Hz is below {MIN_RELATIVE_CUTOFF:g} of the Nyquist "
            f"frequency {nyquist:.6g} Hz: float64 cannot hold that filter; use at least "
            f"{MIN_RELATIVE_CUTOFF * nyquist:.3g} Hz"
        )
    if regular:
        grid, values = tt, xx
    else:
        m = round((tt[-1] - tt[0]) / h) + 1
        grid = tt[0] + h * np.arange(m)
        grid[-1] = min(grid[-1], tt[-1])
        values = _interp_rows(grid, tt, xx)
    design, padlen = _butter_lowpass(order, float(cutoff), 1.0 / h)
    if grid.size <= padlen:
        raise InputError(
            f"log of {grid.size} samples is shorter than the low-pass filter's padding "
            f"({padlen + 1} samples needed)"
        )
    y = _filtfilt(design, padlen, values)
    if regular:
        return np.asarray(y, dtype=np.float64)
    return _interp_rows(tt, grid, np.asarray(y, dtype=np.float64))


#: Lowest cut-off :func:`lowpass` designs, as a fraction of the Nyquist frequency: the
#: Butterworth's DC gain error in float64 grows as ``1e-16 / ratio**2`` (1.5e-8 at 1e-5, 8e-6
#: at 1e-6, and at 1e-9 its initial-state system is singular).
MIN_RELATIVE_CUTOFF = 1e-5


@functools.lru_cache(maxsize=64)
def _butter_lowpass(order: int, cutoff: float, fs: float) -> tuple[NDArray[np.float64], int]:
    """The Butterworth's second-order sections and ``sosfiltfilt``'s default padding.

    Designed once per (order, cut-off, rate): a log in blocks filters every piece of every
    block with the same filter, and the design costs as much as filtering 20 k samples.
    """
    from torquemap._signal_design import butter_lowpass_sos

    sos = butter_lowpass_sos(order, cutoff, fs)  # scipy.signal.butter's, bit for bit
    sos.setflags(write=False)
    padlen = 3 * (2 * len(sos) + 1 - min(int((sos[:, 2] == 0).sum()), int((sos[:, 5] == 0).sum())))
    return sos, padlen


@functools.lru_cache(maxsize=64)
def _initial_state(sos: bytes) -> NDArray[np.float64]:
    """``scipy.signal.sosfilt_zi`` of one section (given as its bytes: a cache key), bit for
    bit."""
    from torquemap._signal_design import sosfilt_zi

    zi = np.ascontiguousarray(sosfilt_zi(np.frombuffer(sos).reshape(1, 6)))
    zi.setflags(write=False)
    return np.asarray(zi, dtype=np.float64)


def _filtfilt(sos: NDArray[np.float64], padlen: int, values: NDArray[np.float64]) -> NDArray[Any]:
    """``scipy.signal.sosfiltfilt(sos, values, axis=0)`` (odd padding of ``padlen``), (n,) or
    (n, m): a single section (the order-2 Butterworth) by the compiled kernel, bit for bit."""
    if sos.shape[0] != 1:
        from scipy import signal

        return np.asarray(signal.sosfiltfilt(sos.copy(), values, axis=0))  # wants it writable
    from torquemap._kernels import sosfiltfilt_odd

    # one signal per row, contiguous in time (a column-major (n, m) is passed without a copy);
    # writable float64 throughout, so that the kernel is compiled for one signature only
    rows = np.ascontiguousarray(values.T if values.ndim == 2 else values[None, :])
    y = sosfiltfilt_odd(sos.copy(), _initial_state(sos.tobytes()).copy(), rows, padlen)
    return y.T if values.ndim == 2 else y[0]


def _interp_rows(
    x: NDArray[np.float64], xp: NDArray[np.float64], fp: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``np.interp`` of a signal (n,) or of each column of (n, m)."""
    if fp.ndim == 1:
        return np.asarray(np.interp(x, xp, fp), dtype=np.float64)
    return np.stack([np.interp(x, xp, fp[:, k]) for k in range(fp.shape[1])], axis=1)
