"""The friction table between two steady passes far apart in speed.

A whole-log fit (:mod:`torquemap.identify_whole`) sets its table's knots at the sweep's steady
pass speeds from the passes' rows. Between two passes more than ``KNOT_RATIO`` apart the sweep
crosses the speeds only on its ramps (often faster than the differentiator window), so the knots
there are set by the table's smoothness prior and by the passes' speed ripple, which extends each
pass's slope linearly in log speed: a Stribeck drop between the passes is missed (docs/
identification.md, "Why the table misses on the steady samples").

This module redraws the friction magnitude ``g(s) = level(s) + viscous * s`` of each direction
at the knots strictly between two anchor knots (the knots at the passes) by an interpolation
through the anchors alone. Above its Stribeck region friction is Coulomb plus viscous, linear in
speed, which no interpolation in log speed follows (``s`` is exponential in ``log s``). So the
viscous slope ``c`` of the two fastest anchors (their secant in speed, >= 0) is taken out, the
rest ``g(s) - c s`` (a Stribeck drop, flat above it) interpolated in log speed, and ``c s`` put
back:

* ``"pchip"``: monotone piecewise cubic Hermite (Fritsch-Carlson slopes from the neighbouring
  anchors): shape-preserving, so a drop between anchors stays a drop with no overshoot.
* ``"linear"``: the chord in log speed.

The anchors themselves and every knot outside the gaps keep their fitted values. The fit's own
viscous coefficient is not used for ``c``: where the table's levels are free it trades off with
them (random robot 3 joint b: 0.60 identified against 0.08 mN m s/rad true).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import PchipInterpolator

from torquemap.friction_law import SpeedTableFriction

__all__ = ["anchor_knots", "redraw_between_anchors", "redraw_law", "redraw_law_by_direction"]

Method = Literal["pchip", "linear"]


def anchor_knots(
    speeds: Sequence[float], anchors: Sequence[float], gap: float = 1.25
) -> NDArray[np.intp]:
    """Indices of the knots at ``anchors`` [rad/s]: each anchor's nearest knot in log speed,
    when within a factor ``gap`` of it (steady speeds closer than that share a knot).

    Examples
    --------
    >>> anchor_knots([0.1, 0.5, 0.9, 1.6, 3.0], [0.5, 2.9, 7.0]).tolist()
    [1, 4]
    """
    logs = np.log(np.asarray(speeds, dtype=np.float64))
    out = set()
    for a in anchors:
        if not (math.isfinite(a) and a > 0):
            continue
        d = np.abs(logs - math.log(a))
        i = int(np.argmin(d))
        if d[i] <= math.log(gap):
            out.add(i)
    return np.array(sorted(out), dtype=np.intp)


def redraw_between_anchors(
    speeds: Sequence[float] | NDArray[np.float64],
    values: Sequence[float] | NDArray[np.float64],
    anchors: NDArray[np.intp],
    method: Method = "pchip",
    held: NDArray[np.bool_] | None = None,
    linear: float = 0.0,
) -> NDArray[np.float64]:
    """``values`` at ``speeds`` [rad/s] with the knots strictly between two anchor knots
    (indices ``anchors``, increasing) redrawn by ``method`` through the anchors' values, in
    log speed; the anchors and every knot outside them unchanged. With ``held`` (one bool per
    knot), only the knots it marks are redrawn (the others are measured). ``linear``: a slope
    in speed (``values`` per rad/s) taken out before the interpolation and put back after.

    Examples
    --------
    >>> v = redraw_between_anchors([1.0, 2.0, 4.0, 8.0], [1.0, 9.0, 9.0, 4.0],
    ...                            np.array([0, 3]), method="linear")
    >>> v.round(6).tolist()
    [1.0, 2.0, 3.0, 4.0]
    """
    out = np.asarray(values, dtype=np.float64).copy()
    idx = np.asarray(anchors, dtype=np.intp)
    if idx.size < 2:
        return out
    x = np.log(np.asarray(speeds, dtype=np.float64))
    inside = np.zeros(out.size, dtype=bool)
    for i, j in itertools.pairwise(idx):
        inside[i + 1 : j] = True
    if held is not None:
        inside &= np.asarray(held, dtype=bool)
    if not inside.any():
        return out
    line = linear * np.asarray(speeds, dtype=np.float64)
    rest = out - line
    if method == "linear" or idx.size == 2:
        out[inside] = np.interp(x[inside], x[idx], rest[idx]) + line[inside]
    else:
        out[inside] = PchipInterpolator(x[idx], rest[idx])(x[inside]) + line[inside]
    return out


def redraw_law(
    law: SpeedTableFriction,
    anchors: Sequence[float],
    method: Method = "pchip",
    held: tuple[NDArray[np.bool_], NDArray[np.bool_]] | None = None,
) -> SpeedTableFriction:
    """``law`` with each direction's friction magnitude between anchor knots (the knots at
    the steady speeds ``anchors`` [rad/s], :func:`anchor_knots`) redrawn
    (:func:`redraw_between_anchors`, with the secant in speed of the two fastest anchors,
    >= 0, taken out); the viscous coefficients kept. ``held``: per direction (positive,
    negative), the knots that may be redrawn (None: all)."""
    idx = anchor_knots(law.speeds, anchors)
    s = np.asarray(law.speeds, dtype=np.float64)
    new = []
    parts = ((law.positive, law.viscous), (law.negative, law.viscous_negative))
    for d, (levels, viscous) in enumerate(parts):
        g = np.asarray(levels, dtype=np.float64) + viscous * s
        mask = None if held is None else held[d]
        c = 0.0
        if idx.size >= 2:
            c = max(0.0, (g[idx[-1]] - g[idx[-2]]) / (s[idx[-1]] - s[idx[-2]]))
        new.append(redraw_between_anchors(s, g, idx, method, mask, c) - viscous * s)
    return law.with_linear_parameters(np.r_[new[0], new[1], law.viscous, law.viscous_negative])


def redraw_law_by_direction(
    law: SpeedTableFriction,
    steady_speeds: Sequence[float],
    method: Method = "pchip",
    held: tuple[NDArray[np.bool_], NDArray[np.bool_]] | None = None,
) -> SpeedTableFriction:
    """:func:`redraw_law` with each direction anchored at its own passes only: the positive
    table at the knots of the positive ``steady_speeds`` [rad/s, signed], the negative table
    at those of the negative ones (their magnitudes); a direction with fewer than two such
    knots at every pass speed (one never swept takes the other's table). :func:`redraw_law`
    anchors both directions at every pass speed, so a speed that only the other direction held steady is kept as the fit's
    free knot and the secant slope taken from it (random robot 332 joint b: passes at 11.7,
    50.4 and 64 rad/s forward but only 11.7 and 64 backward; the backward table, bowed by 3
    mN m between them, was held at 50.4 as if measured: 8.9x the oracle on the steady
    samples).

    Examples
    --------
    Friction linear in speed at the anchors (viscous in the levels here), the backward knots
    at 2 and 4 rad/s bowed off it and held by no backward pass; :func:`redraw_law` would keep
    the one at 4 rad/s (a forward pass's speed):

    >>> law = SpeedTableFriction(speeds=(1.0, 2.0, 4.0, 8.0), positive=(1.0, 2.0, 4.0, 8.0),
    ...                          negative=(1.0, 3.0, 6.0, 8.0))
    >>> out = redraw_law_by_direction(law, [1.0, 4.0, 8.0, -1.0, -8.0], method="linear")
    >>> out.positive == law.positive, [round(x, 6) for x in out.negative]
    (True, [1.0, 2.0, 4.0, 8.0])
    >>> [round(x, 6) for x in redraw_law(law, [1.0, 4.0, 8.0], method="linear").negative]
    [1.0, 3.25, 6.0, 8.0]
    """
    signed = [float(x) for x in steady_speeds if math.isfinite(x) and x]
    both = [abs(x) for x in signed]

    def own(anchors: list[float]) -> list[float]:
        # a direction held steady at fewer than two knots (one never swept, whose table is
        # the other's) is drawn as redraw_law draws it
        return anchors if anchor_knots(law.speeds, anchors).size >= 2 else both

    forward = redraw_law(law, own([x for x in signed if x > 0]), method, held)
    backward = redraw_law(law, own([-x for x in signed if x < 0]), method, held)
    return law.with_linear_parameters(
        np.r_[forward.positive, backward.negative, law.viscous, law.viscous_negative]
    )
