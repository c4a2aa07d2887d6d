"""The zero-phase low-pass of a regressor's combinations run at a decimated rate.

The parameters' share of the sigma (:func:`torquemap.uncertainty.parameter_variance`) low-passes
``p`` combinations of each sample's regressor row with the order-2 Butterworth forward and
backward (cut-off ``f_c``, 2 Hz by default) and sums their squares. Its result carries nothing
above a few ``f_c``, while the log is sampled at 250 Hz to 10 kHz: the filter and the
``p x p`` factor product are run at a rate ``f_s / m`` at least :data:`DECIMATED_RATE` times
the cut-off, the regressor rows only summed at the full rate.

The scheme (:func:`torquemap._kernels.decimated_variance`):

1. Anti-alias and decimate: each row into three cascaded boxcars of ``m`` samples (a CIC of
   order 3; ``m`` odd, so that the response is centred on a sample), one output every ``m``
   samples. Its gain ``(sin(pi f m / f_s) / (m sin(pi f / f_s)))^3`` has nulls at the
   multiples of ``f_s / m``, the frequencies that alias onto 0, and drops by
   ``(m^2 - 1) (pi f / f_s)^2 / 2`` at low ``f`` (5.8e-3 at ``f_c`` for ``f_s / m = 50 f_c``);
   a 3-tap ``(1 + 2 a, -a, -a)`` with ``a = (m^2 - 1) / (8 m^2)`` at the decimated rate
   cancels that droop to fourth order.
2. Filter: both passes advance the full-rate section's own state ``m`` samples at a time over
   the input interpolated between decimated samples by cubic Lagrange polynomials (exact for
   cubics: :func:`multirate_plan` sums the ``m`` steps into one 2x2 update and four input
   weights). It is the same filter, not a second design at the lower rate (a Butterworth
   designed at ``f_s / m`` differs by its bilinear warping, 9e-4 of the gain near 1.7 ``f_c``
   at ``f_s / m = 50 f_c``), so the first and last three decimated steps run at the full rate
   as :func:`torquemap.filters.lowpass` does (odd extension, initial state) and hand their
   state on.
3. Interpolate the sum of squares back to every sample (6-point Lagrange).

Error, against the full-rate filter (tests/test_multirate.py): for a sine and a cosine of unit
amplitude at one frequency as two combinations, the variance (``|H(f)|^4`` between the ends)
is off by at most 5.6e-6 away from the ends and 5.0e-5 within the full-rate ends (where the
odd extension makes it large at any frequency), at every frequency up to the log's Nyquist
frequency (45 frequencies, logs at 1, 2 and 5 kHz): :data:`SINE_BOUND` states 1e-4. Between
the ends the error is that of the interpolations and the compensation, fourth order in
``f / (f_s / m)``; above half the decimated rate the full-rate filter has already removed all
but ``(f_c / f)^4`` of the input. At the ends the stretch over which the decimated passes are
fitted to the full-rate ones (least squares, :data:`torquemap._kernels.FIT_STEPS`) leaves
the input's high frequencies a fraction of their amplitude. On the SCARA bench's circle
(2 kHz, ``m = 19``) the variance is within 7.9e-5 relative of the full-rate result at every
sample (median 7e-7); the tests hold random regressors to :data:`VARIANCE_RTOL`.

Irregular stamps (jitter, dropouts): :func:`torquemap.filters.lowpass` resamples such a log
linearly to a grid at its median step and interpolates the output back, so the direct formula
is the variance of combinations resampled that way. The decimated kernel runs on that grid
(:func:`resample_grid`): each grid point's row is interpolated between its two samples' rows
(formed at the samples, as the direct formula's columns are), and the variance is taken back
to the samples as the signals are interpolated (:func:`variance_at`, with the step term
``w (1 - w) |y_(i+1) - y_i|^2`` that interpolating the variance alone would add: it is not
small next to a variance that dips to near zero). What differs from the direct formula is the
decimation alone: jittered (3 % of a step) logs with one sample in 50 or 61 dropped, a sine and
a cosine at any frequency up to 0.45 of the rate within 2.3e-5 (2 kHz) and 6.5e-5 (1 kHz) of
unit amplitude (:data:`SINE_BOUND`), random regressors within 2.0e-5 relative, the SCARA
table law within 1.2e-4 relative (:data:`VARIANCE_RTOL`; tests/test_multirate.py,
tests/test_uncertainty.py).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: The decimated rate is at least this many cut-offs: the boxcars' alias of the content near
#: ``k f_s / m`` into the pass band is attenuated by their gain ``<= (f_c / (f_s / m))^3``
#: (8e-6), the cubic interpolation's error at ``f_c`` is ``(2 pi / 50)^4 9 / 384`` (6e-6),
#: the 6-point interpolation of the squares' content at ``2 f_c`` ``(4 pi / 50)^6 3.5 / 720``
#: (1.2e-6).
DECIMATED_RATE = 50.0
#: Fewest decimated samples a log must give: the full-rate ends and the stretches over
#: which the decimated passes are fitted to them (:data:`torquemap._kernels.FIT_STEPS`).
MIN_DECIMATED = 40
#: Error of the variance [per unit amplitude squared] of a sine and a cosine of one frequency
#: as two combinations, at any sample and frequency: measured worst 5.0e-5 (module notes),
#: a factor 2 of margin.
SINE_BOUND = 1e-4
#: Relative error of the variance the decimated form is held to on logs (tests): the
#: sinusoids' bound relative to the variance depends on how much of the regressor's content
#: lies above ``f_c`` against what passes; the worst measured is 7.9e-5 on the SCARA bench's
#: circle, where the friction table's columns switch within a few samples.
VARIANCE_RTOL = 1e-3


def decimation_factor(step: float, cutoff: float) -> int:
    """The odd decimation factor ``m`` with ``1 / (m step) >= DECIMATED_RATE cutoff``.

    Parameters
    ----------
    step : float
        Sample step of the log [s].
    cutoff : float
        Low-pass cut-off [Hz].

    Returns
    -------
    int
        ``m >= 1``; 1 where the log is too slow to decimate.

    Examples
    --------
    >>> decimation_factor(5e-4, 2.0)  # 2 kHz, 2 Hz: 100 Hz decimated is 20, odd 19
    19
    >>> decimation_factor(4e-3, 2.0)  # 250 Hz: no room
    1
    """
    m = math.floor(1.0 / (step * DECIMATED_RATE * cutoff) + 1e-9)
    if m % 2 == 0:
        m -= 1
    return max(m, 1)


@dataclass(frozen=True, slots=True, eq=False)
class RegularGrid:
    """The regular grid :func:`torquemap.filters.lowpass` resamples an irregular log to.

    Attributes
    ----------
    step : float
        The grid's step [s]: the log's median step.
    times : ndarray
        The grid's times [s], shape (m,): from the log's first stamp, the last one clipped to
        the log's last.
    index : ndarray
        Per grid point, the sample at or before it (int64, ``0 .. n - 2``), shape (m,).
    weight : ndarray
        Per grid point, how far it lies from sample ``index`` towards the next, 0 to 1,
        shape (m,).
    """

    step: float
    times: NDArray[np.float64]
    index: NDArray[np.int64]
    weight: NDArray[np.float64]


def resample_grid(t: NDArray[np.float64]) -> RegularGrid | None:
    """The grid at the median step over ``t`` [s] (strictly increasing, shape (n,), n >= 2)
    and where each of its points falls between the samples, as
    :func:`torquemap.filters.lowpass` resamples (``numpy.interp``); None when ``t`` is not
    finite and strictly increasing (the low-pass refuses it).

    Examples
    --------
    >>> g = resample_grid(np.array([0.0, 1.0, 2.5, 3.0, 4.0]))
    >>> g.step, g.times.tolist(), g.index.tolist(), g.weight.tolist()
    (1.0, [0.0, 1.0, 2.0, 3.0, 4.0], [0, 1, 1, 3, 3], [0.0, 0.0, 0.6666666666666666, 0.0, 1.0])
    """
    n = t.size
    if n < 2:
        return None
    dt = np.diff(t)
    if not (np.all(np.isfinite(t)) and np.all(dt > 0)):
        return None
    h = float(np.median(dt))  # filters.uniform_step
    size = round((t[-1] - t[0]) / h) + 1
    times = t[0] + h * np.arange(size)
    times[-1] = min(times[-1], t[-1])
    from torquemap._fit_kernels import search_increasing

    # numpy.searchsorted's indices by one forward walk (both increase)
    index = np.clip(search_increasing(t, times, True) - 1, 0, n - 2)
    weight = np.clip((times - t[index]) / dt[index], 0.0, 1.0)
    return RegularGrid(step=h, times=times, index=index.astype(np.int64), weight=weight)


def variance_at(
    t: NDArray[np.float64],
    times: NDArray[np.float64],
    variance: NDArray[np.float64],
    steps: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The variance at ``t`` [s] of signals interpolated linearly from a grid (``times``
    (m,), increasing) as :func:`torquemap.filters.lowpass` interpolates its output back.

    ``variance`` (m,) is ``sum_k y_k^2`` at the grid's points and ``steps`` (m - 1,) is
    ``sum_k (y_k(i + 1) - y_k(i))^2`` over each step: at a fraction ``w`` into step ``i``,
    ``sum_k ((1 - w) y_k(i) + w y_k(i + 1))^2 = (1 - w) v_i + w v_(i+1) - w (1 - w) s_i``
    (exact algebra). Interpolating the variance alone would overstate it by the last term,
    which is not small next to a variance that dips to near zero. Outside the grid: its end
    values (``numpy.interp``'s).

    Examples
    --------
    >>> times = np.array([0.0, 1.0])
    >>> y = np.array([[1.0, 0.0], [-1.0, 2.0]])  # two signals at the two points
    >>> v, s = (y**2).sum(axis=1), (np.diff(y, axis=0) ** 2).sum(axis=1)
    >>> variance_at(np.array([0.5]), times, v, s).tolist()  # y(0.5) = (0, 1)
    [1.0]
    """
    from torquemap._fit_kernels import search_increasing

    size = times.size
    t = np.ascontiguousarray(t, dtype=np.float64)
    if t.size > 1 and not bool(np.all(t[1:] >= t[:-1])):
        at = np.searchsorted(times, t, side="right") - 1  # not sorted: no forward walk
    else:
        at = search_increasing(np.ascontiguousarray(times), t, True) - 1
    at = np.clip(at, 0, size - 2)
    w = np.clip((t - times[at]) / (times[at + 1] - times[at]), 0.0, 1.0)
    out = variance[at] + (variance[at + 1] - variance[at]) * w - w * (1.0 - w) * steps[at]
    return np.asarray(np.maximum(out, 0.0), dtype=np.float64)


def lagrange_weights(nodes: NDArray[np.float64], at: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lagrange interpolation weights (len(at), len(nodes)) of the polynomial through
    ``nodes`` evaluated at ``at`` (both in units of the grid step)."""
    nodes = np.asarray(nodes, dtype=np.float64)
    at = np.asarray(at, dtype=np.float64)
    out = np.ones((at.size, nodes.size))
    for q, a in enumerate(nodes):
        for b in nodes:
            if b != a:
                out[:, q] *= (at - b) / (a - b)
    return out


@functools.lru_cache(maxsize=16)
def multirate_plan(sos: bytes, m: int) -> tuple[object, ...]:
    """The :data:`torquemap._kernels.MultiratePlan` of one order-2 section (its bytes: a
    cache key) decimated by ``m`` (odd, >= 3).

    With scipy's transposed direct form ``z' = A z + B x`` (``A = [[-a1, 1], [-a2, 0]]``,
    ``B = [b1 - a1 b0, b2 - a2 b0]``) and the input between decimated samples ``j`` and
    ``j + 1`` taken as the cubic through ``x[j - 1 .. j + 2]`` (weights ``L_q(i / m)`` at
    the ``i``-th sample), ``m`` steps are ``z' = A^m z + sum_q (sum_i A^(m - i) B L_q(i / m))
    x[j - 1 + q]``.
    """
    b0, b1, b2, _, a1, a2 = np.frombuffer(sos).reshape(6)
    a = np.array([[-a1, 1.0], [-a2, 0.0]])
    b = np.array([b1 - a1 * b0, b2 - a2 * b0])
    cubic = lagrange_weights(np.array([-1.0, 0.0, 1.0, 2.0]), np.arange(1, m + 1) / m)
    # powers[i] = A^(m - 1 - i) B for i = 0 .. m - 1 (sample i + 1 of the step)
    powers = np.empty((m, 2))
    power = b.copy()
    for i in range(m - 1, -1, -1):
        powers[i] = power
        power = a @ power
    inputs = cubic.T @ powers  # (4, 2): sum_i L_q((i + 1) / m) A^(m - 1 - i) B
    inputs_short = cubic[: m - 1].T @ (powers[1:] if m > 1 else powers[:0])
    step = np.linalg.matrix_power(a, m)
    step_short = np.linalg.matrix_power(a, m - 1)
    box = np.full(m, 1.0 / m)
    cic = np.convolve(np.convolve(box, box), box)
    alpha = (m * m - 1.0) / (8.0 * m * m)
    offsets = np.arange(m) / m
    centred = lagrange_weights(np.arange(-2.0, 4.0), offsets)
    first = lagrange_weights(np.arange(-1.0, 5.0), offsets)
    return (
        m,
        np.ascontiguousarray(cic),
        float(alpha),
        np.ascontiguousarray(step),
        np.ascontiguousarray(inputs),
        np.ascontiguousarray(step_short),
        np.ascontiguousarray(inputs_short),
        np.ascontiguousarray(centred),
        np.ascontiguousarray(first),
    )
