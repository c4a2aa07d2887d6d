"""The torque channel's delay as whole-log identification sees it: a profile of the fit's cost.

:func:`delay_profile` scans a cost over trial delays and bounds the delay by a profile F test;
:func:`judge_delay` picks the delay to keep and words what the profile says (an ambiguous
delay, a minimum at the search's bound, a disagreement with the pass method's delay).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from torquemap.robust import HUBER_K


@dataclass(frozen=True, slots=True, eq=False)
class DelayProfile:
    """The whole-log fit's cost against the torque channel's delay.

    Attributes
    ----------
    grid, cost
        The grid of delays [s] and the robust cost of the fit at each (``nan`` where a
        coarse-to-fine search did not try it).
    best
        The cost-minimising delay (grid, refined by a parabola) [s].
    low, high
        The 95 % profile confidence interval [s] (the delays whose cost is not significantly
        worse than at ``best``; correlated neighbours counted once per window).
    candidates
        Separate local minima of the cost within that threshold (``best`` first) [s]: more than
        one means the logs do not tell the delay apart.
    """

    grid: NDArray[np.float64]
    cost: NDArray[np.float64]
    best: float
    low: float
    high: float
    candidates: tuple[float, ...]


#: Delays tried by :func:`delay_profile` before its parabola.
STEPS = 25


def delay_grid(max_delay: float, steps: int = STEPS) -> NDArray[np.float64]:
    """The delays [s] :func:`delay_profile` tries first: ``steps`` evenly from ``-max_delay``
    to ``max_delay`` (a caller may prepare the costs of all of them at once)."""
    return np.linspace(-max_delay, max_delay, steps)


def profile_ratio(dof: float) -> float:
    """The cost ratio a delay's profile accepts at 95 %: a delay whose cost is at most this
    times the least cost lies inside the interval (the F test of :func:`delay_profile`).

    Parameters
    ----------
    dof
        Degrees of freedom of the profile F test (at least 1).

    Examples
    --------
    >>> round(profile_ratio(100.0), 4)
    1.0394
    """
    dof = max(dof, 1.0)
    return 1.0 + float(stats.f.ppf(0.95, 1, dof)) / dof


def delay_profile(
    cost: Callable[[float], float],
    max_delay: float,
    *,
    dof: float,
    steps: int = STEPS,
    search: Literal["grid", "refine"] = "grid",
    prepare: Callable[[NDArray[np.float64]], None] | None = None,
) -> DelayProfile:
    """Scan ``cost`` over delays in ``[-max_delay, max_delay]`` (grid, then a parabola through
    the best three) and bound the delay by a profile F test at 95 % with ``dof`` degrees of
    freedom.

    Parameters
    ----------
    cost
        The fit's cost at a delay [s] (squared units).
    max_delay
        Search range [s].
    dof
        Degrees of freedom of the profile F test.
    steps
        Points of the grid (:func:`delay_grid`).
    search
        ``"grid"``: ``cost`` at every grid point. ``"refine"``: the same grid, tried coarse to
        fine (:func:`refine_grid`): every point that can lie within the test's limit, or
        beside one that does, is tried; the rest are left untried (``nan`` in
        :attr:`DelayProfile.cost`). The same profile as ``"grid"`` wherever the cost between
        tried points curves no more than twice the most the tried points show.
    prepare
        Called with each batch of delays [s] before they are costed (a caller that computes
        the trials' inputs several at a time).

    Examples
    --------
    >>> p = delay_profile(lambda d: 100.0 + 1e6 * (d - 0.05) ** 2, 0.25, dof=100.0)
    >>> round(p.best, 4), p.low < 0.05 < p.high, p.candidates == (p.best,)
    (0.05, True, True)
    >>> q = delay_profile(
    ...     lambda d: 100.0 + 1e6 * (d - 0.05) ** 2, 0.25, dof=100.0, search="refine"
    ... )
    >>> (q.best, q.low, q.high) == (p.best, p.low, p.high), int(np.isnan(q.cost).sum()) > 0
    (True, True)
    """
    grid = delay_grid(max_delay, steps)
    dof = max(dof, 1.0)
    ratio = profile_ratio(dof)
    vals = np.full(grid.size, np.nan)

    def run(index: list[int]) -> None:
        if prepare is not None and index:
            prepare(grid[index])
        for i in index:
            vals[i] = cost(float(grid[i]))

    if search == "grid":
        run(list(range(grid.size)))
    else:
        refine_grid(grid, vals, run, ratio)
    k = int(np.nanargmin(vals))
    best, c_best = float(grid[k]), float(vals[k])
    if 0 < k < grid.size - 1:
        y0, y1, y2 = vals[k - 1], vals[k], vals[k + 1]
        den = y0 - 2 * y1 + y2
        if den > 0:
            step = float(grid[1] - grid[0])
            trial = float(grid[k] + 0.5 * step * (y0 - y2) / den)
            c_trial = cost(trial)
            if c_trial <= y1:
                best, c_best = trial, c_trial
    limit = c_best * ratio
    inside = vals <= limit  # untried points (nan) are outside
    # the interval: the grid points around the best within the limit, half a step beyond
    half = 0.5 * float(grid[1] - grid[0])
    lo_k = hi_k = k
    while lo_k > 0 and inside[lo_k - 1]:
        lo_k -= 1
    while hi_k < grid.size - 1 and inside[hi_k + 1]:
        hi_k += 1
    low = max(float(grid[lo_k]) - half, -max_delay)
    high = min(float(grid[hi_k]) + half, max_delay)
    # other local minima within the limit, outside that interval
    others = [
        float(grid[i])
        for i in range(grid.size)
        if inside[i]
        and (i < lo_k or i > hi_k)
        and (i == 0 or vals[i] <= vals[i - 1])
        and (i == grid.size - 1 or vals[i] <= vals[i + 1])
    ]
    return DelayProfile(
        grid=grid,
        cost=vals,
        best=best,
        low=low,
        high=high,
        candidates=(best, *others),
    )


#: Stride of :func:`refine_grid`'s first, coarsest pass (in grid steps).
COARSE_STRIDE = 4


def refine_grid(
    grid: NDArray[np.float64],
    cost: NDArray[np.float64],
    run: Callable[[list[int]], None],
    ratio: float,
) -> None:
    """Fill ``cost`` (nan where untried) at the points of ``grid`` a profile test at ``ratio``
    (the limit over the best cost) needs, coarse to fine.

    First every :data:`COARSE_STRIDE`-th point and the last; then, until no gap between
    neighbouring tried points ``a < b`` is split, the point halfway between them is tried
    when ``a`` or ``b`` lies within the limit (``ratio`` times the best tried cost: the
    interval's walk and the local-minimum test read both neighbours of a point within it), or
    when the cost there may: its straight line between ``a`` and ``b`` less
    ``D (x - x_a)(x_b - x)`` is within the limit, ``D`` twice the largest second divided
    difference of the tried points (linear interpolation's error is at most that for
    ``|cost''| <= 2 D``). ``run(index)`` fills ``cost[index]``.

    Notes
    -----
    The cost is assumed to curve, between tried points, no more than twice the most its
    second divided differences at the tried points show. A dip narrower than the coarse
    stride and deeper than that would be missed (a well-determined delay's minimum is not such
    a dip: the coarse best's neighbours are always tried).

    Examples
    --------
    >>> grid = delay_grid(0.25)
    >>> cost = np.full(grid.size, np.nan)
    >>> def run(index):
    ...     cost[index] = 1.0 + (grid[index] - 0.05) ** 2
    >>> refine_grid(grid, cost, run, 1.001)
    >>> int(np.nanargmin(cost)) == int(np.argmin((grid - 0.05) ** 2)), int(np.isnan(cost).sum())
    (True, 14)
    """
    n = grid.size
    run(sorted({*range(0, n, COARSE_STRIDE), n - 1}))
    while True:
        tried = np.flatnonzero(~np.isnan(cost))
        x, y = grid[tried], cost[tried]
        limit = float(np.min(y)) * ratio
        if tried.size >= 3:
            slope = np.diff(y) / np.diff(x)
            divided = np.abs(np.diff(slope) / (x[2:] - x[:-2]))  # |cost''| / 2
            bend = 2.0 * float(np.max(divided))
        else:
            bend = np.inf
        todo = []
        for a, b in itertools.pairwise(tried.tolist()):
            if b - a < 2:
                continue
            c = (a + b) // 2
            xa, xb, xc = grid[a], grid[b], grid[c]
            line = cost[a] + (cost[b] - cost[a]) * (xc - xa) / (xb - xa)
            bound = line - bend * (xc - xa) * (xb - xc)
            if min(cost[a], cost[b]) <= limit or bound <= limit:
                todo.append(c)
        if not todo:
            return
        run(todo)


def huber_cost(residual: NDArray[np.float64], scale: float) -> float:
    """Sum of Huber's loss of ``residual`` at ``scale`` (k = 1.345), in squared units.

    Examples
    --------
    >>> huber_cost(np.array([0.0, 1.0, 10.0]), 1.0) == 0.5 + 1.345 * 10 - 0.5 * 1.345**2
    True
    """
    if scale <= 0:
        return float(0.5 * np.sum(residual**2))
    k = HUBER_K * scale
    a = np.abs(residual)
    return float(np.sum(np.where(a <= k, 0.5 * a * a, k * a - 0.5 * k * k)))


def interval_around(
    interval: tuple[float, float], best: float, step: float, max_delay: float
) -> tuple[float, float]:
    """``interval`` [s] widened to hold ``best`` +- half the grid's ``step`` (within the
    search's bound ``max_delay``).

    :func:`delay_profile`'s interval is the grid points within the test's limit, half a step
    beyond: around the best *grid* point, while the delay kept is the parabola's minimum
    between grid points, up to half a step from it. A sharp profile then left the kept delay
    at the interval's edge, the other side of it untried (random robot 327: 73 ms kept,
    interval 72.9-93.8 ms, the truth 73 ms).

    Examples
    --------
    >>> lo, hi = interval_around((0.0729, 0.0938), 0.073, 0.0208, 0.25)
    >>> round(lo, 4), round(hi, 4)
    (0.0626, 0.0938)
    """
    half = 0.5 * step
    return (
        max(min(interval[0], best - half), -max_delay),
        min(max(interval[1], best + half), max_delay),
    )


def confirms(
    cost: Callable[[float], float],
    delay: float,
    profile: DelayProfile,
    best: float,
    interval: tuple[float, float],
    dof: float,
) -> bool:
    """Whether another profile's ``delay`` [s] agrees with ``profile`` of ``cost``: it lies in
    the ``interval`` around ``best`` (:func:`judge_delay`'s), or its own cost is within the
    ratio the profile's test accepts (:func:`profile_ratio`) of the least cost seen.

    The second test catches what the grid's coarse-to-fine search misses: a minimum narrower
    than a grid step that the other profile found (random robot 368, joint b: the check on the
    table's rows read 167 ms from a secondary minimum beside the truth's 134 ms, where the
    every-row profile read 131 ms and the check's own cost at 131 ms was lower than at 167).

    Examples
    --------
    A narrow deep minimum at 131 ms between the 125 ms and 146 ms grid points, a broad and
    shallower one at 167 ms:

    >>> def cost(d: float) -> float:
    ...     broad = 1.0 + 40.0 * (d - 0.167) ** 2
    ...     return broad - 0.3 * np.exp(-(((d - 0.131) / 0.003) ** 2))
    >>> p = delay_profile(cost, 0.25, dof=400.0, search="refine")
    >>> best, interval, _ = judge_delay(p, None, 0.25)
    >>> round(best, 3), interval[0] <= 0.131 <= interval[1]
    (0.167, False)
    >>> [confirms(cost, d, p, best, interval, 400.0) for d in (0.131, 0.05)]
    [True, False]
    """
    if interval[0] <= delay <= interval[1]:
        return True
    least = min(cost(best), float(np.nanmin(profile.cost)))
    return bool(cost(delay) <= least * profile_ratio(dof))


def judge_delay(
    profile: DelayProfile, reference: float | None, max_delay: float
) -> tuple[float, tuple[float, float], list[str]]:
    """The delay to keep, its interval and warnings: an ambiguous profile takes the candidate
    nearest the pass method's delay ``reference`` (when given) and says so; a minimum at the
    search's bound is reported; a pass method's delay outside the interval is reported."""
    notes: list[str] = []
    d = profile.best
    interval = (profile.low, profile.high)
    step = float(profile.grid[1] - profile.grid[0])
    if len(profile.candidates) > 1:
        listed = ", ".join(f"{1000 * c:.0f}" for c in profile.candidates)
        if reference is not None:
            d = min(profile.candidates, key=lambda c: abs(c - reference))
        notes.append(
            f"the torque channel's delay is not identifiable from these logs (the fit is "
            f"about as good at {listed} ms); {1000 * d:.0f} ms kept"
            + (" (nearest the pass method's)" if reference is not None else "")
            + "; record sweeps with clear accelerations (ramps) so that the delay shows"
        )
        lo = min(profile.candidates) - 0.5 * step
        hi = max(profile.candidates) + 0.5 * step
        interval = (max(min(lo, profile.low), -max_delay), min(max(hi, profile.high), max_delay))
    elif abs(d) > max_delay - step:
        notes.append(
            f"the torque channel's delay found ({1000 * d:.0f} ms) lies at the bound of the "
            f"search ({1000 * max_delay:.0f} ms): the logs may be misaligned by more"
        )
    elif reference is not None and not interval[0] - step <= reference <= interval[1] + step:
        notes.append(
            f"the pass method's delay ({1000 * reference:.0f} ms) lies outside the whole-log "
            f"fit's 95 % interval ({1000 * interval[0]:.0f} to {1000 * interval[1]:.0f} ms); "
            f"the whole-log delay ({1000 * d:.0f} ms) is kept"
        )
    return d, interval, notes
