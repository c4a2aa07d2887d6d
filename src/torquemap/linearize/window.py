"""The onset law's fitting window chosen by what the tables face: a measured position left out.

The onset law (:mod:`torquemap.linearize.onset`) is fitted over each position's curve between
the smallest torque the rig reads and a fraction of the position-independent torque (the
window's top, :data:`WINDOWS`). A narrower window reads the law nearer the friction zone, where
the tables use it, but from fewer readings: on a convex amplifier's onset it can place the dead
zone where the wider window reads a straight law (family motor 360), and on another motor it
misplaces it (160; docs/linearize.md, "stop 43 (L61)").

The tables interpolate between measured positions through the structured surface
(:mod:`torquemap.linearize.surface`), whose ``phi`` follows the law below the actuations that
read torque. So each candidate law is scored by what the tables face: the measured positions are
split into :data:`FOLDS` interleaved folds; each fold in turn is left out (all its cells), the
surface is fitted to the rest under the candidate law, and it predicts the left-out positions'
lowest :data:`LOWEST` cells that read torque (at least ``readable``), the cells nearest the
friction zone. A candidate other than the first (the default window) is taken only when the
mean paired difference of its squared errors from the default's is below ``-CHOICE_SE``
standard errors (one-sided: :func:`torquemap.linearize.onset.paired_choice`, the test of
``fit_onset``'s ``"choose"``).

This module never imports the simulator.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from torquemap.linearize.onset import paired_choice
from torquemap.linearize.surface import fit_surface, surface_prediction

#: The windows' tops tried, as fractions of the position-independent torque; the first is the
#: default (docs/linearize.md, "stop 44 (L67)").
WINDOWS = (0.3, 0.15)
#: Interleaved folds of the measured positions.
FOLDS = 4
#: Cells per left-out position scored: its lowest that read at least ``readable``.
LOWEST = 2
#: ``build_tables``' ``onset_window``: a window's top (a fraction of the position-independent
#: torque) or ``"choose"`` among :data:`WINDOWS`.
OnsetWindow = float | Literal["choose"]


@dataclass(frozen=True, slots=True)
class WindowChoice:
    """The window chosen and the test behind it.

    Attributes
    ----------
    index
        Index of the law taken among the candidates (0: the default).
    mse
        Mean squared error of each candidate's prediction of the left-out cells [N m^2].
    t
        Each candidate's mean paired difference of squared errors from the default's over its
        standard error (0 for the default; negative: it predicts better).
    cells
        Left-out cells scored.
    """

    index: int
    mse: tuple[float, ...]
    t: tuple[float, ...]
    cells: int


def left_out_cells(
    grid: NDArray[np.float64], anchors: NDArray[np.int64], readable: float
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Each measured position's lowest :data:`LOWEST` cells reading at least ``readable``.

    Returns
    -------
    ndarray, ndarray
        Their positions and columns (flat, ascending by position).

    Examples
    --------
    >>> g = np.array([[0.0, 0.1, 0.5, 0.9, 1.2], [0.0, 0.0, 0.0, 0.6, 1.0]])
    >>> p, j = left_out_cells(g, np.array([0, 1]), 0.4)
    >>> p.tolist(), j.tolist()
    ([0, 0, 1, 1], [2, 3, 3, 4])
    """
    ps: list[int] = []
    js: list[int] = []
    for p in anchors:
        cols = np.flatnonzero(np.isfinite(grid[p]) & (grid[p] >= readable))[:LOWEST]
        ps.extend([int(p)] * cols.size)
        js.extend(int(j) for j in cols)
    return np.asarray(ps, dtype=np.int64), np.asarray(js, dtype=np.int64)


def choose_window(
    grid: NDArray[np.float64],
    levels: NDArray[np.float64],
    ramp: NDArray[np.float64],
    laws: list[tuple[float, float, float]],
    *,
    readable: float,
    actuation_max: int,
    coupling: bool | Literal["checked"] = False,
) -> WindowChoice:
    """Choose among onset laws ``(d, n, c)`` by the surface's prediction of left-out positions.

    Parameters
    ----------
    grid
        Sensed torque [N m], shape (P, J), NaN where not measured (the surface's cells).
    levels
        Base pulse width of each column, shape (J,).
    ramp
        Shape (P, m).
    laws
        The candidates' laws, the default first (from the windows of :data:`WINDOWS`).
    readable
        Smallest torque read reliably [N m].
    actuation_max
        Full-scale pulse width.
    coupling
        :func:`~torquemap.linearize.surface.fit_surface`'s ``coupling``.

    Returns
    -------
    WindowChoice
        The law taken, each one's error and test statistic.
    """
    anchors = np.flatnonzero(np.isfinite(grid[:, 0]))
    cp, cj = left_out_cells(grid, anchors, readable)
    fold = np.searchsorted(anchors, cp) % FOLDS
    if cp.size < 2 * FOLDS or all(law == laws[0] for law in laws):
        return WindowChoice(0, (0.0,) * len(laws), (0.0,) * len(laws), int(cp.size))
    errors = []
    for d, n, c in laws:
        err = np.empty(cp.size)
        for f in range(FOLDS):
            rest = grid.copy()
            rest[anchors[np.arange(anchors.size) % FOLDS == f]] = np.nan
            fit = fit_surface(
                rest,
                levels,
                ramp,
                actuation_max=actuation_max,
                readable=readable,
                dead_zone=d,
                exponent=n,
                curve=c,
                coupling=coupling,
            )
            pred = np.maximum(surface_prediction(fit, ramp, levels), 0.0)
            at = fold == f
            err[at] = pred[cp[at], cj[at]] - grid[cp[at], cj[at]]
        errors.append(err)
    index, ts = paired_choice(errors)
    mse = tuple(float(np.mean(e**2)) for e in errors)
    return WindowChoice(index, mse, ts, int(cp.size))
