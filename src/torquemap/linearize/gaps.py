"""Does the torque at rest hold across the widest gaps between measured positions? A held-out test.

On unevenly spaced measured positions (an adaptive collection, a grid with positions missing)
the tables carry the torque at rest ``o(p)`` across the gaps by its Fourier series (the
harmonics the leave-one-out error kept, :mod:`torquemap.linearize.surface`) plus the series'
residuals interpolated linearly. Whether that holds inside a gap of width ``W`` cannot be read
at the gap's unmeasured positions; it can be read where the data are denser: every measured
position is predicted with the measured positions within ``W / 2`` of it left out (a gap of at
least ``W`` centred on it, the same interpolation, the same harmonics refitted), and the
prediction errors ``d_i`` are what a gap that wide costs, plus the measurement's own noise.

The same position predicted with itself alone left out (``e_i``, the narrowest gap) carries the
same measurement noise, so ``d_i^2 - e_i^2`` is what the wide gap adds. The warning fires when
a one-sided t-test rejects, at level ``ALPHA``, that its mean is at most ``matters^2``
(``matters``: a fifth of the torque of command 1, :data:`torquemap.linearize.sampling.MATTERS`):
the false-alarm rate is at most ``ALPHA`` wherever the widest gap adds less than ``matters``
of RMS error (measured on a closed-form series with Gaussian noise,
tests/test_linearize_gap_check.py), and no constant is tuned to a motor. A fired test names
the gaps at least ``W`` wide.

An earlier rule warned wherever a gap sampled the fastest kept harmonic at most twice a period
(``2 d h >= P``) or a harmonic had been refused for its leverage: a periodic ripple that the
dense stretches fix is held across such a gap by its series, and on the random benches 101 to
110 that rule fired on 8 adaptive collections of 10 (docs/linearize-adaptive.md).

This module never imports the simulator.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.stats import t as t_dist

#: The test's false-alarm rate: the probability of warning when the error across the widest
#: gap is below ``matters`` in RMS.
ALPHA = 0.05


@dataclass(frozen=True, slots=True, eq=False)
class GapTest:
    """The held-out error of the torque at rest across the widest gap.

    Attributes
    ----------
    width
        Widest gap between consecutive measured positions [table positions] (0: evenly
        spaced, not tested).
    wide_errors
        Prediction error at each measured position with the measured positions within
        ``width / 2`` left out [N m], shape (K,) (NaN where too few would be left).
    narrow_errors
        The same with that position alone left out [N m], shape (K,).
    excess_rms
        ``sqrt(mean(wide^2 - narrow^2))``: what the widest gap adds to the error [N m].
    p_value
        One-sided p-value of a t-test that the mean of ``wide^2 - narrow^2`` exceeds
        ``matters^2``.
    matters
        The RMS error that matters [N m].
    unheld
        True inside every gap at least ``width`` wide when the test fires, shape (P,).
    """

    width: int
    wide_errors: NDArray[np.float64]
    narrow_errors: NDArray[np.float64]
    excess_rms: float
    p_value: float
    matters: float
    unheld: NDArray[np.bool_]

    @property
    def fired(self) -> bool:
        """Whether the error across the widest gap matters at confidence ``1 - ALPHA``."""
        return bool(self.unheld.any())


def fourier_design(p: NDArray[np.float64], harmonics: Sequence[int], n: int) -> NDArray[np.float64]:
    """The Fourier series' design over positions ``p`` of a cycle of ``n``: a constant, then
    the cosines and the sines of ``harmonics`` (periods per cycle); shape (len(p), 1 + 2 H)."""
    x = 2.0 * np.pi * p[:, None] / n
    h = np.asarray(harmonics, dtype=np.float64)[None, :]
    return np.concatenate([np.ones((p.size, 1)), np.cos(x * h), np.sin(x * h)], axis=1)


def predict_across(
    rest: NDArray[np.float64],
    anchors: NDArray[np.int64],
    harmonics: tuple[int, ...],
    n: int,
    at: int,
) -> float:
    """The torque at rest at ``at`` from the measured positions ``anchors`` (``at`` not among
    them): the series with ``harmonics`` fitted to them, plus its residuals interpolated
    linearly (cyclically) between the two measured positions around ``at``."""
    x = anchors.astype(np.float64)
    design = fourier_design(x, harmonics, n)
    coef, *_ = np.linalg.lstsq(design, rest, rcond=None)
    resid = rest - design @ coef
    ext = np.concatenate([x - n, x, x + n])
    smooth = float((fourier_design(np.array([float(at)]), harmonics, n) @ coef)[0])
    return smooth + float(np.interp(float(at), ext, np.tile(resid, 3)))


def check_gaps(
    rest: ArrayLike,
    anchors: ArrayLike,
    harmonics: tuple[int, ...],
    positions_per_cycle: int,
    *,
    matters: float,
    alpha: float = ALPHA,
) -> GapTest:
    """Whether the torque at rest's interpolation across the widest gap errs by ``matters``.

    Parameters
    ----------
    rest
        Torque at rest at every table position [N m], shape (P,); only the measured positions
        are read.
    anchors
        The measured positions, ascending, shape (K,).
    harmonics
        The series' harmonics (periods per cycle), as the tables interpolate with.
    positions_per_cycle
        ``P``.
    matters
        RMS error [N m] that matters (the caller: a fifth of the torque of command 1).
    alpha
        False-alarm rate.

    Returns
    -------
    GapTest
        Not tested (``width`` 0, nothing unheld) on evenly spaced positions or fewer than
        ``2 len(harmonics) + 4`` of them.

    Examples
    --------
    A ripple of 6 periods held by its series across a gap of 8 (error = noise only):

    >>> n = 96
    >>> a = np.setdiff1d(np.arange(0, n, 2), [38, 40, 42])
    >>> o = 0.3 * np.sin(2 * np.pi * 6 * np.arange(n) / n)
    >>> check_gaps(o, a, (6,), n, matters=0.02).fired
    False

    The same gap without the harmonic in the series: linear interpolation across it misses the
    ripple.

    >>> check_gaps(o, a, (), n, matters=0.02).fired
    True
    """
    a = np.asarray(anchors, dtype=np.int64)
    y_all = np.asarray(rest, dtype=np.float64)
    n = int(positions_per_cycle)
    nothing = np.zeros(n, dtype=bool)
    width_after = (np.roll(a, -1) - a) % n
    width_after[width_after == 0] = n
    if a.size < 2 * len(harmonics) + 4 or np.all(width_after == width_after[0]):
        return GapTest(0, np.zeros(0), np.zeros(0), 0.0, 1.0, float(matters), nothing)
    wide = int(width_after.max())
    y = y_all[a]
    wide_err = np.full(a.size, np.nan)
    narrow_err = np.full(a.size, np.nan)
    for i, p in enumerate(a.tolist()):
        near = np.abs((a - p + n // 2) % n - n // 2) < wide / 2.0
        if (~near).sum() < 2 * len(harmonics) + 3:
            continue
        wide_err[i] = y[i] - predict_across(y[~near], a[~near], harmonics, n, p)
        alone = np.arange(a.size) != i
        narrow_err[i] = y[i] - predict_across(y[alone], a[alone], harmonics, n, p)
    ok = np.isfinite(wide_err) & np.isfinite(narrow_err)
    excess = wide_err[ok] ** 2 - narrow_err[ok] ** 2
    if excess.size < 3:
        return GapTest(wide, wide_err, narrow_err, 0.0, 1.0, float(matters), nothing)
    mean = float(np.mean(excess))
    spread = float(np.std(excess, ddof=1)) / np.sqrt(excess.size)
    # one-sided t-test of the mean excess against matters^2: at most ALPHA of the draws fire
    # where the widest gap adds less than ``matters`` of RMS error
    floor = float(matters) ** 2
    p_value = (
        float(t_dist.sf((mean - floor) / spread, excess.size - 1))
        if spread > 0
        else float(mean <= floor)
    )
    rms = float(np.sqrt(max(mean, 0.0)))
    unheld = nothing.copy()
    if p_value < alpha:
        for start, w in zip(a.tolist(), width_after.tolist(), strict=True):
            if w >= wide:
                unheld[(start + np.arange(1, w)) % n] = True
    return GapTest(wide, wide_err, narrow_err, rms, p_value, float(matters), unheld)
