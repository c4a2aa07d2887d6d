"""Compiled kernels of identification's per-sample sums (differentiation on irregular time,
the whole-log fit's row smoother).

Like :mod:`torquemap._kernels`: plain functions on C-contiguous arrays, called lazily by the
module that owns the concept (:mod:`torquemap.filters`, :mod:`torquemap.smooth_rows`), each
performing the floating-point operations of the numpy code it replaced in the same order (bit
for bit; tests/test_fit_kernels.py compares them with that code).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from torquemap._jit import jit
from torquemap._kernels import TILE

#: Slots of the cosines and sines :func:`smooth_both_ways_at_rows` keeps (a power of two:
#: 3 MB, the angles of 131 072 encoder counts, 16 motor revolutions of an 8192-count encoder).
TRIG_SLOTS = 1 << 17


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
    without its full-length temporaries per lag. The sums accumulate in local variables (the
    same additions from 0.0 in the same order), stored once per sample: an accumulator in
    the output array is reloaded and stored at every lag.
    """
    n, m = x.shape
    s_sum = np.empty((5, n))
    sx_sum = np.empty((3, n, m))
    acc = np.empty((m, 3))
    for i in range(n):
        ti = tt[i]
        sc = scale[i]
        a0 = a1 = a2 = a3 = a4 = 0.0
        for c in range(m):
            acc[c, 0] = acc[c, 1] = acc[c, 2] = 0.0
        for j in range(lo[i], hi[i]):
            s = (tt[j] - ti) / sc
            p1 = 1.0 * s
            p2 = p1 * s
            p3 = p2 * s
            p4 = p3 * s
            a0 += 1.0
            a1 += p1
            a2 += p2
            a3 += p3
            a4 += p4
            for c in range(m):
                xs = x[j, c] - x[i, c]
                acc[c, 0] += 1.0 * xs
                acc[c, 1] += p1 * xs
                acc[c, 2] += p2 * xs
        s_sum[0, i] = a0
        s_sum[1, i] = a1
        s_sum[2, i] = a2
        s_sum[3, i] = a3
        s_sum[4, i] = a4
        for c in range(m):
            sx_sum[0, i, c] = acc[c, 0]
            sx_sum[1, i, c] = acc[c, 1]
            sx_sum[2, i, c] = acc[c, 2]
    return s_sum, sx_sum


@jit
def curvature_weights(
    t: NDArray[np.float64],
    rows: NDArray[np.intp],
    lo: NDArray[np.intp],
    hi: NDArray[np.intp],
    width: int,
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """The row smoother's weights (:class:`torquemap.smooth_rows.RowSmoother`): per row ``r``,
    twice the curvature of a local quadratic least-squares fit over samples ``lo:hi`` of time
    ``t`` [s] as weights on those samples, ``width`` slots per row (a shorter window padded with
    zero weights on the last sample); returns the weights and their sample indices, each
    shape (rows * width,).

    With ``s = (t_j - t_r) / c``, ``c`` half the window's span, and ``S_p`` the window's sums
    of ``s^p``, the fit's curvature is ``e^T (1, s_j, s_j^2)`` per sample with ``e`` the last
    column of the inverse of ``[[S_0, S_1, S_2], [S_1, S_2, S_3], [S_2, S_3, S_4]]`` (its
    cofactors over its determinant), times ``2 / c^2``. The numpy code it replaced solved
    each 3x3 system by LU: the same weights to rounding (1e-13 of the largest).
    """
    n = t.size
    m = rows.size
    data = np.zeros(m * width)
    index = np.empty(m * width, dtype=np.intp)
    for r in range(m):
        a, b = lo[r], hi[r]
        scale = max(0.5 * (t[b - 1] - t[a]), 1e-300)
        tr = t[rows[r]]
        s0 = s1 = s2 = s3 = s4 = 0.0
        for j in range(a, b):
            u = (t[j] - tr) / scale
            u2 = u * u
            s0 += 1.0
            s1 += u
            s2 += u2
            s3 += u2 * u
            s4 += u2 * u2
        c0 = s1 * s3 - s2 * s2
        c1 = s1 * s2 - s0 * s3
        c2 = s0 * s2 - s1 * s1
        det = s2 * c0 + s3 * c1 + s4 * c2
        f = 2.0 / (det * scale * scale)
        for k in range(width):
            j = a + k
            index[r * width + k] = min(j, n - 1)
            if j < b:
                u = (t[j] - tr) / scale
                data[r * width + k] = f * (c0 + c1 * u + c2 * u * u)
    return data, index


@jit
def column_centres(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """A centre of each column of ``x`` (n, m), subtracted before the row smoother's double
    integral (which would otherwise grow with the square of the time): the mean of every
    ``max(1, n // 1024)``-th sample, summed in order.

    Any value near the column's level serves (the smoothing is exact for a constant, so the
    centre only sets the rounding), and this one costs a thousandth of a pass and is the same
    for a column whatever columns are smoothed beside it (numpy's mean is not: it sums one
    column pairwise, several row by row).
    """
    n, m = x.shape
    step = max(1, n // 1024)
    out = np.zeros(m)
    count = 0
    for i in range(0, n, step):
        count += 1
        for c in range(m):
            out[c] += x[i, c]
    for c in range(m):
        out[c] = out[c] / max(count, 1)
    return out


@jit
def smooth_at_rows(
    t: NDArray[np.float64],
    x: NDArray[np.float64],
    mean: NDArray[np.float64],
    indptr: NDArray[np.int32],
    indices: NDArray[np.int32],
    data: NDArray[np.float64],
    starts: NDArray[np.intp],
) -> NDArray[np.float64]:
    """The rows' smoothing of :class:`torquemap.smooth_rows.RowSmoother`: ``operator`` (CSR
    arrays ``indptr``, ``indices``, ``data``) applied to twice the cumulative trapezoidal
    integral of ``x - mean`` (n, m) over ``t`` [s], in one pass instead of a dozen (n, m)
    temporaries. ``starts`` (:func:`run_starts`): per row, the first sample of its indices
    when they are a run of consecutive samples (read by position, not from ``indices``:
    a third less memory traffic), else -1.

    The same floating-point operations in the same order as the numpy code (the trapezoids'
    running sums, then each row's weighted sum from zero in the operator's order): the
    numbers are that code's bit for bit.
    """
    n, m = x.shape
    rows = indptr.size - 1
    out = np.empty((rows, m))
    if m == 1:
        return _smooth_one(t, x, mean[0], indptr, indices, data, starts, out)
    second = np.zeros((n, 4))
    # four columns at a time (a column past the last repeats the last; its results are
    # dropped): their running sums side by side in registers, then the operator (a dozen bytes
    # per weight, the bulk of the memory traffic) read once for the four
    for c0 in range(0, m, 4):
        cols = (c0, min(c0 + 1, m - 1), min(c0 + 2, m - 1), min(c0 + 3, m - 1))
        ca, cb, cc, cd = cols
        ma, mb, mc, md = mean[ca], mean[cb], mean[cc], mean[cd]
        pa, pb, pc, pd = x[0, ca] - ma, x[0, cb] - mb, x[0, cc] - mc, x[0, cd] - md
        fa = fb = fc = fd = 0.0  # the first integrals
        sa = sb = sc = sd = 0.0  # the second
        for i in range(1, n):
            dt = t[i] - t[i - 1]
            ua, ub, uc, ud = x[i, ca] - ma, x[i, cb] - mb, x[i, cc] - mc, x[i, cd] - md
            ea = 0.5 * (ua + pa) * dt
            eb = 0.5 * (ub + pb) * dt
            ec = 0.5 * (uc + pc) * dt
            ed = 0.5 * (ud + pd) * dt
            ga, gb, gc, gd = (ea, eb, ec, ed) if i == 1 else (fa + ea, fb + eb, fc + ec, fd + ed)
            ha = 0.5 * (ga + fa) * dt
            hb = 0.5 * (gb + fb) * dt
            hc = 0.5 * (gc + fc) * dt
            hd = 0.5 * (gd + fd) * dt
            sa, sb, sc, sd = (ha, hb, hc, hd) if i == 1 else (sa + ha, sb + hb, sc + hc, sd + hd)
            second[i, 0] = sa
            second[i, 1] = sb
            second[i, 2] = sc
            second[i, 3] = sd
            fa, fb, fc, fd = ga, gb, gc, gd
            pa, pb, pc, pd = ua, ub, uc, ud
        for r in range(rows):
            sa = sb = sc = sd = 0.0
            first = indptr[r]
            if starts[r] >= 0:  # consecutive samples: the same terms in the same order
                at = starts[r] - first
                for jj in range(first, indptr[r + 1]):
                    w = data[jj]
                    j = at + jj
                    sa += w * second[j, 0]
                    sb += w * second[j, 1]
                    sc += w * second[j, 2]
                    sd += w * second[j, 3]
            else:
                for jj in range(first, indptr[r + 1]):
                    w = data[jj]
                    j = indices[jj]
                    sa += w * second[j, 0]
                    sb += w * second[j, 1]
                    sc += w * second[j, 2]
                    sd += w * second[j, 3]
            out[r, cols[0]] = sa
            out[r, cols[1]] = sb
            out[r, cols[2]] = sc
            out[r, cols[3]] = sd
    return out


@jit
def _smooth_one(
    t: NDArray[np.float64],
    x: NDArray[np.float64],
    mean: float,
    indptr: NDArray[np.int32],
    indices: NDArray[np.int32],
    data: NDArray[np.float64],
    starts: NDArray[np.intp],
    out: NDArray[np.float64],
) -> NDArray[np.float64]:
    """:func:`smooth_at_rows` of one column (n, 1) into ``out`` (rows, 1): the same operations
    in scalars, without the three columns' work that a group of four would drop."""
    n = x.shape[0]
    second = np.zeros(n)
    prev = x[0, 0] - mean
    first = 0.0
    acc = 0.0
    for i in range(1, n):
        cur = x[i, 0] - mean
        dt = t[i] - t[i - 1]
        step = 0.5 * (cur + prev) * dt
        new_first = step if i == 1 else first + step
        step2 = 0.5 * (new_first + first) * dt
        acc = step2 if i == 1 else acc + step2
        second[i] = acc
        first = new_first
        prev = cur
    for r in range(indptr.size - 1):
        s0 = 0.0
        first = indptr[r]
        if starts[r] >= 0:
            at = starts[r] - first
            for jj in range(first, indptr[r + 1]):
                s0 += data[jj] * second[at + jj]
        else:
            for jj in range(first, indptr[r + 1]):
                s0 += data[jj] * second[indices[jj]]
        out[r, 0] = s0
    return out


@jit
def smooth_both_ways_at_rows(
    t: NDArray[np.float64],
    theta: NDArray[np.float64],
    velocity: NDArray[np.float64],
    order: float,
    per_slot: float,
    indptr: NDArray[np.int32],
    indices: NDArray[np.int32],
    data: NDArray[np.float64],
    starts: NDArray[np.intp],
) -> NDArray[np.float64]:
    """:class:`torquemap.smooth_rows.RowSmoother` of the six PDTV columns of one line
    (:func:`torquemap.identify_whole.pdtv_basis`'s: ``cos, sin`` of ``order * theta``, then
    both times ``velocity > 0``, then both times ``velocity < 0``), shape (rows, 6), the
    columns formed per sample as they are integrated instead of as an (n, 6) array first.

    Per column the operations of :func:`column_centres`, :func:`smooth_at_rows` and the
    smoother's ``+ centre`` in the same order, the masks a product by 1.0 or 0.0 as numpy's
    bool cast makes them: the same bits where numpy's ``cos`` and ``sin`` are the C library's
    (where numpy uses its own SIMD versions, those differ from it within an ulp). A sample
    whose argument ``order * theta`` equals the last sample's (nonzero) reuses its cosine and
    sine: an encoder's angle repeats on most samples of a sweep, and the pair costs two
    thirds of a sample's work. Beyond the last sample's, the pairs of earlier arguments are
    kept in :data:`TRIG_SLOTS` slots, the slot of angle ``theta`` being
    ``round(theta * per_slot)`` modulo their number (``per_slot``: slots per radian, the
    inverse of the encoder's step; 0 keeps one slot): a sweep passes the same encoder counts
    again and again (the bench's 4 M samples hold 30 000 distinct angles per joint, and 1.2
    to 1.8 M changes of angle), and a slot's pair is reused only for an argument equal to the
    one it was computed for (the same bits, a zero always recomputed).
    """
    n = t.size
    rows = indptr.size - 1
    out = np.empty((rows, 6))
    centre = np.zeros(6)
    step = max(1, n // 1024)
    count = 0
    for i in range(0, n, step):
        count += 1
        c = math.cos(order * theta[i])
        s = math.sin(order * theta[i])
        up = 1.0 if velocity[i] > 0 else 0.0
        down = 1.0 if velocity[i] < 0 else 0.0
        centre[0] += c
        centre[1] += s
        centre[2] += c * up
        centre[3] += s * up
        centre[4] += c * down
        centre[5] += s * down
    for k in range(6):
        centre[k] = centre[k] / max(count, 1)
    ca, cb, cc, cd, ce, cf = centre[0], centre[1], centre[2], centre[3], centre[4], centre[5]
    second = np.zeros((n, 6))
    # the running sums in scalars (registers), as smooth_at_rows keeps them
    pa = pb = pc = pd = pe = pf = 0.0  # the previous sample, centred
    fa = fb = fc = fd = fe = ff = 0.0  # the first integrals
    sa = sb = sc = sd = se = sf = 0.0  # the second
    # an encoder's angle repeats from sample to sample (a joint at rest or slow, and the
    # other joint's sweep): the cosine and sine of a repeated nonzero argument are the last
    # ones (the same bits; a zero's sine keeps its sign, so a zero is always recomputed)
    last = math.nan
    c = s = 0.0
    mask = TRIG_SLOTS - 1
    keys = np.full(TRIG_SLOTS, math.nan)  # NaN equals no argument: every slot empty
    cos_kept = np.empty(TRIG_SLOTS)
    sin_kept = np.empty(TRIG_SLOTS)
    for i in range(n):
        x = order * theta[i]
        if x != last or x == 0.0:
            g = theta[i] * per_slot
            if x != 0.0 and abs(g) < 4.0e18:
                slot = math.floor(g + 0.5) & mask
                if keys[slot] == x:
                    c = cos_kept[slot]
                    s = sin_kept[slot]
                else:
                    c = math.cos(x)
                    s = math.sin(x)
                    keys[slot] = x
                    cos_kept[slot] = c
                    sin_kept[slot] = s
            else:
                c = math.cos(x)
                s = math.sin(x)
            last = x
        up = 1.0 if velocity[i] > 0 else 0.0
        down = 1.0 if velocity[i] < 0 else 0.0
        ua, ub = c - ca, s - cb
        uc, ud = c * up - cc, s * up - cd
        ue, uf = c * down - ce, s * down - cf
        if i > 0:
            dt = t[i] - t[i - 1]
            ea = 0.5 * (ua + pa) * dt
            eb = 0.5 * (ub + pb) * dt
            ec = 0.5 * (uc + pc) * dt
            ed = 0.5 * (ud + pd) * dt
            ee = 0.5 * (ue + pe) * dt
            ef = 0.5 * (uf + pf) * dt
            if i == 1:
                ga, gb, gc, gd, ge, gf = ea, eb, ec, ed, ee, ef
            else:
                ga, gb, gc, gd, ge, gf = fa + ea, fb + eb, fc + ec, fd + ed, fe + ee, ff + ef
            ha = 0.5 * (ga + fa) * dt
            hb = 0.5 * (gb + fb) * dt
            hc = 0.5 * (gc + fc) * dt
            hd = 0.5 * (gd + fd) * dt
            he = 0.5 * (ge + fe) * dt
            hf = 0.5 * (gf + ff) * dt
            if i == 1:
                sa, sb, sc, sd, se, sf = ha, hb, hc, hd, he, hf
            else:
                sa, sb, sc, sd, se, sf = sa + ha, sb + hb, sc + hc, sd + hd, se + he, sf + hf
            second[i, 0] = sa
            second[i, 1] = sb
            second[i, 2] = sc
            second[i, 3] = sd
            second[i, 4] = se
            second[i, 5] = sf
            fa, fb, fc, fd, fe, ff = ga, gb, gc, gd, ge, gf
        pa, pb, pc, pd, pe, pf = ua, ub, uc, ud, ue, uf
    for r in range(rows):
        s0 = s1 = s2 = s3 = s4 = s5 = 0.0
        lo = indptr[r]
        if starts[r] >= 0:
            at = starts[r] - lo
            for jj in range(lo, indptr[r + 1]):
                w = data[jj]
                j = at + jj
                s0 += w * second[j, 0]
                s1 += w * second[j, 1]
                s2 += w * second[j, 2]
                s3 += w * second[j, 3]
                s4 += w * second[j, 4]
                s5 += w * second[j, 5]
        else:
            for jj in range(lo, indptr[r + 1]):
                w = data[jj]
                j = indices[jj]
                s0 += w * second[j, 0]
                s1 += w * second[j, 1]
                s2 += w * second[j, 2]
                s3 += w * second[j, 3]
                s4 += w * second[j, 4]
                s5 += w * second[j, 5]
        out[r, 0] = s0 + centre[0]
        out[r, 1] = s1 + centre[1]
        out[r, 2] = s2 + centre[2]
        out[r, 3] = s3 + centre[3]
        out[r, 4] = s4 + centre[4]
        out[r, 5] = s5 + centre[5]
    return out


@jit
def smooth_angle_harmonics_at_rows(
    t: NDArray[np.float64],
    q: NDArray[np.float64],
    k: int,
    planar: bool,
    indptr: NDArray[np.int32],
    indices: NDArray[np.int32],
    data: NDArray[np.float64],
    starts: NDArray[np.intp],
) -> NDArray[np.float64]:
    """:class:`torquemap.smooth_rows.RowSmoother` of the joint-angle columns of
    :func:`torquemap.identify_whole.gravity_basis` (``q`` the joint angles (n, joints) [rad],
    joint ``k``, ``planar``: the cosines, then the sines, of the absolute link angles from
    joint ``k`` on, each the joint angles summed from the first in order as numpy's
    ``cumsum`` sums them, or of joint ``k``'s angle), at most two angles (four columns):
    shape (rows, 2 * angles), formed per sample as they are integrated instead of as an
    (n, 4) array first.

    Per column the operations of :func:`column_centres`, :func:`smooth_at_rows` and the
    smoother's ``+ centre`` in the same order (as :func:`smooth_both_ways_at_rows`), and the
    cosine and sine of an angle equal to the last sample's (nonzero) reused: the same bits
    where numpy's ``cos`` and ``sin`` are the C library's.
    """
    n = t.size
    joints = q.shape[1]
    m = joints - k if planar else 1
    rows = indptr.size - 1
    out = np.empty((rows, 2 * m))
    second = np.zeros((n, 4))
    # slots: cos of angle 0, cos of angle 1, sin of angle 0, sin of angle 1 (one angle: the
    # second slot repeats the first, its results dropped)
    centre = np.zeros(4)
    step = max(1, n // 1024)
    count = 0
    for i in range(0, n, step):
        count += 1
        x0 = x1 = q[i, k]
        if planar:
            acc = q[i, 0]
            for j in range(1, k + 1):
                acc = acc + q[i, j]
            x0 = acc
            x1 = acc + q[i, k + 1] if m == 2 else acc
        centre[0] += math.cos(x0)
        centre[1] += math.cos(x1)
        centre[2] += math.sin(x0)
        centre[3] += math.sin(x1)
    for c in range(4):
        centre[c] = centre[c] / max(count, 1)
    ma, mb, mc, md = centre[0], centre[1], centre[2], centre[3]
    pa = pb = pc = pd = 0.0  # the previous sample, centred
    fa = fb = fc = fd = 0.0  # the first integrals
    sa = sb = sc = sd = 0.0  # the second
    last0 = last1 = math.nan
    c0 = c1 = s0 = s1 = 0.0
    for i in range(n):
        x0 = x1 = q[i, k]
        if planar:
            acc = q[i, 0]
            for j in range(1, k + 1):
                acc = acc + q[i, j]
            x0 = acc
            x1 = acc + q[i, k + 1] if m == 2 else acc
        if x0 != last0 or x0 == 0.0:
            c0 = math.cos(x0)
            s0 = math.sin(x0)
            last0 = x0
        if x1 != last1 or x1 == 0.0:
            c1 = math.cos(x1)
            s1 = math.sin(x1)
            last1 = x1
        ua, ub, uc, ud = c0 - ma, c1 - mb, s0 - mc, s1 - md
        if i > 0:
            dt = t[i] - t[i - 1]
            ea = 0.5 * (ua + pa) * dt
            eb = 0.5 * (ub + pb) * dt
            ec = 0.5 * (uc + pc) * dt
            ed = 0.5 * (ud + pd) * dt
            if i == 1:
                ga, gb, gc, gd = ea, eb, ec, ed
            else:
                ga, gb, gc, gd = fa + ea, fb + eb, fc + ec, fd + ed
            ha = 0.5 * (ga + fa) * dt
            hb = 0.5 * (gb + fb) * dt
            hc = 0.5 * (gc + fc) * dt
            hd = 0.5 * (gd + fd) * dt
            if i == 1:
                sa, sb, sc, sd = ha, hb, hc, hd
            else:
                sa, sb, sc, sd = sa + ha, sb + hb, sc + hc, sd + hd
            second[i, 0] = sa
            second[i, 1] = sb
            second[i, 2] = sc
            second[i, 3] = sd
            fa, fb, fc, fd = ga, gb, gc, gd
        pa, pb, pc, pd = ua, ub, uc, ud
    for r in range(rows):
        r0 = r1 = r2 = r3 = 0.0
        lo = indptr[r]
        if starts[r] >= 0:
            at = starts[r] - lo
            for jj in range(lo, indptr[r + 1]):
                w = data[jj]
                j = at + jj
                r0 += w * second[j, 0]
                r1 += w * second[j, 1]
                r2 += w * second[j, 2]
                r3 += w * second[j, 3]
        else:
            for jj in range(lo, indptr[r + 1]):
                w = data[jj]
                j = indices[jj]
                r0 += w * second[j, 0]
                r1 += w * second[j, 1]
                r2 += w * second[j, 2]
                r3 += w * second[j, 3]
        if m == 2:
            out[r, 0] = r0 + centre[0]
            out[r, 1] = r1 + centre[1]
            out[r, 2] = r2 + centre[2]
            out[r, 3] = r3 + centre[3]
        else:
            out[r, 0] = r0 + centre[0]
            out[r, 1] = r2 + centre[2]
    return out


@jit
def cos_sin(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``cos(x)`` and ``sin(x)`` (n,) by the C library, a value equal to the last one
    (nonzero) taking the last results: an encoder's angle repeats on most samples of a sweep.
    numpy's ``cos`` and ``sin`` bit for bit where those are the C library's."""
    n = x.size
    c = np.empty(n)
    s = np.empty(n)
    last = math.nan
    cv = sv = 0.0
    for i in range(n):
        v = x[i]
        if v != last or v == 0.0:
            cv = math.cos(v)
            sv = math.sin(v)
            last = v
        c[i] = cv
        s[i] = sv
    return c, s


@jit
def run_starts(indptr: NDArray[np.int32], indices: NDArray[np.int32]) -> NDArray[np.intp]:
    """Per row of a CSR matrix (``indptr``, ``indices``), its first column index when its
    indices are consecutive (``i, i + 1, ...``), else -1 (:func:`smooth_at_rows`)."""
    rows = indptr.size - 1
    out = np.full(rows, -1, dtype=np.intp)
    for r in range(rows):
        first, stop = indptr[r], indptr[r + 1]
        if stop == first:
            continue
        run = True
        for jj in range(first + 1, stop):
            if indices[jj] != indices[first] + (jj - first):
                run = False
                break
        if run:
            out[r] = indices[first]
    return out


@jit
def interp_increasing(
    x: NDArray[np.float64], xp: NDArray[np.float64], fp: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``numpy.interp(x, xp, fp)`` for non-decreasing ``x`` and increasing ``xp``: the same
    formula per sample (numpy's ``slope * (x - xp[j]) + fp[j]``, the ends held, a sample on
    a knot taking its value) with the knot found by walking forward instead of by bisection.
    """
    out = np.empty((x.size, 1))
    _interp_walk(x, 0.0, xp, fp, out, 0)
    return out[:, 0]


@jit
def delayed_columns(
    t: NDArray[np.float64], y: NDArray[np.float64], delays: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``y`` (n,) read ``delays[c]`` [s] later at the times ``t`` (n,), increasing, as column
    ``c`` of the result (n, m): :func:`interp_increasing` of ``t + delays[c]`` (``y`` itself
    for a delay of 0), without the shifted times' and the columns' temporaries."""
    m = delays.size
    out = np.empty((t.size, m))
    for c in range(m):
        if delays[c] == 0.0:
            out[:, c] = y
        else:
            _interp_walk(t, delays[c], t, y, out, c)
    return out


@jit
def _interp_walk(
    x: NDArray[np.float64],
    shift: float,
    xp: NDArray[np.float64],
    fp: NDArray[np.float64],
    out: NDArray[np.float64],
    column: int,
) -> None:
    """``out[:, column] = numpy.interp(x + shift, xp, fp)`` by the forward walk of
    :func:`interp_increasing` (``x + shift`` formed per sample as numpy forms it)."""
    n = xp.size
    j = 0
    for i in range(x.size):
        xv = x[i] if shift == 0.0 else x[i] + shift
        if xv != xv:
            out[i, column] = xv
        elif xv < xp[0]:
            out[i, column] = fp[0]
        elif xv > xp[n - 1]:
            out[i, column] = fp[n - 1]
        else:
            while j + 1 < n and xp[j + 1] <= xv:
                j += 1
            while j > 0 and xp[j] > xv:
                j -= 1
            if j == n - 1 or xp[j] == xv:
                out[i, column] = fp[j]
            else:
                slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
                v = slope * (xv - xp[j]) + fp[j]
                if v != v:
                    v = slope * (xv - xp[j + 1]) + fp[j + 1]
                    if v != v and fp[j] == fp[j + 1]:
                        v = fp[j]
                out[i, column] = v


@jit
def speed_table_block(
    speed: NDArray[np.float64],
    up: NDArray[np.float64],
    down: NDArray[np.float64],
    knot: NDArray[np.int64],
    fraction: NDArray[np.float64],
    columns: NDArray[np.int64],
    k: int,
) -> NDArray[np.float64]:
    """Columns ``columns`` of the speed-table friction basis of
    :func:`torquemap.identify_whole._friction_columns` (shape (n, len(columns))).

    Per sample: ``speed`` |v| [rad/s], the direction weights ``up`` = b and ``down`` =
    -(1 - b), the knot ``knot`` (i) below the sample's log speed and the ``fraction`` (u)
    of the way to the next. Column ``j < 2 k`` is the hat of knot ``j mod k`` times ``up``
    (``j < k``) or ``down``; ``2 k`` and ``2 k + 1`` are ``speed`` times ``up``, ``down``.
    The hat is ``(1 - u if i == knot else 0) + (u if i + 1 == knot else 0)``: numpy's
    sums of two ``where`` (bit for bit).
    """
    n = speed.size
    out = np.empty((n, columns.size))
    for c in range(columns.size):
        j = columns[c]
        if j >= 2 * k:
            w = up if j == 2 * k else down
            for t in range(n):
                out[t, c] = speed[t] * w[t]
        else:
            at = j % k
            w = up if j < k else down
            for t in range(n):
                i = knot[t]
                u = fraction[t]
                hat = ((1.0 - u) if i == at else 0.0) + (u if i + 1 == at else 0.0)
                out[t, c] = hat * w[t]
    return out


@jit
def smooth_speed_table_at_rows(
    t: NDArray[np.float64],
    speed: NDArray[np.float64],
    up: NDArray[np.float64],
    down: NDArray[np.float64],
    knot: NDArray[np.int64],
    fraction: NDArray[np.float64],
    columns: NDArray[np.int64],
    k: int,
    indptr: NDArray[np.int32],
    indices: NDArray[np.int32],
    data: NDArray[np.float64],
    starts: NDArray[np.intp],
) -> NDArray[np.float64]:
    """:class:`torquemap.smooth_rows.RowSmoother` of :func:`speed_table_block`'s columns
    ``columns`` (same arguments), shape (rows, columns.size), each value formed as it is
    integrated instead of as an (n, 4) block first.

    Per column the operations of :func:`speed_table_block`, :func:`column_centres`,
    :func:`smooth_at_rows` and the smoother's ``+ centre`` in the same order: the same bits.
    """
    n = t.size
    m = columns.size
    rows = indptr.size - 1
    out = np.empty((rows, m))
    step = max(1, n // 1024)
    second = np.zeros((n, 4))
    for c0 in range(0, m, 4):
        # four columns at a time (a slot past the last repeats the last; its results dropped)
        ja, jb = columns[c0], columns[min(c0 + 1, m - 1)]
        jc, jd = columns[min(c0 + 2, m - 1)], columns[min(c0 + 3, m - 1)]
        # per column: viscous (speed times the direction weight) or a knot's hat (its knot
        # ``at``), and which direction weight (``up`` or ``down``); written out per slot so
        # that the compiler keeps the four values in registers
        va, vb, vc, vd = ja >= 2 * k, jb >= 2 * k, jc >= 2 * k, jd >= 2 * k
        wa = ja == 2 * k if va else ja < k
        wb = jb == 2 * k if vb else jb < k
        wc = jc == 2 * k if vc else jc < k
        wd = jd == 2 * k if vd else jd < k
        ta, tb, tc, td = ja % k, jb % k, jc % k, jd % k
        ma = mb = mc = md = 0.0
        count = 0
        for i in range(0, n, step):
            count += 1
            s, q, u = speed[i], knot[i], fraction[i]
            xa = up[i] if wa else down[i]
            xb = up[i] if wb else down[i]
            xc = up[i] if wc else down[i]
            xd = up[i] if wd else down[i]
            ma += (
                s * xa
                if va
                else (((1.0 - u) if q == ta else 0.0) + (u if q + 1 == ta else 0.0)) * xa
            )
            mb += (
                s * xb
                if vb
                else (((1.0 - u) if q == tb else 0.0) + (u if q + 1 == tb else 0.0)) * xb
            )
            mc += (
                s * xc
                if vc
                else (((1.0 - u) if q == tc else 0.0) + (u if q + 1 == tc else 0.0)) * xc
            )
            md += (
                s * xd
                if vd
                else (((1.0 - u) if q == td else 0.0) + (u if q + 1 == td else 0.0)) * xd
            )
        count = max(count, 1)
        ma, mb, mc, md = ma / count, mb / count, mc / count, md / count
        pa = pb = pc = pd = 0.0  # the previous sample, centred
        fa = fb = fc = fd = 0.0  # the first integrals
        sa = sb = sc = sd = 0.0  # the second
        for i in range(n):
            s, q, u = speed[i], knot[i], fraction[i]
            xa = up[i] if wa else down[i]
            xb = up[i] if wb else down[i]
            xc = up[i] if wc else down[i]
            xd = up[i] if wd else down[i]
            ua = (
                s * xa
                if va
                else (((1.0 - u) if q == ta else 0.0) + (u if q + 1 == ta else 0.0)) * xa
            ) - ma
            ub = (
                s * xb
                if vb
                else (((1.0 - u) if q == tb else 0.0) + (u if q + 1 == tb else 0.0)) * xb
            ) - mb
            uc = (
                s * xc
                if vc
                else (((1.0 - u) if q == tc else 0.0) + (u if q + 1 == tc else 0.0)) * xc
            ) - mc
            ud = (
                s * xd
                if vd
                else (((1.0 - u) if q == td else 0.0) + (u if q + 1 == td else 0.0)) * xd
            ) - md
            if i > 0:
                dt = t[i] - t[i - 1]
                ea = 0.5 * (ua + pa) * dt
                eb = 0.5 * (ub + pb) * dt
                ec = 0.5 * (uc + pc) * dt
                ed = 0.5 * (ud + pd) * dt
                if i == 1:
                    ga, gb, gc, gd = ea, eb, ec, ed
                else:
                    ga, gb, gc, gd = fa + ea, fb + eb, fc + ec, fd + ed
                ha = 0.5 * (ga + fa) * dt
                hb = 0.5 * (gb + fb) * dt
                hc = 0.5 * (gc + fc) * dt
                hd = 0.5 * (gd + fd) * dt
                if i == 1:
                    sa, sb, sc, sd = ha, hb, hc, hd
                else:
                    sa, sb, sc, sd = sa + ha, sb + hb, sc + hc, sd + hd
                second[i, 0] = sa
                second[i, 1] = sb
                second[i, 2] = sc
                second[i, 3] = sd
                fa, fb, fc, fd = ga, gb, gc, gd
            pa, pb, pc, pd = ua, ub, uc, ud
        cols = (c0, min(c0 + 1, m - 1), min(c0 + 2, m - 1), min(c0 + 3, m - 1))
        for r in range(rows):
            sa = sb = sc = sd = 0.0
            lo = indptr[r]
            if starts[r] >= 0:
                at = starts[r] - lo
                for jj in range(lo, indptr[r + 1]):
                    w = data[jj]
                    j = at + jj
                    sa += w * second[j, 0]
                    sb += w * second[j, 1]
                    sc += w * second[j, 2]
                    sd += w * second[j, 3]
            else:
                for jj in range(lo, indptr[r + 1]):
                    w = data[jj]
                    j = indices[jj]
                    sa += w * second[j, 0]
                    sb += w * second[j, 1]
                    sc += w * second[j, 2]
                    sd += w * second[j, 3]
            out[r, cols[0]] = sa + ma
            out[r, cols[1]] = sb + mb
            out[r, cols[2]] = sc + mc
            out[r, cols[3]] = sd + md
    return out


@jit
def group_sums(groups: NDArray[np.intp], x: NDArray[np.float64], count: int) -> NDArray[np.float64]:
    """The sum of the rows of ``x`` (n, m) per group, shape (count, m): row ``i`` added to
    group ``groups[i]`` in the rows' order, from zero (``numpy.add.at``'s operations and
    order, bit for bit, without its per-row dispatch)."""
    n, m = x.shape
    out = np.zeros((count, m))
    for i in range(n):
        g = groups[i]
        for c in range(m):
            out[g, c] += x[i, c]
    return out


@jit
def search_increasing(
    a: NDArray[np.float64], keys: NDArray[np.float64], right: bool
) -> NDArray[np.intp]:
    """``numpy.searchsorted(a, keys, side="right" if right else "left")`` for increasing ``a``
    and non-decreasing ``keys``: the same indices, found by one forward walk."""
    n = a.size
    out = np.empty(keys.size, dtype=np.intp)
    j = 0
    for i in range(keys.size):
        k = keys[i]
        if right:
            while j < n and a[j] <= k:
                j += 1
        else:
            while j < n and a[j] < k:
                j += 1
        out[i] = j
    return out


@jit
def dilate_mask(t: NDArray[np.float64], mask: NDArray[np.bool_], reach: float) -> NDArray[np.bool_]:
    """:func:`torquemap.filters.dilate`: the samples of non-decreasing ``t`` [s] within
    ``reach`` >= 0 [s] of a sample of ``mask``, by one forward walk.

    Per marked sample ``j`` the samples from the first with ``t >= t[j] - reach`` to the
    last with ``t <= t[j] + reach`` (the keys formed and compared as ``numpy.searchsorted``
    compares them, :func:`search_increasing`), each marked once: the same samples as the
    numpy code's counts of covering intervals, without its four arrays of the log's length.
    """
    n = t.size
    out = np.zeros(n, dtype=np.bool_)
    lo = 0
    hi = 0
    filled = 0
    for j in range(n):
        if not mask[j]:
            continue
        key_lo = t[j] - reach
        key_hi = t[j] + reach
        while lo < n and t[lo] < key_lo:
            lo += 1
        while hi < n and t[hi] <= key_hi:
            hi += 1
        for i in range(max(lo, filled), hi):
            out[i] = True
        filled = max(filled, hi)
    return out


@jit
def segment_medians(
    v: NDArray[np.float64], starts: NDArray[np.intp], stops: NDArray[np.intp]
) -> NDArray[np.float64]:
    """The median of each segment ``v[starts[s]:stops[s]]`` (non-empty), the mean of the two
    middle values of an even count: the value numpy's sorted order gives (the two order
    statistics found by selection, a segment holding a NaN sorted as numpy sorts it)."""
    out = np.empty(starts.size)
    longest = 0
    for s in range(starts.size):
        longest = max(longest, stops[s] - starts[s])
    buf = np.empty(longest)
    for s in range(starts.size):
        m = stops[s] - starts[s]
        nan = False
        for i in range(m):
            x = v[starts[s] + i]
            buf[i] = x
            nan = nan or x != x
        if nan:  # numpy's order, NaNs last
            seg = np.sort(v[starts[s] : stops[s]])
            out[s] = 0.5 * (seg[(m - 1) // 2] + seg[m // 2])
            continue
        # the order statistics by selection (Hoare's quickselect), not a sort: the same values
        half = m // 2
        _select(buf, m, half)
        upper = buf[half]
        lower = upper
        if m % 2 == 0:  # the largest of the values left of ``half``: the order statistic below
            lower = buf[0]
            for i in range(1, half):
                if buf[i] > lower:
                    lower = buf[i]
        out[s] = 0.5 * (lower + upper)
    return out


@jit
def _select(buf: NDArray[np.float64], m: int, k: int) -> None:
    """Reorder ``buf[:m]`` (no NaN) so that ``buf[k]`` holds its ``k``-th smallest value, the
    values before it not larger and those after not smaller (quickselect, median-of-three
    pivots)."""
    lo, hi = 0, m - 1
    while hi > lo:
        mid = (lo + hi) // 2
        # median of three to buf[mid]
        if buf[mid] < buf[lo]:
            buf[mid], buf[lo] = buf[lo], buf[mid]
        if buf[hi] < buf[lo]:
            buf[hi], buf[lo] = buf[lo], buf[hi]
        if buf[hi] < buf[mid]:
            buf[hi], buf[mid] = buf[mid], buf[hi]
        pivot = buf[mid]
        i, j = lo, hi
        while i <= j:
            while buf[i] < pivot:
                i += 1
            while buf[j] > pivot:
                j -= 1
            if i <= j:
                buf[i], buf[j] = buf[j], buf[i]
                i += 1
                j -= 1
        # buf[lo:j + 1] <= pivot <= buf[i:hi + 1], and lo..hi between j and i equal the pivot
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            return


@jit
def delayed_columns_at(
    t: NDArray[np.float64],
    y: NDArray[np.float64],
    at: NDArray[np.intp],
    delays: NDArray[np.float64],
) -> NDArray[np.float64]:
    """:func:`delayed_columns` at the samples ``at`` only (increasing indices into ``t``):
    ``out[i, c] = numpy.interp(t[at[i]] + delays[c], t, y)`` (``y[at[i]]`` for a delay of
    0), shape (at.size, delays.size); the knot found by bisection where ``at`` skips samples
    and by :func:`delayed_columns`' forward walk between, the same formula per sample (bit for
    bit the rows ``at`` of :func:`delayed_columns`)."""
    n = t.size
    m = delays.size
    out = np.empty((at.size, m))
    for c in range(m):
        shift = delays[c]
        if shift == 0.0:
            for i in range(at.size):
                out[i, c] = y[at[i]]
            continue
        j = 0
        for i in range(at.size):
            xv = t[at[i]] + shift
            if i == 0 or at[i] != at[i - 1] + 1:
                # numpy.searchsorted(t, xv, side="right") - 1: the last knot at or below xv
                j = max(int(np.searchsorted(t, xv, side="right")) - 1, 0)
            # _interp_walk's step, written in place: as a shared helper returning (value, knot)
            # numba compiled delayed_columns 1.6x slower (2 M samples x 25 delays, 0.55 -> 0.88 s)
            if xv != xv:
                out[i, c] = xv
            elif xv < t[0]:
                out[i, c] = y[0]
            elif xv > t[n - 1]:
                out[i, c] = y[n - 1]
            else:
                while j + 1 < n and t[j + 1] <= xv:
                    j += 1
                while j > 0 and t[j] > xv:
                    j -= 1
                if j == n - 1 or t[j] == xv:
                    out[i, c] = y[j]
                else:
                    slope = (y[j + 1] - y[j]) / (t[j + 1] - t[j])
                    v = slope * (xv - t[j]) + y[j]
                    if v != v:
                        v = slope * (xv - t[j + 1]) + y[j + 1]
                        if v != v and y[j] == y[j + 1]:
                            v = y[j]
                    out[i, c] = v
    return out


@jit
def savgol_acceleration(
    y: NDArray[np.float64], even: NDArray[np.float64], acceleration: NDArray[np.float64]
) -> None:
    """The acceleration of :func:`torquemap._kernels.savgol_fit` alone, in place (``y`` (n,),
    ``even[k]`` the acceleration's weights at lags ``k = 0..half``), for the smoothing that
    reads the acceleration only (:func:`torquemap.filters.smooth_as_acceleration`).

    The same operations in the same order as ``savgol_fit``'s acceleration (four lags per pass
    over a stretch of 512 outputs, then one at a time; each from the local differences
    ``(y[i + k] - y[i]) + (y[i - k] - y[i])``), without the velocity's sums: the same bits.
    """
    n = y.size
    half = even.size - 1
    acc_a = np.empty(TILE)  # savgol_fit's stretches, and so the sums' order
    for start in range(half, n - half, TILE):
        m = min(TILE, n - half - start)
        centre = y[start : start + m]
        for j in range(m):
            acc_a[j] = 0.0
        k = 1
        while k + 3 <= half:
            e1, e2, e3, e4 = even[k], even[k + 1], even[k + 2], even[k + 3]
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
                acc_a[j] += (e1 * d1 + e2 * d2) + (e3 * d3 + e4 * d4)
            k += 4
        while k <= half:
            ek = even[k]
            ahead = y[start + k : start + k + m]
            behind = y[start - k : start - k + m]
            for j in range(m):
                c = centre[j]
                acc_a[j] += ek * ((ahead[j] - c) + (behind[j] - c))
            k += 1
        for j in range(m):
            acceleration[start + j] = acc_a[j]


@jit
def double_integral(
    t: NDArray[np.float64], x: NDArray[np.float64], mean: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Twice scipy's ``cumulative_trapezoid(..., initial=0.0, axis=0)`` of ``x - mean`` (x (n,
    m), mean (m,)) over ``t`` [s] (n,), shape (n, m), in one pass without the temporaries.

    scipy's operations in its order: ``u = x - mean``, each step's area ``(dt * (u[i] +
    u[i - 1])) / 2.0`` with ``dt = t[i] - t[i - 1]``, summed from the first area itself (as
    ``cumulative_sum`` starts), 0.0 at the first sample: the same bits.
    """
    n, m = x.shape
    out = np.empty((n, m))
    if n == 0:
        return out
    for c in range(m):
        mc = mean[c]
        prev = x[0, c] - mc
        first = 0.0
        second = 0.0
        out[0, c] = 0.0
        for i in range(1, n):
            dt = t[i] - t[i - 1]
            cur = x[i, c] - mc
            step = (dt * (cur + prev)) / 2.0
            new_first = step if i == 1 else first + step
            area = (dt * (new_first + first)) / 2.0
            second = area if i == 1 else second + area
            out[i, c] = second
            first = new_first
            prev = cur
    return out
