"""Compiled per-sample terms of an estimate's sigma (:func:`torquemap.uncertainty.joint_sigma`).

One pass over a joint's velocity in place of some thirty numpy passes (each a temporary of the
log's size): the speed table's sign and extrapolation terms and the residual table's level,
written side by side into the array the low-pass then filters. The same operations as the
numpy code they replace (tests/test_sigma_kernels.py: equal to rounding), compiled and cached
as :mod:`torquemap._kernels` is.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from torquemap._jit import jit


@jit
def _interp_at(
    x: float, xp: NDArray[np.float64], fp: NDArray[np.float64], j: int
) -> tuple[float, int]:
    """``numpy.interp(x, xp, fp)`` (the same formula and edge cases) and the knot index found,
    searched from the guess ``j`` (the last sample's: speeds change little sample to sample)."""
    k = xp.size
    if math.isnan(x):
        return x, j
    if x < xp[0]:
        return fp[0], 0
    if x > xp[k - 1]:
        return fp[k - 1], k - 1
    # xp[j] <= x < xp[j + 1], or j = k - 1 where x == xp[k - 1]
    j = min(max(j, 0), k - 1)
    while j > 0 and xp[j] > x:
        j -= 1
    while j < k - 1 and xp[j + 1] <= x:
        j += 1
    if j == k - 1 or xp[j] == x:
        return fp[j], j
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    y = slope * (x - xp[j]) + fp[j]
    if math.isnan(y):
        y = slope * (x - xp[j + 1]) + fp[j + 1]
        if math.isnan(y) and fp[j] == fp[j + 1]:
            y = fp[j]
    return y, j


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
    bit.
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
        g_up, at = _interp_at(x, knot_logs, positive, at)
        g_up += viscous * speed
        g_down, _ = _interp_at(x, knot_logs, negative, at)
        g_down += viscous_negative * speed
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
        out[i, col] = math.hypot(level, spread)
        if misfit:
            at_x = x if speed >= 1e-12 else floor_log  # log(max(|w|, 1e-12))
            y, at_r = _interp_at(at_x, residual_logs, residual_rms, at_r)
            y = y * residual_gain
            if per_acceleration > 0:
                y = math.hypot(y, per_acceleration * abs(acceleration[i]))
            out[i, 0] = y
