"""Compiled kernels of identification's per-sample sums (differentiation on irregular time,
the whole-log fit's row smoother).

Like :mod:`torquemap._kernels`: plain functions on C-contiguous arrays, called lazily by the
module that owns the concept (:mod:`torquemap.filters`, :mod:`torquemap.smooth_rows`), each
performing the floating-point operations of the numpy code it replaced in the same order (bit
for bit; tests/test_fit_kernels.py compares them with that code).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from torquemap._jit import jit


@jit
def window_sums(
    tt: NDArray[np.float64],
    x: NDArray[np.float64],
    lo: NDArray[np.intp],
    hi: NDArray[np.intp],
    scale: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The normal equations' sums of :func:`torquemap.filters.differentiate` on irregular
    time: per sample ``i``, ``sum_j s^p`` (p = 0..4, shape (5, n)) and ``sum_j s^p (x_j - x_i)`` (p = 0..2,
    shape (3, n, m)) over its window ``lo[i]:hi[i]``, ``s = (t_j - t_i) / scale[i]``.

    Each sum runs over the window in time order, each power as the previous one times ``s``:
    the operations and their order of the numpy loop over lags it replaces (bit for bit),
    without its full-length temporaries per lag.
    """
    n, m = x.shape
    s_sum = np.zeros((5, n))
    sx_sum = np.zeros((3, n, m))
    for i in range(n):
        ti = tt[i]
        sc = scale[i]
        for j in range(lo[i], hi[i]):
            s = (tt[j] - ti) / sc
            p1 = 1.0 * s
            p2 = p1 * s
            p3 = p2 * s
            p4 = p3 * s
            s_sum[0, i] += 1.0
            s_sum[1, i] += p1
            s_sum[2, i] += p2
            s_sum[3, i] += p3
            s_sum[4, i] += p4
            for c in range(m):
                xs = x[j, c] - x[i, c]
                sx_sum[0, i, c] += 1.0 * xs
                sx_sum[1, i, c] += p1 * xs
                sx_sum[2, i, c] += p2 * xs
    return s_sum, sx_sum


@jit
def smooth_at_rows(
    t: NDArray[np.float64],
    x: NDArray[np.float64],
    mean: NDArray[np.float64],
    indptr: NDArray[np.int32],
    indices: NDArray[np.int32],
    data: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The rows' smoothing of :class:`torquemap.smooth_rows.RowSmoother`: ``operator`` (CSR
    arrays ``indptr``, ``indices``, ``data``) applied to twice the cumulative trapezoidal
    integral of ``x - mean`` (n, m) over ``t`` [s], in one pass instead of a dozen (n, m)
    temporaries; the columns run side by side, so that their running sums overlap.

    The same floating-point operations in the same order as the numpy code (the trapezoids'
    running sums, then each row's weighted sum from zero in the operator's order): the
    numbers are that code's bit for bit.
    """
    n, m = x.shape
    rows = indptr.size - 1
    out = np.zeros((rows, m))
    second = np.zeros((n, m))
    prev = np.empty(m)
    first = np.zeros(m)
    for c in range(m):
        prev[c] = x[0, c] - mean[c]
    # the columns side by side: their running sums' dependency chains overlap
    for i in range(1, n):
        dt = t[i] - t[i - 1]
        for c in range(m):
            cur = x[i, c] - mean[c]
            step = 0.5 * (cur + prev[c]) * dt
            new_first = step if i == 1 else first[c] + step
            step2 = 0.5 * (new_first + first[c]) * dt
            second[i, c] = step2 if i == 1 else second[i - 1, c] + step2
            first[c] = new_first
            prev[c] = cur
    for r in range(rows):
        for jj in range(indptr[r], indptr[r + 1]):
            w = data[jj]
            j = indices[jj]
            for c in range(m):
                out[r, c] += w * second[j, c]
    return out
