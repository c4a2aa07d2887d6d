"""The phases' hand-over between measured positions: each phase read at its own actuation.

The collection measures every few table positions (the paper: every 4th). Between two measured
positions the torque surface is usually interpolated linearly at a fixed base pulse width. Where
a phase's ramp switches on or off between them (a wide ramp takes a phase from 0 to 1 in
``W / 12`` positions, fewer than the paper's spacing on motors with few positions per phase),
that interpolation is wrong: at a position where the phase receives the share ``rho`` of the base
pulse width ``u``, its torque is that of the actuation ``rho u``, not ``rho`` times that of ``u``
(the torque grows with the square of the current in a variable-reluctance motor, and every
amplifier has a dead zone).

Where exactly one phase's share differs between the two measured positions ``a`` and ``b`` and a
position ``p`` between them (shares ``alpha``, ``beta``, ``rho``; every other phase the same),
the torque is written as the rest ``R(u)`` plus that phase's own contribution ``T(rho u)``,
``T(0) = 0``. The two measured curves give ``S_b(u) - S_a(u) = T(beta u) - T(alpha u)`` (say
``beta > alpha``), so ``T(v) = sum_j D(v (alpha / beta)**j / beta)``, ``D = S_b - S_a``, a single
term when ``alpha = 0``. The estimate at ``p`` keeps each side's rest, weighed by the distance
like the linear interpolation, and adds the phase's contribution at its own actuation:

``S(p, u) = w_a (S_a(u) - T(alpha u)) + w_b (S_b(u) - T(beta u)) + T(rho u)``.

It is exact for a motor whose phases add and whose phase curves change little between the two
positions, and it reduces to the linear interpolation where the shares do not change. It is not
exact where the phases saturate each other (mutual saturation of a variable-reluctance motor with
both phases energised), so it is used only where the data prefer it: every measured cell that
lies between two other measured cells of its level, inside a ramp, is predicted from those two
both ways, and the hand-over replaces the linear interpolation only when its prediction errors
are smaller by a significant margin (a paired t statistic above 2 over the cells tested).

The estimate is made level by level, between the positions holding data at that level (the
rig's compliance moves the high-torque rows of a block off its target position), from a
preliminary model on every pulse width for the values at ``alpha u``, ``beta u`` and ``rho u``.

Both steps run as one compiled loop over the cells (:mod:`torquemap._handover_kernels`, the
same floating-point operations as the numpy code they replaced, bit for bit).

This module never imports the simulator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: Tolerance on the ramp's shares.
SHARE_TOL = 1e-9
#: Paired t statistic the hand-over's prediction errors must beat the linear ones by.
SIGNIFICANCE = 2.0


@dataclass(frozen=True, slots=True, eq=False)
class HandoverCheck:
    """How the hand-over predicts measured cells, against the linear interpolation.

    Attributes
    ----------
    cells
        Measured cells predicted from their two neighbours at the same level.
    rms_linear, rms_handover
        Root mean square prediction error [N m] of either estimate.
    t_statistic
        Paired t statistic of the squared errors (linear minus hand-over; 0 when fewer than
        3 cells).
    """

    cells: int
    rms_linear: float
    rms_handover: float
    t_statistic: float

    @property
    def preferred(self) -> bool:
        """Whether the hand-over predicts significantly better than the linear interpolation."""
        return self.t_statistic > SIGNIFICANCE


def _contiguous(
    mean: NDArray[np.float64],
    levels: NDArray[np.float64],
    fine: NDArray[np.float64],
    ramp: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The arrays as the kernels of :mod:`torquemap._handover_kernels` take them."""

    def c(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.ascontiguousarray(x, dtype=np.float64)

    return c(mean), c(levels), c(fine), c(ramp)


def check_handover(
    mean: NDArray[np.float64],
    levels: NDArray[np.float64],
    fine: NDArray[np.float64],
    ramp: NDArray[np.float64],
    *,
    max_gap: int,
) -> HandoverCheck:
    """Predict every measured cell inside a ramp from its two neighbours at the same level,
    linearly and by the hand-over, and compare.

    Parameters
    ----------
    mean
        Measured torque per (position, level) cell [N m], NaN where no data, shape (P, J).
    levels
        Base pulse width of each column, shape (J,).
    fine
        A preliminary model on every pulse width ``0 .. A``, shape (P, A + 1); cells whose
        estimate needs a NaN of it are skipped.
    ramp
        The ramping function, shape (P, m).
    max_gap
        Longest run of positions interpolated across.

    Returns
    -------
    HandoverCheck
        The comparison.
    """
    from torquemap._handover_kernels import check_errors

    lin, ray = check_errors(*_contiguous(mean, levels, fine, ramp), int(max_gap))
    if not lin.size:
        return HandoverCheck(0, 0.0, 0.0, 0.0)
    a, b = np.square(lin), np.square(ray)
    d = a - b
    spread = float(np.std(d, ddof=1)) if d.size > 2 else 0.0
    t = float(np.mean(d) / (spread / np.sqrt(d.size))) if spread > 0 else 0.0
    return HandoverCheck(int(lin.size), float(np.sqrt(a.mean())), float(np.sqrt(b.mean())), t)


def fill_handover(
    mean: NDArray[np.float64],
    levels: NDArray[np.float64],
    fine: NDArray[np.float64],
    ramp: NDArray[np.float64],
    *,
    max_gap: int,
) -> tuple[NDArray[np.float64], int]:
    """Fill the empty cells between two data positions of one level where one phase's share
    changes (module docstring).

    Parameters
    ----------
    mean, levels, fine, ramp, max_gap
        As for :func:`check_handover`.

    Returns
    -------
    ndarray, int
        The grid with those cells filled (a copy) and how many were filled.

    Examples
    --------
    A phase that switches on between two measured positions, torque ``u**2`` per phase:

    >>> ramp = np.array([[1.0, 0.0], [1.0, 0.5], [1.0, 1.0]])
    >>> u = np.arange(5.0)
    >>> fine = np.array([u**2, u**2 + (0.5 * u) ** 2, 2 * u**2])
    >>> mean = np.full((3, 1), np.nan)
    >>> mean[0, 0], mean[2, 0] = 16.0, 32.0
    >>> grid, n = fill_handover(mean, np.array([4.0]), fine, ramp, max_gap=2)
    >>> float(grid[1, 0]), n  # 4**2 + 2**2, where the linear interpolation gives 24
    (20.0, 1)
    """
    from torquemap._handover_kernels import fill

    out, filled = fill(*_contiguous(mean, levels, fine, ramp), int(max_gap))
    return out, int(filled)
