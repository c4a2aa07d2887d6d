"""The friction zone between measured positions: the knee carried in the uncensored torque.

The force sensor reads ``sensed = max(z, 0)``, where ``z(p, u)`` is the motor's torque less
the rig's static friction at table position ``p`` and base pulse width ``u``: zero below the
knee (where the torque overcomes the friction), ``z`` above it. The structured surface
(:mod:`torquemap.linearize.surface`) models ``z`` as ``U(p, u)``; what it misses at the measured
cells, ``r = sensed - U``, is added back and carried between measured positions by the linear
interpolation at a fixed pulse width.

Below the knee, ``r`` is a residual of the *censored* reading: ``-U`` where the model is above
zero and the sensor reads nothing. Interpolated between two measured positions ``a`` and ``b``
whose knees differ by a few pulse widths (a narrow ramp moves the knee by up to 3 pulse widths a
table position), the estimate at ``p`` between them is then about ``w_a sensed_a + w_b
sensed_b``: it rises at the earlier knee, with the weight of that side, while the truth ``max(w_a
z_a + w_b z_b, 0)`` (for ``z`` linear in the position) is still zero there; ``max`` is convex,
so the interpolation of censored curves lies above the censored interpolation. The forward
model then holds torque where there is none, and the tables under-deliver the lowest commands
between measured positions (on the family, seeds 0 to 19, by 34 % to 70 % on average at command
1 on VR and BLDC motors with narrow ramps, against 12 % to 35 % at the measured positions).

Here the residual is carried in ``z`` instead. At a measured position, the readings above one
row's noise (the first level from which the denoised reading is distinguishable from zero, and
every level above) give ``r`` as before. Below that level the position's ``z`` is continued
with the model's own shape, ``U + c``, with ``c`` the residual at that first level, but never
above zero at the level below it (the reading there says at most one row's noise): ``c =
min(r_k, -U_{k-1})``. ``U`` is non-decreasing in the pulse width, so ``U + c <= 0`` at every
level below the knee: at the measured positions the censored curve is the readings from the
first one above the noise on and zero below it, and between them ``max(U_p + w_a c_a + w_b c_b,
0)`` puts the knee where the model's own shape at ``p``, shifted by the interpolated offsets,
crosses zero.

It is exact when ``z`` (what the model misses included) changes linearly between measured
positions; where a position's rest torque alone loads the contact (cogging above the friction)
there is no knee and its residual stays. Since ``z`` need not be linear between measured
positions (cogging between them), the data decide, as for the hand-over
(:mod:`torquemap.linearize.handover`): every measured position's censored curve is predicted
from the measured positions on either side both ways, and the uncensored residual is used only
when its squared errors, summed per position, are smaller with a paired t statistic above 2.

Each offset ``c`` rests on one reading (the first above the noise), so it carries that
reading's noise into the knee of its position and, interpolated, of the positions between.
:func:`pool_onset` pools them: ``o + c``, the torque at rest less the friction that puts the
model's knee where the data do, is one friction and a few harmonics of cogging, smooth over
the cycle; it is fitted as a Fourier series over the measured positions (harmonics added while
each explains more than the offsets' noise would, a chi-square test at a known noise), and what
the series misses at a position is given back with a Wiener weight (all of it where it stands
well above the noise, none where it is noise).

This module never imports the simulator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

from torquemap.linearize.gaps import fourier_design

#: Paired t statistic (over the measured positions) the uncensored residual's prediction
#: errors must beat the censored one's by (the same bar as the hand-over's).
SIGNIFICANCE = 2.0
#: False-alarm rate of adding a harmonic to the knee's pooled torque at rest (:func:`pool_onset`).
POOL_LEVEL = 0.01
#: Measured positions on either side whose mean square sets a position's Wiener weight.
POOL_HALF_WIDTH = 2


@dataclass(frozen=True, slots=True, eq=False)
class KneeCheck:
    """How the uncensored residual predicts the measured positions, against the censored one.

    Attributes
    ----------
    positions
        Measured positions predicted from their two neighbours.
    rms_censored, rms_uncensored
        Root mean square prediction error of the sensed torque [N m] of either estimate.
    t_statistic
        Paired t statistic of the per-position squared-error sums (censored minus uncensored);
        above :data:`SIGNIFICANCE`: the uncensored residual predicts better.
    """

    positions: int
    rms_censored: float
    rms_uncensored: float
    t_statistic: float

    @property
    def preferred(self) -> bool:
        """Whether the uncensored residual is used."""
        return self.t_statistic > SIGNIFICANCE


def uncensored_residual(
    residual: NDArray[np.float64],
    sensed: NDArray[np.float64],
    model: NDArray[np.float64],
    *,
    noise: float,
) -> NDArray[np.float64]:
    """Continue each measured position's residual below its knee in the uncensored torque.

    Parameters
    ----------
    residual
        What the model misses at the measured cells, ``sensed - model`` (0 where both are at
        most zero) [N m], shape (P, J); NaN where no data.
    sensed
        The readings per (position, level) cell [N m], shape (P, J); NaN where no data.
    model
        The model's uncensored torque at the same cells [N m], shape (P, J), non-decreasing
        along the levels.
    noise
        One row's noise [N m]: readings up to it are not told from zero.

    Returns
    -------
    ndarray
        The residual, shape (P, J): at every position whose levels are measured from 0 up to
        its first reading above ``noise`` (``k >= 1``), the levels below ``k`` get
        ``min(residual[k], -model[k - 1])``; other cells as given.

    Examples
    --------
    A model early by 4 pulse widths (``0.1 (u - 16)`` against the truth ``0.1 (u - 20)``),
    measured every 4th pulse width: the censored residual is ``-model`` below the knee, the
    uncensored one the model's offset, -0.4 N m.

    >>> u = np.arange(0.0, 40.0, 4.0)
    >>> model = 0.1 * (u - 16.0)
    >>> sensed = np.maximum(0.1 * (u - 20.0), 0.0)
    >>> residual = np.where((model <= 0) & (sensed <= 0), 0.0, sensed - model)
    >>> residual[:7].round(2).tolist()
    [0.0, 0.0, 0.0, 0.0, 0.0, -0.4, -0.4]
    >>> out = uncensored_residual(residual[None], sensed[None], model[None], noise=0.01)
    >>> out[0, :7].round(2).tolist()
    [-0.4, -0.4, -0.4, -0.4, -0.4, -0.4, -0.4]
    """
    out = residual.copy()
    for p in range(residual.shape[0]):
        have = np.isfinite(sensed[p]) & np.isfinite(residual[p])
        up = have & (sensed[p] > noise)
        if not up.any():
            continue
        k = int(np.argmax(up))
        if k == 0 or not have[:k].all():
            continue  # no knee (the rest torque loads the contact) or a level missing below it
        out[p, :k] = min(float(residual[p, k]), -float(model[p, k - 1]))
    return out


def check_uncensored(
    censored: NDArray[np.float64],
    uncensored: NDArray[np.float64],
    sensed: NDArray[np.float64],
    model: NDArray[np.float64],
    anchors: NDArray[np.int64],
) -> KneeCheck:
    """Predict every measured position's sensed torque from its two neighbours both ways.

    Parameters
    ----------
    censored, uncensored
        The residual at the measured cells either way [N m], shape (P, J); NaN where no data.
    sensed
        The readings [N m], shape (P, J).
    model
        The model's uncensored torque at the cells [N m], shape (P, J).
    anchors
        The measured positions (the blocks' targets), ascending, shape (k,).

    Returns
    -------
    KneeCheck
        The comparison; ``t_statistic`` 0 when fewer than 3 positions differ.

    Notes
    -----
    Position ``anchors[i]`` is predicted from ``anchors[i - 1]`` and ``anchors[i + 1]``
    (cyclic), at twice the collection's spacing, as ``max(U_p + w_a r_a + w_b r_b, 0)`` with
    the linear interpolation's weights, on the levels all three hold. The squared errors
    against ``max(sensed, 0)`` are summed per position: the cells of one position share its
    knee, so the positions, not the cells, are the independent samples.
    """
    n = censored.shape[0]
    diffs: list[float] = []
    sq_c = sq_u = 0.0
    cells = 0
    for i in range(anchors.size):
        a, p, b = int(anchors[i - 1]), int(anchors[i]), int(anchors[(i + 1) % anchors.size])
        span = (b - a) % n
        if span == 0 or a == p:
            continue
        wb = ((p - a) % n) / span
        ok = np.isfinite(censored[a]) & np.isfinite(censored[b]) & np.isfinite(sensed[p])
        ok &= np.isfinite(model[p])
        if not ok.any():
            continue
        truth = np.maximum(sensed[p, ok], 0.0)
        pc = np.maximum(model[p, ok] + (1 - wb) * censored[a, ok] + wb * censored[b, ok], 0.0)
        pu = np.maximum(model[p, ok] + (1 - wb) * uncensored[a, ok] + wb * uncensored[b, ok], 0.0)
        ec, eu = float(np.sum((pc - truth) ** 2)), float(np.sum((pu - truth) ** 2))
        sq_c, sq_u, cells = sq_c + ec, sq_u + eu, cells + int(ok.sum())
        diffs.append(ec - eu)
    d = np.asarray(diffs)
    rms_c = float(np.sqrt(sq_c / cells)) if cells else 0.0
    rms_u = float(np.sqrt(sq_u / cells)) if cells else 0.0
    if np.count_nonzero(d) < 3:
        return KneeCheck(d.size, rms_c, rms_u, 0.0)
    spread = float(np.std(d, ddof=1))
    t = float(np.mean(d) / (spread / np.sqrt(d.size))) if spread > 0 else 0.0
    return KneeCheck(d.size, rms_c, rms_u, t)


def knee_levels(sensed: NDArray[np.float64], noise: float) -> NDArray[np.int64]:
    """Each position's first level reading above ``noise`` when every level below it is
    measured and it is not the first (a knee in the data), else -1, shape (P,)."""
    out = np.full(sensed.shape[0], -1, dtype=np.int64)
    for p in range(sensed.shape[0]):
        have = np.isfinite(sensed[p])
        up = have & (sensed[p] > noise)
        if not up.any():
            continue
        k = int(np.argmax(up))
        if k >= 1 and have[:k].all():
            out[p] = k
    return out


def pool_onset(
    offset: NDArray[np.float64],
    rest: NDArray[np.float64],
    anchors: NDArray[np.int64],
    *,
    noise: float,
) -> NDArray[np.float64]:
    """Pool the knee's offsets over the measured positions through a smooth torque at rest.

    Parameters
    ----------
    offset
        What the model misses below each position's knee (the uncensored residual's constant
        ``c``) [N m], shape (P,); NaN where the position has no knee.
    rest
        The model's torque at rest ``o(p)`` [N m], shape (P,).
    anchors
        The measured positions, ascending.
    noise
        One row's noise [N m]: the noise of one offset.

    Returns
    -------
    ndarray
        The pooled offsets, shape (P,); NaN where ``offset`` is.

    Notes
    -----
    ``e = o + c`` is the torque at rest less the friction that puts the model's knee where the
    data put it: the friction is one constant and the torque at rest a few harmonics of the
    cycle, so ``e`` is smooth over the cycle while each ``c`` carries one reading's noise.
    ``e`` is fitted by a Fourier series over the measured positions with a knee, a harmonic
    added while the best of those not yet kept explains more than noise would (its drop of the
    residual sum of squares, in units of ``noise**2``, beyond the chi-square quantile at
    :data:`POOL_LEVEL` over the number of harmonics tried, with two degrees of freedom); what
    the series misses at a position, ``d``, is given back in part, ``alpha d`` with ``alpha =
    max(0, 1 - noise^2 / MS)``, ``MS`` the mean square of ``d`` over the
    ``2 POOL_HALF_WIDTH + 1`` nearest such positions (a Wiener shrinkage: the weight that
    minimises the expected squared error of a structure ``m`` under noise ``noise``, ``m^2``
    read as ``MS - noise^2``).
    """
    n = offset.size
    out = offset.copy()
    at = anchors[np.isfinite(offset[anchors])]
    if at.size < 5 or not noise > 0:
        return out
    e = rest[at] + offset[at]
    x = at.astype(np.float64)
    top = (at.size - 1) // 2
    kept: list[int] = []
    design = fourier_design(x, kept, n)
    coef = np.linalg.lstsq(design, e, rcond=None)[0]
    sse = float(np.sum((e - design @ coef) ** 2))
    while 2 * len(kept) + 3 < at.size:
        trials = []
        for h in range(1, top + 1):
            if h not in kept:
                d = fourier_design(x, [*kept, h], n)
                c = np.linalg.lstsq(d, e, rcond=None)[0]
                trials.append((float(np.sum((e - d @ c) ** 2)), h, c))
        if not trials:
            break
        best, h, c = min(trials, key=lambda t: t[0])
        if (sse - best) / noise**2 <= chi2.isf(POOL_LEVEL / len(trials), 2):
            break
        kept.append(h)
        sse, coef = best, c
    smooth = fourier_design(x, kept, n) @ coef
    d = e - smooth
    k = at.size
    w = POOL_HALF_WIDTH
    ms = np.array([np.mean(d[[(i + j) % k for j in range(-w, w + 1)]] ** 2) for i in range(k)])
    alpha = np.clip(1.0 - noise**2 / np.maximum(ms, 1e-300), 0.0, 1.0)
    out[at] = smooth + alpha * d - rest[at]
    return out
