"""Does the pass method's model explain the whole sweep? A test against a law of no fixed form.

The pass method (``identify --friction passes``) fits friction to the means of constant-speed
passes and inertia to the ramps. When its law's form, its inertia or its delay is wrong, the
model still reproduces the pass means, and nothing says so. :func:`check_pass_model` fits, to
every sample where the joint moves (ramps included), a model with a free friction law (per
direction, piecewise linear in log speed), a free inertia and free PDTV amplitudes, and tests
by an F test whether the pass model's residual is significantly larger than that free model's.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from torquemap.delay import _friction_basis, speed_knots
from torquemap.filters import smooth_as_acceleration


@dataclass(frozen=True, slots=True, eq=False)
class PassModelCheck:
    """Result of :func:`check_pass_model`.

    Attributes
    ----------
    rms_model, rms_free
        RMS residual of the pass model and of the free model over the rows [N m].
    f_statistic
        ``((rss_model - rss_free) / p) / (rss_free / (n - p))`` divided by the rows' correlation
        factor (rows per window).
    dof_model, dof_residual
        ``p`` and the independent residuals ``n / c - p`` of the F test.
    consistent
        False when the F test rejects the pass model at ``confidence``.
    """

    rms_model: float
    rms_free: float
    f_statistic: float
    dof_model: int
    dof_residual: float
    consistent: bool


def check_pass_model(
    t: Sequence[NDArray[np.float64]],
    angle: Sequence[NDArray[np.float64]],
    acceleration: Sequence[NDArray[np.float64]],
    torque: Sequence[NDArray[np.float64]],
    rows: Sequence[NDArray[np.bool_]],
    model_torque: Sequence[NDArray[np.float64]],
    inertia_torque: Sequence[NDArray[np.float64]],
    orders: Sequence[float],
    *,
    window: float,
    velocity: Sequence[NDArray[np.float64]],
    inertia_modulation: Sequence[NDArray[np.float64]] | None = None,
    confidence: float = 1.0 - 1e-6,
) -> PassModelCheck:
    """Test the pass model against a free model on every moving sample.

    Parameters
    ----------
    t, angle, acceleration, torque
        Per log: time [s], motor angle [rad], differentiated acceleration [rad/s^2] and motor
        torque with the channel's delay undone [N m], each shape (n_log,).
    rows
        Per log: the samples tested, boolean shape (n_log,).
    model_torque
        Per log: the pass model's friction plus PDTV torque [N m] (not smoothed).
    inertia_torque
        Per log: the pass model's inertia times the differentiated acceleration [N m].
    orders
        PDTV orders [CPR] the free model fits amplitudes for.
    window
        The differentiator's window [s]: torque and model are smoothed by the acceleration's
        kernel (:func:`torquemap.filters.smooth_as_acceleration`), and one residual per window
        counts as independent.
    velocity
        Per log: the velocity friction is evaluated at [rad/s].
    inertia_modulation
        Per log: the factor of a second free inertia column (``cos`` of the elbow), or None.
    confidence
        Level of the F test.

    Returns
    -------
    PassModelCheck
    """
    from scipy import stats

    idx = [np.flatnonzero(r) for r in rows]
    total = sum(i.size for i in idx)
    if total < 10:
        return PassModelCheck(math.nan, math.nan, 0.0, 0, 0.0, True)
    speeds = np.concatenate([np.abs(v[i]) for v, i in zip(velocity, idx, strict=True)])
    knots = speed_knots(speeds)
    blocks, ys, rm, steps = [], [], [], []
    for li, i in enumerate(idx):
        if i.size == 0:
            continue
        parts = [_friction_basis(velocity[li], knots), model_torque[li][:, None]]
        parts += [np.c_[np.cos(n * angle[li]), np.sin(n * angle[li])] for n in orders]
        smooth = smooth_as_acceleration(t[li], np.hstack(parts), window=window)
        a = acceleration[li][:, None]
        cols = [a, smooth[:, : 2 * knots.size], smooth[:, 2 * knots.size + 1 :]]
        if inertia_modulation is not None:
            cols.append(a * inertia_modulation[li][:, None])
        blocks.append(np.hstack(cols)[i])
        y = smooth_as_acceleration(t[li], torque[li], window=window)[i]
        ys.append(y)
        rm.append(y - smooth[i, 2 * knots.size] - inertia_torque[li][i])
        steps.append(np.diff(t[li]))
    design = np.vstack(blocks)
    design = design[:, np.any(design != 0, axis=0)]
    y = np.concatenate(ys)
    r_model = np.concatenate(rm)
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    r_free = y - design @ coef
    n, p = y.size, design.shape[1]
    rss_model, rss_free = float(r_model @ r_model), float(r_free @ r_free)
    c = max(window / max(float(np.median(np.concatenate(steps))), 1e-12), 1.0)
    dof = max(n / c - p, 1.0)
    f = (rss_model - rss_free) / p / max(rss_free / max(n - p, 1), np.finfo(float).tiny) / c
    return PassModelCheck(
        rms_model=math.sqrt(rss_model / n),
        rms_free=math.sqrt(rss_free / n),
        f_statistic=float(f),
        dof_model=p,
        dof_residual=dof,
        consistent=bool(f <= stats.f.ppf(confidence, p, dof)),
    )
