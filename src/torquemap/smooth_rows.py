"""The differentiator's smoothing evaluated at a subset of a log's rows.

Whole-log identification (:mod:`torquemap.identify_whole`) regresses signals smoothed by the
kernel through which :func:`torquemap.filters.differentiate` sees acceleration. Neighbouring
smoothed rows carry nearly the same information, so the fit keeps a few rows per window and
needs the smoothing only there: :class:`RowSmoother` gives it at a cost of a few operations per
sample, whatever the window holds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import sparse


@dataclass(frozen=True, slots=True, eq=False)
class RowSmoother:
    """:func:`torquemap.filters.smooth_as_acceleration` evaluated at some rows only.

    The smoothed signal at row ``i`` is the differentiator's acceleration (a local quadratic
    least-squares fit over the window of ``i``, :func:`torquemap.filters.differentiate`) of the
    signal's double integral; that fit is a fixed linear combination of the window's samples,
    precomputed here once per time axis. Evaluating it at one row per quarter window costs
    about four operations per sample, whatever the window holds, where smoothing every sample
    costs the window's length per sample: the nonlinear search's trials use this.

    Attributes
    ----------
    t
        Time [s] of the whole piece, shape (n,).
    operator
        The rows' weights on the double integral, sparse (rows, n).
    starts
        Per row, the first sample of its weights when they lie on consecutive samples (every
        row whose window ends before the piece's last sample), else -1, shape (rows,).
    spans
        Per row, the first sample of its window and one past its last, each shape (rows,)
        (:meth:`build`'s; None for a smoother made otherwise): what :meth:`subset` reads.
    """

    t: NDArray[np.float64]
    operator: sparse.csr_matrix
    starts: NDArray[np.intp]
    spans: tuple[NDArray[np.intp], NDArray[np.intp]] | None = None

    @classmethod
    def build(cls, t: NDArray[np.float64], rows: NDArray[np.intp], window: float) -> RowSmoother:
        """The smoother of time axis ``t`` [s] at ``rows`` for a window of ``window`` [s]."""
        from torquemap.filters import MIN_WINDOW_SAMPLES, uniform_step

        n = t.size
        h = uniform_step(t)
        half = math.floor(window / (2 * h) + 1e-9)
        if half >= 2 and 2 * half + 1 <= n and np.allclose(np.diff(t), h, rtol=1e-9, atol=0.0):
            length = 2 * half + 1
            lo = np.clip(rows - half, 0, n - length)
            hi = lo + length
        else:
            start = np.clip(t[rows] - window / 2, t[0], t[-1] - window)
            lo = np.searchsorted(t, start, side="left")
            hi = np.searchsorted(t, start + window * (1 + 1e-12), side="right")
            short = (hi - lo) < MIN_WINDOW_SAMPLES
            if short.any():
                i = rows[short]
                left = np.clip(i - MIN_WINDOW_SAMPLES // 2, 0, n - MIN_WINDOW_SAMPLES)
                lo[short] = np.minimum(lo[short], left)
                hi[short] = np.maximum(hi[short], left + MIN_WINDOW_SAMPLES)
        from torquemap._fit_kernels import curvature_weights, run_starts

        width = int((hi - lo).max()) if rows.size else 1
        lo, hi = lo.astype(np.intp), hi.astype(np.intp)
        data, index = curvature_weights(t, rows.astype(np.intp), lo, hi, width)
        operator = sparse.csr_matrix(
            (data, index, np.arange(0, data.size + 1, width)), shape=(rows.size, n)
        )
        return cls(
            t=t,
            operator=operator,
            starts=run_starts(operator.indptr, operator.indices),
            spans=(lo, hi),
        )

    def subset(self, index: NDArray[np.intp], rows: NDArray[np.intp], window: float) -> RowSmoother:
        """The smoother of this one's rows ``index`` (positions among its rows, increasing;
        ``rows`` their samples, ``window`` [s] the window it was built for) alone:
        ``build(t, rows, window)``, bit for bit. A row's window and weights do not depend on
        the other rows, only the slots per row do (the widest window's, shorter ones padded
        with zero weights on the last sample): when the rows' widest window is as wide as
        this smoother's, their weights are read from this one's; otherwise (or for a
        smoother not made by :meth:`build`) they are built again."""
        from torquemap._fit_kernels import run_starts

        op = self.operator
        count = op.shape[0]
        width = int(op.indptr[1] - op.indptr[0]) if count else 1
        if self.spans is None or index.size == 0 or op.nnz != count * width:
            return RowSmoother.build(self.t, rows, window)
        lo, hi = self.spans[0][index], self.spans[1][index]
        if int((hi - lo).max()) != width:
            return RowSmoother.build(self.t, rows, window)
        data = op.data.reshape(count, width)[index].ravel()
        cols = op.indices.reshape(count, width)[index].ravel()
        operator = sparse.csr_matrix(
            (data, cols, np.arange(0, data.size + 1, width)), shape=(index.size, op.shape[1])
        )
        return RowSmoother(
            t=self.t,
            operator=operator,
            starts=run_starts(operator.indptr, operator.indices),
            spans=(lo, hi),
        )

    def __call__(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The smoothed ``x`` (n, m) at the rows, shape (rows, m)."""
        from torquemap._fit_kernels import column_centres, smooth_at_rows

        x = np.asarray(x, dtype=np.float64)
        if x.strides[0] < x.strides[1] or x.strides[1] != x.itemsize:
            # rows of columns side by side (a slice of a wider array's columns is read as it
            # is, without a copy: the kernel reads each row's few columns together)
            x = np.ascontiguousarray(x)
        centre = column_centres(x)
        op = self.operator
        out = smooth_at_rows(self.t, x, centre, op.indptr, op.indices, op.data, self.starts)
        return np.asarray(out + centre, dtype=np.float64)

    def both_ways(
        self, theta: NDArray[np.float64], velocity: NDArray[np.float64], order: float
    ) -> NDArray[np.float64]:
        """The smoothed PDTV columns of line ``order`` [CPR] at the rows, shape (rows, 6):
        ``cos, sin`` of ``order * theta`` (``theta`` the motor angle [rad], shape (n,)), then
        both where ``velocity`` [rad/s] > 0 (else 0), then both where it is < 0; the same
        numbers as this smoother applied to those six columns, without forming them."""
        from torquemap._fit_kernels import smooth_both_ways_at_rows

        op = self.operator
        theta = np.ascontiguousarray(theta, dtype=np.float64)
        return np.asarray(
            smooth_both_ways_at_rows(
                self.t,
                theta,
                np.ascontiguousarray(velocity, dtype=np.float64),
                float(order),
                slots_per_radian(theta),
                op.indptr,
                op.indices,
                op.data,
                self.starts,
            ),
            dtype=np.float64,
        )

    def angle_harmonics(self, q: NDArray[np.float64], k: int, planar: bool) -> NDArray[np.float64]:
        """The smoothed joint-angle columns of a gravity torque on joint ``k`` at the rows
        (:func:`torquemap.identify_whole.gravity_basis` of the joint angles ``q`` [rad],
        shape (n, joints), at most two absolute angles), shape (rows, 2 or 4): the same
        numbers as this smoother applied to those columns, without forming them."""
        from torquemap._fit_kernels import smooth_angle_harmonics_at_rows

        op = self.operator
        return np.asarray(
            smooth_angle_harmonics_at_rows(
                self.t,
                np.ascontiguousarray(q, dtype=np.float64),
                int(k),
                bool(planar),
                op.indptr,
                op.indices,
                op.data,
                self.starts,
            ),
            dtype=np.float64,
        )

    def speed_table(
        self,
        speed: NDArray[np.float64],
        up: NDArray[np.float64],
        down: NDArray[np.float64],
        knot: NDArray[np.int64],
        fraction: NDArray[np.float64],
        columns: NDArray[np.int64],
        knots: int,
    ) -> NDArray[np.float64]:
        """The speed-table friction basis's columns ``columns`` smoothed at the rows, shape
        (rows, columns.size): :func:`torquemap._fit_kernels.speed_table_block`'s columns (its
        arguments per sample, ``knots`` the table's knot count) through this smoother, the
        same numbers, without forming them."""
        from torquemap._fit_kernels import smooth_speed_table_at_rows

        op = self.operator
        return np.asarray(
            smooth_speed_table_at_rows(
                self.t,
                speed,
                up,
                down,
                knot,
                fraction,
                np.ascontiguousarray(columns, dtype=np.int64),
                int(knots),
                op.indptr,
                op.indices,
                op.data,
                self.starts,
            ),
            dtype=np.float64,
        )


def slots_per_radian(theta: NDArray[np.float64]) -> float:
    """The inverse of the smallest nonzero step of the angle ``theta`` [rad] over its first
    65 536 samples (an encoder's count, at the motor), 0 when it does not move or the step is
    not finite: the cosine cache's slots per radian of
    :func:`torquemap._fit_kernels.smooth_both_ways_at_rows` (any value gives the same
    numbers; this one puts neighbouring counts in neighbouring slots)."""
    steps = np.abs(np.diff(theta[: 1 << 16]))
    steps = steps[steps > 0]
    if not steps.size:
        return 0.0
    inverse = 1.0 / float(np.min(steps))
    return inverse if math.isfinite(inverse) else 0.0
