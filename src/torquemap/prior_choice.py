"""Which prior the whole fit's friction table takes, chosen by rows the fit did not see.

The whole fit (:mod:`torquemap.identify_whole`) holds its friction table, where no steady row
measures it (below the slowest pass, between passes far apart), by a smoothness prior centred
either on ``a + b log s`` (the default) or on a generalized Stribeck curve
(:mod:`torquemap.friction_prior`). Neither is right on every motor: a Stribeck drop below the
slowest pass wants the curve, a table that rises towards rest (or a hump) the plain prior.

The log itself can tell. The rows the table is not fitted on (a ramp's rows whose
differentiator window reaches below half the slowest pass, reversals, creep) still carry the
torque there, smeared by the window and mixed with inertia, static friction and noise that
both fits share. Each fit predicts them with its own coefficients; the fit whose predictions
lose less (Huber's loss, at one scale for both) is chosen per direction, when the gain stands
out of the rows' noise: the gain's sum over clusters of rows (about a second each) against its
cluster-robust standard error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from torquemap.robust import HUBER_K, mad_scale

__all__ = ["HELD_OUT_Z", "PriorChoice", "held_out_gain", "huber_loss"]

#: How many standard errors the held-out gain of the curve-centred prior must stand above 0
#: for a direction to take it.
HELD_OUT_Z = 1.0


@dataclass(frozen=True, slots=True)
class PriorChoice:
    """The choice per direction (positive, negative).

    Attributes
    ----------
    curved
        Whether the direction's table takes the Stribeck-centred prior.
    gain
        Huber's loss of the plain prior's predictions less the curve-centred one's, summed
        over the direction's held-out rows, in units of the loss scale squared (> 0: the
        curve predicts better).
    z
        ``gain`` over its cluster-robust standard error (0 without rows).
    rows
        Held-out rows of the direction.
    velocity
        The Stribeck velocities [rad/s] of the curve the search found (0: none in that
        direction), chosen or not.
    """

    curved: tuple[bool, bool]
    gain: tuple[float, float]
    z: tuple[float, float]
    rows: tuple[int, int]
    velocity: tuple[float, float] = (0.0, 0.0)


def huber_loss(residual: NDArray[np.float64], scale: float) -> NDArray[np.float64]:
    """Huber's loss per row of ``residual`` [N m] at ``scale`` [N m] (k = ``HUBER_K``), in
    units of ``scale`` squared.

    Examples
    --------
    >>> huber_loss(np.array([0.0, 1.0, 10.0]), 1.0).round(4).tolist()
    [0.0, 0.5, 12.5455]
    """
    u = np.abs(np.asarray(residual, dtype=np.float64)) / max(scale, 1e-300)
    return np.asarray(np.where(u <= HUBER_K, 0.5 * u * u, HUBER_K * u - 0.5 * HUBER_K**2))


def held_out_gain(
    plain: NDArray[np.float64],
    curve: NDArray[np.float64],
    clusters: NDArray[np.int64],
    scale: float | None = None,
) -> tuple[float, float]:
    """The held-out gain of the curve-centred fit and its z score.

    Parameters
    ----------
    plain, curve
        Residuals [N m] of the two fits' predictions on the same held-out rows, shape (n,).
    clusters
        Cluster label of each row (rows within a cluster are correlated), shape (n,).
    scale
        Huber's scale [N m]; None: the robust scale of ``plain``.

    Returns
    -------
    tuple
        ``(gain, z)``: the loss of ``plain`` less that of ``curve`` summed over the rows (in
        units of ``scale`` squared), and the gain over its cluster-robust standard error
        (``sqrt(sum_c g_c^2)``, ``g_c`` the cluster's summed gain); ``(0, 0)`` without rows.

    Examples
    --------
    >>> r0 = np.array([1.0, -1.0, 1.0, -1.0])
    >>> gain, z = held_out_gain(r0, 0.5 * r0, np.array([0, 0, 1, 1]), 1.0)
    >>> gain, round(z, 3)
    (1.5, 1.414)
    """
    p = np.asarray(plain, dtype=np.float64)
    c = np.asarray(curve, dtype=np.float64)
    if p.size == 0:
        return 0.0, 0.0
    s = mad_scale(p) if scale is None else scale
    if not s > 0:
        s = float(np.sqrt(np.mean(p * p))) or 1.0
    d = huber_loss(p, s) - huber_loss(c, s)
    _, inverse = np.unique(np.asarray(clusters), return_inverse=True)
    per = np.bincount(inverse, weights=d)
    se = math.sqrt(float(np.sum(per * per)))
    gain = float(np.sum(d))
    return gain, gain / se if se > 0 else 0.0
