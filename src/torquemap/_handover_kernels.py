"""Compiled kernels of the phases' hand-over (:mod:`torquemap.linearize.handover`).

Like :mod:`torquemap._fit_kernels`: plain functions on C-contiguous arrays, called lazily by
the module that owns the concept, each performing the floating-point operations of the numpy
code it replaced in the same order (bit for bit: ``numpy.interp``'s formula, numpy's pairwise
summation, ``pow`` and ``log`` from the same C library; tests/test_handover_kernels.py
compares them with that code). One call covers every cell of a grid, where the Python loop
paid a few numpy calls per cell and phase (2 to 6 s a table build).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from torquemap._estimate_kernels import _pairwise_sum
from torquemap._jit import jit
from torquemap.linearize.handover import SHARE_TOL


@jit
def interp_unit(x: float, fp: NDArray[np.float64]) -> float:
    """``numpy.interp(x, numpy.arange(fp.size, dtype=float), fp)`` for one ``x``: the ends
    held, a sample on a knot taking its value, else ``slope * (x - j) + fp[j]`` (and from the
    right knot where that is NaN), as numpy's C loop computes it."""
    top = fp.size - 1
    if x > top:
        return float(fp[top])
    if x < 0.0:
        return float(fp[0])
    if x != x:  # NaN
        return x
    j = int(x)
    if j >= top:
        return float(fp[top])
    xj = float(j)
    if xj == x:
        return float(fp[j])
    slope = (fp[j + 1] - fp[j]) / (float(j + 1) - xj)
    out = slope * (x - xj) + fp[j]
    if out != out:
        out = slope * (x - float(j + 1)) + fp[j + 1]
        if out != out and fp[j] == fp[j + 1]:
            out = fp[j]
    return float(out)


@jit
def pairwise_sum(a: NDArray[np.float64], n: int) -> float:
    """``numpy.sum(a[:n])``: numpy's reduction adds its pairwise sum
    (:func:`torquemap._estimate_kernels._pairwise_sum`) to the identity 0.0."""
    return 0.0 + _pairwise_sum(a, n)


@jit
def _value(row: NDArray[np.float64], v: float) -> float:
    """``row`` (on the pulse widths 0 .. len - 1) at the real pulse width ``v``."""
    top = row.size - 1
    x = min(max(v, 0.0), float(top))
    i = min(int(x), top - 1)
    f = x - i
    return float(row[i] * (1.0 - f) + row[i + 1] * f)


@jit
def contribution(
    high: NDArray[np.float64],
    low: NDArray[np.float64],
    hi: float,
    lo: float,
    v: float,
    work: NDArray[np.float64],
) -> float:
    """``T(v)`` from ``D = high - low``: ``T(hi u) - T(lo u) = D(u)``, ``T(0) = 0`` (the
    telescoping sum down to a quarter pulse width, at most 64 terms); ``work``: 64 floats."""
    first = v / hi
    if lo <= 0.0 or first < 0.25:
        return _value(high, first) - _value(low, first)
    ratio = lo / hi
    count = min(64, 1 + int(np.ceil(np.log(0.25 / first) / np.log(ratio))))
    count = max(count, 1)
    top = float(high.size - 1)
    for i in range(count):
        arg = min(first * ratio ** float(i), top)
        work[i] = interp_unit(arg, high) - interp_unit(arg, low)
    return pairwise_sum(work, count)


@jit
def changed_phase(ramp: NDArray[np.float64], pa: int, pb: int, p: int) -> int:
    """The one phase whose share differs among the three positions (-1 if not one), with the
    middle share between the outer two and the outer two different."""
    m = ramp.shape[1]
    k = -1
    for c in range(m):
        if abs(ramp[pa, c] - ramp[p, c]) > SHARE_TOL or abs(ramp[pb, c] - ramp[p, c]) > SHARE_TOL:
            if k >= 0:
                return -1
            k = c
    if k < 0:
        return -1
    al, be, rho = ramp[pa, k], ramp[pb, k], ramp[p, k]
    if abs(al - be) <= SHARE_TOL:
        return -1
    if not (min(al, be) - SHARE_TOL <= rho <= max(al, be) + SHARE_TOL):
        return -1
    return k


@jit
def estimate(
    fine: NDArray[np.float64],
    ramp: NDArray[np.float64],
    pa: int,
    pb: int,
    p: int,
    k: int,
    sa: float,
    sb: float,
    u: float,
    wb: float,
    work: NDArray[np.float64],
) -> float:
    """The hand-over's estimate at ``p`` between ``pa`` and ``pb`` (phase ``k`` changing)."""
    al, be, rho = ramp[pa, k], ramp[pb, k], ramp[p, k]
    if be > al:
        high, low = fine[pb], fine[pa]
    else:
        high, low = fine[pa], fine[pb]
    hi, lo = max(al, be), min(al, be)
    ta = contribution(high, low, hi, lo, al * u, work)
    tb = contribution(high, low, hi, lo, be * u, work)
    tr = contribution(high, low, hi, lo, rho * u, work)
    return (1.0 - wb) * (sa - ta) + wb * (sb - tb) + tr


@jit
def finite_rows(mean: NDArray[np.float64], j: int, have: NDArray[np.int64]) -> int:
    """The positions whose level ``j`` is measured, in order, into ``have``; their count."""
    size = 0
    for q in range(mean.shape[0]):
        if np.isfinite(mean[q, j]):
            have[size] = q
            size += 1
    return size


@jit
def check_errors(
    mean: NDArray[np.float64],
    levels: NDArray[np.float64],
    fine: NDArray[np.float64],
    ramp: NDArray[np.float64],
    max_gap: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The prediction errors [N m] of the linear interpolation and of the hand-over at every
    measured cell inside a ramp, from its two neighbours at the same level (in the order of
    :func:`torquemap.linearize.handover.check_handover`'s loop)."""
    n, levels_n = mean.shape
    lin = np.empty(mean.size)
    ray = np.empty(mean.size)
    work = np.empty(64)
    have = np.empty(n, dtype=np.int64)
    count = 0
    for j in range(levels_n):
        size = finite_rows(mean, j, have)
        if size < 3:
            continue
        for i in range(size):
            pa = have[i]
            pb = have[(i + 2) % size]
            span = (pb - pa) % n
            if not 1 < span <= max_gap + 2:
                continue
            p = have[(i + 1) % size]
            k = changed_phase(ramp, pa, pb, p)
            if k < 0:
                continue
            al, be, rho = ramp[pa, k], ramp[pb, k], ramp[p, k]
            if not (min(al, be) + SHARE_TOL < rho < max(al, be) - SHARE_TOL):
                continue
            wb = ((p - pa) % n) / span
            sa, sb, truth = mean[pa, j], mean[pb, j], mean[p, j]
            est = estimate(fine, ramp, pa, pb, p, k, sa, sb, levels[j], wb, work)
            if not np.isfinite(est):
                continue
            lin[count] = (1.0 - wb) * sa + wb * sb - truth
            ray[count] = est - truth
            count += 1
    return lin[:count].copy(), ray[:count].copy()


@jit
def fill(
    mean: NDArray[np.float64],
    levels: NDArray[np.float64],
    fine: NDArray[np.float64],
    ramp: NDArray[np.float64],
    max_gap: int,
) -> tuple[NDArray[np.float64], int]:
    """:func:`torquemap.linearize.handover.fill_handover`'s grid and count."""
    n, levels_n = mean.shape
    out = mean.copy()
    work = np.empty(64)
    have = np.empty(n, dtype=np.int64)
    filled = 0
    for j in range(levels_n):
        size = finite_rows(mean, j, have)
        if size < 2:
            continue
        for i in range(size):
            pa = have[i]
            pb = have[(i + 1) % size]
            span = (pb - pa) % n
            if not 1 < span <= max_gap + 1:
                continue
            for step in range(1, span):
                p = (pa + step) % n
                k = changed_phase(ramp, pa, pb, p)
                if k < 0:
                    continue
                est = estimate(
                    fine, ramp, pa, pb, p, k, mean[pa, j], mean[pb, j], levels[j],
                    step / span, work,
                )  # fmt: skip
                if np.isfinite(est):
                    out[p, j] = est
                    filled += 1
    return out, filled
