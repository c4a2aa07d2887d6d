"""Compiled per-sample terms of an estimate's sigma (:func:`torquemap.uncertainty.joint_sigma`).

One pass over a joint's velocity in place of some thirty numpy passes (each a temporary of the
log's size): the speed table's sign and extrapolation terms and the residual table's level,
written side by side into the array the low-pass then filters. The same operations as the
numpy code they replace (tests/test_estimate_kernels.py: bit for bit but one ``hypot``, within an
ulp), compiled and cached as :mod:`torquemap._kernels` is.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from torquemap._jit import jit


@jit
def _knot(x: float, xp: NDArray[np.float64], j: int) -> int:
    """The knot ``j`` with ``xp[j] <= x < xp[j + 1]``; -1 below ``xp[0]``, ``k - 1`` at or
    beyond the last (``k`` knots, at least two), searched from the guess ``j`` (the last
    sample's: speeds change little from sample to sample). NaN keeps the guess."""
    k = xp.size
    if x < xp[0]:
        return -1
    if x >= xp[k - 1]:
        return k - 1
    j = min(max(j, 0), k - 2)
    while xp[j] > x:
        j -= 1
    while xp[j + 1] <= x:
        j += 1
    return j


@jit
def _value(x: float, xp: NDArray[np.float64], fp: NDArray[np.float64], j: int) -> float:
    """``numpy.interp(x, xp, fp)`` at the knot ``j`` of :func:`_knot`: its formula and its
    edge cases (NaN for NaN; numpy's second formula, for a NaN from finite knots and a
    finite ``x``, is never needed)."""
    k = xp.size
    if j < 0:
        return float(fp[0])
    if j >= k - 1 or xp[j] == x:
        return float(fp[j])
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    return float(slope * (x - xp[j]) + fp[j])


@jit
def _hypot(a: float, b: float) -> float:
    """``hypot(a, b)`` as ``sqrt(a^2 + b^2)`` where the squares neither overflow nor underflow
    (within an ulp of the C library's, which costs 30 ns a call), else the C library's (NaN
    and infinity too: ``hypot(0, NaN)`` is NaN, ``hypot(NaN, inf)`` inf)."""
    if a != a or b != b:
        return math.hypot(a, b)
    a, b = abs(a), abs(b)
    big, small = max(a, b), min(a, b)
    if small == 0.0:
        return big  # exactly the C library's
    if big < 1e150 and small > 1e-150:
        return math.sqrt(a * a + b * b)
    return math.hypot(a, b)


@jit
def hypot_into(a: NDArray[np.float64], b: NDArray[np.float64], out: NDArray[np.float64]) -> None:
    """``out[i] = hypot(a[i], b[i])`` (shape (n,), C-contiguous; ``out`` may be ``a``) by
    :func:`_hypot`: within an ulp of ``numpy.hypot`` (the C library's, 23-30 ns a value),
    NaN and infinity as it gives them."""
    for i in range(a.size):
        out[i] = _hypot(a[i], b[i])


@jit
def coupling_torques(
    elbow: NDArray[np.float64],
    velocity: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    gears: NDArray[np.float64],
    a2: float,
    a3: float,
    out: NDArray[np.float64],
) -> None:
    """The planar arm's coupling torques [N m, joint side] into ``out`` (n, 2), 0 where not
    finite: :func:`torquemap.uncertainty.coupling_level`'s ``c_1``, ``c_2`` from the elbow
    angle ``elbow`` [rad] (n,) and the motor-side ``velocity`` and ``acceleration`` (n, 2)
    over ``gears`` (2,), in one pass; the numpy expressions' operations in their order."""
    g0, g1 = gears[0], gears[1]
    for i in range(elbow.size):
        qd0 = velocity[i, 0] / g0
        qd1 = velocity[i, 1] / g1
        qdd0 = acceleration[i, 0] / g0
        qdd1 = acceleration[i, 1] / g1
        c = math.cos(elbow[i])
        s = math.sin(elbow[i])
        t0 = a2 * (c * qdd1 - s * (2.0 * qd0 * qd1 + qd1 * qd1))
        t0 = t0 + a3 * qdd1
        t1 = a2 * (c * qdd0 + s * (qd0 * qd0)) + a3 * qdd0
        out[i, 0] = t0 if abs(t0) < math.inf else 0.0
        out[i, 1] = t1 if abs(t1) < math.inf else 0.0


@jit
def table_sigma_levels(
    velocity: NDArray[np.float64],
    blend: NDArray[np.float64],
    log_speed: NDArray[np.float64],
    knot_logs: NDArray[np.float64],
    positive: NDArray[np.float64],
    negative: NDArray[np.float64],
    viscous: float,
    viscous_negative: float,
    slowest: float,
    up0: float,
    down0: float,
    form: float,
    residual_logs: NDArray[np.float64],
    residual_rms: NDArray[np.float64],
    residual_gain: float,
    per_acceleration: float,
    acceleration: NDArray[np.float64],
    out: NDArray[np.float64],
) -> None:
    """A speed table's sigma terms before the low-pass, per sample, into ``out`` (n, c).

    The last column: the sign term ``sqrt(p (1 - p)) |g+ + g-|`` (``p = (1 + blend) / 2``,
    ``blend = tanh(w / width)``, ``g+-`` the table's levels at the speed ``|w|``, whose
    ``log(max(|w|, 1e-300))`` is ``log_speed``), ``hypot`` with ``form``
    times the mean of ``|g+|`` and ``|g-|`` when ``form > 0``, then with the extrapolation
    spread below ``slowest`` (:func:`torquemap.uncertainty._table_sign_terms`, ``up0``,
    ``down0``: the levels at ``slowest``). With two columns, the first: the residual table's
    level (:func:`torquemap.uncertainty._residual_level`: ``interp(log |w|,
    residual_logs, residual_rms)`` times ``residual_gain``, ``hypot`` with
    ``per_acceleration |acceleration|`` when that is positive; ``acceleration`` low-passed by
    the caller). ``blend`` and ``log_speed`` come from numpy (its vectorised ``tanh`` and
    ``log`` differ from the C library's in the last bit): the numpy code's numbers bit for
    bit, but for the acceleration's ``hypot`` (:func:`_hypot`, within an ulp).
    """
    n = velocity.size
    misfit = out.shape[1] == 2
    col = out.shape[1] - 1
    floor_log = math.log(1e-12)  # numpy's and the C library's agree on it
    at = 0
    at_r = 0
    for i in range(n):
        v = velocity[i]
        p = 0.5 * (1.0 + blend[i])
        speed = abs(v)
        x = log_speed[i]
        at = _knot(x, knot_logs, at)
        g_up = _value(x, knot_logs, positive, at) + viscous * speed
        g_down = _value(x, knot_logs, negative, at) + viscous_negative * speed
        level = math.sqrt(p * (1.0 - p)) * abs(g_up + g_down)
        spread = 0.0
        if slowest > 0:
            if speed > slowest:
                up, down = up0, down0
            else:
                up, down = g_up, g_down
            s = min(speed, slowest)
            spread_up = abs(up - viscous * s - (up0 - viscous * slowest))
            spread_down = abs(down - viscous_negative * s - (down0 - viscous_negative * slowest))
            spread = p * spread_up + (1.0 - p) * spread_down
        if form > 0:
            level = math.hypot(level, form * 0.5 * (abs(g_up) + abs(g_down)))
        # hypot(x, 0) is |x| exactly, and the C library's hypot costs 30 ns
        out[i, col] = math.hypot(level, spread) if spread != 0.0 else abs(level)
        if misfit:
            at_x = x if speed >= 1e-12 else floor_log  # log(max(|w|, 1e-12))
            at_r = _knot(at_x, residual_logs, at_r)
            y = _value(at_x, residual_logs, residual_rms, at_r) * residual_gain
            if per_acceleration > 0:
                y = _hypot(y, per_acceleration * abs(acceleration[i]))
            out[i, 0] = y


@jit
def _pairwise_sum(a: NDArray[np.float64], n: int) -> float:
    """numpy's pairwise sum of ``a[:n]`` (``DOUBLE_pairwise_sum``: sequential below 8
    values, eight accumulators up to 128, halves above), the operations in its order."""
    if n < 8:
        res = -0.0
        for i in range(n):
            res += a[i]
        return res
    if n <= 128:
        r0, r1, r2, r3 = a[0], a[1], a[2], a[3]
        r4, r5, r6, r7 = a[4], a[5], a[6], a[7]
        i = 8
        while i < n - (n % 8):
            r0 += a[i]
            r1 += a[i + 1]
            r2 += a[i + 2]
            r3 += a[i + 3]
            r4 += a[i + 4]
            r5 += a[i + 5]
            r6 += a[i + 6]
            r7 += a[i + 7]
            i += 8
        res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        while i < n:
            res += a[i]
            i += 1
        return float(res)
    n2 = n // 2
    n2 -= n2 % 8
    return _pairwise_sum(a, n2) + _pairwise_sum(a[n2:], n - n2)


@jit
def _mean(a: NDArray[np.float64], n: int) -> float:
    """``a[:n].mean()`` as numpy computes it (a reduction from 0.0, then the division)."""
    return (0.0 + _pairwise_sum(a, n)) / n


@jit
def _left(t: NDArray[np.float64], x: float) -> int:
    """``np.searchsorted(t, x, side="left")``."""
    lo, hi = 0, t.size
    while lo < hi:
        mid = (lo + hi) >> 1
        if t[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    return lo


@jit
def _right(t: NDArray[np.float64], x: float) -> int:
    """``np.searchsorted(t, x, side="right")``."""
    lo, hi = 0, t.size
    while lo < hi:
        mid = (lo + hi) >> 1
        if t[mid] <= x:
            lo = mid + 1
        else:
            hi = mid
    return lo


@jit
def bridge_runs(
    t: NDArray[np.float64],
    values: NDArray[np.float64],
    gaps: NDArray[np.bool_],
    starts: NDArray[np.int64],
    stops: NDArray[np.int64],
    longest: float,
    support: float,
    ends: bool,
    tie: float,
    out: NDArray[np.float64],
) -> None:
    """The runs ``starts[r]:stops[r]`` of :func:`torquemap.estimate.bridge_gaps` bridged in
    ``out`` (a copy of ``values``), in place: each side's mean of its samples that are not
    gaps (numpy's pairwise sum), and ``np.interp`` of the run's times between the sides
    (its formula and its NaN cases), the operations of the numpy code in its order."""
    n = t.size
    scratch_t = np.empty(n)
    scratch_v = np.empty(n)
    xs = np.empty(2)
    ys = np.empty(2)
    for r in range(starts.size):
        a, b = starts[r], stops[r]
        if t[b - 1] - t[a] > longest or ((a == 0 or b == n) and not ends):
            continue
        origin = t[a]
        m = 0
        for side in range(2):
            if side == 0:
                if a == 0:
                    continue
                lo = min(_left(t, t[a - 1] - support - tie), a - 1)
                hi = a
            else:
                if b >= n:
                    continue
                lo = b
                hi = max(_right(t, t[b] + support + tie), b + 1)
            k = 0
            for i in range(lo, hi):
                if not gaps[i]:
                    scratch_t[k] = t[i] - origin
                    scratch_v[k] = values[i]
                    k += 1
            xs[m] = _mean(scratch_t, k)
            ys[m] = _mean(scratch_v, k)
            m += 1
        if m == 1:
            out[a:b] = ys[0]  # interp of one point: its value, left, right and at it
            continue
        slope = (ys[1] - ys[0]) / (xs[1] - xs[0])
        for i in range(a, b):
            x = t[i] - origin
            if x < xs[0]:
                out[i] = ys[0]
            elif x >= xs[1] or xs[0] == x:
                out[i] = ys[1] if x >= xs[1] else ys[0]
            else:
                y = slope * (x - xs[0]) + ys[0]
                if y != y:
                    y = slope * (x - xs[1]) + ys[1]
                    if y != y and ys[0] == ys[1]:
                        y = ys[0]
                out[i] = y


@jit
def _side_slope(
    t: NDArray[np.float64],
    estimate: NDArray[np.float64],
    bridged: NDArray[np.bool_],
    lo: float,
    hi: float,
    xs: NDArray[np.float64],
    ys: NDArray[np.float64],
) -> tuple[int, float]:
    """The least-squares slope of ``estimate`` against ``t - lo`` over the samples in ``[lo,
    hi]`` that are not ``bridged``, in closed form about the means (two passes). Returns
    ``(1, slope)``, ``(0, nan)`` below three samples, or ``(-1, nan)`` where the closed form
    does not stand for ``np.polyfit`` (a value not finite, the times all equal)."""
    i0 = _left(t, lo)
    i1 = _right(t, hi)
    k = 0
    for i in range(i0, i1):
        if not bridged[i]:
            xs[k] = t[i] - lo
            ys[k] = estimate[i]
            k += 1
    if k < 3:
        return 0, math.nan
    sx = 0.0
    sy = 0.0
    for j in range(k):
        sx += xs[j]
        sy += ys[j]
    if not math.isfinite(sy):
        return -1, math.nan
    mx = sx / k
    my = sy / k
    sxx = 0.0
    sxy = 0.0
    for j in range(k):
        dx = xs[j] - mx
        sxx += dx * dx
        sxy += dx * (ys[j] - my)
    if not (sxx > 0.0 and math.isfinite(sxy)):
        return -1, math.nan
    return 1, sxy / sxx


@jit
def departure_runs(
    t: NDArray[np.float64],
    estimate: NDArray[np.float64],
    bridged: NDArray[np.bool_],
    starts: NDArray[np.int64],
    stops: NDArray[np.int64],
    span: float,
    out: NDArray[np.float64],
) -> bool:
    """:func:`torquemap.uncertainty.bridge_departure` of the runs ``starts[r]:stops[r]``
    into ``out`` (zeros), in place: each side's slope by :func:`_side_slope` (within an ulp
    or so of ``np.polyfit``'s, which solves by LAPACK's SVD), the chord's parabola or the
    end run's line in numpy's order of operations. False (``out`` part written) where a side
    holds a value that is not finite or times all equal: the caller then takes
    ``np.polyfit``'s path."""
    n = t.size
    xs = np.empty(n)
    ys = np.empty(n)
    slopes = np.empty(2)
    for r in range(starts.size):
        a, b = starts[r], stops[r]
        ta = t[a - 1] if a > 0 else t[a]
        tb = t[b] if b < n else t[b - 1]
        d = max(tb - ta, 1e-12)
        reach = min(0.5 * d, span)
        m = 0
        for side in range(2):
            if side == 0:
                status, slope = _side_slope(t, estimate, bridged, ta - reach, ta, xs, ys)
            else:
                status, slope = _side_slope(t, estimate, bridged, tb, tb + reach, xs, ys)
            if status < 0:
                return False
            if status > 0:
                slopes[m] = slope
                m += 1
        if m == 0:
            continue
        if a > 0 and b < n and m == 2:
            c = abs(slopes[1] - slopes[0])
            for i in range(a, b):
                out[i] = c * (t[i] - ta) * (tb - t[i]) / (2.0 * d)
        else:
            c = abs(slopes[0])
            for i in range(a, b):
                out[i] = c * (t[i] - ta) if b == n else c * (tb - t[i])
    return True
