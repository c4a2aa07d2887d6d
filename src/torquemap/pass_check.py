"""Does the pass method's model explain the whole sweep? A test against a law of no fixed form.

The pass method (``identify --friction passes``) fits friction to the means of constant-speed
passes and inertia to the ramps. When its law's form, its inertia or its delay is wrong, the
model still reproduces the pass means, and nothing says so. :func:`check_pass_model` fits, to
the samples where the joint moves (ramps included; at most about 60 000), a model with a
free friction law (per direction, piecewise linear in log speed), a free inertia and free
PDTV amplitudes (:func:`torquemap.free_law.free_law_rows`), and tests by an F test whether
the pass model's residual is significantly larger than that free model's.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from torquemap.free_law import MAX_ROWS, free_law_rows


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
    model_torque: Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]],
    inertia_torque: Sequence[NDArray[np.float64]],
    orders: Sequence[float],
    *,
    window: float,
    inertia_modulation: Sequence[NDArray[np.float64]] | None = None,
    confidence: float = 1.0 - 1e-6,
    max_rows: int = MAX_ROWS,
) -> PassModelCheck:
    """Test the pass model against a free model on the moving samples.

    Both models are fitted on the same rows: all moving samples, or at most ``max_rows`` of
    them as contiguous stretches of every run of moving rows (its ramps and evenly spaced
    stretches between; :func:`torquemap.free_law.select_stretches`), so the cost does not
    grow with the log.

    Parameters
    ----------
    t, angle, acceleration, torque
        Per log: time [s], motor angle [rad], differentiated acceleration [rad/s^2] and motor
        torque with the channel's delay undone [N m], each shape (n_log,).
    rows
        Per log: the samples that may be tested, boolean shape (n_log,).
    model_torque
        The pass model's friction plus PDTV torque [N m] as a function of the motor angle
        [rad] and the velocity friction is evaluated at [rad/s] (a central difference of the
        angle over +-1/8 window, :func:`torquemap.free_law.free_law_rows`), each shape (m,).
    inertia_torque
        Per log: the pass model's inertia times the differentiated acceleration [N m].
    orders
        PDTV orders [CPR] the free model fits amplitudes for.
    window
        The differentiator's window [s]: torque and model are smoothed by the acceleration's
        kernel (:func:`torquemap.filters.smooth_as_acceleration`), and one residual per window
        counts as independent.
    inertia_modulation
        Per log: the factor of a second free inertia column (``cos`` of the elbow), or None.
    confidence
        Level of the F test.
    max_rows
        The rows tested at most.

    Returns
    -------
    PassModelCheck
    """
    from scipy import stats

    if sum(int(np.count_nonzero(r)) for r in rows) < 10:
        return PassModelCheck(math.nan, math.nan, 0.0, 0, 0.0, True)
    free = free_law_rows(
        t,
        angle,
        acceleration,
        torque,
        rows,
        orders,
        window=window,
        inertia_modulation=inertia_modulation,
        model_torque=model_torque,
        max_rows=max_rows,
    )
    design, y = free.design, free.torque
    inertia = np.concatenate(
        [np.empty(0), *(j[i] for j, i in zip(inertia_torque, free.index, strict=True))]
    )
    r_model = y - free.model - inertia
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    r_free = y - design @ coef
    n, p = y.size, design.shape[1]
    rss_model, rss_free = float(r_model @ r_model), float(r_free @ r_free)
    c = free.correlation
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
