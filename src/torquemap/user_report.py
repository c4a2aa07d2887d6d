"""``torquemap report``: a self-contained HTML report of a model and a user's own logs.

The page opens with a one-screen summary: what the model holds per joint, how well it explains
the logs (the share of the torque ripple its PDTV lines remove, how close friction sits to the
passes it was fitted to) and what to do next. Then, per log:

identification sweeps (logs with constant-speed passes)
    per joint, the cogging map against motor angle (the log's residual torque folded over one
    motor revolution, with its standard error, and the model's PDTV), friction against speed
    (each pass's angle-averaged torque with its standard error, and the model's law), the
    residual spectrum before and after subtracting the model, and the residual along the
    slowest pass before and after (the ripple compensation removes), plus thin-data warnings;
other logs
    the external torques and forces the ``model`` method estimates, with their sigma band when
    the estimator provides one (columns ``tau_ext_<j>_sigma``, ``fx_sigma``, ``fy_sigma``).

Everything is computed from the model file and the log with public functions (the estimation
signal of Eq 7, position-domain binning, the spectrum); nothing is identified again, so the
report takes seconds. Charts are interactive (:mod:`torquemap.plots.chart`).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.estimate import (
    FLAG_LOW_SPEED,
    FLAG_SINGULAR,
    estimate_forces,
    estimation_signal,
    model_window,
)
from torquemap.identify import resolvable_order
from torquemap.io import Log, read_log
from torquemap.model import Model, friction_torque, load_model, pdtv_torque
from torquemap.pdtv import discrete_position_signal, position_spectrum
from torquemap.pdtv_map import pdtv_map
from torquemap.plots.chart import Chart, series, spans_from_mask
from torquemap.report import Report, Section, Table, table, write_report
from torquemap.sanitize import slow_time_warning

TWO_PI = 2.0 * math.pi

#: Fewer constant-speed passes per direction than this is thin data for friction.
MIN_PASSES = 2
#: Bins per motor revolution of the cogging map (orders up to 127 CPR resolved).
MAP_BINS = 256
#: A log is an identification sweep when this share of its samples lie in steady passes.
SWEEP_SHARE = 0.3


@dataclass(frozen=True, slots=True, eq=False)
class SteadyPass:
    """A stretch of one joint at a steady speed in one direction.

    Attributes
    ----------
    start, stop
        Sample slice.
    velocity
        Mean motor velocity [rad/s] (signed).
    torque, torque_se
        Angle-averaged ``torque - J acceleration`` [N m] and its standard error (from the
        scatter of its whole-revolution means; NaN under two revolutions).
    revolutions
        Motor revolutions covered.
    samples_per_rev
        Samples per motor revolution.
    """

    start: int
    stop: int
    velocity: float
    torque: float
    torque_se: float
    revolutions: float
    samples_per_rev: float


def steady_passes(
    t: NDArray[np.float64],
    motor_angle: NDArray[np.float64],
    velocity: NDArray[np.float64],
    torque: NDArray[np.float64],
    *,
    tolerance: float = 0.1,
    min_revolutions: float = 0.5,
) -> tuple[SteadyPass, ...]:
    """Cut one joint's motion into passes at a steady speed.

    A pass is the longest stretch of one direction of motion whose speed stays within
    ``tolerance`` of the stretch's median speed, covering ``min_revolutions`` or more.

    Parameters
    ----------
    t, motor_angle, velocity, torque
        Time [s], motor angle [rad], smoothed motor velocity [rad/s] and ``torque - J acc``
        [N m], each shape (n,).
    tolerance
        Relative speed band [-].
    min_revolutions
        Shortest pass [motor revolutions].

    Returns
    -------
    tuple of SteadyPass
    """
    top = float(np.percentile(np.abs(velocity), 99)) if velocity.size else 0.0
    if top <= 0:
        return ()
    moving = np.abs(velocity) > 0.004 * top
    sign = np.where(moving, np.sign(velocity), 0).astype(np.int64)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], sign, [0]])))
    out: list[SteadyPass] = []
    for a_, b_ in itertools.pairwise(edges):
        a, b = int(a_), int(b_)
        if sign[a] == 0 or b - a < 16:
            continue
        speed = np.abs(velocity[a:b])
        med = float(np.median(speed))
        steady = np.concatenate([[0], (np.abs(speed - med) < tolerance * med).astype(np.int8), [0]])
        se = np.flatnonzero(np.diff(steady))
        if se.size < 2:
            continue
        lengths = se[1::2] - se[::2]
        i = int(np.argmax(lengths))
        s0, s1 = a + int(se[2 * i]), a + int(se[2 * i + 1])
        revs = abs(float(motor_angle[s1 - 1] - motor_angle[s0])) / TWO_PI
        if revs < min_revolutions:
            continue
        theta = motor_angle[s0:s1]
        whole = math.floor(revs)
        if whole >= 1:
            # mean over whole revolutions, so the PDTV averages out
            rev_index = np.floor(np.abs(theta - theta[0]) / TWO_PI).astype(np.int64)
            sums = np.bincount(rev_index, weights=torque[s0:s1])[:whole]
            counts = np.bincount(rev_index)[:whole]
            means = sums / counts
            mean = float(np.mean(means))
            se_ = float(np.std(means, ddof=1) / math.sqrt(whole)) if whole >= 2 else math.nan
        else:
            mean, se_ = float(np.mean(torque[s0:s1])), math.nan
        out.append(
            SteadyPass(
                start=s0,
                stop=s1,
                velocity=float(np.mean(velocity[s0:s1])),
                torque=mean,
                torque_se=se_,
                revolutions=revs,
                samples_per_rev=(s1 - s0) / revs,
            )
        )
    return tuple(out)


@dataclass(frozen=True, slots=True, eq=False)
class JointView:
    """What one sweep shows about one joint: data against the model.

    Attributes
    ----------
    name
        Joint name.
    passes
        The steady passes found.
    friction_rms
        RMS of the pass torques about the model's friction law [N m].
    map_angle, map_value, map_se, map_model
        Bin centres over one motor revolution [rad]; the residual torque averaged in each bin,
        its standard error, and the model's PDTV there [N m] (None without a slow pass).
    ripple_before, ripple_after
        Standard deviation over the bins of the residual, before and after subtracting the
        model [N m].
    empty_bins
        Share of bins no sample fell in [-].
    spectrum
        ``(order [CPR], amplitude before, amplitude after [N m])`` of the slow passes.
    trace
        ``(motor angle [rad], residual before, residual after [N m])`` along the slowest pass,
        averaged in the map's bins.
    resolvable
        Highest order the slowest pass resolves [CPR].
    """

    name: str
    passes: tuple[SteadyPass, ...]
    friction_rms: float
    map_angle: NDArray[np.float64] | None = None
    map_value: NDArray[np.float64] | None = None
    map_se: NDArray[np.float64] | None = None
    map_model: NDArray[np.float64] | None = None
    ripple_before: float = math.nan
    ripple_after: float = math.nan
    empty_bins: float = 0.0
    spectrum: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None = None
    trace: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None = None
    resolvable: int = 0

    @property
    def explained(self) -> float:
        """Share of the ripple variance over one revolution the model removes [-]."""
        if not (self.ripple_before > 0 and math.isfinite(self.ripple_after)):
            return math.nan
        return 1.0 - (self.ripple_after / self.ripple_before) ** 2


def _joint_view(
    model: Model, log: Log, k: int, signal: tuple[NDArray[np.float64], ...]
) -> JointView:
    t_est, angle, velocity = (s[:, k] for s in signal)
    name = model.robot.joint_names[k]
    jm = model.joints[name]
    fr = friction_torque(velocity, jm.friction)
    passes = steady_passes(log.t, angle, velocity, t_est + fr)
    if passes:
        model_f = friction_torque(np.array([p.velocity for p in passes]), jm.friction)
        friction_rms = float(
            np.sqrt(np.mean((np.array([p.torque for p in passes]) - model_f) ** 2))
        )
    else:
        friction_rms = math.nan
    best = max((p.samples_per_rev for p in passes), default=0.0)
    if best < 8:
        return JointView(name=name, passes=passes, friction_rms=friction_rms)
    nb = MAP_BINS if best >= 1.5 * MAP_BINS else 2 ** max(int(math.log2(best / 1.5)), 2)
    slow = [p for p in passes if p.samples_per_rev >= 1.5 * nb] or [
        max(passes, key=lambda p: p.samples_per_rev)
    ]
    theta = np.concatenate([angle[p.start : p.stop] for p in slow])
    vel = np.concatenate([velocity[p.start : p.stop] for p in slow])
    resid = np.concatenate(
        [t_est[p.start : p.stop] - np.mean(t_est[p.start : p.stop]) for p in slow]
    )
    model_at = pdtv_torque(theta, jm.pdtv, velocity=vel)
    bw = TWO_PI / nb
    k_bin = np.floor(np.mod(theta, TWO_PI) / bw).astype(np.int64) % nb
    count = np.bincount(k_bin, minlength=nb).astype(np.float64)
    total = np.bincount(k_bin, weights=resid, minlength=nb)
    square = np.bincount(k_bin, weights=resid**2, minlength=nb)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = total / count
        var = square / count - mean**2
        se = np.sqrt(np.maximum(var, 0.0) / np.maximum(count - 1, 1))
    centres = (np.arange(nb) + 0.5) * bw
    curve = pdtv_map(model, name, motor_angle=centres).torque
    filled = count > 0
    before = float(np.std(mean[filled])) if filled.any() else math.nan
    after = float(np.std((mean - curve)[filled])) if filled.any() else math.nan
    limit = resolvable_order(best)
    spectrum = None
    try:
        order_top = min(limit, nb // 2 - 1)
        sig_b = discrete_position_signal(theta, resid, bin_width=bw)
        sig_a = discrete_position_signal(theta, resid - model_at, bin_width=bw)
        sp_b = position_spectrum(sig_b, max_order=order_top)
        sp_a = position_spectrum(sig_a, max_order=order_top)
        spectrum = (sp_b.order, sp_b.amplitude, sp_a.amplitude)
    except InputError:
        spectrum = None
    p0 = max(slow, key=lambda p: p.samples_per_rev)
    span = slice(p0.start, p0.stop)
    r0 = t_est[span] - np.mean(t_est[span])
    # binned along the pass (nb bins per revolution): the ripple without the current noise
    tb = discrete_position_signal(angle[span], r0, bin_width=bw)
    ta = discrete_position_signal(
        angle[span], r0 - pdtv_torque(angle[span], jm.pdtv, velocity=velocity[span]), bin_width=bw
    )
    trace = (tb.angle, tb.value, ta.value)
    return JointView(
        name=name,
        passes=passes,
        friction_rms=friction_rms,
        map_angle=centres,
        map_value=np.where(filled, mean, np.nan),
        map_se=np.where(filled, se, np.nan),
        map_model=curve,
        ripple_before=before,
        ripple_after=after,
        empty_bins=float(np.mean(~filled)),
        spectrum=spectrum,
        trace=trace,
        resolvable=limit,
    )


def sweep_views(model: Model, log: Log, window: float | None = None) -> tuple[JointView, ...]:
    """Per joint, what a log's steady passes show against the model (see the module docstring).

    Parameters
    ----------
    model
        The model the report describes.
    log
        A log read for ``model.robot``.
    window
        Differentiator window [s]; default the model's (:func:`torquemap.estimate.model_window`).

    Returns
    -------
    tuple of JointView
        One per joint, in the robot's order (``passes`` empty where the joint never held a
        steady speed).
    """
    win = model_window(model) if window is None else window
    signal = estimation_signal(model, log, window=win)
    return tuple(_joint_view(model, log, k, signal) for k in range(len(model.robot.joints)))


def thin_data_warnings(model: Model, view: JointView) -> list[str]:
    """Warnings where a sweep is thin for identification (one line each)."""
    out: list[str] = []
    name = view.name
    pos = sum(1 for p in view.passes if p.velocity > 0)
    neg = sum(1 for p in view.passes if p.velocity < 0)
    if pos < MIN_PASSES or neg < MIN_PASSES:
        out.append(
            f"joint {name}: {pos} positive and {neg} negative constant-speed passes; "
            f"friction needs at least {MIN_PASSES} per direction at distinct speeds"
        )
    if view.map_angle is not None and view.empty_bins > 0:
        out.append(
            f"joint {name}: {view.empty_bins:.1%} of the {view.map_angle.size} position bins of "
            "a motor revolution hold no sample in the slow passes; a slower or longer sweep "
            "fills them"
        )
    orders = [ln.order for ln in model.joints[name].pdtv]
    if view.passes and orders:
        best = max(p.samples_per_rev for p in view.passes)
        high = sorted({o for o in orders if o > view.resolvable})
        if high:
            out.append(
                f"joint {name}: the slowest pass gives {best:.0f} samples per motor "
                f"revolution, too fast for the position Nyquist of the model's orders "
                f"{', '.join(f'{o:g}' for o in high)} CPR (resolves up to {view.resolvable} CPR)"
            )
    return out


def _joint_charts(model: Model, view: JointView) -> list[Chart]:
    name = view.name
    jm = model.joints[name]
    charts: list[Chart] = []
    if view.map_angle is not None and view.map_value is not None:
        charts.append(
            Chart(
                title=f"joint {name}: cogging map (PDTV) over one motor revolution",
                x_label="motor angle [rad] from the encoder zero",
                y_label="torque [N m], motor side",
                series=(
                    series(
                        "binned data (+/- standard error)",
                        view.map_angle,
                        view.map_value,
                        style="points",
                        sigma=view.map_se,
                    ),
                    series(
                        "model",
                        view.map_angle,
                        np.asarray(view.map_model, dtype=np.float64),
                        color="#d62728",
                    ),
                ),
                caption=f"Joint {name}: the log's residual torque (Eq 7, minus each pass's mean) "
                f"averaged in {view.map_angle.size} bins of motor angle over its slow passes, "
                "against the model's PDTV (the anti-cogging map).",
            )
        )
    if view.passes:
        v = np.array([p.velocity for p in view.passes])
        top = float(np.max(np.abs(v)))
        grid = np.linspace(-1.05 * top, 1.05 * top, 801)
        charts.append(
            Chart(
                title=f"joint {name}: friction against speed",
                x_label="motor velocity [rad/s]",
                y_label="torque [N m], motor side",
                series=(
                    series(
                        "passes (+/- standard error)",
                        v,
                        [p.torque for p in view.passes],
                        style="markers",
                        sigma=np.nan_to_num([p.torque_se for p in view.passes]),
                    ),
                    series("model", grid, friction_torque(grid, jm.friction), color="#d62728"),
                ),
                caption=f"Joint {name}: each steady pass's angle-averaged torque minus inertia "
                "torque, with its standard error (scatter of its whole-revolution means), "
                "against the model's friction law.",
            )
        )
    if view.spectrum is not None:
        order, before, after = view.spectrum
        lines = sorted(jm.pdtv, key=lambda ln: ln.order)
        items = [
            series("before", order, before, color="#7f7f7f"),
            series("after subtracting the model", order, after, color="#1f77b4"),
        ]
        if lines:
            items.append(
                series(
                    "model lines",
                    [ln.order for ln in lines],
                    [ln.amplitude for ln in lines],
                    style="markers",
                    color="#d62728",
                )
            )
        charts.append(
            Chart(
                title=f"joint {name}: residual spectrum before and after the model",
                x_label="position frequency [CPR]",
                y_label="amplitude [N m]",
                series=tuple(items),
                x_log=True,
                y_log=True,
                caption=f"Joint {name}: position-domain spectrum of the residual torque in the "
                "slow passes, before and after subtracting the model's PDTV.",
            )
        )
    if view.trace is not None:
        theta, before_t, after_t = view.trace
        charts.append(
            Chart(
                title=f"joint {name}: torque ripple before and after compensation",
                x_label="motor angle [rad]",
                y_label="residual torque [N m]",
                series=(
                    series("before", theta, before_t, color="#7f7f7f"),
                    series("after subtracting the model", theta, after_t, color="#1f77b4"),
                ),
                caption=f"Joint {name}: the residual torque along the slowest pass (averaged in "
                "the map's bins of motor angle), as measured and with the model's PDTV "
                "subtracted: what an anti-cogging feed-forward leaves. Zoom in to see single "
                "cycles.",
            )
        )
    return charts


@dataclass(frozen=True, slots=True, eq=False)
class _LogResult:
    section: Section
    views: tuple[JointView, ...]
    sweep: bool
    path: str
    kind: str = "sweep"


def _sweep_section(
    model: Model, log: Log, path: str, window: float | None = None
) -> _LogResult | None:
    views = sweep_views(model, log, window)
    in_passes = (
        sum(p.stop - p.start for v in views for p in v.passes) / log.t.size if views else 0.0
    )
    if in_passes < SWEEP_SHARE:
        return None
    warnings: list[str] = []
    charts: list[Chart] = []
    rows = []
    for v in views:
        if not v.passes:
            continue
        warnings.extend(thin_data_warnings(model, v))
        charts.extend(_joint_charts(model, v))
        rows.append(
            (
                v.name,
                len(v.passes),
                min(abs(p.velocity) for p in v.passes),
                max(abs(p.velocity) for p in v.passes),
                v.friction_rms,
                v.ripple_before,
                v.ripple_after,
                "n/a" if math.isnan(v.explained) else f"{100 * v.explained:.1f} %",
            )
        )
    paragraphs = [
        f"{log.t.size} samples over {log.t[-1] - log.t[0]:.3g} s "
        f"(median step {1e3 * float(np.median(np.diff(log.t))):.3g} ms); {in_passes:.0%} of "
        "them in constant-speed passes: treated as an identification sweep (no load, so no "
        "force is estimated)."
    ]
    tables = (
        table(
            (
                "joint",
                "passes",
                "slowest [rad/s]",
                "fastest [rad/s]",
                "friction residual RMS [N m]",
                "ripple before [N m]",
                "ripple after [N m]",
                "ripple explained",
            ),
            rows,
            caption="Per joint: the steady passes; RMS of the pass torques about the model's "
            "friction; standard deviation of the binned ripple over one motor revolution "
            "before and after subtracting the model's PDTV, and the share of its variance the "
            "model explains.",
        ),
    )
    section = Section(
        f"Log: {Path(path).name}",
        paragraphs=tuple(paragraphs),
        tables=tables,
        charts=tuple(charts),
        warnings=tuple(dict.fromkeys(warnings)),
    )
    return _LogResult(section=section, views=views, sweep=True, path=path)


def _force_section(
    model: Model, log: Log, path: str, note: str, window: float | None = None
) -> _LogResult:
    paragraphs = [
        f"{log.t.size} samples over {log.t[-1] - log.t[0]:.3g} s "
        f"(median step {1e3 * float(np.median(np.diff(log.t))):.3g} ms). {note}"
    ]
    warnings: list[str] = []
    charts: list[Chart] = []
    tables: list[Table] = []
    try:
        est = estimate_forces(model, log, method="model", window=window)
    except InputError as exc:
        warnings.append(f"no force estimate: {exc.message}")
        return _LogResult(
            Section(f"Log: {Path(path).name}", tuple(paragraphs), warnings=tuple(warnings)),
            (),
            False,
            path,
            "forces",
        )
    from torquemap.estimate import check_answered, forces_columns

    try:  # a log too slow for the model: say what to record instead
        check_answered(est, model)
    except InputError as exc:
        warnings.append(f"no sound force estimate: {exc.message}")
    cols = forces_columns(est)
    for w in est.warnings:
        # resting and reversing are normal: say how much was flagged, do not alarm
        if "at or near zero velocity" in w:
            paragraphs.append(f"Note: {w}; normal where a joint rests or reverses.")
        else:
            warnings.append(w)
    flagged = est.flag != 0
    spans = spans_from_mask(est.t, flagged)
    names = [(f"tau_ext_{n}", "N m", f"external torque on joint {n}") for n in est.joint_names]
    if est.force is not None:
        names += [("fx", "N", "force on the end effector, x"), ("fy", "N", "force, y")]
    for col, unit, what in names:
        sigma = cols.get(f"{col}_sigma")
        if sigma is not None and not np.isfinite(np.asarray(sigma, dtype=np.float64)).any():
            sigma = None  # the estimator has no uncertainty for this model: no band
        charts.append(
            Chart(
                title=f"{col} [{unit}]",
                x_label="time [s]",
                y_label=f"{col} [{unit}]",
                series=(
                    series(
                        f"{col} ({est.method} method)"
                        + (" +/- sigma" if sigma is not None else ""),
                        est.t,
                        np.asarray(cols[col], dtype=np.float64),
                        sigma=None if sigma is None else np.asarray(sigma, dtype=np.float64),
                    ),
                ),
                spans=spans,
                caption=f"{what.capitalize()} estimated by the {est.method} method"
                + (", with its one-sigma band" if sigma is not None else "")
                + "; flagged samples shaded grey. Zoom to read single events.",
            )
        )
    ok = ~flagged
    rows = []
    for k, name in enumerate(est.joint_names):
        tau = est.tau_ext[ok, k]
        if tau.size:
            rows.append((f"tau_ext_{name} [N m]", float(np.mean(tau)), float(np.std(tau))))
    if est.force is not None and ok.any():
        mag = np.hypot(est.force[ok, 0], est.force[ok, 1])
        rows.append(("|F| [N]", float(np.mean(mag)), float(np.std(mag))))
    tables.append(
        table(
            ("estimate (sound samples)", "mean", "std"),
            rows,
            caption=f"{ok.mean():.1%} of samples sound; flagged: "
            f"{np.mean((est.flag & FLAG_LOW_SPEED) > 0):.1%} near zero velocity, "
            f"{np.mean((est.flag & FLAG_SINGULAR) > 0):.1%} singular pose.",
        )
    )
    return _LogResult(
        Section(
            f"Log: {Path(path).name}",
            paragraphs=tuple(paragraphs),
            tables=tuple(tables),
            charts=tuple(charts),
            warnings=tuple(dict.fromkeys(warnings)),
        ),
        (),
        False,
        path,
        "forces",
    )


def _holds_section(model: Model, log: Log, path: str) -> _LogResult | None:
    """Position holds (quasi-static calibration): the holding torques against the model."""
    from torquemap.quasistatic import find_holds

    charts: list[Chart] = []
    rows = []
    for k, joint in enumerate(model.robot.joints):
        theta = joint.gear_ratio * log.q[:, k]
        holds = find_holds(log.t, theta, log.motor_torque[:, k])
        folded = np.mod(holds.motor_angle, TWO_PI)
        if np.unique(np.round(folded, 3)).size < 8:
            continue
        curve_at = pdtv_map(model, joint.name, motor_angle=holds.motor_angle).torque
        # each side of approach has its own friction offset: remove its mean
        torque = holds.torque.copy()
        for side in (-1, 1):
            m = holds.approach == side
            if m.any():
                torque[m] -= np.mean(torque[m] - curve_at[m])
        grid = np.linspace(0.0, TWO_PI, 1025)
        before = float(np.std(torque))
        after = float(np.std(torque - curve_at))
        explained = 1.0 - (after / before) ** 2 if before > 0 else math.nan
        rows.append((joint.name, holds.torque.size, before, after, f"{100 * explained:.1f} %"))
        charts.append(
            Chart(
                title=f"joint {joint.name}: holding torque over one motor revolution",
                x_label="motor angle [rad] from the encoder zero",
                y_label="torque [N m], motor side",
                series=(
                    series("holds", folded, torque, style="points"),
                    series(
                        "model",
                        grid,
                        pdtv_map(model, joint.name, motor_angle=grid).torque,
                        color="#d62728",
                    ),
                ),
                caption=f"Joint {joint.name}: the mean torque of each position hold (each "
                "side of approach less its own friction offset) against the model's PDTV.",
            )
        )
    if not rows:
        return None
    section = Section(
        f"Log: {Path(path).name}",
        paragraphs=(
            f"{log.t.size} samples over {log.t[-1] - log.t[0]:.3g} s: position holds "
            "(quasi-static calibration, `identify --quasi-static`).",
        ),
        tables=(
            table(
                ("joint", "holds", "ripple [N m]", "about the model [N m]", "ripple explained"),
                rows,
                caption="Standard deviation of the holding torques, and about the model's PDTV.",
            ),
        ),
        charts=tuple(charts),
    )
    return _LogResult(section=section, views=(), sweep=False, path=path, kind="holds")


def _arm_force_section(
    model: Model, log: Log, path: str, window: float | None = None
) -> _LogResult:
    """An arm with a URDF (docs/arm.md): the wrench the acceleration method estimates."""
    from torquemap.estimate_arm import estimate_arm
    from torquemap.plots.arm import wrench_charts

    paragraphs = [
        f"{log.t.size} samples over {log.t[-1] - log.t[0]:.3g} s "
        f"(median step {1e3 * float(np.median(np.diff(log.t))):.3g} ms). The wrench on the "
        "end effector estimated with the arm's rigid-body model (acceleration method, 2 Hz "
        "low-pass; `torquemap estimate --method momentum` for the observer)."
    ]
    try:
        est = estimate_arm(model, log, window=0.05 if window is None else window)
    except InputError as exc:
        return _LogResult(
            Section(
                f"Log: {Path(path).name}",
                tuple(paragraphs),
                warnings=(f"no force estimate: {exc.message}",),
            ),
            (),
            False,
            path,
            "forces",
        )
    ok = (est.flag == 0) & np.isfinite(est.wrench).all(axis=1)
    rows = []
    for k, axis in enumerate(est.wrench_axes):
        if ok.any():
            unit = "N" if axis.startswith("f") else "N m"
            w, sw = est.wrench[ok, k], est.wrench_sigma[ok, k]
            rows.append(
                (f"{axis} [{unit}]", float(np.mean(w)), float(np.std(w)), float(np.median(sw)))
            )
    section = Section(
        f"Log: {Path(path).name}",
        paragraphs=tuple(paragraphs),
        tables=(
            table(
                ("estimate (sound samples)", "mean", "std", "median sigma"),
                rows,
                caption=f"{ok.mean():.1%} of samples sound; the rest near a singular pose.",
            ),
        ),
        charts=tuple(wrench_charts({"acceleration": est})),
        warnings=tuple(dict.fromkeys(est.warnings)),
    )
    return _LogResult(section, (), False, path, "forces")


def _log_result(model: Model, path: str, window: float | None = None) -> _LogResult:
    log = read_log(path, model.robot)
    from torquemap.identify_arm import is_rigid_body_arm

    if is_rigid_body_arm(model.robot.arm):
        return _arm_force_section(model, log, path, window)
    try:
        swept = _sweep_section(model, log, path, window)
    except InputError:
        swept = None
    read = swept if swept is not None else _holds_section(model, log, path)
    if read is not None:
        # a log stamped in ms reads as 1000 times slower: passes at a thousandth of the
        # speed, or motion as holds; say so where both readings are possible
        slow = slow_time_warning(log.t, model_window(model) if window is None else window)
        if slow is not None:
            section = dataclasses.replace(read.section, warnings=(slow, *read.section.warnings))
            return dataclasses.replace(read, section=section)
        return read
    return _force_section(
        model,
        log,
        path,
        f"Fewer than {SWEEP_SHARE:.0%} of the samples are constant-speed passes: not treated "
        "as an identification sweep (no spectrum, no thin-data check); forces estimated.",
        window,
    )


def _model_section(model: Model, path: str) -> Section:
    rows = []
    lines = []
    for name, jm in model.joints.items():
        f, i = jm.friction.to_dict(), jm.inertia
        keys = (
            "coulomb_positive",
            "coulomb_negative",
            "viscous",
            "stribeck_positive",
            "stribeck_negative",
            "stribeck_velocity",
        )
        rows.append((name, *(f.get(k, float("nan")) for k in keys), i.constant, i.cos_elbow))
        for ln in sorted(jm.pdtv, key=lambda x: -x.amplitude):
            lines.append((name, f"{ln.order:g}", ln.direction, ln.amplitude, ln.phase))
    warnings: list[str] = []
    notes = model.notes.get("warnings", [])
    if isinstance(notes, list):
        warnings.extend(str(w) for w in notes)
    if not lines:
        warnings.append("the model holds no PDTV line (a plain robot file, or none was identified)")
    return Section(
        # a robot file need not name the robot: "Model: " + "" read "Model: : <warning>"
        f"Model: {model.robot.name or os.path.basename(path)}",
        paragraphs=(f"From {path}. Motor side; kinematics {model.robot.kinematics}.",),
        tables=(
            table(
                (
                    "joint",
                    "Coulomb + [N m]",
                    "Coulomb - [N m]",
                    "viscous [N m s/rad]",
                    "Stribeck + [N m]",
                    "Stribeck - [N m]",
                    "Stribeck velocity [rad/s]",
                    "inertia [kg m^2]",
                    "inertia cos(q2) [kg m^2]",
                ),
                rows,
                caption="Friction and inertia.",
            ),
            table(
                ("joint", "order [CPR]", "direction", "amplitude [N m]", "phase [rad]"),
                lines,
                caption="PDTV lines: amplitude * cos(order * motor angle + phase).",
            ),
        ),
        warnings=tuple(warnings),
    )


def _summary(model: Model, model_path: str, results: Sequence[_LogResult]) -> Section:
    rows = []
    steps: list[str] = []
    for name, jm in model.joints.items():
        f = jm.friction.to_dict()
        top = max(jm.pdtv, key=lambda ln: ln.amplitude, default=None)
        views = [v for r in results for v in r.views if v.name == name and v.passes]
        explained = [v.explained for v in views if math.isfinite(v.explained)]
        fr = [v.friction_rms for v in views if math.isfinite(v.friction_rms)]
        rows.append(
            (
                name,
                f"+{f.get('coulomb_positive', math.nan):.3g} / "
                f"-{f.get('coulomb_negative', math.nan):.3g}",
                f"{f.get('viscous', math.nan):.3g}",
                f"{jm.inertia.constant:.3g}",
                f"{len(jm.pdtv)}"
                + ("" if top is None else f" (largest {top.order:g} CPR, {top.amplitude:.3g} N m)"),
                "n/a" if not explained else f"{100 * min(explained):.1f} %",
                "n/a" if not fr else f"{max(fr):.3g}",
            )
        )
        if jm.pdtv:
            steps.append(
                f"Joint {name}: export the anti-cogging map with `torquemap pdtv-map "
                f"{model_path} --joint {name} --bins 1024 -o cog_{name}.csv` (docs/odrive.md, "
                "docs/moteus.md), then check it with `torquemap cogging verify`."
            )
        if not any(jm.friction.linear_parameters()):
            steps.append(
                f"Joint {name}: the model holds no friction (a quasi-static calibration "
                "identifies PDTV only); identify from constant-speed sweeps before estimating "
                "forces."
            )
        if explained and min(explained) < 0.8:
            steps.append(
                f"Joint {name}: the model explains only {100 * min(explained):.0f} % of the "
                "ripple in a sweep: identify again from a slower or longer sweep, or raise "
                "--max-order."
            )
    warned = sum(len(r.section.warnings) for r in results)
    if warned:
        steps.append(
            f"Read the {warned} warning(s) below: they say where the data is thin and how to "
            "sweep for better data."
        )
    if not any(
        not r.sweep and not r.views and "holds" not in r.section.paragraphs[0] for r in results
    ):
        steps.append(
            "Estimate forces on a task log: `torquemap estimate MODEL LOG -o forces.csv` "
            "(or add the log to this report)."
        )
    sweeps = sum(r.sweep for r in results)
    return Section(
        "Summary",
        paragraphs=(
            f"Model {model_path}: {len(model.joints)} joint(s)"
            + (f" of {model.robot.name}" if model.robot.name else "")
            + "; "
            f"{len(results)} log(s), {sweeps} of them identification sweeps.",
        ),
        tables=(
            table(
                (
                    "joint",
                    "Coulomb [N m]",
                    "viscous [N m s/rad]",
                    "inertia [kg m^2]",
                    "PDTV lines",
                    "ripple explained",
                    "friction residual [N m]",
                ),
                rows,
                caption="What was identified (motor side) and how well it fits the sweeps in "
                "this report: the share of the torque ripple over a motor revolution the PDTV "
                "lines explain (worst sweep), and the RMS of the pass torques about the "
                "friction law (worst sweep).",
            ),
        ),
        items=tuple(steps),
    )


def write_user_report(
    model_path: str | os.PathLike[str],
    log_paths: Sequence[str | os.PathLike[str]],
    out: str | os.PathLike[str],
    *,
    window: float | None = None,
) -> Report:
    """Build and write the report of a model and logs; returns it.

    ``window`` is the differentiator window [s] (default: the model's).

    Raises
    ------
    InputError
        On a bad model or log file (nothing is written then).
    """
    model = load_model(model_path)
    mp = os.fspath(model_path)
    results = [_log_result(model, os.fspath(path), window) for path in log_paths]
    sections = [_summary(model, mp, results), _model_section(model, mp)]
    sections.extend(r.section for r in results)
    report = Report(
        title=f"torquemap report: {model.robot.name or os.path.basename(mp)}",
        subtitle=f"model {mp}; {len(log_paths)} log(s)",
        sections=tuple(sections),
    )
    write_report(out, report)
    return report
