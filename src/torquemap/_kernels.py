"""Compiled per-sample kernels of the estimate's and identification's hot paths.

Each kernel fuses what numpy does in several passes over a log (a temporary of the log's size
per operation) into one compiled loop over cache-sized stretches. They are plain functions on
C-contiguous float64 arrays, called by the module that owns the concept (:mod:`filters`,
:mod:`model`, :mod:`kinematics`, :mod:`sanitize`); each is tested against the numpy/scipy
code it replaces (tests/test_kernels.py). Compiled once per signature and cached on disk
(:func:`torquemap._jit.jit`): the callers always pass the same dtypes and layouts.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from torquemap._jit import jit

#: Samples per stretch of the tiled kernels: a few arrays of it stay in the L1/L2 cache.
TILE = 512

#: The regressor of :func:`regressor_directions`, a tuple: ``(dense, dense_index, theta,
#: velocity, line_order, line_power, line_cos, line_sin, line_direction, knot_logs,
#: knot_positive, knot_negative, viscous, viscous_negative, zero_velocity, directions,
#: reach, cos_theta, sin_theta)`` (the arrays float64 or int64, C-contiguous; ``viscous``,
#: ``viscous_negative`` int, ``zero_velocity`` float; ``cos_theta``, ``sin_theta`` the
#: cosine and sine of ``theta`` when the caller has them, else empty).
RegressorSpec = tuple[Any, ...]


@jit
def sosfiltfilt_odd(
    sos: NDArray[np.float64], zi: NDArray[np.float64], x: NDArray[np.float64], pad: int
) -> NDArray[np.float64]:
    """``scipy.signal.sosfiltfilt(sos, x, axis=1, padtype="odd", padlen=pad)`` of (m, n):
    ``m`` signals of ``n`` samples each, one per row (contiguous in time).

    One second-order section ``sos`` (1, 6) (an order-2 Butterworth); ``zi`` is
    ``scipy.signal.sosfilt_zi(sos)``, shape (1, 2); ``n > pad``. Each signal's recurrence is
    that of scipy's ``_sosfilt`` in the same order of operations (bit for bit); four signals
    run side by side in registers, so that their recurrences overlap instead of each waiting
    on its own previous sample, and the odd extensions at the ends are read on the fly.
    """
    m, n = x.shape
    out = np.empty((m, n))
    work = np.empty((n + 2 * pad, 4))
    for c0 in range(0, m, 4):
        _filtfilt_four(sos, zi, x, pad, c0, work, out)
    return out


@jit
def _filtfilt_four(
    sos: NDArray[np.float64],
    zi: NDArray[np.float64],
    x: NDArray[np.float64],
    pad: int,
    c0: int,
    work: NDArray[np.float64],
    out: NDArray[np.float64],
) -> None:
    """:func:`sosfiltfilt_odd` of one section on rows ``c0:c0 + 4`` of ``x`` into ``out`` (a
    row past the last repeats the last: its result is dropped)."""
    m, n = x.shape
    total = n + 2 * pad
    ca = c0
    cb = min(c0 + 1, m - 1)
    cc = min(c0 + 2, m - 1)
    cd = min(c0 + 3, m - 1)
    b0, b1, b2, a1, a2 = sos[0, 0], sos[0, 1], sos[0, 2], sos[0, 4], sos[0, 5]
    za, zb = zi[0, 0], zi[0, 1]
    # forward, over the odd extension: ext[j] = 2 x[0] - x[pad - j] (j < pad), x[j - pad],
    # 2 x[n - 1] - x[2 n + pad - 2 - j] (j >= pad + n)
    ea = 2.0 * x[ca, 0] - x[ca, pad]
    eb = 2.0 * x[cb, 0] - x[cb, pad]
    ec = 2.0 * x[cc, 0] - x[cc, pad]
    ed = 2.0 * x[cd, 0] - x[cd, pad]
    z0a, z1a = za * ea, zb * ea
    z0b, z1b = za * eb, zb * eb
    z0c, z1c = za * ec, zb * ec
    z0d, z1d = za * ed, zb * ed
    for j in range(total):
        if j < pad:
            xa = 2.0 * x[ca, 0] - x[ca, pad - j]
            xb = 2.0 * x[cb, 0] - x[cb, pad - j]
            xc = 2.0 * x[cc, 0] - x[cc, pad - j]
            xd = 2.0 * x[cd, 0] - x[cd, pad - j]
        elif j < pad + n:
            xa, xb, xc, xd = x[ca, j - pad], x[cb, j - pad], x[cc, j - pad], x[cd, j - pad]
        else:
            k = 2 * n + pad - 2 - j
            xa = 2.0 * x[ca, n - 1] - x[ca, k]
            xb = 2.0 * x[cb, n - 1] - x[cb, k]
            xc = 2.0 * x[cc, n - 1] - x[cc, k]
            xd = 2.0 * x[cd, n - 1] - x[cd, k]
        ya = b0 * xa + z0a
        yb = b0 * xb + z0b
        yc = b0 * xc + z0c
        yd = b0 * xd + z0d
        z0a = b1 * xa - a1 * ya + z1a
        z0b = b1 * xb - a1 * yb + z1b
        z0c = b1 * xc - a1 * yc + z1c
        z0d = b1 * xd - a1 * yd + z1d
        z1a = b2 * xa - a2 * ya
        z1b = b2 * xb - a2 * yb
        z1c = b2 * xc - a2 * yc
        z1d = b2 * xd - a2 * yd
        work[j, 0], work[j, 1], work[j, 2], work[j, 3] = ya, yb, yc, yd
    last = total - 1
    z0a, z1a = za * work[last, 0], zb * work[last, 0]
    z0b, z1b = za * work[last, 1], zb * work[last, 1]
    z0c, z1c = za * work[last, 2], zb * work[last, 2]
    z0d, z1d = za * work[last, 3], zb * work[last, 3]
    count = min(4, m - c0)
    for step in range(total):
        j = last - step
        xa, xb, xc, xd = work[j, 0], work[j, 1], work[j, 2], work[j, 3]
        ya = b0 * xa + z0a
        yb = b0 * xb + z0b
        yc = b0 * xc + z0c
        yd = b0 * xd + z0d
        z0a = b1 * xa - a1 * ya + z1a
        z0b = b1 * xb - a1 * yb + z1b
        z0c = b1 * xc - a1 * yc + z1c
        z0d = b1 * xd - a1 * yd + z1d
        z1a = b2 * xa - a2 * ya
        z1b = b2 * xb - a2 * yb
        z1c = b2 * xc - a2 * yc
        z1d = b2 * xd - a2 * yd
        if pad <= j < pad + n:
            i = j - pad
            out[ca, i] = ya
            if count > 1:
                out[cb, i] = yb
            if count > 2:
                out[cc, i] = yc
            if count > 3:
                out[cd, i] = yd


@jit
def savgol_fit(
    y: NDArray[np.float64],
    smooth: NDArray[np.float64],
    odd: NDArray[np.float64],
    even: NDArray[np.float64],
    position: NDArray[np.float64],
    velocity: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    with_position: bool,
) -> None:
    """The centred Savitzky-Golay fit of ``y`` (n,): position (if ``with_position``), velocity
    and acceleration, in place.

    ``smooth[k]``, ``odd[k]`` and ``even[k]`` (k = 0..half) are the position's symmetric, the
    velocity's antisymmetric and the acceleration's symmetric correlation weights at lag ``k``.
    For ``half <= i < n - half`` and ``d[k] = (y[i + k] - y[i]) + (y[i - k] - y[i])``:
    ``position[i] = y[i] + sum_k smooth[k] d[k]`` (the weights sum to one),
    ``velocity[i] = sum_k odd[k] (y[i + k] - y[i - k])`` and ``acceleration[i] = sum_k
    even[k] d[k]`` (they sum to zero: the centre's own weight is implied). All in one pass
    over a stretch of outputs at a time, four lags at a time outside (so the compiler
    vectorises across samples); the sums are of local differences, exact to the rounding of
    the signal's change over the window, not of its value.
    """
    n = y.size
    half = odd.size - 1
    acc_p = np.empty(TILE)
    acc_v = np.empty(TILE)
    acc_a = np.empty(TILE)
    for start in range(half, n - half, TILE):
        m = min(TILE, n - half - start)
        centre = y[start : start + m]
        for j in range(m):
            acc_p[j] = 0.0
            acc_v[j] = 0.0
            acc_a[j] = 0.0
        k = 1
        while k + 3 <= half:  # four lags per pass over the stretch: fewer loads and stores
            c1, c2, c3, c4 = odd[k], odd[k + 1], odd[k + 2], odd[k + 3]
            e1, e2, e3, e4 = even[k], even[k + 1], even[k + 2], even[k + 3]
            s1, s2, s3, s4 = smooth[k], smooth[k + 1], smooth[k + 2], smooth[k + 3]
            a1 = y[start + k : start + k + m]
            a2 = y[start + k + 1 : start + k + 1 + m]
            a3 = y[start + k + 2 : start + k + 2 + m]
            a4 = y[start + k + 3 : start + k + 3 + m]
            b1 = y[start - k : start - k + m]
            b2 = y[start - k - 1 : start - k - 1 + m]
            b3 = y[start - k - 2 : start - k - 2 + m]
            b4 = y[start - k - 3 : start - k - 3 + m]
            for j in range(m):
                c = centre[j]
                d1 = (a1[j] - c) + (b1[j] - c)
                d2 = (a2[j] - c) + (b2[j] - c)
                d3 = (a3[j] - c) + (b3[j] - c)
                d4 = (a4[j] - c) + (b4[j] - c)
                acc_v[j] += (c1 * (a1[j] - b1[j]) + c2 * (a2[j] - b2[j])) + (
                    c3 * (a3[j] - b3[j]) + c4 * (a4[j] - b4[j])
                )
                acc_a[j] += (e1 * d1 + e2 * d2) + (e3 * d3 + e4 * d4)
                if with_position:
                    acc_p[j] += (s1 * d1 + s2 * d2) + (s3 * d3 + s4 * d4)
            k += 4
        while k <= half:
            ck = odd[k]
            ek = even[k]
            sk = smooth[k]
            ahead = y[start + k : start + k + m]
            behind = y[start - k : start - k + m]
            for j in range(m):
                p = ahead[j]
                q = behind[j]
                c = centre[j]
                d = (p - c) + (q - c)
                acc_v[j] += ck * (p - q)
                acc_a[j] += ek * d
                if with_position:
                    acc_p[j] += sk * d
            k += 1
        for j in range(m):
            velocity[start + j] = acc_v[j]
            acceleration[start + j] = acc_a[j]
            if with_position:
                position[start + j] = centre[j] + acc_p[j]


@jit
def phasor_lines(
    cos_theta: NDArray[np.float64],
    sin_theta: NDArray[np.float64],
    velocity: NDArray[np.float64],
    orders: NDArray[np.int64],
    real: NDArray[np.float64],
    imag: NDArray[np.float64],
    direction: NDArray[np.int64],
    out: NDArray[np.float64],
) -> None:
    """``out += sum_j Re((real[j] + i imag[j]) z^orders[j])``, ``z = cos + i sin``, in place.

    For a line ``a cos(k theta + phi)``: ``real = a cos(phi)``, ``imag = a sin(phi)`` (then
    ``Re(...) = a (cos phi cos k theta - sin phi sin k theta)``). ``direction[j]`` is 0 for a
    line that always applies, +1 (-1) for one that applies where ``velocity`` is positive
    (negative). The powers by repeated squaring and one product per further set bit of the
    order (48: five squarings and a product), a stretch of samples at a time.
    """
    n = cos_theta.size
    top = 1
    for k in orders:
        while (1 << top) <= k:
            top += 1
    sq_re = np.empty((top, TILE))
    sq_im = np.empty((top, TILE))
    pr = np.empty(TILE)
    pi = np.empty(TILE)
    for start in range(0, n, TILE):
        stop = min(start + TILE, n)
        m = stop - start
        for i in range(m):
            sq_re[0, i] = cos_theta[start + i]
            sq_im[0, i] = sin_theta[start + i]
        for b in range(1, top):
            for i in range(m):
                re = sq_re[b - 1, i]
                im = sq_im[b - 1, i]
                sq_re[b, i] = re * re - im * im
                sq_im[b, i] = 2.0 * re * im
        for j in range(orders.size):
            k = orders[j]
            first = True
            for b in range(top):
                if (k >> b) & 1:
                    if first:
                        for i in range(m):
                            pr[i] = sq_re[b, i]
                            pi[i] = sq_im[b, i]
                        first = False
                    else:
                        for i in range(m):
                            re = pr[i] * sq_re[b, i] - pi[i] * sq_im[b, i]
                            pi[i] = pr[i] * sq_im[b, i] + pi[i] * sq_re[b, i]
                            pr[i] = re
            ar = real[j]
            ai = imag[j]
            d = direction[j]
            if d == 0:
                for i in range(m):
                    out[start + i] += ar * pr[i] - ai * pi[i]
            else:
                for i in range(m):
                    v = velocity[start + i]
                    if (d > 0 and v > 0) or (d < 0 and v < 0):
                        out[start + i] += ar * pr[i] - ai * pi[i]


@jit
def max_abs(x: NDArray[np.float64]) -> float:
    """``max(|x|)`` (NaN if any is NaN), without the temporary of ``numpy.abs``."""
    top = 0.0
    for v in x:
        a = abs(v)
        if a != a:
            return float(a)
        if a > top:
            top = float(a)
    return top


@jit
def step_counts(x: NDArray[np.float64], scale: float, guess: float) -> tuple[int, int]:
    """For ``d = |diff(x / scale)|``: the number of nonzero ``d`` and of ``d >= guess``."""
    nonzero = 0
    reach = 0
    previous = x[0] / scale
    for i in range(1, x.size):
        u = x[i] / scale
        d = abs(u - previous)
        previous = u
        if d > 0:
            nonzero += 1
        if d >= guess:
            reach += 1
    return nonzero, reach


@jit
def median_reach_suspects(x: NDArray[np.float64], scale: float, bound: float) -> NDArray[np.int64]:
    """Samples ``i`` of ``u = x / scale`` farther than ``bound`` from one of ``u[i - 2..i + 2]``
    (the ends repeated, ``mode="nearest"``): those that may leave the running median of 9 by
    more than ``bound`` (:func:`torquemap.sanitize._none_beyond`). Sorted indices.

    A stretch at a time: ``u`` with two samples either side, then the test of every sample
    (vectorised), then the rare suspects collected.
    """
    n = x.size
    out = np.empty(16, dtype=np.int64)
    count = 0
    u = np.empty(TILE + 4)
    far = np.empty(TILE, dtype=np.bool_)
    for start in range(0, n, TILE):
        m = min(TILE, n - start)
        for j in range(m + 4):
            u[j] = x[min(max(start + j - 2, 0), n - 1)] / scale
        hits = 0
        for j in range(m):
            c = u[j + 2]
            top = max(max(max(u[j], u[j + 1]), max(u[j + 3], u[j + 4])), c)
            low = min(min(min(u[j], u[j + 1]), min(u[j + 3], u[j + 4])), c)
            f = (top - c > bound) | (c - low > bound)
            far[j] = f
            hits += f
        if hits == 0:
            continue
        for j in range(m):
            if far[j]:
                if count == out.size:
                    grown = np.empty(2 * out.size, dtype=np.int64)
                    grown[:count] = out[:count]
                    out = grown
                out[count] = start + j
                count += 1
    return out[:count].copy()


@jit
def angle_step_summary(t: NDArray[np.float64], q: NDArray[np.float64]) -> tuple[bool, float]:
    """Whether every ``|diff(q)|`` is finite and every ``diff(t)`` positive, and the largest
    ``|diff(q)|`` (:func:`torquemap.sanitize.angle_jumps`)."""
    ok = True
    top = 0.0
    for i in range(1, q.size):
        d = abs(q[i] - q[i - 1])
        if not (math.isfinite(d) and t[i] - t[i - 1] > 0):
            ok = False
        if d > top:
            top = d
    return ok, top


@jit
def step_range(t: NDArray[np.float64]) -> tuple[bool, float, float]:
    """Whether every ``t`` is finite, and the smallest and largest of ``numpy.diff(t)`` (NaN
    both when a difference is NaN, as ``numpy.min``/``max`` give); ``t`` has >= 2 values. One
    pass, no temporary: what :func:`torquemap.filters.regular_step` and the filters' input
    checks take from ``t``."""
    finite = True
    lo = math.inf
    hi = -math.inf
    nan = False
    for i in range(t.size):
        if not math.isfinite(t[i]):
            finite = False
        if i:
            d = t[i] - t[i - 1]
            if d != d:
                nan = True
            lo = min(lo, d)
            hi = max(hi, d)
    if nan:
        return finite, math.nan, math.nan
    return finite, lo, hi


@jit
def count_at_least(x: NDArray[np.float64], reach: float) -> int:
    """The number of ``|diff(x)| >= reach``."""
    count = 0
    for i in range(1, x.size):
        if abs(x[i] - x[i - 1]) >= reach:
            count += 1
    return count


@jit
def planar_force(
    q: NDArray[np.float64],
    tau: NDArray[np.float64],
    tau_sigma: NDArray[np.float64],
    l1: float,
    l2: float,
    guard: float,
    force: NDArray[np.float64],
    sigma: NDArray[np.float64],
    singular: NDArray[np.bool_],
) -> None:
    """The planar two-link arm's ``F = J^-T tau`` and its sigma, per sample, in place.

    ``J = [[a, b], [c, d]]`` with ``a = -l1 sin q1 - l2 sin q12``, ``b = -l2 sin q12``,
    ``c = l1 cos q1 + l2 cos q12``, ``d = l2 cos q12``; ``A = J^-T = [[d, -c], [-b, a]] /
    det`` (:func:`torquemap.kinematics.force_map`), NaN where ``|sin q2| < guard``. ``F = A
    tau`` with NaN torques taken as 0 (``numpy.nan_to_num``) and ``sigma_i = sqrt(sum_j
    A_ij^2 sigma_j^2)``. Shapes (n, 2), ``singular`` (n,).
    """
    big = np.finfo(np.float64).max
    for i in range(q.shape[0]):
        q1 = q[i, 0]
        q2 = q[i, 1]
        bad = abs(math.sin(q2)) < guard
        q12 = q1 + q2
        s12 = math.sin(q12)
        c12 = math.cos(q12)
        a = -l1 * math.sin(q1) - l2 * s12
        c = l1 * math.cos(q1) + l2 * c12
        b = -l2 * s12
        d = l2 * c12
        inv = math.nan if bad else 1.0 / (a * d - b * c)
        m00 = d * inv
        m01 = -c * inv
        m10 = -b * inv
        m11 = a * inv
        t0 = tau[i, 0]
        t1 = tau[i, 1]
        t0 = 0.0 if t0 != t0 else (big if t0 > big else (-big if t0 < -big else t0))
        t1 = 0.0 if t1 != t1 else (big if t1 > big else (-big if t1 < -big else t1))
        force[i, 0] = m00 * t0 + m01 * t1
        force[i, 1] = m10 * t0 + m11 * t1
        v0 = tau_sigma[i, 0] ** 2
        v1 = tau_sigma[i, 1] ** 2
        sigma[i, 0] = math.sqrt(m00**2 * v0 + m01**2 * v1)
        sigma[i, 1] = math.sqrt(m10**2 * v0 + m11**2 * v1)
        singular[i] = bad


@jit
def _powers_top(line_power: NDArray[np.int64]) -> int:
    """The number of squarings of ``exp(i theta)`` the largest integer order needs, plus one."""
    top = 1
    for k in line_power:
        while (1 << top) <= k:
            top += 1
    return top


@jit
def _line_values(
    start: int, stop: int, spec: RegressorSpec, values: NDArray[np.float64], offset: int
) -> None:
    """The PDTV lines' cosines and sines of samples ``start:stop`` into ``values[0:stop -
    start]``, line ``l`` at columns ``offset + 2 l`` and ``offset + 2 l + 1`` (0 where the
    line's direction of motion excludes the sample). Each line's powers of ``exp(i theta)``
    run over the stretch's samples side by side (independent: vectorised), not sample by
    sample (a chain of dependent products each)."""
    theta, velocity = spec[2], spec[3]
    line_order, line_power, line_direction = spec[4], spec[5], spec[8]
    count = stop - start
    if not line_order.size:
        return
    top = _powers_top(line_power)
    sq_re = np.empty((top, count))
    sq_im = np.empty((top, count))
    cos_theta, sin_theta = spec[17], spec[18]
    if cos_theta.size:  # the caller's: the same libm values, not computed twice
        for at_row in range(count):
            sq_re[0, at_row] = cos_theta[start + at_row]
            sq_im[0, at_row] = sin_theta[start + at_row]
    else:
        for at_row in range(count):
            sq_re[0, at_row] = math.cos(theta[start + at_row])
            sq_im[0, at_row] = math.sin(theta[start + at_row])
    for b in range(1, top):
        for at_row in range(count):
            re = sq_re[b - 1, at_row]
            im = sq_im[b - 1, at_row]
            sq_re[b, at_row] = re * re - im * im
            sq_im[b, at_row] = 2.0 * re * im
    pr = np.empty(count)
    pi = np.empty(count)
    for line in range(line_order.size):
        k = line_power[line]
        if k >= 0:
            for at_row in range(count):
                pr[at_row] = 1.0
                pi[at_row] = 0.0
            for b in range(top):
                if (k >> b) & 1:
                    for at_row in range(count):
                        re = pr[at_row] * sq_re[b, at_row] - pi[at_row] * sq_im[b, at_row]
                        pi[at_row] = pr[at_row] * sq_im[b, at_row] + pi[at_row] * sq_re[b, at_row]
                        pr[at_row] = re
        else:
            for at_row in range(count):
                angle = line_order[line] * theta[start + at_row]
                pr[at_row] = math.cos(angle)
                pi[at_row] = math.sin(angle)
        direction = line_direction[line]
        at_cos = offset + 2 * line
        for at_row in range(count):
            w = velocity[start + at_row]
            if (direction > 0 and not w > 0) or (direction < 0 and not w < 0):
                values[at_row, at_cos] = 0.0
                values[at_row, at_cos + 1] = 0.0
            else:
                values[at_row, at_cos] = pr[at_row]
                values[at_row, at_cos + 1] = pi[at_row]


@jit
def _regressor_lines(start: int, stop: int, spec: RegressorSpec, rows: NDArray[np.float64]) -> None:
    """Rows ``0:stop - start`` zeroed and the PDTV lines' cosines and sines of samples
    ``start:stop`` written (:func:`regressor_directions`, :func:`_line_values`)."""
    line_cos, line_sin = spec[6], spec[7]
    count = stop - start
    p = rows.shape[1]
    for at_row in range(count):
        for j in range(p):
            rows[at_row, j] = 0.0
    lines = line_cos.size
    if not lines:
        return
    values = np.empty((count, 2 * lines))
    _line_values(start, stop, spec, values, 0)
    for line in range(lines):
        at_cos = line_cos[line]
        at_sin = line_sin[line]
        for at_row in range(count):
            if at_cos >= 0:
                rows[at_row, at_cos] = values[at_row, 2 * line]
            if at_sin >= 0:
                rows[at_row, at_sin] = values[at_row, 2 * line + 1]


@jit
def _branch_blend(w: float, saturated: float, zero_velocity: float) -> float:
    """The positive branch's weight ``(1 + tanh(w / zero_velocity)) / 2`` of a speed table
    (:func:`regressor_directions`); 1 or 0 exactly beyond ``saturated``."""
    if w > saturated:
        return 1.0
    if w < -saturated:
        return 0.0
    return 0.5 * (1.0 + math.tanh(w / zero_velocity))


@jit
def _knot_segment(s: float, lo: int, knot_logs: NDArray[np.float64]) -> tuple[int, int, float]:
    """The knot count ``lo`` below ``log(s)`` (``numpy.searchsorted(knot_logs, log(s),
    side="right")``, walked from the last sample's), the segment ``at`` it falls in and the
    fraction ``u`` of the way to knot ``at + 1`` (clipped to [0, 1])."""
    k_knots = knot_logs.size
    x = math.log(max(s, 1e-300))
    while lo > 0 and knot_logs[lo - 1] > x:
        lo -= 1
    while lo < k_knots and knot_logs[lo] <= x:
        lo += 1
    at = min(max(lo - 1, 0), k_knots - 2)
    u = (x - knot_logs[at]) / (knot_logs[at + 1] - knot_logs[at])
    return lo, at, min(max(u, 0.0), 1.0)


@jit
def _regressor_block(start: int, stop: int, spec: RegressorSpec, rows: NDArray[np.float64]) -> None:
    """Samples ``start:stop``'s regressor rows (p,) into ``rows[0:stop - start]``
    (:func:`regressor_directions`); a stretch per call (a call passes every array)."""
    dense, dense_index, velocity = spec[0], spec[1], spec[3]
    knot_logs, knot_positive, knot_negative = spec[9], spec[10], spec[11]
    viscous, viscous_negative, zero_velocity = spec[12], spec[13], spec[14]
    k_knots = knot_logs.size
    # tanh(x) is 1.0 exactly in float64 beyond 19.1: the blend needs no libm call there
    saturated = 20.0 * abs(zero_velocity)
    lo = 0  # the knot count below the speed, carried from sample to sample
    _regressor_lines(start, stop, spec, rows)
    for i in range(start, stop):
        at_row = i - start  # indexed, not a view per sample (each would touch a refcount)
        for d in range(dense_index.size):
            rows[at_row, dense_index[d]] = dense[d, i]
        w = velocity[i]
        if k_knots >= 2 or viscous >= 0 or viscous_negative >= 0:
            s = abs(w)
            blend = _branch_blend(w, saturated, zero_velocity)
            other = -(1.0 - blend)
            if k_knots >= 2:
                lo, at, u = _knot_segment(s, lo, knot_logs)
                if knot_positive[at] >= 0:
                    rows[at_row, knot_positive[at]] = blend * (1.0 - u)
                if knot_negative[at] >= 0:
                    rows[at_row, knot_negative[at]] = other * (1.0 - u)
                if knot_positive[at + 1] >= 0:
                    rows[at_row, knot_positive[at + 1]] = blend * u
                if knot_negative[at + 1] >= 0:
                    rows[at_row, knot_negative[at + 1]] = other * u
            if viscous >= 0:
                rows[at_row, viscous] = blend * s
            if viscous_negative >= 0:
                rows[at_row, viscous_negative] = other * s


@jit
def _regressor_rows(start: int, stop: int, spec: RegressorSpec, out: NDArray[np.float64]) -> None:
    """Samples ``start:stop``'s regressor rows times ``directions`` into ``out[0:stop -
    start]`` (:func:`regressor_directions`), a tile at a time."""
    directions, reach = spec[15], spec[16]
    p = directions.shape[0]
    rows = np.empty((min(TILE, max(stop - start, 0)), p))
    for first in range(start, stop, TILE):
        last = min(first + TILE, stop)
        _regressor_block(first, last, spec, rows)
        for i in range(first, last):
            _combine_rows(rows, i - first, directions, reach, out, i - start)


@jit
def regressor_directions(spec: RegressorSpec) -> NDArray[np.float64]:
    """Each sample's regressor row ``g`` (p,) times ``directions`` (p, r): shape (n, r),
    without forming the (n, p) regressor. Row ``j`` of ``directions`` is read up to
    ``reach[j]`` (the rest taken as zero: a triangular factor); ``spec`` is
    :data:`RegressorSpec`.

    The row (:func:`torquemap.uncertainty.regressor_columns`): ``dense[d]`` (n,) at parameter
    ``dense_index[d]``; PDTV line ``l`` as ``cos`` and ``sin`` of ``line_order[l] theta`` at
    parameters ``line_cos[l]``, ``line_sin[l]`` (-1: absent), by powers of ``exp(i theta)``
    where ``line_power[l] >= 0`` (an integer order), applying only while the velocity is
    positive (negative) where ``line_direction[l]`` is +1 (-1); a speed table's knot weights
    (linear in log speed, :class:`torquemap.friction_law.SpeedTableFriction`) times the
    branch blend ``b = (1 + tanh(w / zero_velocity)) / 2`` at the positive knots
    ``knot_positive`` and ``-(1 - b)`` at the negative ones, ``b |w|`` and ``-(1 - b) |w|``
    at ``viscous`` and ``viscous_negative`` (-1: absent; no table when ``knot_logs`` is
    empty).
    """
    n = spec[2].size
    out = np.empty((n, spec[15].shape[1]))
    for start in range(0, n, TILE):
        stop = min(start + TILE, n)
        _regressor_rows(start, stop, spec, out[start:stop])
    return out


@jit
def _forward_step(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    z0: NDArray[np.float64],
    z1: NDArray[np.float64],
    b0: float,
    b1: float,
    b2: float,
    a1: float,
    a2: float,
) -> None:
    """One sample of the order-2 section (scipy's ``_sosfilt``) for every signal, in place."""
    for k in range(x.size):
        xk = x[k]
        yk = b0 * xk + z0[k]
        z0[k] = b1 * xk - a1 * yk + z1[k]
        z1[k] = b2 * xk - a2 * yk
        y[k] = yk


@jit
def lowpassed_variance(
    spec: RegressorSpec,
    weights: NDArray[np.float64],
    sos: NDArray[np.float64],
    zi: NDArray[np.float64],
    pad: int,
) -> NDArray[np.float64]:
    """``sum_k weights[k] y_k^2`` per sample (n,), ``y = scipy.signal.sosfiltfilt(sos, x,
    axis=0, padtype="odd", padlen=pad)`` of the ``r`` signals ``x`` (n, r) that
    :func:`regressor_directions` gives for ``spec``.

    The rows of ``x`` are formed a stretch at a time into the rows the forward pass then
    overwrites with its output (the odd extension's few rows beforehand): one (n + 2 pad, r)
    array in all; the backward pass keeps only the weighted sum of its squares. Each signal's recurrence is that
    of :func:`sosfiltfilt_odd` (scipy's ``_sosfilt``, the same operations in the same order),
    all ``r`` of a sample side by side (contiguous: the loop over signals vectorises).
    """
    n = spec[2].size
    r = spec[15].shape[1]
    total = n + 2 * pad
    # the rows the odd extensions read: x[0 .. pad] and x[n - 1 - pad .. n - 1]
    head = np.empty((pad + 1, r))
    tail = np.empty((pad + 1, r))
    for first, rows in ((0, head), (n - 1 - pad, tail)):
        _regressor_rows(first, first + pad + 1, spec, rows)
    b0, b1, b2, a1, a2 = sos[0, 0], sos[0, 1], sos[0, 2], sos[0, 4], sos[0, 5]
    za, zb = zi[0, 0], zi[0, 1]
    work = np.empty((total, r))
    ext = np.empty(r)
    z0 = np.empty(r)
    z1 = np.empty(r)
    for k in range(r):
        e = 2.0 * head[0, k] - head[pad, k]
        z0[k] = za * e
        z1[k] = zb * e
    for j in range(pad):
        for k in range(r):
            ext[k] = 2.0 * head[0, k] - head[pad - j, k]
        _forward_step(ext, work[j], z0, z1, b0, b1, b2, a1, a2)
    # the log's own rows, a stretch at a time, formed into the work rows they are filtered in
    for start in range(0, n, TILE):
        stop = min(start + TILE, n)
        _regressor_rows(start, stop, spec, work[pad + start : pad + stop])
        for i in range(pad + start, pad + stop):
            for k in range(r):
                xk = work[i, k]
                yk = b0 * xk + z0[k]
                z0[k] = b1 * xk - a1 * yk + z1[k]
                z1[k] = b2 * xk - a2 * yk
                work[i, k] = yk
    for j in range(pad + n, total):
        mirrored = (2 * n + pad - 2 - j) - (n - 1 - pad)
        for k in range(r):
            ext[k] = 2.0 * tail[pad, k] - tail[mirrored, k]
        _forward_step(ext, work[j], z0, z1, b0, b1, b2, a1, a2)
    out = np.empty(n)
    for k in range(r):
        z0[k] = za * work[total - 1, k]
        z1[k] = zb * work[total - 1, k]
    squares = np.empty(r)
    for step in range(total):
        j = total - 1 - step
        for k in range(r):
            xk = work[j, k]
            yk = b0 * xk + z0[k]
            z0[k] = b1 * xk - a1 * yk + z1[k]
            z1[k] = b2 * xk - a2 * yk
            squares[k] = weights[k] * (yk * yk)
        if pad <= j < pad + n:
            out[j - pad] = _sum_four(squares)
    return out


#: Decimated samples over which :func:`decimated_variance` fits the state its forward pass
#: starts from to the full-rate pass (a fifth of a second at 100 Hz).
FIT_STEPS = 24

#: The multirate plan of :func:`decimated_variance`, a tuple: ``(m, cic, alpha, step,
#: inputs, step_short, inputs_short, centred, first)``: the odd decimation factor ``m``; the
#: anti-alias weights ``cic`` (3 m - 2,), three boxcars of ``m`` convolved, summing to 1;
#: the droop compensation ``alpha`` of the 3-tap ``(1 + 2 alpha, -alpha, -alpha)``; the
#: order-2 section's state over ``m`` samples of input interpolated (cubic Lagrange) from 4
#: decimated samples ``z' = step z + inputs^T x[j - 1 : j + 3]`` (2, 2) and (4, 2), and the
#: same over ``m - 1`` samples (``_short``); the 6-point Lagrange weights (m, 6) of the
#: output's interpolation at offsets ``0 .. m - 1`` past a decimated sample, ``centred``
#: on nodes ``-2 .. 3`` and ``first`` on ``-1 .. 4``.
MultiratePlan = tuple[Any, ...]

#: A regular grid over an irregular log, a tuple ``(index, weight)``: grid point ``g`` lies
#: between samples ``index[g]`` and ``index[g] + 1`` (int64, ``0 <= index[g] <= n - 2``), a
#: fraction ``weight[g]`` (float64, 0 to 1) of the way. Two empty arrays: the log is regular
#: and is its own grid.
ResampleGrid = tuple[Any, ...]


@jit
def _combine_rows(
    x: NDArray[np.float64],
    at_x: int,
    directions: NDArray[np.float64],
    reach: NDArray[np.int64],
    out: NDArray[np.float64],
    at_out: int,
) -> None:
    """``out[at_out, k] = sum_j x[at_x, j] directions[j, k]`` for ``k < reach[j]`` (a
    triangular factor), skipping the row's zeros; rows indexed, not viewed (a view per
    sample would touch a reference count)."""
    for k in range(out.shape[1]):
        out[at_out, k] = 0.0
    for j in range(x.shape[1]):
        g = x[at_x, j]
        if g != 0.0:
            for k in range(reach[j]):
                out[at_out, k] += g * directions[j, k]


@jit
def _exact_pass(
    x: NDArray[np.float64],
    z0: NDArray[np.float64],
    z1: NDArray[np.float64],
    sos: NDArray[np.float64],
    start: int,
    stop: int,
    backward: bool,
) -> None:
    """The order-2 section over rows ``start:stop`` of ``x`` (forward, or from ``stop - 1``
    down to ``start``), each row's output written over its input; state ``z0``, ``z1`` (r,)."""
    b0, b1, b2, a1, a2 = sos[0, 0], sos[0, 1], sos[0, 2], sos[0, 4], sos[0, 5]
    r = z0.size
    for step in range(stop - start):
        j = stop - 1 - step if backward else start + step
        for k in range(r):
            xk = x[j, k]
            yk = b0 * xk + z0[k]
            z0[k] = b1 * xk - a1 * yk + z1[k]
            z1[k] = b2 * xk - a2 * yk
            x[j, k] = yk


@jit
def _multirate_step(
    x: NDArray[np.float64],
    at: int,
    direction: int,
    z0: NDArray[np.float64],
    z1: NDArray[np.float64],
    b0: float,
    plan: MultiratePlan,
    out: NDArray[np.float64],
) -> None:
    """One decimated step of the section from decimated sample ``at`` to ``at + direction``:
    the state after ``m`` full-rate samples of the input interpolated (cubic Lagrange) from
    ``x[at - direction], x[at], x[at + direction], x[at + 2 direction]``, and the output at
    the new sample into ``out`` (r,)."""
    step, inputs, step_short, inputs_short = plan[3], plan[4], plan[5], plan[6]
    # the plan's coefficients as scalars: read from the arrays inside the loop they are
    # loaded again for every column (the compiler cannot prove ``out`` does not alias them)
    t00, t01 = step_short[0, 0], step_short[0, 1]
    u0, u1, u2, u3 = inputs_short[0, 0], inputs_short[1, 0], inputs_short[2, 0], inputs_short[3, 0]
    s00, s01, s10, s11 = step[0, 0], step[0, 1], step[1, 0], step[1, 1]
    a0, a1, a2, a3 = inputs[0, 0], inputs[1, 0], inputs[2, 0], inputs[3, 0]
    c0, c1, c2, c3 = inputs[0, 1], inputs[1, 1], inputs[2, 1], inputs[3, 1]
    r = z0.size
    ia, ib = at - direction, at
    ic, id_ = at + direction, at + 2 * direction
    for k in range(r):
        a, b, c, d = x[ia, k], x[ib, k], x[ic, k], x[id_, k]
        s0, s1 = z0[k], z1[k]
        short0 = t00 * s0 + t01 * s1 + u0 * a + u1 * b + u2 * c + u3 * d
        out[k] = b0 * c + short0
        z0[k] = s00 * s0 + s01 * s1 + a0 * a + a1 * b + a2 * c + a3 * d
        z1[k] = s10 * s0 + s11 * s1 + c0 * a + c1 * b + c2 * c + c3 * d


@jit
def _sum_four(values: NDArray[np.float64]) -> float:
    """The sum of ``values`` in four partial sums: the chain of dependent additions a quarter
    as long."""
    r = values.size
    s0 = s1 = s2 = s3 = 0.0
    k = 0
    while k + 4 <= r:
        s0 += values[k]
        s1 += values[k + 1]
        s2 += values[k + 2]
        s3 += values[k + 3]
        k += 4
    while k < r:
        s0 += values[k]
        k += 1
    return (s0 + s1) + (s2 + s3)


@jit
def _weighted_squares(
    y: NDArray[np.float64], weights: NDArray[np.float64], squares: NDArray[np.float64]
) -> float:
    """``sum_k weights[k] y[k]^2`` (:func:`_sum_four`; ``squares`` is scratch of y's size)."""
    for k in range(y.size):
        squares[k] = weights[k] * (y[k] * y[k])
    return _sum_four(squares)


@jit
def _grid_block(
    start: int,
    stop: int,
    spec: RegressorSpec,
    grid: ResampleGrid,
    rows: NDArray[np.float64],
) -> None:
    """Grid points ``start:stop``'s regressor rows (p,) into ``rows[0:stop - start]``: on a
    regular log (``grid``'s arrays empty) the samples' own (:func:`_regressor_block`); else
    each point's row interpolated linearly between the rows of the samples either side of it
    (:data:`ResampleGrid`), as :func:`torquemap.filters.lowpass` resamples every column."""
    index, weight = grid[0], grid[1]
    if index.size == 0:
        _regressor_block(start, stop, spec, rows)
        return
    first = index[start]
    last = index[stop - 1] + 1
    p = rows.shape[1]
    samples = np.empty((last - first + 1, p))
    _regressor_block(first, last + 1, spec, samples)
    for g in range(start, stop):
        at = index[g] - first
        w = weight[g]
        for q in range(p):
            a = samples[at, q]
            rows[g - start, q] = a + (samples[at + 1, q] - a) * w


@jit
def _grid_rows(
    start: int, stop: int, spec: RegressorSpec, grid: ResampleGrid, out: NDArray[np.float64]
) -> None:
    """:func:`_regressor_rows` of grid points ``start:stop`` (:func:`_grid_block`)."""
    directions, reach = spec[15], spec[16]
    p = directions.shape[0]
    rows = np.empty((min(TILE, max(stop - start, 0)), p))
    for first in range(start, stop, TILE):
        last = min(first + TILE, stop)
        _grid_block(first, last, spec, grid, rows)
        for i in range(first, last):
            _combine_rows(rows, i - first, directions, reach, out, i - start)


@jit
def _boxcar_rows_grid(
    spec: RegressorSpec, plan: MultiratePlan, grid: ResampleGrid, n: int, count: int
) -> NDArray[np.float64]:
    """The grid points' regressor rows (:func:`_grid_block`) through the decimation's three
    boxcars of ``m`` (``plan[1]``), centred on grid point ``(3 m - 3) / 2 + j m`` for
    decimated sample ``j``: shape (count, p). Each row (p,) in full into the (about three)
    decimated rows it falls under."""
    m, cic = plan[0], plan[1]
    p = spec[15].shape[0]
    span = 3 * m - 2
    block = np.empty((TILE, p))
    rows = np.zeros((count, p))
    for begin in range(0, n, TILE):
        end = min(begin + TILE, n)
        _grid_block(begin, end, spec, grid, block)
        for i in range(begin, end):
            lo = max(0, -((span - 1 - i) // m))
            hi = min(i // m, count - 1)
            for j in range(lo, hi + 1):
                w = cic[i - j * m]
                for q in range(p):
                    rows[j, q] += w * block[i - begin, q]
    return rows


@jit
def boxcar_rows(
    spec: RegressorSpec, plan: MultiratePlan, n: int, count: int
) -> NDArray[np.float64]:
    """:func:`_boxcar_rows_grid` of a regular log's own samples, bit for bit, without the
    zeros: a speed table's row (:func:`regressor_directions`) has two knots of each
    direction's table out of every knot, so only those four go into the decimated rows, and
    the columns every row has (dense, PDTV lines, viscous) are accumulated side by side in a
    row of their own. Each decimated row's sum over the samples runs in the same order and
    adds the same products; the zeros it skips add nothing (``x + 0.0`` is ``x``; a sum that
    starts at ``+0.0`` stays ``+0.0`` under added zeros of either sign)."""
    m, cic = plan[0], plan[1]
    dense, dense_index, velocity = spec[0], spec[1], spec[3]
    line_cos, line_sin = spec[6], spec[7]
    knot_logs, knot_positive, knot_negative = spec[9], spec[10], spec[11]
    viscous, viscous_negative, zero_velocity = spec[12], spec[13], spec[14]
    p = spec[15].shape[0]
    span = 3 * m - 2
    n_dense = dense_index.size
    lines = line_cos.size
    k_knots = knot_logs.size
    friction = k_knots >= 2 or viscous >= 0 or viscous_negative >= 0
    # the compact row: dense, the lines' cos and sin, viscous and viscous_negative
    width = n_dense + 2 * lines + 2
    column = np.full(width, -1, dtype=np.int64)
    for d in range(n_dense):
        column[d] = dense_index[d]
    for line in range(lines):
        column[n_dense + 2 * line] = line_cos[line]
        column[n_dense + 2 * line + 1] = line_sin[line]
    column[width - 2] = viscous
    column[width - 1] = viscous_negative
    values = np.zeros((TILE, width))
    knot_value = np.zeros((TILE, 4))
    knot_column = np.full((TILE, 4), -1, dtype=np.int64)
    compact = np.zeros((count, width))
    rows = np.zeros((count, p))
    saturated = 20.0 * abs(zero_velocity)
    lo = 0
    for begin in range(0, n, TILE):
        end = min(begin + TILE, n)
        for i in range(begin, end):
            for d in range(n_dense):
                values[i - begin, d] = dense[d, i]
        _line_values(begin, end, spec, values, n_dense)
        if friction:
            for i in range(begin, end):
                w = velocity[i]
                s = abs(w)
                blend = _branch_blend(w, saturated, zero_velocity)
                other = -(1.0 - blend)
                if k_knots >= 2:
                    lo, at, u = _knot_segment(s, lo, knot_logs)
                    knot_column[i - begin, 0] = knot_positive[at]
                    knot_value[i - begin, 0] = blend * (1.0 - u)
                    knot_column[i - begin, 1] = knot_negative[at]
                    knot_value[i - begin, 1] = other * (1.0 - u)
                    knot_column[i - begin, 2] = knot_positive[at + 1]
                    knot_value[i - begin, 2] = blend * u
                    knot_column[i - begin, 3] = knot_negative[at + 1]
                    knot_value[i - begin, 3] = other * u
                values[i - begin, width - 2] = blend * s
                values[i - begin, width - 1] = other * s
        for i in range(begin, end):
            lo_j = max(0, -((span - 1 - i) // m))
            hi_j = min(i // m, count - 1)
            for j in range(lo_j, hi_j + 1):
                w = cic[i - j * m]
                for q in range(width):
                    compact[j, q] += w * values[i - begin, q]
                for e in range(4):
                    q = knot_column[i - begin, e]
                    if q >= 0:
                        rows[j, q] += w * knot_value[i - begin, e]
    for q in range(width):
        at = column[q]
        if at >= 0:
            for j in range(count):
                rows[j, at] = compact[j, q]
    return rows


@jit
def decimated_variance(
    spec: RegressorSpec,
    weights: NDArray[np.float64],
    sos: NDArray[np.float64],
    zi: NDArray[np.float64],
    pad: int,
    plan: MultiratePlan,
    grid: ResampleGrid,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`lowpassed_variance` with the filter run at the rate ``1/m`` of the log's
    (:func:`torquemap.multirate.multirate_plan`); shape (n,).

    Each sample's regressor row (p,) is accumulated into the decimated rows it falls under
    (three boxcars of ``m``, centred on every ``m``-th sample from ``(3 m - 3) / 2``), the
    boxcars' droop compensated, and only the decimated rows are multiplied by the factor.
    The stretches up to decimated sample 3 and from ``count - 6 - FIT_STEPS`` on are
    filtered at the full rate exactly as :func:`lowpassed_variance` does (the odd
    extensions, the initial states); between, each pass advances the full-rate section's
    own state ``m`` samples at a time over the input interpolated from the decimated one
    (:data:`MultiratePlan`). Where the forward pass goes from one rate to the other, the
    state is fitted (least squares, over :data:`FIT_STEPS` decimated samples) to the other
    rate's output through the anti-alias. The output's sum of squares is interpolated back
    to every sample (6-point Lagrange). The caller ensures ``n`` gives at least
    :data:`torquemap.multirate.MIN_DECIMATED` decimated samples and ``pad <= 2 m``.

    ``grid`` (:data:`ResampleGrid`) puts an irregular log on a regular grid first (each grid
    point's row interpolated linearly between its neighbouring samples' rows); the result is
    then at the grid's points (the grid's size). Empty arrays: the log's own samples.

    Returns the variance (n,) and, on a grid, the weighted sum of squares of the output's
    change over each step (n - 1,) (:func:`_step_squares`; empty without a grid): linear
    interpolation of the output to a time a fraction ``w`` into step ``i`` has the variance
    ``(1 - w) v_i + w v_(i+1) - w (1 - w) steps[i]``.
    """
    m, alpha = plan[0], plan[2]
    centred = plan[7]
    directions, reach = spec[15], spec[16]
    p, r = directions.shape
    n = grid[0].size if grid[0].size else spec[2].size
    half = (3 * m - 3) // 2
    count = (n - 1 - 2 * half) // m + 1  # decimated samples, c_j = half + j m
    b0 = sos[0, 0]
    za, zb = zi[0, 0], zi[0, 1]
    # 1. the regressor's rows through the boxcars, at the decimated samples
    if grid[0].size:
        rows = _boxcar_rows_grid(spec, plan, grid, n, count)
    else:
        rows = boxcar_rows(spec, plan, n, count)
    row = np.empty((1, p))
    # 2. droop compensated and times the factor (decimated samples 1 .. count - 2)
    x = np.zeros((count, r))
    for j in range(1, count - 1):
        for q in range(p):
            row[0, q] = (1.0 + 2.0 * alpha) * rows[j, q] - alpha * (rows[j - 1, q] + rows[j + 1, q])
        _combine_rows(row, 0, directions, reach, x, j)
    # 3. forward: the start exactly up to c_3, then decimated up to c_last, then exactly.
    # What passes from a full-rate stretch to the decimated passes goes through the same
    # anti-alias (boxcars and compensation, :func:`_antialiased`): a sample of the full-rate
    # output would alias its residue of the input's high frequencies into the pass band.
    first_fwd = 3
    fit = min(FIT_STEPS, (count - 12) // 2)
    last_fwd = count - 6 - fit  # the full-rate end starts here
    c_first = half + first_fwd * m
    c_last = half + last_fwd * m
    head_n = half + (first_fwd + fit) * m + half + m + 1  # the anti-alias reads this far
    head = np.empty((head_n, r))
    _grid_rows(0, head_n, spec, grid, head)
    z0 = np.zeros(r)
    z1 = np.zeros(r)
    ext = np.empty((pad, r))
    for k in range(r):
        e = 2.0 * head[0, k] - head[pad, k]
        z0[k] = za * e
        z1[k] = zb * e
        for j in range(pad):
            ext[j, k] = 2.0 * head[0, k] - head[pad - j, k]
    _exact_pass(ext, z0, z1, sos, 0, pad, False)
    _exact_pass(head, z0, z1, sos, 0, head_n, False)
    # The decimated forward pass starts at c_3 from the state that best continues the
    # full-rate output through the anti-alias over the next ``fit`` decimated samples
    # (least squares): the full-rate state holds the input's high frequencies, which the
    # decimated pass does not see, and handing it on as it is starts a transient.
    u = np.empty((count, r))  # the forward output at the decimated samples
    for j in range(first_fwd - 1, first_fwd + fit + 1):
        _antialiased(head, half + j * m, plan, u[j])
    free = np.zeros((fit + 1, r))  # the decimated pass from the zero state
    z0[:] = 0.0
    z1[:] = 0.0
    for j in range(first_fwd, first_fwd + fit):
        _multirate_step(x, j, 1, z0, z1, b0, plan, free[j - first_fwd + 1])
    step, step_short = plan[3], plan[5]
    a1, a2 = sos[0, 4], sos[0, 5]
    g00 = g01 = g11 = 0.0
    basis = np.zeros((fit + 1, 2))  # its output from the unit states, without input
    for unit in range(2):
        s0 = 1.0 if unit == 0 else 0.0
        s1 = 1.0 - s0
        for j in range(1, fit + 1):
            basis[j, unit] = step_short[0, 0] * s0 + step_short[0, 1] * s1
            s0, s1 = step[0, 0] * s0 + step[0, 1] * s1, step[1, 0] * s0 + step[1, 1] * s1
    for j in range(1, fit + 1):
        g00 += basis[j, 0] * basis[j, 0]
        g01 += basis[j, 0] * basis[j, 1]
        g11 += basis[j, 1] * basis[j, 1]
    det = g00 * g11 - g01 * g01
    for k in range(r):
        h0 = h1 = 0.0
        for j in range(1, fit + 1):
            miss = u[first_fwd + j, k] - free[j, k]
            h0 += basis[j, 0] * miss
            h1 += basis[j, 1] * miss
        z0[k] = (g11 * h0 - g01 * h1) / det
        z1[k] = (g00 * h1 - g01 * h0) / det
    # on to c_last and its state, then as far as the decimated input goes (count - 3)
    kept0 = np.empty(r)
    kept1 = np.empty(r)
    for j in range(first_fwd, count - 3):
        if j == last_fwd:
            kept0[:] = z0
            kept1[:] = z1
        _multirate_step(x, j, 1, z0, z1, b0, plan, u[j + 1])
    # The full-rate end starts at c_last from the state whose output, through the
    # anti-alias, best follows the decimated one over its last ``fit`` samples
    # (least squares), as at the start: the decimated state lacks the input's high
    # frequencies.
    tail_n = n - c_last
    tail = np.empty((tail_n + pad, r))  # samples c_last .. n - 1, then the odd extension
    _grid_rows(c_last, n, spec, grid, tail[:tail_n])
    for j in range(pad):
        for k in range(r):
            tail[tail_n + j, k] = 2.0 * tail[tail_n - 1, k] - tail[tail_n - 2 - j, k]
    free_tail = tail.copy()
    z0[:] = 0.0
    z1[:] = 0.0
    _exact_pass(free_tail, z0, z1, sos, 1, tail_n, False)
    units = np.zeros((tail_n, 2))  # the full-rate pass's output from the unit states
    for unit in range(2):
        s0 = 1.0 if unit == 0 else 0.0
        s1 = 1.0 - s0
        for i in range(1, tail_n):
            yk = s0  # no input
            s0 = s1 - a1 * yk
            s1 = -a2 * yk
            units[i, unit] = yk
    fitted = np.empty(r)
    unit_fit = np.empty(2)
    g00 = g01 = g11 = 0.0
    sums0 = np.zeros(r)
    sums1 = np.zeros(r)
    for j in range(count - 3 - fit, count - 3 + 1):
        at = half + j * m - c_last
        _antialiased(free_tail, at, plan, fitted)
        _antialiased(units, at, plan, unit_fit)
        g00 += unit_fit[0] * unit_fit[0]
        g01 += unit_fit[0] * unit_fit[1]
        g11 += unit_fit[1] * unit_fit[1]
        for k in range(r):
            miss = u[j, k] - fitted[k]
            sums0[k] += unit_fit[0] * miss
            sums1[k] += unit_fit[1] * miss
    det = g00 * g11 - g01 * g01
    for k in range(r):
        z0[k] = (g11 * sums0[k] - g01 * sums1[k]) / det
        z1[k] = (g00 * sums1[k] - g01 * sums0[k]) / det
    _exact_pass(tail, z0, z1, sos, 1, tail_n + pad, False)
    tail[0] = u[last_fwd]
    # 4. backward: the end exactly down to c_last, decimated down to c_3, then exactly
    for k in range(r):
        z0[k] = za * tail[tail_n + pad - 1, k]
        z1[k] = zb * tail[tail_n + pad - 1, k]
    _exact_pass(tail, z0, z1, sos, 0, tail_n + pad, True)
    y = x  # the decimated input is spent: the backward output takes its place
    for j in range(last_fwd, count):
        y[j] = tail[half + j * m - c_last]
    for j in range(last_fwd, first_fwd, -1):
        _multirate_step(u, j, -1, z0, z1, b0, plan, y[j - 1])
    _exact_pass(head, z0, z1, sos, 0, c_first, True)
    for j in range(first_fwd):
        y[j] = head[half + j * m]
    # 5. the sum of squares: exact at the ends, interpolated between the decimated samples
    level = np.empty(count)
    scratch = np.empty(r)
    for j in range(count):
        level[j] = _weighted_squares(y[j], weights, scratch)
    out = np.empty(n)
    for i in range(c_first):
        out[i] = _weighted_squares(head[i], weights, scratch)
    for i in range(c_last, n):
        out[i] = _weighted_squares(tail[i - c_last], weights, scratch)
    for i in range(c_first, c_last):
        j = (i - half) // m
        offset = i - half - j * m
        v = 0.0
        for q in range(6):
            v += centred[offset, q] * level[j - 2 + q]
        out[i] = max(v, 0.0)
    steps = np.zeros(n - 1 if grid[0].size else 0)
    if grid[0].size:
        _step_squares(y, head, tail, c_first, c_last, half, m, centred, weights, steps)
    return out, steps


@jit
def _step_squares(
    y: NDArray[np.float64],
    head: NDArray[np.float64],
    tail: NDArray[np.float64],
    c_first: int,
    c_last: int,
    half: int,
    m: int,
    centred: NDArray[np.float64],
    weights: NDArray[np.float64],
    steps: NDArray[np.float64],
) -> None:
    """``steps[i] = sum_k weights[k] (y_k(i + 1) - y_k(i))^2`` for every step of
    :func:`decimated_variance`'s output ``y`` (n, r): exact over the full-rate ends (``head``
    below ``c_first``, ``tail`` from ``c_last``), from the 6-point interpolant of the
    decimated samples ``y`` (count, r) between."""
    n = steps.size + 1
    r = weights.size
    prev = np.empty(r)
    cur = np.empty(r)
    scratch = np.empty(r)
    for i in range(n):
        if i < c_first:
            for k in range(r):
                cur[k] = head[i, k]
        elif i >= c_last:
            for k in range(r):
                cur[k] = tail[i - c_last, k]
        else:
            j = (i - half) // m
            offset = i - half - j * m
            for k in range(r):
                cur[k] = 0.0
            for q in range(6):
                c = centred[offset, q]
                for k in range(r):
                    cur[k] += c * y[j - 2 + q, k]
        if i > 0:
            for k in range(r):
                prev[k] = cur[k] - prev[k]
            steps[i - 1] = _weighted_squares(prev, weights, scratch)
        for k in range(r):
            prev[k] = cur[k]


@jit
def _antialiased(
    a: NDArray[np.float64], at: int, plan: MultiratePlan, out: NDArray[np.float64]
) -> None:
    """Row ``at`` of ``a`` (rows, r) through the decimation's anti-alias: the three boxcars
    centred on rows ``at - m``, ``at``, ``at + m`` and the droop compensation, into ``out``."""
    m, cic, alpha = plan[0], plan[1], plan[2]
    half = (3 * m - 3) // 2
    r = out.size
    for k in range(r):
        out[k] = 0.0
    for centre, gain in ((at - m, -alpha), (at, 1.0 + 2.0 * alpha), (at + m, -alpha)):
        for t in range(cic.size):
            w = gain * cic[t]
            for k in range(r):
                out[k] += w * a[centre - half + t, k]
