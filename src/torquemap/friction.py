"""Friction and inertia identification from no-load motion (Simpson, Cook & Li, Eq 5).

The motion of one joint is cut into runs (one direction, between stops), each run into a
constant-speed pass and accelerating ramps. Friction comes from the passes (torque averaged
over whole motor revolutions, so PDTV averages out), inertia from the ramps. Everything here is
motor side: angle [rad], velocity [rad/s], torque [N m], inertia [kg m^2].
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError
from torquemap.model import FrictionModel, InertiaModel, friction_torque

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, slots=True, eq=False)
class Pass:
    """A constant-speed pass of one joint: samples ``start:stop`` of one log.

    Attributes
    ----------
    start, stop
        Sample slice in the log.
    direction
        ``"positive"`` or ``"negative"`` motion.
    speed
        Mean motor velocity over the pass [rad/s] (signed), angle travelled over time taken.
    mean_torque
        Motor torque averaged over the motor angle, over whole revolutions when the pass
        covers at least one [N m].
    revolutions
        Motor revolutions covered.
    samples_per_rev
        Samples per motor revolution (the position sampling rate of this pass).
    """

    start: int
    stop: int
    direction: Literal["positive", "negative"]
    speed: float
    mean_torque: float
    revolutions: float
    samples_per_rev: float


@dataclass(frozen=True, slots=True, eq=False)
class Segmentation:
    """Motion segments of one joint in one log (:func:`segment_motion`).

    Attributes
    ----------
    passes
        The constant-speed passes.
    accelerating
        Mask of samples in a run but outside its pass (ramps), shape (n,).
    speed_threshold
        Speed [rad/s] above which the joint counted as moving.
    """

    passes: tuple[Pass, ...]
    accelerating: NDArray[np.bool_]
    speed_threshold: float


def angle_mean(motor_angle: ArrayLike, values: ArrayLike) -> tuple[float, float]:
    """Mean of ``values`` over the motor angle, on whole revolutions when there are any.

    Returns ``(mean, revolutions)``: the trapezoidal integral of ``values`` over the angle
    divided by the angle covered, using the longest prefix of whole revolutions (so a PDTV of
    integer order averages to zero exactly), or everything when under one revolution.

    Examples
    --------
    >>> theta = np.linspace(0.0, 3.5 * 2 * np.pi, 3501)
    >>> m, revs = angle_mean(theta, 1.0 + np.cos(theta))
    >>> round(m, 6), round(revs, 3)
    (1.0, 3.5)
    """
    theta = np.asarray(motor_angle, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    travel = np.abs(theta - theta[0])
    revs = float(travel.max() / TWO_PI)
    if revs >= 1.0:
        end = int(np.searchsorted(np.maximum.accumulate(travel), math.floor(revs) * TWO_PI))
        theta, v = theta[: end + 1], v[: end + 1]
    d = np.diff(theta)
    total = float(np.sum(np.abs(d)))
    if total <= 0:
        return float(np.mean(v)), revs
    return float(np.sum(0.5 * (v[1:] + v[:-1]) * np.abs(d)) / total), revs


def segment_motion(
    t: ArrayLike,
    motor_angle: ArrayLike,
    velocity: ArrayLike,
    torque: ArrayLike,
    *,
    allowed: ArrayLike | None = None,
    speed_threshold: float | None = None,
    steady_tolerance: float = 0.2,
    min_revolutions: float = 0.25,
    window: float | None = None,
) -> Segmentation:
    """Cut one joint's motion into constant-speed passes and accelerating ramps.

    1. Moving samples: ``|velocity| > speed_threshold`` (default 2 % of the 99th percentile of
       ``|velocity|``) and ``allowed`` (for example: the other joints still).
    2. Runs: maximal stretches moving in one direction; short interruptions (under 1 s and
       under 0.02 revolution of travel, such as speed ripple dipping through zero) are bridged.
       With ``window`` given, the bursts of a joint that sticks and slips are then chained into
       one run, unless the joint holds still within them for two windows (a hold-and-step
       calibration; :func:`_chain`).
    3. In each run the velocity is averaged over a centred window of one motor revolution
       (shrinking symmetrically at the run's ends), which cancels PDTV ripple of every integer
       order; the pass is the span from the first to the last sample whose averaged speed is
       at least ``1 - steady_tolerance`` times the run's median averaged speed. The rest of
       the run is ramps.

    Parameters
    ----------
    t
        Time [s], shape (n,).
    motor_angle
        Motor angle [rad], shape (n,).
    velocity
        Motor velocity [rad/s], shape (n,) (from :func:`torquemap.filters.differentiate`).
    torque
        Motor torque [N m], shape (n,).
    allowed
        Boolean mask of usable samples, shape (n,); default all.
    speed_threshold
        Moving threshold [rad/s].
    steady_tolerance
        Relative speed drop that ends a pass.
    min_revolutions
        Passes covering fewer motor revolutions are dropped (their samples count as ramps).
    window
        Differentiator window of ``velocity`` [s]; None (default): no stick-slip chaining.

    Returns
    -------
    Segmentation
        Passes, the ramp mask and the threshold used.
    """
    tt = np.asarray(t, dtype=np.float64)
    theta = np.asarray(motor_angle, dtype=np.float64)
    w = np.asarray(velocity, dtype=np.float64)
    tau = np.asarray(torque, dtype=np.float64)
    n = tt.size
    ok = np.ones(n, dtype=bool) if allowed is None else np.asarray(allowed, dtype=bool)
    accelerating = np.zeros(n, dtype=bool)
    if not ok.any():
        return Segmentation(passes=(), accelerating=accelerating, speed_threshold=0.0)
    thr = (
        0.02 * float(np.percentile(np.abs(w[ok]), 99))
        if speed_threshold is None
        else float(speed_threshold)
    )
    if thr <= 0:
        return Segmentation(passes=(), accelerating=accelerating, speed_threshold=0.0)
    label = np.where(ok & (w > thr), 1, np.where(ok & (w < -thr), -1, 0))
    runs = _runs(label)
    runs = _bridge(runs, tt, theta)
    if window is not None:
        runs = _chain(runs, tt, theta, 2.0 * float(window))
    passes: list[Pass] = []
    for a, b, sign in runs:
        if sign == 0 or b - a < 5:
            continue
        travel = abs(theta[b - 1] - theta[a])
        if travel / TWO_PI < min_revolutions:
            continue
        mean_speed = travel / (tt[b - 1] - tt[a])
        smooth = np.abs(_revolution_average(tt[a:b], theta[a:b], w[a:b], mean_speed))
        level = float(np.median(smooth))
        band = np.flatnonzero(smooth >= (1.0 - steady_tolerance) * level)
        if band.size < 5:
            accelerating[a:b] = True
            continue
        p0, p1 = a + int(band[0]), a + int(band[-1]) + 1
        accelerating[a:b] = True
        accelerating[p0:p1] = False
        revs = abs(theta[p1 - 1] - theta[p0]) / TWO_PI
        if revs < min_revolutions:
            accelerating[p0:p1] = True
            continue
        mean_torque, _ = angle_mean(theta[p0:p1], tau[p0:p1])
        speed = (theta[p1 - 1] - theta[p0]) / (tt[p1 - 1] - tt[p0])
        passes.append(
            Pass(
                start=p0,
                stop=p1,
                direction="positive" if sign > 0 else "negative",
                speed=float(speed),
                mean_torque=mean_torque,
                revolutions=float(revs),
                samples_per_rev=float((p1 - p0) / revs),
            )
        )
    return Segmentation(passes=tuple(passes), accelerating=accelerating, speed_threshold=thr)


def _revolution_average(
    t: NDArray[np.float64], theta: NDArray[np.float64], w: NDArray[np.float64], speed: float
) -> NDArray[np.float64]:
    """Velocity averaged over a centred window of one motor revolution at ``speed``.

    The window (at most half the run) shrinks symmetrically at the ends of the run, so ramps
    stay visible; averaging over a revolution cancels PDTV ripple of every integer order.
    """
    big = min(TWO_PI / speed, 0.5 * (t[-1] - t[0]))
    half = np.minimum(np.minimum(0.5 * big, t - t[0]), t[-1] - t)
    lo = np.searchsorted(t, t - half, side="left")
    hi = np.searchsorted(t, t + half, side="right") - 1
    dt = t[hi] - t[lo]
    wide = dt > 0
    out = w.copy()
    out[wide] = (theta[hi[wide]] - theta[lo[wide]]) / dt[wide]
    return out


def _runs(label: NDArray[np.int64]) -> list[tuple[int, int, int]]:
    change = np.flatnonzero(np.diff(label)) + 1
    edges = np.concatenate(([0], change, [label.size]))
    return [(int(a), int(b), int(label[a])) for a, b in itertools.pairwise(edges)]


def _small_span(t: NDArray[np.float64], theta: NDArray[np.float64], a: int, b: int) -> bool:
    """Whether samples ``a:b`` last under 1 s and travel under 0.02 revolution."""
    return bool((t[b - 1] - t[a]) < 1.0 and abs(theta[b - 1] - theta[a]) < 0.02 * TWO_PI)


def _held_share(t: NDArray[np.float64], theta: NDArray[np.float64], span: float) -> float:
    """Share of the samples (those a half ``span`` from both ends) around which the angle
    travels, over ``span`` [s], less than a quarter of its mean speed over all of ``t``."""
    inner = (t - t[0] >= 0.5 * span) & (t[-1] - t >= 0.5 * span)
    if not inner.any():
        return 1.0
    lo = np.searchsorted(t, t[inner] - 0.5 * span, side="left")
    hi = np.searchsorted(t, t[inner] + 0.5 * span, side="right") - 1
    local = np.abs(theta[hi] - theta[lo]) / np.maximum(t[hi] - t[lo], 1e-300)
    mean = abs(theta[-1] - theta[0]) / (t[-1] - t[0])
    return float(np.mean(local < 0.25 * mean))


#: Largest share of a chain of bursts over which the joint may hold still for two
#: differentiator windows (:func:`_chain`).
HELD_SHARE = 0.1


def _chain(
    runs: list[tuple[int, int, int]],
    t: NDArray[np.float64],
    theta: NDArray[np.float64],
    span: float,
) -> list[tuple[int, int, int]]:
    """Merge chains of small runs of one direction separated by short, small interruptions.

    A joint that sticks and slips (a slow pass below its Stribeck speed, a short
    differentiator window) moves in bursts: each burst's run is small (under 1 s and 0.02
    revolution), the velocity between them falls to zero, and :func:`_bridge`, which bridges
    only between significant runs, would see no pass at all (random SCARA 204's slowest sweep
    pass: bursts of 0.05 to 0.10 s, rests of 0.03 to 0.05 s at the 0.05 s window). A chain of
    small runs of one direction, each interruption under 1 s and 0.02 revolution of travel and
    no significant run in between, becomes one run. It runs after :func:`_bridge` and never
    joins a significant run: a fast pass followed by slow bursts the same way stays the pass it
    was.

    A hold-and-step calibration (an anti-cogging log) is the same pattern of runs, but the joint
    holds still between its steps for longer than the differentiator resolves: a chain is kept
    only if the angle travels, over ``span`` (two differentiator windows) about each sample, at
    least a quarter of the chain's mean speed on all but ``HELD_SHARE`` of its samples (none of
    204's stick-slip pass; 37 % to 69 % of the hold logs of the tests, holds of 0.2 to 0.4 s).
    The share of time the velocity clears the threshold does not tell them apart: a stiff hold
    loop creeping through the stiction band clears it in short runs (57 % of the simulated
    stand's 0.4 s holds, 70 % of 204's pass; docs/estimation.md, robot 204's rests).
    """
    out: list[tuple[int, int, int]] = []
    i, n = 0, len(runs)
    while i < n:
        a, b, s = runs[i]
        if s == 0 or not _small_span(t, theta, a, b):
            out.append(runs[i])
            i += 1
            continue
        end, j = i, i + 1
        while j < n:
            aj, bj, sj = runs[j]
            if t[aj] - t[runs[end][1] - 1] >= 1.0 or (
                sj != 0 and not _small_span(t, theta, aj, bj)
            ):
                break
            if sj == s:
                if not _small_span(t, theta, runs[end][1] - 1, aj + 1):
                    break
                end = j
            j += 1
        stop = runs[end][1]
        if end > i and _held_share(t[a:stop], theta[a:stop], span) <= HELD_SHARE:
            out.append((a, stop, s))
        else:
            out.extend(runs[i : end + 1])
        i = end + 1
    return out


def _bridge(
    runs: list[tuple[int, int, int]], t: NDArray[np.float64], theta: NDArray[np.float64]
) -> list[tuple[int, int, int]]:
    """Merge runs of one direction separated by short, small interruptions.

    A run is significant if it moves and lasts at least 1 s or travels 0.02 revolution. Between
    two significant runs of the same direction, everything is bridged when it lasts under 1 s
    and travels under 0.02 revolution in all (speed ripple dipping through zero).
    """

    def small(a: int, b: int) -> bool:
        return bool((t[b - 1] - t[a]) < 1.0 and abs(theta[b - 1] - theta[a]) < 0.02 * TWO_PI)

    big = [i for i, (a, b, s) in enumerate(runs) if s != 0 and not small(a, b)]
    if not big:
        return runs
    out: list[tuple[int, int, int]] = list(runs[: big[0]])
    current = runs[big[0]]
    for prev, nxt in itertools.pairwise(big):
        a, b, s = runs[nxt]
        gap_a, gap_b = runs[prev][1], a
        bridged = s == current[2] and (gap_b <= gap_a or small(gap_a - 1, gap_b + 1))
        if bridged:
            current = (current[0], b, s)
        else:
            out.append(current)
            out.extend(runs[prev + 1 : nxt])
            current = runs[nxt]
    out.append(current)
    out.extend(runs[big[-1] + 1 :])
    return out


@dataclass(frozen=True, slots=True, eq=False)
class FrictionFit:
    """Friction identified from pass means (:func:`fit_friction`).

    Attributes
    ----------
    friction
        The model.
    residual
        Pass mean torque minus the model at the pass speed [N m], shape (p,).
    stribeck_used
        Whether the Stribeck term passed the test.
    stribeck_f
        F statistic of the Stribeck test (nan when not tested).
    warnings
        What the data could not determine and what was assumed instead.
    """

    friction: FrictionModel
    residual: NDArray[np.float64]
    stribeck_used: bool
    stribeck_f: float
    warnings: tuple[str, ...]


def _linear_fit(
    speed: NDArray[np.float64], torque: NDArray[np.float64], basis: Sequence[NDArray[np.float64]]
) -> tuple[NDArray[np.float64], float]:
    a = np.column_stack(basis)
    coef, *_ = np.linalg.lstsq(a, torque, rcond=None)
    rss = float(np.sum((torque - a @ coef) ** 2))
    return np.asarray(coef, dtype=np.float64), rss


def fit_friction(
    speed: ArrayLike,
    mean_torque: ArrayLike,
    *,
    stribeck: Literal["auto", "never", "always"] = "auto",
    zero_velocity: float = 1e-3,
    joint: str = "",
    significance: float = 0.001,
) -> FrictionFit:
    """Fit Coulomb (per direction), viscous and, when supported, Stribeck friction.

    Model (:class:`torquemap.model.FrictionModel`) fitted to the pass means
    ``tau_i = f(w_i)`` by least squares: first ``[c+, c-, b]`` (Coulomb per direction and one
    viscous coefficient), then ``[c+, c-, b, s+, s-]`` for each Stribeck velocity on a
    logarithmic grid spanning the pass speeds. Stribeck is kept (``stribeck="auto"``) only if
    it clearly improves the fit: at least 3 distinct speeds in each direction with Stribeck,
    positive break-away terms, and the nested-model F test significant at ``significance``
    (a residual that falls by more than noise can explain with the extra 3 parameters).

    Parameters
    ----------
    speed
        Signed mean motor velocity of each pass [rad/s], shape (p,).
    mean_torque
        Angle-averaged motor torque of each pass [N m], shape (p,).
    stribeck
        ``"auto"`` (test), ``"never"`` or ``"always"`` (when the data allows).
    zero_velocity
        Written into the model: half width of the blend through zero [rad/s].
    joint
        Joint name for the warnings.
    significance
        Level of the Stribeck F test.

    Returns
    -------
    FrictionFit
        The model, pass residuals and warnings (a direction never moved in, one speed only).

    Raises
    ------
    InputError
        If there is no pass.

    Examples
    --------
    >>> w = np.array([1.0, 2.0, 4.0, -1.0, -2.0, -4.0])
    >>> tau = np.where(w > 0, 0.1, -0.2) + 0.01 * w
    >>> f = fit_friction(w, tau).friction
    >>> round(f.coulomb_positive, 6), round(f.coulomb_negative, 6), round(f.viscous, 6)
    (0.1, 0.2, 0.01)
    """
    from scipy import stats

    w = np.asarray(speed, dtype=np.float64)
    tau = np.asarray(mean_torque, dtype=np.float64)
    name = f"joint {joint} " if joint else ""
    if w.size == 0:
        raise InputError(f"{name}has no constant-speed pass to identify friction from")
    pos, neg = w > 0, w < 0
    warnings: list[str] = []
    speeds_distinct = _distinct(np.abs(w))
    one_speed = speeds_distinct < 2
    if not neg.any() or not pos.any():
        have, miss = ("positive", "negative") if pos.any() else ("negative", "positive")
        warnings.append(
            f"{name}never moves in the {miss} direction: coulomb_{miss} set equal to coulomb_{have}"
        )
    if one_speed:
        warnings.append(f"{name}was swept at one speed only: viscous friction set to 0")
    basis = [pos.astype(float), -neg.astype(float)]
    if not one_speed:
        basis.append(w)
    if not (pos.any() and neg.any()):
        basis = [np.sign(w), *basis[2:]]
    coef, rss = _linear_fit(w, tau, basis)
    if pos.any() and neg.any():
        cp, cn = float(coef[0]), float(coef[1])
        rest = coef[2:]
    else:
        cp = cn = float(coef[0])
        rest = coef[1:]
    b = float(rest[0]) if not one_speed else 0.0
    model = FrictionModel(
        coulomb_positive=max(cp, 0.0),
        coulomb_negative=max(cn, 0.0),
        viscous=b,
        zero_velocity=zero_velocity,
    )
    used, fstat = False, math.nan
    # "auto" wants four distinct speeds per direction: with three, the Stribeck law (a level
    # and a drop per direction, a viscous slope and a Stribeck speed) passes through the six
    # mean torques exactly, whatever the friction's true shape, and its F test sees only the
    # passes' scatter
    need = 3 if stribeck == "always" else 4
    enough = _distinct(np.abs(w[pos])) >= need and _distinct(np.abs(w[neg])) >= need
    if stribeck != "never" and enough and w.size >= 8:
        from scipy import optimize

        def stribeck_fit(vs: float) -> tuple[NDArray[np.float64], float]:
            e = np.exp(-((w / vs) ** 2))
            return _linear_fit(w, tau, [*basis, pos.astype(float) * e, -neg.astype(float) * e])

        lo, hi = float(np.min(np.abs(w))), float(np.max(np.abs(w)))
        grid = np.geomspace(lo / 2.0, hi, 40)
        rss_grid = [stribeck_fit(float(vs))[1] for vs in grid]
        i = int(np.argmin(rss_grid))
        # variable projection: the grid brackets the best Stribeck velocity, a bounded scalar
        # search on its logarithm refines it (the linear terms are refitted at every trial)
        bounds = (math.log(grid[max(i - 1, 0)]), math.log(grid[min(i + 1, grid.size - 1)]))
        vs = float(grid[i])
        if bounds[1] > bounds[0]:
            res = optimize.minimize_scalar(
                lambda x: stribeck_fit(math.exp(x))[1],
                bounds=bounds,
                method="bounded",
                options={"xatol": 1e-4},
            )
            if float(res.fun) <= rss_grid[i]:
                vs = math.exp(float(res.x))
        c2, rss2 = stribeck_fit(vs)
        dof = w.size - 6
        fstat = ((rss - rss2) / 3.0) / max(rss2 / dof, np.finfo(float).tiny) if dof > 0 else 0.0
        passes_test = dof > 0 and fstat > stats.f.ppf(1.0 - significance, 3, dof)
        # a Stribeck term is physical only with Coulomb levels >= 0 (the level it decays to):
        # a law of another form (friction rising faster than linearly, say) can be matched at a
        # few speeds by a huge Stribeck term over a negative Coulomb level, which clipping the
        # latter at 0 would turn into a wildly wrong law below the slowest pass
        unphysical = c2[0] < 0 or c2[1] < 0
        if (stribeck == "always" or passes_test) and c2[3] > 0 and c2[4] > 0 and unphysical:
            warnings.append(
                f"{name}would need a negative Coulomb level "
                f"({min(float(c2[0]), float(c2[1])):.3g} N m) under a Stribeck term: not "
                "physical, not used (friction of another form than Stribeck's; --friction "
                "whole fits any shape)"
            )
        elif (stribeck == "always" or passes_test) and c2[3] > 0 and c2[4] > 0:
            used = True
            model = FrictionModel(
                coulomb_positive=max(float(c2[0]), 0.0),
                coulomb_negative=max(float(c2[1]), 0.0),
                viscous=float(c2[2]),
                stribeck_positive=float(c2[3]),
                stribeck_negative=float(c2[4]),
                stribeck_velocity=vs,
                zero_velocity=zero_velocity,
            )
    if cp < 0 or cn < 0:
        warnings.append(f"{name}fitted a negative Coulomb friction; clipped to 0")
    residual = tau - friction_torque(w, model)
    return FrictionFit(
        friction=model,
        residual=residual,
        stribeck_used=used,
        stribeck_f=float(fstat),
        warnings=tuple(warnings),
    )


def _distinct(speeds: NDArray[np.float64], *, relative: float = 0.1) -> int:
    """Number of speed levels differing by more than ``relative``."""
    if speeds.size == 0:
        return 0
    s = np.sort(speeds)
    return 1 + int(np.sum(np.diff(s) > relative * s[1:]))


@dataclass(frozen=True, slots=True, eq=False)
class InertiaFit:
    """Inertia identified from accelerating samples (:func:`fit_inertia`).

    Attributes
    ----------
    inertia
        The model.
    samples
        Samples used.
    standard_error
        Standard errors of ``(constant, cos_elbow)`` [kg m^2].
    warnings
        What could not be determined.
    """

    inertia: InertiaModel
    samples: int
    standard_error: tuple[float, float]
    warnings: tuple[str, ...]


def fit_inertia(
    acceleration: ArrayLike,
    torque: ArrayLike,
    *,
    elbow_angle: ArrayLike | None = None,
    joint: str = "",
    min_cos_spread: float = 0.2,
) -> InertiaFit:
    """Least-squares motor-side inertia from torque (friction removed) against acceleration.

    ``torque = J acceleration`` or, with ``elbow_angle``,
    ``torque = (J0 + J1 cos(q_elbow)) acceleration`` (the first joint of a planar 2R arm,
    Simpson et al.: "the B axis position affects the A axis inertia"). ``J1`` is fitted only if
    ``cos(q_elbow)`` spans at least ``min_cos_spread`` over the samples, else set to 0 with a
    warning.

    Parameters
    ----------
    acceleration
        Motor acceleration [rad/s^2], shape (n,).
    torque
        Motor torque minus friction (and PDTV when known) [N m], shape (n,).
    elbow_angle
        Elbow joint angle [rad], shape (n,), or None.
    joint
        Joint name for the warnings.
    min_cos_spread
        See above.

    Returns
    -------
    InertiaFit
        The inertia, sample count, standard errors, warnings.

    Examples
    --------
    >>> acc = np.array([10.0, -5.0, 20.0, -15.0])
    >>> round(fit_inertia(acc, 2e-4 * acc).inertia.constant, 9)
    0.0002
    """
    acc = np.asarray(acceleration, dtype=np.float64)
    y = np.asarray(torque, dtype=np.float64)
    name = f"joint {joint} " if joint else ""
    if acc.size < 3 or not np.any(acc != 0):
        return InertiaFit(
            inertia=InertiaModel(),
            samples=int(acc.size),
            standard_error=(math.nan, math.nan),
            warnings=(f"{name}has no accelerating segment: inertia set to 0",),
        )
    warnings: list[str] = []
    cols = [acc]
    with_elbow = False
    if elbow_angle is not None:
        c = np.cos(np.asarray(elbow_angle, dtype=np.float64))
        if float(c.max() - c.min()) >= min_cos_spread:
            cols.append(acc * c)
            with_elbow = True
        else:
            q = np.asarray(elbow_angle, dtype=np.float64)
            lo, hi, spread = float(q.min()), float(q.max()), float(c.max() - c.min())
            seen = (
                f"at one elbow angle only ({lo:.3g} rad)"
                if hi - lo < 1e-6
                else f"at elbow angles {lo:.3g} to {hi:.3g} rad only, whose cosines differ by "
                f"{spread:.2g}"
            )
            warnings.append(
                f"{name}was swept {seen}: inertia cos_elbow set to 0; for an inertia that "
                f"follows the elbow, sweep it at elbow angles whose cosines differ by "
                f"{min_cos_spread:g} or more (0.6 and 2.6 rad, say)"
            )
    a = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    dof = max(acc.size - a.shape[1], 1)
    s2 = float(np.sum((y - a @ coef) ** 2)) / dof
    cov = s2 * np.linalg.pinv(a.T @ a)
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    j0 = float(coef[0])
    j1 = float(coef[1]) if with_elbow else 0.0
    if j0 <= 0:
        warnings.append(f"{name}fitted a non-positive inertia ({j0:.3g} kg m^2)")
    return InertiaFit(
        inertia=InertiaModel(constant=j0, cos_elbow=j1),
        samples=int(acc.size),
        standard_error=(float(se[0]), float(se[1]) if with_elbow else 0.0),
        warnings=tuple(warnings),
    )
