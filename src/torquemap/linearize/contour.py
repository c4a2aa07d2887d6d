"""What the structured surface misses, carried between measured positions along its contours.

The table builder adds to the structured surface (:mod:`torquemap.linearize.surface`) what it
misses at the measured cells, the residual ``r(p, u)``, interpolated between the measured
positions ``a < p < b`` at a fixed base pulse width ``u``:
``r(p, u) = w_a r(a, u) + w_b r(b, u)``. Near the knee, where the sensed torque leaves zero,
that is biased: the knee moves by a few pulse widths from one measured position to the next
(friction, cogging and the ramp's shares set it), the residual changes sign across the model's
knee, and at a fixed ``u`` the interpolation mixes a residual from below one position's knee
with one from above the other's. The interpolated curve then leaves zero at the earlier of the
two knees and under-delivers the lowest commands between the measured positions.

Carried along the model's contours instead, the residual is read at each measured position where
the model's torque equals the model's torque at ``(p, u)``:

``r(p, u) = w_a r(a, u_a) + w_b r(b, u_b)``, ``S(a, u_a) = S(b, u_b) = S(p, u)``,

so a correction that belongs to the knee moves with the knee. It is used where the model's torque
lies above the torque at rest of the three positions (below, the contours are flat and name no
operating point) and below ``limit`` (the friction zone; above it the residual is the phases'
mutual saturation and the rig's compliance, which follow the actuation). Where an additive torque
at rest (cogging) varies between the measured positions, the contours shift with it and the fixed
pulse width is right, so the data decide, like the phases' hand-over
(:mod:`torquemap.linearize.handover`): every measured position is predicted from the next measured
positions on either side both ways, at its measured pulse widths inside the zone, and the
contours are used only when their squared errors are smaller with a paired t statistic above 2.

This module never imports the simulator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: Paired t statistic the contours' prediction errors must beat the fixed pulse width's by.
SIGNIFICANCE = 2.0
#: Top of the zone, in units of the smallest torque the rig reads reliably (three times a
#: row's noise): where the knee's position decides the lowest commands. Chosen among 1, 3 and
#: no limit on seeds 13, 4, 1, 11, 6 of the family (docs/linearize.md).
ZONE = 3.0


@dataclass(frozen=True, slots=True, eq=False)
class ContourCheck:
    """How the contours predict held-out measured positions, against the fixed pulse width.

    Attributes
    ----------
    cells
        Measured cells predicted (inside the zone).
    rms_fixed, rms_contour
        Root mean square prediction error [N m] of either interpolation.
    t_statistic
        Paired t statistic of the squared errors (fixed minus contour; 0 when fewer than 3
        cells).
    """

    cells: int
    rms_fixed: float
    rms_contour: float
    t_statistic: float

    @property
    def preferred(self) -> bool:
        """Whether the contours predict significantly better than the fixed pulse width."""
        return self.t_statistic > SIGNIFICANCE


def _between(
    model: NDArray[np.float64],
    residual: NDArray[np.float64],
    p: int,
    a: int,
    b: int,
    weight_a: float,
    limit: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """At position ``p`` between ``a`` and ``b``: the residual along the contours, at the
    fixed pulse width, and where the contours apply."""
    u = np.arange(model.shape[1], dtype=np.float64)
    level = model[p]

    def at(q: int) -> NDArray[np.float64]:
        # the model is non-decreasing in u; the tiny slope breaks its flat runs' ties
        rising = np.maximum.accumulate(model[q]) + 1e-9 * u
        out: NDArray[np.float64] = np.interp(np.interp(level, rising, u), u, residual[q])
        return out

    along = weight_a * at(a) + (1.0 - weight_a) * at(b)
    fixed = weight_a * residual[a] + (1.0 - weight_a) * residual[b]
    rest = max(float(model[p, 0]), float(model[a, 0]), float(model[b, 0]), 0.0)
    zone = (level > rest) & (level < limit)
    return along, fixed, zone


def check_contour(
    model: NDArray[np.float64],
    residual: NDArray[np.float64],
    anchors: NDArray[np.int64],
    levels: NDArray[np.float64],
    *,
    limit: float,
) -> ContourCheck:
    """Predict every measured position's residual from its neighbours both ways.

    Parameters
    ----------
    model
        The surface's (uncensored) torque on every base pulse width [N m], shape (P, A + 1).
    residual
        What the surface misses [N m], shape (P, A + 1): at the measured positions the
        measured cells' residual, linear between the measured pulse widths.
    anchors
        The measured positions, ascending, shape (k,).
    levels
        The measured base pulse widths, shape (J,).
    limit
        Top of the zone [N m].

    Returns
    -------
    ContourCheck
        The prediction errors of both interpolations and the paired t statistic.
    """
    n = model.shape[0]
    columns = np.clip(np.rint(levels).astype(np.int64), 0, model.shape[1] - 1)
    diffs: list[NDArray[np.float64]] = []
    fixed_sq: list[NDArray[np.float64]] = []
    along_sq: list[NDArray[np.float64]] = []
    k = anchors.size
    for i in range(k if k >= 3 else 0):
        a, p, b = int(anchors[i - 1]), int(anchors[i]), int(anchors[(i + 1) % k])
        weight_a = ((b - p) % n) / ((b - a) % n)
        along, fixed, zone = _between(model, residual, p, a, b, weight_a, limit)
        inside = zone[columns]
        truth = residual[p, columns][inside]
        e_fixed = (fixed[columns][inside] - truth) ** 2
        e_along = (along[columns][inside] - truth) ** 2
        fixed_sq.append(e_fixed)
        along_sq.append(e_along)
        diffs.append(e_fixed - e_along)
    d = np.concatenate(diffs) if diffs else np.zeros(0)
    t = 0.0
    if d.size >= 3 and float(np.std(d)) > 0.0:
        t = float(np.mean(d) / (np.std(d, ddof=1) / np.sqrt(d.size)))
    return ContourCheck(
        cells=int(d.size),
        rms_fixed=float(np.sqrt(np.mean(np.concatenate(fixed_sq)))) if d.size else 0.0,
        rms_contour=float(np.sqrt(np.mean(np.concatenate(along_sq)))) if d.size else 0.0,
        t_statistic=t,
    )


def carry_along_contours(
    model: NDArray[np.float64],
    residual: NDArray[np.float64],
    anchors: NDArray[np.int64],
    *,
    limit: float,
) -> NDArray[np.float64]:
    """The residual between measured positions, carried along the model's contours.

    Parameters
    ----------
    model
        The surface's (uncensored) torque on every base pulse width [N m], shape (P, A + 1).
    residual
        What the surface misses [N m], shape (P, A + 1), at the measured positions (the rows
        of the other positions are kept outside the zone).
    anchors
        The measured positions, ascending, shape (k,), at least 2.
    limit
        Top of the zone [N m].

    Returns
    -------
    ndarray
        The residual, shape (P, A + 1): unchanged at the measured positions and outside the
        zone; inside it, read where the measured positions' model equals the position's.

    Examples
    --------
    A sharp knee (unit slope) that moves from pulse width 10 to 14 between two measured
    positions, modelled 2 pulse widths early everywhere. At the middle position (knee 12) the
    fixed pulse width puts torque 1 at 12; carried along the contours the residual keeps it
    at zero there, and reads 1 at 13 like the truth.

    >>> u = np.arange(30.0)
    >>> knee = np.array([10.0, 12.0, 14.0])
    >>> model = u[None, :] - (knee[:, None] - 2.0)
    >>> data = np.maximum(u[None, :] - knee[:, None], 0.0)
    >>> residual = np.where((model <= 0) & (data <= 0), 0.0, data - model)
    >>> out = carry_along_contours(model, residual, np.array([0, 2]), limit=5.0)
    >>> fixed = 0.5 * (residual[0] + residual[2])
    >>> [float(max(model[1, v] + fixed[v], 0.0)) for v in (12, 13)]
    [1.0, 1.5]
    >>> [float(max(model[1, v] + out[1, v], 0.0)) for v in (12, 13)]
    [0.0, 1.0]
    """
    n = model.shape[0]
    out = residual.copy()
    measured = np.zeros(n, dtype=bool)
    measured[anchors] = True
    wrapped = np.concatenate([anchors - n, anchors, anchors + n])
    for p in (int(q) for q in np.flatnonzero(~measured)):
        i = int(np.searchsorted(wrapped, p))
        a, b = int(wrapped[i - 1]), int(wrapped[i])
        along, _, zone = _between(model, residual, p, a % n, b % n, (b - p) / (b - a), limit)
        out[p] = np.where(zone, along, residual[p])
    return out
