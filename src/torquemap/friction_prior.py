"""A physical prior for the whole fit's friction table: a generalized Stribeck curve.

The whole fit's table (:class:`torquemap.friction_law.SpeedTableFriction`) is held between and
below the logs' steady speeds by a smoothness prior on its differences in log speed
(:func:`torquemap.identify_whole._prior`), whose smoothest curves are ``a + b log s``. Here
the prior is centred on a curve per direction instead::

    level(s) = Fc + Fs exp(-(s / vs) ** delta) + deviation(s)

with ``Fc`` and ``Fs`` linear, fitted jointly with the knots in the same penalised least
squares, and the deviation held by the smoothness prior. ``Fc`` is already free (a constant
table has no differences); ``Fs`` with a Gaussian prior of standard deviation ``spread``
integrated out of the prior leaves a rank-one reduction of each direction's precision
(Woodbury)::

    P' = P - P phi phi^T P / (phi^T P phi + 1 / spread^2),    phi = exp(-(s_i / vs) ** delta)

so the fit needs no new column: the curve's direction costs little, everything else what it
did. The nonlinear ``(vs, delta)`` are searched outside the linear solve on a grid, per
direction, by the penalised objective of the fit (the curve that the knots need deviate from
least). Where passes hold the table, the data still decide; between and below them the knots
follow the curve's shape rather than a line in log speed. A law of another form keeps what the
passes say: the deviation takes it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "EXPONENTS",
    "SPREAD",
    "VELOCITY_STEP",
    "StribeckPrior",
    "amplitude",
    "curve_precision",
    "search_curve",
    "stribeck_shape",
]

#: Exponents ``delta`` of the curve tried (the family draws 0.6-3.0; LuGre's steady state is 2).
EXPONENTS = (0.75, 1.0, 1.5, 2.0, 3.0)
#: Ratio between neighbouring Stribeck velocities tried, from the table's first knot to its
#: last.
VELOCITY_STEP = 1.25
#: Prior standard deviation of the Stribeck amplitude ``Fs`` in units of the joint's friction
#: level: loose (a static level twice the Coulomb one is one sigma).
SPREAD = 1.0


@dataclass(frozen=True, slots=True)
class StribeckPrior:
    """The curve the table's prior is centred on, per direction (positive, negative).

    Attributes
    ----------
    velocity
        Stribeck velocities ``vs`` [rad/s]; 0 for a direction the search left without a
        curve.
    exponent
        Exponents ``delta`` [-].
    objective
        The fit's penalised objective at the chosen curves (weighted residual sum of squares
        plus the prior's penalty, in the units of the objective searched: the fit's noise
        variances).
    gain
        How much each direction's curve lowers that objective (the other's held); a curve
        whose gain is below the search's ``min_gain`` is dropped (velocity 0).
    """

    velocity: tuple[float, float]
    exponent: tuple[float, float]
    objective: float
    gain: tuple[float, float] = (0.0, 0.0)


def stribeck_shape(
    speeds: Sequence[float] | NDArray[np.float64], velocity: float, exponent: float
) -> NDArray[np.float64]:
    """``exp(-(s / vs) ** delta)`` at ``speeds`` [rad/s] (0 everywhere for ``vs`` = 0).

    Examples
    --------
    >>> [round(float(x), 3) for x in stribeck_shape([0.5, 1.0, 2.0], 1.0, 2.0)]
    [0.779, 0.368, 0.018]
    """
    s = np.asarray(speeds, dtype=np.float64)
    if velocity <= 0:
        return np.zeros(s.shape)
    return np.exp(-((s / velocity) ** exponent))


def curve_precision(
    precision: NDArray[np.float64],
    offset: int,
    k: int,
    shapes: tuple[NDArray[np.float64], NDArray[np.float64]],
    spread: float,
) -> NDArray[np.float64]:
    """``precision`` with each direction's table block (rows ``offset`` to ``offset + 2k``:
    positive knots, then negative) reduced along its curve shape ``phi`` (shape (k,)):
    ``P - P phi phi^T P / (phi^T P phi + 1 / spread^2)``, the prior of ``knots = Fs phi +
    deviation`` with ``Fs ~ N(0, spread^2)`` integrated out and the deviation of precision
    ``P``. ``spread`` [N m] > 0.

    Examples
    --------
    >>> p = np.diag([0.0, 0.0, 1.0, 1.0])  # a prior of (other, other, knot 1, knot 2)
    >>> q = curve_precision(p, 2, 1, (np.ones(1), np.zeros(1)), 1.0)
    >>> float(q[2, 2]), float(q[3, 3])  # 1 - 1 / (1 + 1): the curve's direction is cheaper
    (0.5, 1.0)
    """
    out = np.array(precision, dtype=np.float64, copy=True)
    for start, phi in ((offset, shapes[0]), (offset + k, shapes[1])):
        phi = np.asarray(phi, dtype=np.float64)
        if not np.any(phi):
            continue
        block = out[start : start + k, start : start + k]
        u = block @ phi
        out[start : start + k, start : start + k] = block - np.outer(u, u) / (
            float(phi @ u) + 1.0 / spread**2
        )
    return out


def amplitude(
    precision: NDArray[np.float64],
    knots: NDArray[np.float64],
    phi: NDArray[np.float64],
    spread: float,
) -> float:
    """The Stribeck amplitude ``Fs`` [N m] that the prior of :func:`curve_precision` (one
    direction's block ``precision``, shape (k, k)) implies for fitted ``knots`` (shape (k,)):
    its conditional mean ``phi^T P knots / (phi^T P phi + 1 / spread^2)``.

    Examples
    --------
    >>> p = np.eye(2)
    >>> round(amplitude(p, np.array([2.0, 0.0]), np.array([1.0, 0.0]), 1e6), 6)
    2.0
    """
    u = precision @ np.asarray(phi, dtype=np.float64)
    return float(u @ knots) / (float(phi @ u) + 1.0 / spread**2)


def search_curve(
    objective: Callable[[NDArray[np.float64]], tuple[float, NDArray[np.float64]]],
    precision: NDArray[np.float64],
    offset: int,
    speeds: Sequence[float],
    level: float,
    *,
    velocities: tuple[float, float] | None = None,
    min_gain: float = 0.0,
    rounds: int = 2,
) -> tuple[StribeckPrior, NDArray[np.float64]]:
    """The Stribeck curves (one per direction) that the fit's penalised objective prefers.

    Parameters
    ----------
    objective
        The fit's penalised objective for a prior precision (the same shape as
        ``precision``) [N^2 m^2], the weights, design and torque held, and the fitted
        coefficients that ``precision`` indexes (the table's knots at ``offset``). A curve
        whose amplitude comes out negative in its direction (friction falling towards rest)
        is not taken.
    precision
        The smoothness prior's precision, every column of the fit (zeros outside the table).
    offset
        Index of the table's first knot (positive direction; the negative direction's ``k``
        knots follow).
    speeds
        The table's knot speeds [rad/s], increasing (``k`` of them).
    level
        The joint's friction level [N m]: the Stribeck amplitude's prior standard deviation
        is ``SPREAD`` times it.
    velocities
        Range of the Stribeck velocities tried [rad/s] (the steady speeds': a drop that no
        two passes see is the prior's guess, not the logs'); None: the knots' range.
    min_gain
        Smallest drop of the objective a direction's curve must bring (the other's held) to
        be kept; below it that direction keeps the smoothness prior alone.
    rounds
        Passes over the two directions (each direction's grid searched with the other's
        curve held).

    Returns
    -------
    tuple
        The chosen curves (:class:`StribeckPrior`) and the precision centred on them.
    """
    k = len(speeds)
    x = np.asarray(speeds, dtype=np.float64)
    spread = SPREAD * max(level, 1e-12)
    lo, hi = (float(x[0]), float(x[-1])) if velocities is None else velocities
    count = max(2, math.ceil(math.log(hi / lo) / math.log(VELOCITY_STEP)) + 1)
    tried = [float(v) for v in np.geomspace(lo, hi, count)]
    grid = [(0.0, 2.0)] + [(v, e) for v in tried for e in EXPONENTS]
    chosen = [(0.0, 2.0), (0.0, 2.0)]

    def shapes(c: list[tuple[float, float]]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return stribeck_shape(x, *c[0]), stribeck_shape(x, *c[1])

    # the objective of each pair of curves, evaluated once: the rounds and the gains come back
    # to pairs already tried (the objective is a function of the precision alone, and the
    # precision of no curve is ``precision`` itself, curve_precision's copy of it)
    tried_pairs: dict[tuple[tuple[float, float], ...], tuple[float, NDArray[np.float64]]] = {}

    def at(c: list[tuple[float, float]]) -> tuple[float, NDArray[np.float64]]:
        key = tuple(c)
        if key not in tried_pairs:
            tried_pairs[key] = objective(curve_precision(precision, offset, k, shapes(c), spread))
        return tried_pairs[key]

    tried_pairs[((0.0, 2.0), (0.0, 2.0))] = objective(precision)
    best = tried_pairs[((0.0, 2.0), (0.0, 2.0))][0]
    for _ in range(rounds):
        moved = False
        for side in (0, 1):
            start = offset + side * k
            block = precision[start : start + k, start : start + k]
            for candidate in grid:
                trial = list(chosen)
                trial[side] = candidate
                value, coef = at(trial)
                if not value < best - 1e-12 * abs(best):
                    continue
                phi = shapes(trial)[side]
                if candidate[0] > 0 and amplitude(block, coef[start : start + k], phi, spread) < 0:
                    continue
                best, chosen, moved = value, trial, True
        if not moved:
            break
    gains = [0.0, 0.0]
    for side in (0, 1):
        if chosen[side][0] > 0:
            trial = list(chosen)
            trial[side] = (0.0, 2.0)
            gains[side] = at(trial)[0] - best
    for side in (0, 1):
        if chosen[side][0] > 0 and gains[side] < min_gain:
            chosen[side] = (0.0, 2.0)
    if any(c[0] == 0 for c in chosen) and gains != [0.0, 0.0]:
        best = at(chosen)[0]
    out = curve_precision(precision, offset, k, shapes(chosen), spread)
    result = StribeckPrior(
        velocity=(chosen[0][0], chosen[1][0]),
        exponent=(chosen[0][1], chosen[1][1]),
        objective=float(best),
        gain=(float(gains[0]), float(gains[1])),
    )
    return result, out
