"""The friction zone: extrapolating each position's torque below what the rig can read.

Below the static friction of the rig (and the amplifier's dead zone) the force sensor reads
nothing: a characterisation row there is zero plus noise, and the first row that reads torque
may lie several pulse widths past the point where the sensed torque leaves zero. The lowest
commands ask for torques in exactly that gap (command 1 is ``1 / 127`` of the
position-independent torque), so interpolating linearly between the last zero row and the first
readable one under-actuates them.

Instead, each position's curve is extended down with one physical onset law, the same for
every motor and fitted to the readings above the gap:

``sensed(p, u) = sum_k G_k(p) psi(r_k(p) u) - F(p)``,  ``psi(a) = max(a - d, 0) ** n``

* ``r_k(p)`` is the ramp (phase ``k``'s share of the base pulse width ``u`` at position ``p``);
* ``psi`` is the phase torque's onset against actuation: the amplifier's dead zone ``d`` and the
  rise of torque with current, about ``current ** 2`` for variable reluctance and ``current``
  for brushless DC motors, times the amplifier's curve near its onset; ``d`` and ``n`` are
  properties of the amplifier and the motor type, shared by every phase and position, and
  chosen from the data (a grid search over ``d`` and ``n`` minimising the residual of all
  positions' fits, each position's ``G`` and ``F`` solved by least squares for each pair);
* ``G_k(p) >= 0`` is phase ``k``'s torque gain at ``p``; ``F(p)`` the friction less any torque
  at rest (cogging) at ``p``.

The fit uses, at each position, the part of the curve between the smallest torque the rig reads
reliably (a few times the noise of a row) and a fraction of the position-independent torque
(below the saturation of the iron and the amplifier, where the law holds). Below that window
the curve is replaced by the law (never above the readings it replaces by more than the noise);
above it the readings stand.

This module never imports the simulator.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

#: Exponents tried for ``psi`` (1: torque ~ current, 2: ~ current squared; between and beyond:
#: the amplifier's curve and the iron's saturation near the onset).
EXPONENTS = np.linspace(0.8, 3.2, 13)
#: Dead zones tried, as fractions of the full-scale pulse width.
DEAD_ZONES = np.linspace(0.0, 0.3, 31)
#: The amplifier's curve tried by the ``"amplifier"`` form: ``c`` of ``expm1(c x) / expm1(c)``
#: (``c > 0`` convex, ``c < 0`` concave, 0 linear; ``|c| = 3`` is a slope ratio of 20 between
#: the two ends of the pulse-width range).
CURVES = np.linspace(-3.0, 3.0, 13)
#: Torque exponents of the ``"amplifier"`` form: torque ~ current (brushless DC) and ~ current
#: squared (variable reluctance).
CURRENT_EXPONENTS = np.array([1.0, 2.0])
#: The onset law's forms: ``"power"`` ``max(a - d, 0)^n`` with ``n`` free, ``"amplifier"``
#: ``i(a)^n`` with the amplifier's current ``i`` a curve ``c`` past the dead zone and ``n``
#: 1 or 2.
OnsetForm = Literal["power", "amplifier", "choose"]
#: How :func:`fit_onset` uses the censored readings (below each position's first reliable one):
#: ``"none"`` not at all, ``"score"`` added to every law's score, ``"ties"`` to choose among the
#: laws that fit the window nearly as well as the best (within :data:`TIE_TOLERANCE`).
CensoredUse = Literal["none", "score", "ties"]
#: Laws whose window residual is within this factor of the least are ties for ``"ties"``.
TIE_TOLERANCE = 1.05
#: Fewest readings in a position's window for it to be fitted.
MIN_POINTS = 3
#: ``"choose"``: the amplifier's curve taken only where its held-out prediction is better by
#: more than this many standard errors of the mean difference (a one-sided 2-sigma test).
CHOICE_SE = 2.0
#: ``"choose"``'s choices; the first is the default law.
CHOICES: tuple[Literal["power", "amplifier"], ...] = ("power", "amplifier")
#: Cells the search over dead zones and exponents runs on (spread over the positions).
SEARCH_CELLS = 4000


@dataclass(frozen=True, slots=True, eq=False)
class OnsetFit:
    """The onset law fitted to a forward model.

    Attributes
    ----------
    dead_zone
        ``d`` [pulse-width units].
    exponent
        ``n``.
    gain
        ``G_k(p)``, shape (P, m) [N m per unit of ``psi``]; NaN where the position was not fitted.
    friction
        ``F(p)`` [N m], shape (P,); NaN where not fitted.
    fitted
        Positions whose curve was extended, shape (P,).
    curve
        ``c``, the amplifier's curve of the ``"amplifier"`` form (0: the ``"power"`` form,
        current linear in the pulse width past the dead zone).
    """

    dead_zone: float
    exponent: float
    gain: NDArray[np.float64]
    friction: NDArray[np.float64]
    fitted: NDArray[np.bool_]
    curve: float = 0.0


def amplifier_shape(x: NDArray[np.float64], curve: float) -> NDArray[np.float64]:
    """The amplifier's current against its drive, both normalised to 0 .. 1.

    Parameters
    ----------
    x
        Drive past the dead zone, as a fraction of the range above it (any shape).
    curve
        ``c``: ``expm1(c x) / expm1(c)``; convex for ``c > 0``, concave for ``c < 0``, ``x``
        for ``c = 0``.

    Returns
    -------
    ndarray
        The current as a fraction of full scale, the shape of ``x``.

    Examples
    --------
    >>> amplifier_shape(np.array([0.0, 0.5, 1.0]), 0.0).tolist()
    [0.0, 0.5, 1.0]
    >>> bool(amplifier_shape(np.array([0.5]), 2.0)[0] < 0.5)  # convex: slow start
    True
    """
    if abs(curve) < 1e-9:
        return np.asarray(x, dtype=np.float64)
    out: NDArray[np.float64] = np.expm1(curve * np.asarray(x, dtype=np.float64)) / np.expm1(curve)
    return out


def onset_psi(
    actuation: NDArray[np.float64],
    dead_zone: float,
    exponent: float,
    top: float,
    curve: float = 0.0,
) -> NDArray[np.float64]:
    """``psi(a) = amplifier_shape(max(a - d, 0) / (top - d), c) ** n``, 0 .. 1 over 0 .. top.

    Examples
    --------
    >>> onset_psi(np.array([0.0, 10.0, 110.0]), 10.0, 2.0, 110.0).tolist()
    [0.0, 0.0, 1.0]
    """
    x = np.clip(np.maximum(actuation - dead_zone, 0.0) / max(top - dead_zone, 1.0), 0.0, None)
    out: NDArray[np.float64] = amplifier_shape(x, curve) ** exponent
    return out


def _solve_cells(
    cp: NDArray[np.int64], design: NDArray[np.float64], y: NDArray[np.float64], n: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Least squares per position over flat cells: ``cp`` (cells,), ``design`` (cells, q),
    ``y`` (cells,). Returns the coefficients (n, q) and each position's residual sum (n,)."""
    q = design.shape[1]
    lhs = np.empty((n, q, q))
    rhs = np.empty((n, q))
    for i in range(q):
        rhs[:, i] = np.bincount(cp, weights=design[:, i] * y, minlength=n)
        for j in range(i, q):
            v = np.bincount(cp, weights=design[:, i] * design[:, j], minlength=n)
            lhs[:, i, j] = lhs[:, j, i] = v
    lhs += 1e-12 * np.eye(q)[None]
    coef = np.asarray(np.linalg.solve(lhs, rhs[..., None])[..., 0], dtype=np.float64)
    res = np.sum(design * coef[cp], axis=1) - y
    sse = np.bincount(cp, weights=res * res, minlength=n).astype(np.float64)
    return coef, sse


def _cell_design(
    u: NDArray[np.float64],
    r: NDArray[np.float64],
    d: float,
    n: float,
    top: float,
    c: float = 0.0,
) -> NDArray[np.float64]:
    """(cells, m + 1): psi(r_k u) per phase (0 where the phase is off), then -1."""
    phi = onset_psi(r * u[:, None], d, n, top, c) * (r > 0)
    return np.concatenate([phi, -np.ones((u.size, 1))], axis=1)


def fit_onset(
    forward: NDArray[np.float64],
    levels: NDArray[np.float64],
    ramp: NDArray[np.float64],
    *,
    readable: float,
    upper: float,
    actuation_max: int,
    form: OnsetForm = "power",
    censored: CensoredUse = "none",
    search: NDArray[np.bool_] | None = None,
    exponents: NDArray[np.float64] | None = None,
    measured: NDArray[np.bool_] | None = None,
) -> OnsetFit:
    """Fit the onset law to each position's curve between ``readable`` and ``upper`` [N m].

    Parameters
    ----------
    forward
        Sensed torque, shape (P, J), monotone in the level; NaN where unknown.
    levels
        Base pulse width of each column, shape (J,).
    ramp
        The ramping function, shape (P, m).
    readable
        Smallest torque the rig reads reliably [N m].
    upper
        Top of the fitting window [N m].
    actuation_max
        Full-scale pulse width.
    form
        ``"power"``: ``psi(a) = max(a - d, 0)^n``, ``d`` and ``n`` searched (``n`` on
        :data:`EXPONENTS`). ``"amplifier"``: ``psi(a) = i(a)^n`` with the amplifier's current
        ``i`` the curve ``c`` (:func:`amplifier_shape`, ``c`` on :data:`CURVES`) past the dead
        zone ``d``, and ``n`` 1 (torque ~ current) or 2 (~ current squared): the onset's
        curvature then need not come from the dead zone. ``d``, ``c`` and ``n`` searched
        jointly over every position (one amplifier, shared by every phase and position).
        ``"choose"``: the ``"power"`` law unless the ``"amplifier"`` form predicts readings
        it was not fitted to better: at each position with more than :data:`MIN_POINTS`
        readings in the window, its lowest one (the reading nearest the friction zone, where
        the law is used) is held out, both forms are searched and solved on the rest and
        predict it, and the amplifier's law (searched on the whole window) is taken when the
        mean difference of the squared errors (amplifier less power) is below
        ``-CHOICE_SE`` standard errors (docs/linearize.md, "stop 43 (L61)").
    censored
        Also score each law on the censored readings: at every position, the readings below
        its first reliable one (``< readable``) are censored: they bound the sensed torque
        from above (the rig reads about zero below its static friction) but not from below
        (the law's negative values read zero). A law whose curve, with that position's gains
        and friction, rises above such a reading ``y`` pays the excess squared, in the same
        units as the window's residual (a one-sided, Tobit-like term at the row's noise),
        ``excess = sum_censored max(law - max(y, 0), 0)^2``; the gains and friction are still
        solved on the window alone. ``"score"``: each law scored by
        ``sum_window (law - y)^2 + excess``; ``"ties"``: among the laws whose window residual
        is within :data:`TIE_TOLERANCE` of the least, the least ``excess`` (instead of the
        smallest dead zone). ``"none"`` by default (docs/linearize.md, "stop 35 (L38)").
    search
        Positions whose cells the search over the laws reads, shape (P,) (None: every
        position): the measured positions, where ``forward`` between them is an interpolation
        of their curves, not readings at those positions' shares. Each position's gains and
        friction are then solved under the chosen law wherever it has cells. Not passed by
        :func:`~torquemap.linearize.tables.build_tables` (docs/linearize.md, "stop 38 (L42)").
    exponents
        The ``"power"`` form's exponents searched (None: :data:`EXPONENTS`). From 1 (no
        infinite slope at the dead zone) it reads a concave amplifier's dead zone where the
        default grid puts it near 0 (tests/test_onset_exponent.py); not the default (stop 38).
    measured
        ``"choose"`` only: the positions whose rows were measured, shape (P,) (None: every
        position). The choice's held-out test fits and predicts on these alone: between them
        ``forward`` interpolates their curves, so a held-out reading would also sit in its
        neighbours' cells.

    Returns
    -------
    OnsetFit
        ``d``, ``n``, ``c`` and per-position gains and friction.
    """
    if form not in ("power", "amplifier", "choose"):
        raise ValueError(f"form must be 'power', 'amplifier' or 'choose', got {form!r}")
    if censored not in ("none", "score", "ties"):
        raise ValueError(f"censored must be 'none', 'score' or 'ties', got {censored!r}")
    n_pos, m = ramp.shape
    inside = np.isfinite(forward) & (forward >= readable) & (forward <= upper)
    enough = inside.sum(axis=1) >= MIN_POINTS
    inside &= enough[:, None]
    top = float(actuation_max)
    searched = enough if search is None else enough & np.asarray(search, dtype=bool)
    if not searched.any():
        searched = enough
    if form == "choose":
        # the power law unless the amplifier's form predicts each measured position's lowest
        # reading in the window, held out, significantly better
        mine = enough if measured is None else enough & np.asarray(measured, dtype=bool)
        chosen = _choose(forward, levels, ramp, inside, mine, readable, top, censored)
        d, n, c = _search(
            forward, levels, ramp, inside, searched, readable, top, chosen, censored, exponents
        )
    else:
        d, n, c = _search(
            forward, levels, ramp, inside, searched, readable, top, form, censored, exponents
        )
    cp, cj = np.nonzero(inside)
    y = forward[cp, cj]
    u = levels[cj]
    r = ramp[cp]
    coef, _ = _solve_cells(cp, _cell_design(u, r, d, n, top, c), y, n_pos)
    active = ramp > 0
    gain = coef[:, :m] * active
    ok = enough & np.all(gain >= 0.0, axis=1) & np.any(gain > 0.0, axis=1)
    gain = np.where(ok[:, None], gain, np.nan)
    friction = np.where(ok, coef[:, m], np.nan)
    return OnsetFit(dead_zone=d, exponent=n, gain=gain, friction=friction, fitted=ok, curve=c)


def _search(
    forward: NDArray[np.float64],
    levels: NDArray[np.float64],
    ramp: NDArray[np.float64],
    inside: NDArray[np.bool_],
    searched: NDArray[np.bool_],
    readable: float,
    top: float,
    form: str,
    censored: CensoredUse,
    exponents: NDArray[np.float64] | None = None,
) -> tuple[float, float, float]:
    """The law ``(d, n, c)`` of one form searched on the window's cells ``inside`` (P, J) at
    the positions ``searched`` (P,), as :func:`fit_onset` describes."""
    n_pos = ramp.shape[0]
    cp, cj = np.nonzero(inside)
    y = forward[cp, cj]
    u = levels[cj]
    r = ramp[cp]
    if form == "amplifier":
        exponents, curves = CURRENT_EXPONENTS, CURVES
    else:
        exponents, curves = EXPONENTS if exponents is None else exponents, np.zeros(1)
    # censored cells: below each fitted position's first reading of at least ``readable``
    reliable = np.isfinite(forward) & (forward >= readable)
    first = np.where(reliable.any(axis=1), np.argmax(reliable, axis=1), forward.shape[1])
    below = (np.arange(forward.shape[1])[None, :] < first[:, None]) & np.isfinite(forward)
    qp, qj = np.nonzero(below & searched[:, None]) if censored != "none" else (cp[:0], cj[:0])
    qu, qr, qy = levels[qj], ramp[qp], np.maximum(forward[qp, qj], 0.0)
    tried: list[tuple[float, float, float, float]] = []
    excess: list[float] = []
    among = np.flatnonzero(searched[cp])
    if among.size:
        # the search on at most SEARCH_CELLS cells spread evenly over the positions searched
        pick = among[
            np.unique(np.linspace(0, among.size - 1, min(among.size, SEARCH_CELLS)).astype(int))
        ]
        sp, su, sr, sy = cp[pick], u[pick], r[pick], y[pick]
        # every combination: the residual has several minima
        for dz in DEAD_ZONES:
            for ex in exponents:
                for cv in curves:
                    design = _cell_design(su, sr, float(dz * top), float(ex), top, float(cv))
                    coef, sse = _solve_cells(sp, design, sy, n_pos)
                    v = float(np.sum(sse))
                    e = 0.0
                    if qp.size:
                        law = np.sum(
                            _cell_design(qu, qr, float(dz * top), float(ex), top, float(cv))
                            * coef[qp],
                            axis=1,
                        )
                        e = float(np.sum(np.maximum(law - qy, 0.0) ** 2))
                    excess.append(e)
                    score = v + e if censored == "score" else v
                    tried.append((score, float(dz * top), float(ex), float(cv)))
    d, n, c = 0.0, 1.0, 0.0
    if tried:
        # among the laws that fit as well as the best (a linear law's dead zone trades with
        # the friction exactly), the smallest dead zone: the law then reaches zero torque
        least = min(t[0] for t in tried)
        scale = float(np.sum(y * y))
        good = [t for t in tried if t[0] <= least * (1 + 1e-3) + 1e-12 * scale]
        _, d, n, c = min(good, key=lambda t: (t[1], abs(t[0] - least)))
        if censored == "ties":
            near = [k for k, t in enumerate(tried) if t[0] <= least * TIE_TOLERANCE]
            k = min(near, key=lambda k: (excess[k], tried[k][0]))
            _, d, n, c = tried[k]
    return d, n, c


def _choose(
    forward: NDArray[np.float64],
    levels: NDArray[np.float64],
    ramp: NDArray[np.float64],
    inside: NDArray[np.bool_],
    mine: NDArray[np.bool_],
    readable: float,
    top: float,
    censored: CensoredUse,
) -> str:
    """The ``"choose"`` form's choice among :data:`CHOICES` by a held-out test.

    At each position of ``mine`` with more than :data:`MIN_POINTS` readings in the window
    ``inside`` (P, J), the lowest reading is held out. Each form is searched and solved on the
    rest of the window at the positions ``mine`` alone, and predicts the held-out readings.
    A form other than the first is taken when the mean difference of its squared errors from
    the first's is below ``-CHOICE_SE`` of its standard errors; among those, the least mean
    squared error."""
    n_pos = ramp.shape[0]
    train = inside & mine[:, None]
    lowest = np.argmax(train, axis=1)
    heldp = np.flatnonzero(mine & (train.sum(axis=1) > MIN_POINTS))
    if heldp.size < 2:
        return CHOICES[0]
    hj = lowest[heldp]
    train[heldp, hj] = False
    train &= (train.sum(axis=1) >= MIN_POINTS)[:, None]
    cp, cj = np.nonzero(train)
    err = []
    for form in CHOICES:
        d, n, c = _search(
            forward,
            levels,
            ramp,
            train,
            np.asarray(train.any(axis=1)),
            readable,
            top,
            form,
            censored,
        )
        coef, _ = _solve_cells(
            cp, _cell_design(levels[cj], ramp[cp], d, n, top, c), forward[cp, cj], n_pos
        )
        design = _cell_design(levels[hj], ramp[heldp], d, n, top, c)
        err.append(np.sum(design * coef[heldp], axis=1) - forward[heldp, hj])
    return CHOICES[paired_choice(err)[0]]


def paired_choice(errors: Sequence[NDArray[np.float64]]) -> tuple[int, tuple[float, ...]]:
    """The candidate taken by a held-out test on the prediction ``errors`` of each candidate at
    the same held-out readings [N m], the default first: another is taken when the mean
    difference of its squared errors from the default's is below ``-CHOICE_SE`` of its standard
    errors (one-sided); among those, the least mean squared error.

    Returns
    -------
    int, tuple of float
        The index taken (0: the default) and each candidate's mean difference over its standard
        error (0 for the default, or where the difference does not vary).

    Examples
    --------
    >>> paired_choice([np.array([1.0, 1.0, 1.0]), np.array([0.5, 0.4, 0.6])])[0]
    1
    >>> paired_choice([np.array([1.0, 0.1, 1.0]), np.array([0.9, 0.2, 0.9])])[0]
    0
    """
    first = errors[0] ** 2
    index, least = 0, float(np.mean(first))
    ts = [0.0]
    for i, e in enumerate(errors[1:], start=1):
        diff = e**2 - first
        se = float(np.std(diff, ddof=1)) / np.sqrt(diff.size)
        ts.append(float(np.mean(diff)) / se if se > 0 else 0.0)
        if np.mean(diff) < -CHOICE_SE * se and float(np.mean(e**2)) < least:
            index, least = i, float(np.mean(e**2))
    return index, tuple(ts)


def onset_curve(
    fit: OnsetFit, ramp: NDArray[np.float64], u: NDArray[np.float64], top: int
) -> NDArray[np.float64]:
    """The law's sensed torque at base pulse widths ``u`` (shape (U,)), shape (P, U); NaN
    where the position was not fitted."""
    a = ramp[:, None, :] * u[None, :, None]
    phi = onset_psi(a, fit.dead_zone, fit.exponent, float(top), fit.curve)
    g = np.where(np.isfinite(fit.gain), fit.gain, 0.0)
    out = (
        np.einsum("pum,pm->pu", phi, g)
        - np.where(np.isfinite(fit.friction), fit.friction, 0)[:, None]
    )
    out = np.maximum(out, 0.0)
    return np.where(fit.fitted[:, None], out, np.nan)


def extend_below(
    fine: NDArray[np.float64],
    fit: OnsetFit,
    ramp: NDArray[np.float64],
    *,
    readable: float,
    actuation_max: int,
    levels: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], int]:
    """Replace each fitted position's curve below its first reliable reading by the law.

    The first reliable reading is the first *measured* pulse width whose torque is at least
    ``readable``. Between it and the last measured pulse width below it, ``fine`` holds the
    linear interpolation between a reading of about zero and one well above zero: where the
    sensed torque leaves zero in that interval (the knee), the interpolation puts torque where
    there is none (the sensed torque is convex there, so the chord lies above it). Below the
    first reliable reading the curve becomes the law, fitted to the readings above: up to
    ``readable`` where the interpolation reads less (those readings are lost in the noise),
    and never above the chord where the interpolation reads more.

    Parameters
    ----------
    fine
        Sensed torque on every base pulse width ``0 .. actuation_max``, shape (P, A + 1).
    fit
        From :func:`fit_onset`.
    ramp
        Shape (P, m).
    readable
        Smallest torque read reliably [N m].
    actuation_max
        ``A``.
    levels
        The measured base pulse widths (integers, ascending), shape (J,); ``fine`` is the
        linear interpolation between them. Default: every pulse width.

    Returns
    -------
    ndarray, int
        The extended curves (monotone in the pulse width) and the cells replaced.

    Examples
    --------
    One position, a sharp knee at pulse width 13 (torque ``0.1 (u - 13)`` above it, the
    law's exponent 1 and its dead zone 13 in this example), measured every 4th pulse width:
    the interpolation between the readings at 12 (zero) and 16 (0.3 N m) reads 0.075 N m at
    13; the law restores zero there.

    >>> u = np.arange(33.0)
    >>> law = OnsetFit(dead_zone=13.0, exponent=1.0, gain=np.array([[2.0]]),
    ...                friction=np.array([0.0]), fitted=np.array([True]))
    >>> measured = np.arange(0.0, 33.0, 4.0)
    >>> fine = np.interp(u, measured, np.maximum(0.1 * (measured - 13.0), 0.0))[None, :]
    >>> out, n = extend_below(fine, law, np.ones((1, 1)), readable=0.25, actuation_max=32,
    ...                       levels=measured)
    >>> round(float(fine[0, 13]), 3), round(float(out[0, 13]), 3), n
    (0.075, 0.0, 16)
    """
    u = np.arange(actuation_max + 1, dtype=np.float64)
    law = onset_curve(fit, ramp, u, actuation_max)
    at = u if levels is None else np.asarray(levels, dtype=np.float64)
    reading = fine[:, np.clip(np.rint(at).astype(np.int64), 0, actuation_max)]
    reliable = np.isfinite(reading) & (reading >= readable)
    has = reliable.any(axis=1)
    j = np.argmax(reliable, axis=1)
    # below the first reliable reading only: beyond it the readings stand
    first = np.where(has, at[j], -1.0)
    take = (
        (u[None, :] < first[:, None]) & np.isfinite(fine) & fit.fitted[:, None] & np.isfinite(law)
    )
    # where the interpolation reads less than the rig can, the law (up to that level); above
    # it, between a reading below that level and the first reliable one, the chord, or the
    # law where it is lower
    out = np.where(take, np.minimum(law, np.maximum(fine, readable)), fine)
    out = np.fmax.accumulate(np.where(np.isnan(out), -np.inf, out), axis=1)
    out = np.where(np.isfinite(out), out, np.nan)
    return out, int(take.sum())
