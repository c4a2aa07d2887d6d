"""Identify a robot's joints from no-load logs: friction, inertia and PDTV (docs/identification.md).

Per joint (Simpson, Cook & Li, Eq 5, motor side)::

    torque = J(q_elbow) * acceleration + friction(velocity) + PDTV(motor_angle)

is identified from the samples where that joint moves and the others are still: friction from
constant-speed passes, inertia from the ramps between them, PDTV from the residual of the
slow passes in the position domain (spectrum, automatic line picking, least-squares harmonic
fit on all samples).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from torquemap._callable import make_callable as _make_callable
from torquemap.above_passes import HOLD_SHARE, hold_share
from torquemap.errors import InputError
from torquemap.filters import (
    Derivatives,
    differentiate,
    differentiate_rates,
    smooth_as_acceleration,
)
from torquemap.free_law import mask_runs, pieces_around
from torquemap.friction import (
    FrictionFit,
    InertiaFit,
    Pass,
    angle_mean,
    fit_friction,
    fit_inertia,
    segment_motion,
)
from torquemap.io import Log
from torquemap.log_quirks import (
    check_angle_units,
    check_pass_torques,
    sub_revolution_line_warnings,
)
from torquemap.model import (
    InertiaModel,
    JointModel,
    Model,
    PdtvLine,
    friction_torque,
    pdtv_torque,
)
from torquemap.pdtv import (
    HarmonicFit,
    HarmonicNormals,
    LinePicks,
    PositionSignal,
    Spectrum,
    bins_per_revolution,
    discrete_position_signal,
    fit_harmonics,
    harmonic_normals,
    pick_lines,
    position_spectrum,
    solve_harmonics,
)
from torquemap.robot import Robot

if TYPE_CHECKING:
    from torquemap.vertical import ResidualPiece

TWO_PI = 2.0 * math.pi
BIN_MARGIN = 1.5  # samples per bin on average that a pass must provide to be used for PDTV
LAG_SIGNIFICANCE = 4.0  # a torque lag is kept only when it exceeds this many standard errors


@dataclass(frozen=True, slots=True, eq=False)
class JointIdentification:
    """Diagnostics of one joint's identification.

    Attributes
    ----------
    name
        Joint name.
    passes
        ``(log index, Pass)`` for every constant-speed pass found.
    pdtv_passes
        Indices into ``passes`` of those slow enough to be used for the PDTV.
    friction
        The friction fit (None when the joint never moved).
    inertia
        The inertia fit (None when the joint never moved).
    signal
        Position-domain PDTV residual (None when no PDTV was identified).
    spectrum
        Its spectrum in CPR.
    picks
        Lines picked from it.
    harmonics
        The least-squares harmonic fit of the kept lines (both directions together).
    bins_per_rev
        Position bins per motor revolution (0 when none).
    max_order
        Highest order searched [CPR].
    torque_lag
        Lag of the torque channel [s] found (0 when none).
    channel_delay
        Delay of the torque channel behind the position [s] undone before identification
        (0 when none; see ``identify_model(channel_delay=...)``).
    warnings
        One line each: what the data did not allow and what was assumed.
    """

    name: str
    passes: tuple[tuple[int, Pass], ...] = ()
    pdtv_passes: tuple[int, ...] = ()
    friction: FrictionFit | None = None
    inertia: InertiaFit | None = None
    signal: PositionSignal | None = None
    spectrum: Spectrum | None = None
    picks: LinePicks | None = None
    harmonics: HarmonicFit | None = None
    bins_per_rev: int = 0
    max_order: float = 0.0
    torque_lag: float = 0.0
    channel_delay: float = 0.0
    warnings: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True, eq=False)
class Identification:
    """Result of :func:`identify_model`.

    Attributes
    ----------
    model
        The identified model (joints not identified keep their input model).
    joints
        Diagnostics per identified joint.
    warnings
        Every joint's warnings, in order.
    """

    model: Model
    joints: Mapping[str, JointIdentification] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True, eq=False)
class _Samples:
    """Pass samples of one joint gathered over logs."""

    angle: NDArray[np.float64]
    torque: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    group: NDArray[np.int64]


def _derivatives(log: Log, robot: Robot, window: float) -> list[Derivatives]:
    out = []
    for k, joint in enumerate(robot.joints):
        try:
            out.append(differentiate(log.t, joint.gear_ratio * log.q[:, k], window=window))
        except InputError as exc:
            raise InputError(exc.message, path=log.path) from None
    return out


def _speed_p99(derivs: Sequence[Sequence[Derivatives]], joints: int) -> list[float]:
    """Per joint, the 99th percentile of its absolute motor speed [rad/s] over every piece."""
    return [
        float(np.percentile(np.concatenate([np.abs(d[k].velocity) for d in derivs]), 99))
        for k in range(joints)
    ]


def _still_mask(deriv: Sequence[Derivatives], k: int, p99: Sequence[float]) -> NDArray[np.bool_]:
    """Samples where every joint but ``k`` is still (slower than 5 % of joint k's speed)."""
    ok = np.ones(deriv[0].velocity.size, dtype=bool)
    for m, d in enumerate(deriv):
        if m != k:
            ok &= np.abs(d.velocity) < max(0.02 * p99[m], 0.05 * p99[k])
    return ok


def _identify_passes(
    robot: Robot | Model,
    logs: Sequence[Log],
    *,
    joints: Sequence[str] | None = None,
    max_order: float | None = None,
    window: float = 0.05,
    false_alarm: float = 0.01,
    stribeck: Literal["auto", "never", "always"] = "auto",
    direction_significance: float = 0.001,
    torque_lag: float | Literal["auto"] = 0.0,
    channel_delay: float | Literal["auto"] = "auto",
    derivatives: Sequence[Sequence[Derivatives]] | None = None,
    check: bool = True,
    p99: Sequence[float] | None = None,
) -> Identification:
    """:func:`identify_model` with ``friction="passes"`` on logs already sanitised.

    The paper's method (friction from the means of constant-speed passes, Eq 5). Parameters,
    result and errors as :func:`identify_model`'s; ``torque_lag`` [s] is the time constant of a
    first-order lag of the torque channel (``"auto"`` fits it, experimental), corrected by
    ``tau + lag * dtau/dt`` before PDTV and inertia. ``derivatives``: those of the logs'
    motor angles when already computed (a torque channel's delay undone leaves them as they
    are). ``check``: warn for each joint whose pass model explains the whole sweep, ramps
    included, significantly worse than a free law (:mod:`torquemap.pass_check`). ``p99``:
    :func:`_speed_p99` of ``derivatives`` when already computed.
    """
    model_in = robot if isinstance(robot, Model) else None
    rb = robot.robot if isinstance(robot, Model) else robot
    if not logs:
        raise InputError("no log given")
    names = list(rb.joint_names) if joints is None else list(joints)
    for name in names:
        rb.joint(name)
    derivs = [_derivatives(log, rb, window) for log in logs] if derivatives is None else derivatives
    if p99 is None or derivatives is None:
        p99 = _speed_p99(derivs, len(rb.joints))
    results: dict[str, JointIdentification] = {}
    new_joints: dict[str, JointModel] = (
        dict(model_in.joints) if model_in else {j.name: JointModel() for j in rb.joints}
    )
    for name in names:
        k = rb.joint_names.index(name)
        res, jm = _identify_joint(
            rb,
            k,
            logs,
            derivs,
            p99,
            max_order=max_order,
            false_alarm=false_alarm,
            stribeck=stribeck,
            direction_significance=direction_significance,
            window=window,
            torque_lag=torque_lag,
        )
        results[name] = res
        if jm is not None:
            new_joints[name] = jm
    if not any(r.passes for r in results.values()):
        raise InputError(
            "no joint moves at a steady speed in the logs; identification needs "
            "constant-speed sweeps: record each joint alone at several steady speeds, both "
            "directions, at least a quarter motor revolution per pass",
            path=logs[0].path if len(logs) == 1 else None,
        )
    if channel_delay == "auto" or channel_delay != 0:
        delays = {}
        for name, res in results.items():
            k = rb.joint_names.index(name)
            jm = new_joints.get(name)
            if channel_delay != "auto":
                delays[name] = float(channel_delay)
            elif jm is not None and res.passes:
                delays[name] = _estimate_joint_delay(rb, k, logs, derivs, res, jm, window, p99)
        if any(d != 0 for d in delays.values()):
            shifted = [_shift_log(log, rb, delays) for log in logs]
            again = _identify_passes(
                model_in if model_in is not None else rb,
                shifted,
                joints=joints,
                max_order=max_order,
                window=window,
                false_alarm=false_alarm,
                stribeck=stribeck,
                direction_significance=direction_significance,
                torque_lag=torque_lag,
                channel_delay=0.0,
                derivatives=derivs,
                check=False,
                p99=p99,
            )
            joints_out = {
                n: dataclasses.replace(r, channel_delay=delays.get(n, 0.0))
                for n, r in again.joints.items()
            }
            warnings = again.warnings
            if check:
                warnings += _check_joints(rb, shifted, derivs, joints_out, again.model, window, p99)
            notes = _notes(
                logs, joints_out, window=window, false_alarm=false_alarm, warnings=warnings
            )
            model = Model(robot=rb, joints=again.model.joints, notes=notes)
            return Identification(model=model, joints=joints_out, warnings=warnings)
    warnings = tuple(w for r in results.values() for w in r.warnings)
    model = Model(robot=rb, joints=new_joints)
    if check:
        warnings += _check_joints(rb, logs, derivs, results, model, window, p99)
    notes = _notes(logs, results, window=window, false_alarm=false_alarm, warnings=warnings)
    model = Model(robot=rb, joints=new_joints, notes=notes)
    return Identification(model=model, joints=results, warnings=warnings)


def _check_joints(
    rb: Robot,
    logs: Sequence[Log],
    derivs: Sequence[Sequence[Derivatives]],
    results: Mapping[str, JointIdentification],
    model: Model,
    window: float,
    p99: Sequence[float],
) -> tuple[str, ...]:
    """One warning per joint whose pass model explains the whole sweep significantly worse
    than a free law does (:func:`torquemap.pass_check.check_pass_model`)."""
    from torquemap.pass_check import check_pass_model

    out = []
    for name, res in results.items():
        if not res.passes:
            continue
        k = rb.joint_names.index(name)
        jm = model.joints[name]
        elbow_k = _elbow_joint(rb, k)
        slowest = min(abs(p.speed) for _, p in res.passes)
        ts, angles, accs, taus, rows, inert, mods = ([] for _ in range(7))
        for li, log in enumerate(logs):
            d = derivs[li][k]
            cos_e = np.cos(log.q[:, elbow_k]) if elbow_k is not None else np.zeros(log.t.size)
            ts.append(log.t)
            angles.append(d.position)
            accs.append(d.acceleration)
            taus.append(log.motor_torque[:, k])
            rows.append(_still_mask(derivs[li], k, p99) & (np.abs(d.velocity) > 0.5 * slowest))
            inert.append((jm.inertia.constant + jm.inertia.cos_elbow * cos_e) * d.acceleration)
            mods.append(cos_e)

        def law(
            angle: NDArray[np.float64], velocity: NDArray[np.float64], jm: JointModel = jm
        ) -> NDArray[np.float64]:
            return friction_torque(velocity, jm.friction) + pdtv_torque(
                angle, jm.pdtv, velocity=velocity
            )

        chk = check_pass_model(
            ts,
            angles,
            accs,
            taus,
            rows,
            law,
            inert,
            sorted({ln.order for ln in jm.pdtv}),
            window=window,
            inertia_modulation=mods if elbow_k is not None else None,
        )
        if not chk.consistent:
            out.append(
                f"joint {name}: the pass model does not explain the sweep (ramps included): its "
                f"residual is {1e3 * chk.rms_model:.3g} mN m against {1e3 * chk.rms_free:.3g} "
                f"mN m for a free friction law and inertia on the same samples (F = "
                f"{chk.f_statistic:.3g} on {chk.dof_model} and {chk.dof_residual:.0f} degrees "
                "of freedom, p < 1e-6): its friction law, inertia or delay is wrong; use the "
                "default whole-log fit (--friction whole)"
            )
    return tuple(out)


def _estimate_joint_delay(
    rb: Robot,
    k: int,
    logs: Sequence[Log],
    derivs: Sequence[Sequence[Derivatives]],
    res: JointIdentification,
    jm: JointModel,
    window: float,
    p99: Sequence[float],
) -> float:
    """The torque channel's delay of joint ``k`` [s], or 0 when not identifiable.

    Scored on every sample where the joint moves alone faster than half its slowest pass,
    ramps included, with friction, inertia and the PDTV amplitudes refitted at every trial
    delay (:func:`torquemap.delay.estimate_motion_delay`). Scoring the PDTV's phase on the
    passes with the friction and inertia identified before the delay was known
    (:func:`torquemap.delay.estimate_delay`) confounds the delay with those terms' errors: on
    a random bench with a 118 ms delay it found 68 ms, and the pass means, still carrying the
    ramps' torque, gave a viscous term 4x and an inertia 1/8 of the truth.
    """
    from torquemap.delay import estimate_motion_delay

    elbow_k = _elbow_joint(rb, k)
    slowest = min(abs(p.speed) for _, p in res.passes)
    ts, angles, accs, torques, rows, mods = [], [], [], [], [], []
    for li, log in enumerate(logs):
        d = derivs[li][k]
        ts.append(log.t)
        angles.append(d.position)
        accs.append(d.acceleration)
        torques.append(log.motor_torque[:, k])
        rows.append(_still_mask(derivs[li], k, p99) & (np.abs(d.velocity) > 0.5 * slowest))
        if elbow_k is not None:
            mods.append(np.cos(log.q[:, elbow_k]))
    orders = sorted({ln.order for ln in jm.pdtv})
    est = estimate_motion_delay(
        ts,
        angles,
        accs,
        torques,
        rows,
        orders,
        window=window,
        inertia_modulation=mods if elbow_k is not None else None,
        max_delay=max(0.25, 4 * window),
    )
    return est.delay


def _shift_log(log: Log, rb: Robot, delays: Mapping[str, float]) -> Log:
    """The log with each joint's torque channel read ``delays[joint]`` later."""
    from torquemap.delay import shift_channel

    tau = log.motor_torque.copy()
    for k, name in enumerate(rb.joint_names):
        d = delays.get(name, 0.0)
        if d != 0:
            tau[:, k] = shift_channel(log.t, tau[:, k], d)
    return dataclasses.replace(log, motor_torque=tau)


#: Pass samples whose acceleration exceeds this many robust standard deviations are ramp
#: samples inside a pass, not ripple (:func:`pass_ripple`).
RIPPLE_OUTLIER = 5.0


def pass_ripple(acceleration: NDArray[np.float64]) -> float:
    """The speed ripple of the passes as an acceleration RMS [rad/s^2]: of the pass samples
    within ``RIPPLE_OUTLIER`` robust standard deviations (``1.4826 median |a|``) of zero.

    A pass is where the revolution-averaged speed lies within 20 % of its run's
    (:func:`torquemap.friction.segment_motion`): a short fast pass between constant-acceleration
    ramps holds ramp samples. Their acceleration in a plain RMS made the ripple as large as a
    third of the ramps' (random SCARA 214: 95 rad/s^2, the ramps 283), so no ramp stood out of
    three ripples and the inertia was left at 0. A ripple (PDTV, noise) never reaches 5 robust
    standard deviations: a sinusoid's peak is 1.35 of them, so for a clean log the value is the
    plain RMS. Identification uses it only when no ramp sample clears three plain RMS (the
    plain RMS keeps the ramps' strong part alone, where a ramp's ends, smoothed by the
    differentiator, would bias the inertia).

    Examples
    --------
    >>> ripple = 2.0 * np.sin(np.linspace(0.0, 60.0, 3000))
    >>> round(pass_ripple(ripple), 2), round(pass_ripple(np.r_[ripple, np.full(900, 300.0)]), 2)
    (1.41, 1.41)
    """
    a = np.abs(np.asarray(acceleration, dtype=np.float64))
    if a.size == 0:
        return 0.0
    scale = 1.4826 * float(np.median(a))
    inside = a[a <= RIPPLE_OUTLIER * scale] if scale > 0 else a
    return float(np.sqrt(np.mean(inside**2))) if inside.size else 0.0


def _identify_joint(
    rb: Robot,
    k: int,
    logs: Sequence[Log],
    derivs: Sequence[Sequence[Derivatives]],
    p99: Sequence[float],
    *,
    max_order: float | None,
    false_alarm: float,
    stribeck: Literal["auto", "never", "always"],
    direction_significance: float,
    window: float,
    torque_lag: float | Literal["auto"],
) -> tuple[JointIdentification, JointModel | None]:
    joint = rb.joints[k]
    name = joint.name
    warnings: list[str] = []
    passes: list[tuple[int, Pass]] = []
    ramps: list[tuple[int, NDArray[np.bool_]]] = []
    thresholds = []
    # moving: faster than 2 % of the top speed, or than five velocity quanta when that is
    # lower (so that slow passes of a sweep that also runs fast are kept)
    resolution = _velocity_resolution(logs, joint.gear_ratio, k, window)
    moving = {k: min(0.02 * p99[k], 5.0 * resolution)}
    for li, (log, d) in enumerate(zip(logs, derivs, strict=True)):
        allowed = _still_mask(d, k, p99)
        seg = segment_motion(
            log.t,
            d[k].position,
            d[k].velocity,
            log.motor_torque[:, k],
            allowed=allowed,
            speed_threshold=moving[k],
            window=window,
        )
        passes.extend((li, p) for p in seg.passes)
        ramps.append((li, seg.accelerating & allowed & (np.abs(d[k].velocity) > moving[k])))
        thresholds.append(seg.speed_threshold)
    if not passes:
        warnings.append(f"joint {name} never moves at a steady speed: left unidentified")
        return JointIdentification(name=name, warnings=tuple(warnings)), None
    # Ramps identify inertia only where their acceleration stands out of the speed ripple of
    # the passes (PDTV makes the speed ripple, so ripple-driven acceleration is correlated with
    # the PDTV torque and would bias the inertia).
    in_passes = np.concatenate([derivs[li][k].acceleration[p.start : p.stop] for li, p in passes])
    ripple = float(np.sqrt(np.mean(in_passes**2)))
    cleared = [(li, m & (np.abs(derivs[li][k].acceleration) > 3.0 * ripple)) for li, m in ramps]
    if sum(int(m.sum()) for _, m in cleared) < 3:
        # no ramp clears the plain RMS: ramp samples inside short fast passes may have made
        # it (pass_ripple); the ripple of the pass samples without them
        ripple = pass_ripple(in_passes)
        cleared = [(li, m & (np.abs(derivs[li][k].acceleration) > 3.0 * ripple)) for li, m in ramps]
    ramps = cleared
    speeds = np.array([p.speed for _, p in passes])
    means = np.array([p.mean_torque for _, p in passes])
    # the sign of motion is trusted from two encoder counts per differentiator window on
    zero_velocity = 2.0 * resolution
    ff = fit_friction(speeds, means, stribeck=stribeck, zero_velocity=zero_velocity, joint=name)
    friction = ff.friction

    elbow_k = _elbow_joint(rb, k)

    # the torque's rate enters only through a lag (zero unless given or fitted)
    rates: list[NDArray[np.float64]] | None = None
    if torque_lag == "auto" or float(torque_lag) != 0.0:
        rates = [
            differentiate_rates(log.t, log.motor_torque[:, k], window=window).velocity
            for log in logs
        ]
    # the ramps are a few per cent of the samples: the inertia fit's torque is formed and
    # smoothed only around them (:func:`_stretches`), not over whole logs
    stretches = [(li, mask, _stretches(logs[li].t, mask, window)) for li, mask in ramps]

    def inertia_fit(pdtv: tuple[PdtvLine, ...], lag: float) -> InertiaFit:
        acc, y, elbow = [], [], []
        for li, mask, spans in stretches:
            d = derivs[li][k]
            for a, b in spans:
                sl = slice(a, b)
                tau = logs[li].motor_torque[sl, k]
                if lag:
                    assert rates is not None
                    tau = tau + lag * rates[li][sl]
                rest = tau - friction_torque(d.velocity[sl], friction)
                rest -= pdtv_torque(d.position[sl], pdtv, velocity=d.velocity[sl])
                # the differentiated acceleration is the true one smoothed over the window:
                # smooth the torque alike, or the fit is biased at every ramp's start and end
                rest = smooth_as_acceleration(logs[li].t[sl], rest, window=window)
                m = mask[sl]
                acc.append(d.acceleration[sl][m])
                y.append(rest[m])
                if elbow_k is not None:
                    elbow.append(logs[li].q[sl, elbow_k][m])
        none = np.empty(0)
        return fit_inertia(
            np.concatenate([none, *acc]),
            np.concatenate([none, *y]),
            elbow_angle=np.concatenate([none, *elbow]) if elbow_k is not None else None,
            joint=name,
        )

    inertia = inertia_fit((), 0.0)
    if inertia.samples >= 3:
        # A pass is never perfectly steady: remove the inertia torque from its mean and fit
        # the friction again (pass means otherwise carry J * mean acceleration).
        means = np.array(
            [
                _steady_mean(derivs[li][k], logs[li], k, p, inertia.inertia, elbow_k)
                for li, p in passes
            ]
        )
        ff = fit_friction(speeds, means, stribeck=stribeck, zero_velocity=zero_velocity, joint=name)
        friction = ff.friction
        inertia = inertia_fit((), 0.0)
    # the warnings of the law the model keeps (the first fit's may not hold after the refit)
    warnings.extend(ff.warnings)
    lines: tuple[PdtvLine, ...] = ()
    pd = _identify_pdtv(
        rb,
        k,
        logs,
        derivs,
        passes,
        friction_model=friction,
        inertia_model=inertia.inertia,
        elbow_k=elbow_k,
        max_order=max_order,
        false_alarm=false_alarm,
        direction_significance=direction_significance,
        torque_rates=rates,
        torque_lag=torque_lag,
    )
    lines = pd.lines
    warnings.extend(pd.warnings)
    if inertia.samples >= 3 and (lines or pd.torque_lag):
        inertia = inertia_fit(lines, pd.torque_lag)
    warnings.extend(inertia.warnings)
    jm = JointModel(inertia=inertia.inertia, friction=friction, pdtv=lines)
    res = JointIdentification(
        name=name,
        passes=tuple(passes),
        pdtv_passes=pd.used,
        friction=ff,
        inertia=inertia,
        signal=pd.signal,
        spectrum=pd.spectrum,
        picks=pd.picks,
        harmonics=pd.harmonics,
        bins_per_rev=pd.bins_per_rev,
        max_order=pd.max_order,
        torque_lag=pd.torque_lag,
        warnings=tuple(warnings),
    )
    return res, jm


def _stretches(
    t: NDArray[np.float64], mask: NDArray[np.bool_], window: float
) -> list[tuple[int, int]]:
    """``(start, stop)`` of stretches that hold every True sample of ``mask`` with a
    differentiator ``window`` [s] (and 3 samples) either side, those within
    :data:`torquemap.free_law.JOIN` samples of each other merged, cut at the log's ends
    (:func:`torquemap.free_law.pieces_around` of the mask's runs).

    A filter whose output at a sample depends only on the samples within half a window of
    it (:func:`torquemap.filters.smooth_as_acceleration`, which annihilates the constant and
    slope that the double integral carries in from earlier samples) gives the same answer
    on such a stretch as on the whole log, to rounding; a stretch that reaches a log's end
    is cut there, where the whole log's filter shifts its window too.

    Examples
    --------
    >>> t = np.arange(10000) * 0.01
    >>> mask = np.zeros(10000, bool); mask[[20, 30, 9000]] = True
    >>> _stretches(t, mask, 0.05)
    [(13, 38), (8992, 9009)]
    """
    return pieces_around(t, mask_runs(mask), margin=window)


def _elbow_joint(rb: Robot, k: int) -> int | None:
    """The joint whose cosine modulates joint ``k``'s inertia (``InertiaModel.cos_elbow``).

    The arm says where the modulation applies (:meth:`torquemap.robots.Arm.inertia_modulation`
    at the zero pose); the modulating angle is the next joint's (the elbow of a planar arm).
    """
    nj = len(rb.joints)
    if k + 1 >= nj:
        return None
    at_zero = rb.arm.inertia_modulation(np.zeros((1, nj)))[0, k]
    return k + 1 if at_zero != 0 else None


def _steady_mean(
    d: Derivatives, log: Log, k: int, p: Pass, inertia: InertiaModel, elbow_k: int | None
) -> float:
    """Angle-averaged ``torque - J(q) * acceleration`` over one pass [N m]."""
    sl = slice(p.start, p.stop)
    elbow = log.q[sl, elbow_k] if elbow_k is not None else np.zeros(p.stop - p.start)
    j = inertia.constant + inertia.cos_elbow * np.cos(elbow)
    mean, _ = angle_mean(d.position[sl], log.motor_torque[sl, k] - j * d.acceleration[sl])
    return mean


def _counts_per_rev(logs: Sequence[Log], gear_ratio: float, k: int, declared: int | None) -> int:
    """Encoder counts per motor revolution: the robot file's, else 2 pi / the smallest step."""
    if declared:
        return int(declared)
    quantum = math.inf
    for log in logs:
        step = np.abs(np.diff(gear_ratio * log.q[:, k]))
        step = step[step > 1e-12]
        if step.size:
            quantum = min(quantum, float(np.min(step)))
    if not math.isfinite(quantum):
        return 1 << 30
    return max(round(2 * math.pi / quantum), 1)


def _velocity_resolution(logs: Sequence[Log], gear_ratio: float, k: int, window: float) -> float:
    """Velocity resolution of the differentiator [rad/s], motor side.

    One position quantum (the smallest step of the motor angle in the logs, the encoder count)
    per differentiator window. Friction at rest is not a function of velocity, and below a few
    of these the sign of motion is unknown: the friction blend through zero spans two.
    """
    quantum = math.inf
    for log in logs:
        step = np.abs(np.diff(gear_ratio * log.q[:, k]))
        step = step[step > 1e-12]
        if step.size:
            quantum = min(quantum, float(np.min(step)))
    if not math.isfinite(quantum):
        return 1e-3
    return max(quantum / window, 1e-6)


@dataclass(frozen=True, slots=True, eq=False)
class _PdtvResult:
    lines: tuple[PdtvLine, ...] = ()
    used: tuple[int, ...] = ()
    signal: PositionSignal | None = None
    spectrum: Spectrum | None = None
    picks: LinePicks | None = None
    harmonics: HarmonicFit | None = None
    bins_per_rev: int = 0
    max_order: float = 0.0
    torque_lag: float = 0.0
    warnings: tuple[str, ...] = ()


def resolvable_order(samples_per_rev: float) -> int:
    """Highest order [CPR] a pass with ``samples_per_rev`` samples per motor revolution resolves.

    Examples
    --------
    >>> resolvable_order(14700.0)
    4095
    """
    return bins_per_revolution(samples_per_rev, margin=BIN_MARGIN) // 2 - 1


def _identify_pdtv(
    rb: Robot,
    k: int,
    logs: Sequence[Log],
    derivs: Sequence[Sequence[Derivatives]],
    passes: Sequence[tuple[int, Pass]],
    *,
    friction_model: Any,
    inertia_model: InertiaModel,
    elbow_k: int | None,
    max_order: float | None,
    false_alarm: float,
    direction_significance: float,
    torque_rates: Sequence[NDArray[np.float64]] | None,
    torque_lag: float | Literal["auto"],
) -> _PdtvResult:
    name = rb.joints[k].name
    best = max(p.samples_per_rev for _, p in passes)
    # Position ripple finer than a few encoder counts is quantisation, not torque: its lines sit
    # at the count rate and its harmonics. Search at most an eighth of the counts per revolution.
    counts = _counts_per_rev(logs, rb.joints[k].gear_ratio, k, rb.joints[k].encoder_counts_per_rev)
    limit = min(resolvable_order(best), max(counts // 8, 1))
    if max_order is not None:
        if max_order > limit:
            slowest = min(abs(p.speed) for _, p in passes)
            raise InputError(
                f"joint {name}: the slowest pass ({slowest:.4g} rad/s at the motor) gives "
                f"{best:.0f} samples per motor revolution, which resolves PDTV orders up to "
                f"{limit} CPR; max order {max_order:g} needs a slower sweep (at most "
                f"{slowest * (limit + 1) / (max_order + 1):.4g} rad/s)",
                path=logs[0].path if len(logs) == 1 else None,
            )
        nb = 2 ** math.ceil(math.log2(2 * (math.floor(max_order) + 1)))
        top = float(max_order)
    else:
        nb = bins_per_revolution(best, margin=BIN_MARGIN)
        top = float(limit)
    if top < 1:
        return _PdtvResult(
            warnings=(f"joint {name}: the sweep is too fast to resolve any PDTV order",)
        )
    used = tuple(i for i, (_, p) in enumerate(passes) if p.samples_per_rev >= BIN_MARGIN * nb)
    if not used:
        used = (int(np.argmax([p.samples_per_rev for _, p in passes])),)
    angle, resid, group, direction, rates, speeds = [], [], [], [], [], []
    for i in used:
        li, p = passes[i]
        d = derivs[li][k]
        s = slice(p.start, p.stop)
        j: float | NDArray[np.float64] = inertia_model.constant
        if elbow_k is not None:
            j = inertia_model.constant + inertia_model.cos_elbow * np.cos(logs[li].q[s, elbow_k])
        r = (
            logs[li].motor_torque[s, k]
            - j * d.acceleration[s]
            - friction_torque(d.velocity[s], friction_model)
        )
        r = r - angle_mean(d.position[s], r)[0]
        angle.append(d.position[s])
        resid.append(r)
        group.append(np.full(r.size, i))
        rates.append(torque_rates[li][s] if torque_rates is not None else np.zeros(r.size))
        direction.append(np.full(r.size, 1 if p.direction == "positive" else -1))
        speeds.append(np.full(r.size, p.speed))
    theta = np.concatenate(angle)
    res = np.concatenate(resid)
    grp = np.concatenate(group)
    sgn = np.concatenate(direction)
    rate = np.concatenate(rates)
    signal = discrete_position_signal(theta, res, bin_width=TWO_PI / nb)
    revs = signal.value.size / nb
    if revs < 0.5:
        return _PdtvResult(
            used=used,
            signal=signal,
            bins_per_rev=nb,
            max_order=top,
            warnings=(
                f"joint {name}: the slow passes cover {revs:.2g} motor revolutions, under the "
                "half revolution a PDTV spectrum needs: no PDTV identified",
            ),
        )
    lag = 0.0 if torque_lag == "auto" else float(torque_lag)
    raw = res
    for _ in range(3):
        res = raw + lag * rate
        signal = discrete_position_signal(theta, res, bin_width=TWO_PI / nb)
        spectrum = position_spectrum(signal, max_order=top)
        picks = pick_lines(spectrum, false_alarm=false_alarm)
        picked_at = lag
        if torque_lag != "auto" or picks.order.size == 0:
            break
        # measured = true - T d(measured)/dt (a first-order lag T): fit T with the lines
        # every integer order up to the highest line, so the lag cannot stand in for lines
        # the first pick missed
        dense = [float(o) for o in range(1, int(np.ceil(picks.order.max())) + 1)]
        dense += [float(o) for o in picks.order if o != round(o)]
        lf = fit_harmonics(theta, raw, orders=dense, groups=grp, extra=-rate)
        new = float(lf.extra[0])
        new = new if new > LAG_SIGNIFICANCE * float(lf.extra_se[0]) else 0.0
        if abs(new - lag) <= 0.01 * max(abs(new), 1e-12):
            lag = new
            break
        lag = new
    if lag != picked_at:  # the last pick was made at another lag: again at this one
        res = raw + lag * rate
        signal = discrete_position_signal(theta, res, bin_width=TWO_PI / nb)
        spectrum = position_spectrum(signal, max_order=top)
        picks = pick_lines(spectrum, false_alarm=false_alarm)
    orders = [float(o) for o in picks.order]
    fit = None
    normals = None
    if orders:
        # one pass over the samples for every fit below: all picked orders, then the kept
        # ones, then each direction (:func:`~torquemap.pdtv.solve_harmonics`)
        normals = harmonic_normals(theta, res, orders=orders, groups=grp, split=sgn > 0)
        fit = solve_harmonics(normals)
        thr = np.interp(fit.order, spectrum.order, picks.threshold)
        keep = fit.amplitude > thr
        if not keep.all() and keep.any():
            fit = solve_harmonics(normals, orders=list(fit.order[keep]))
        elif not keep.any():
            fit = None
    notes: tuple[str, ...] = ()
    if fit is not None and normals is not None:
        fit, notes = _without_time_lines(
            name, theta, res, grp, np.concatenate(speeds), normals, fit
        )
    if fit is None or normals is None:
        return _PdtvResult(
            used=used,
            signal=signal,
            spectrum=spectrum,
            picks=picks,
            bins_per_rev=nb,
            max_order=top,
            torque_lag=lag,
            warnings=notes,
        )
    lines = _directional_lines(normals, grp, sgn, fit, direction_significance)
    return _PdtvResult(
        lines=lines,
        used=used,
        signal=signal,
        spectrum=spectrum,
        picks=picks,
        harmonics=fit,
        bins_per_rev=nb,
        max_order=top,
        torque_lag=lag,
        warnings=notes,
    )


def _without_time_lines(
    name: str,
    theta: NDArray[np.float64],
    res: NDArray[np.float64],
    grp: NDArray[np.int64],
    speed: NDArray[np.float64],
    normals: HarmonicNormals,
    fit: HarmonicFit,
) -> tuple[HarmonicFit | None, tuple[str, ...]]:
    """``fit`` without the picked orders that follow time, not the motor angle (present at
    one pass speed, absent at another: :mod:`torquemap.time_lines`), and a warning per order
    left out."""
    from torquemap.time_lines import time_frequency_lines

    timed = time_frequency_lines(theta, res, orders=list(fit.order), groups=grp, speed=speed)
    if not timed:
        return fit, ()
    notes = tuple(
        f"joint {name}: the {ln.order:g} CPR line of the {ln.speed:.3g} rad/s passes "
        f"({ln.present:.3g} N m) is absent at {ln.absent_speed:.3g} rad/s "
        f"({ln.absent:.2g} N m): a ripple of {ln.frequency:.4g} Hz in time (the current "
        "loop, PWM, mains), not of the motor angle; left out of PDTV"
        for ln in timed
    )
    dropped = {ln.order for ln in timed}
    rest = [float(o) for o in fit.order if float(o) not in dropped]
    return (solve_harmonics(normals, orders=rest) if rest else None), notes


def _directional_lines(
    normals: HarmonicNormals,
    grp: NDArray[np.int64],
    sgn: NDArray[np.int64],
    fit: HarmonicFit,
    significance: float,
) -> tuple[PdtvLine, ...]:
    """Lines per direction where the two directions differ significantly, else "both".

    A line differs when the chi-square of the difference of its cosine/sine coefficients
    (2 degrees of freedom, covariances of the two independent fits) exceeds the
    ``1 - significance / p`` quantile (Bonferroni over the p lines) and the amplitudes differ
    by more than 10 % of the larger: statistically and practically significant. The fits
    come from ``normals``, accumulated with the split ``sgn > 0`` (part 1: positive).
    """
    from scipy import stats

    both = tuple(
        PdtvLine(order=float(o), amplitude=float(a), phase=float(ph))
        for o, a, ph in zip(fit.order, fit.amplitude, fit.phase, strict=True)
    )
    pos, neg = sgn > 0, sgn < 0
    n_unknown = 2 * fit.order.size + np.unique(grp).size + 1
    if pos.sum() < n_unknown or neg.sum() < n_unknown:
        return both
    orders = list(fit.order)
    fp = solve_harmonics(normals, orders=orders, parts=[1])
    fn = solve_harmonics(normals, orders=orders, parts=[0])
    crit = stats.chi2.ppf(1.0 - significance / fit.order.size, 2)
    lines: list[PdtvLine] = []
    for i, line in enumerate(both):
        delta = fp.cos_sin[i] - fn.cos_sin[i]
        cov = fp.covariance[i] + fn.covariance[i]
        chi = float(delta @ np.linalg.pinv(cov) @ delta)
        big = max(fp.amplitude[i], fn.amplitude[i])
        if chi > crit and np.hypot(*delta) > 0.1 * big:
            for f, direction in ((fp, "positive"), (fn, "negative")):
                lines.append(
                    PdtvLine(
                        order=line.order,
                        amplitude=float(f.amplitude[i]),
                        phase=float(f.phase[i]),
                        direction=direction,  # type: ignore[arg-type]
                    )
                )
        else:
            lines.append(line)
    return tuple(lines)


def motor_torque_level(logs: Sequence[Log], name: str) -> float | None:
    """The 99th percentile of ``|motor torque|`` [N m] of joint ``name`` over ``logs`` (rounded
    to 4 digits), or None where no log holds the joint or the level is not positive:
    ``estimate`` compares a log's with it (:func:`torquemap.estimate.torque_scale_warnings`)."""
    parts = [
        np.abs(log.motor_torque[:, log.joint_names.index(name)])
        for log in logs
        if name in log.joint_names
    ]
    if not parts:
        return None
    level = float(np.percentile(np.concatenate(parts), 99))
    return float(f"{level:.4g}") if math.isfinite(level) and level > 0 else None


def _notes(
    logs: Sequence[Log],
    results: Mapping[str, JointIdentification],
    *,
    window: float,
    false_alarm: float,
    warnings: tuple[str, ...],
) -> dict[str, Any]:
    joints: dict[str, Any] = {}
    for name, r in results.items():
        entry: dict[str, Any] = {
            "passes": len(r.passes),
            "speeds": [round(p.speed, 6) for _, p in r.passes],
            "pdtv_speeds": [round(r.passes[i][1].speed, 6) for i in r.pdtv_passes],
            "bins_per_rev": r.bins_per_rev,
            "max_order": r.max_order,
            "torque_lag": r.torque_lag,
            "channel_delay": r.channel_delay,
        }
        if r.friction is not None:
            entry["stribeck"] = r.friction.stribeck_used
        if r.spectrum is not None:
            entry["spectrum_revolutions"] = round(r.spectrum.revolutions, 6)
        if r.picks is not None:
            entry["threshold_multiple"] = round(r.picks.multiple, 4)
        if r.inertia is not None:
            entry["inertia_samples"] = r.inertia.samples
        level = motor_torque_level(logs, name)
        if level is not None:
            entry["motor_torque_p99"] = level
        joints[name] = entry
    return {
        "logs": [log.path for log in logs],
        "differentiation_window": window,
        "false_alarm": false_alarm,
        "warnings": list(warnings),
        "joints": joints,
    }


FrictionMethod = Literal["whole", "passes"]
FRICTION_METHODS: tuple[FrictionMethod, ...] = ("whole", "passes")


def identify_model(
    robot: Robot | Model,
    logs: Sequence[Log],
    *,
    joints: Sequence[str] | None = None,
    max_order: float | None = None,
    window: float = 0.05,
    false_alarm: float = 0.01,
    stribeck: Literal["auto", "never", "always"] = "auto",
    direction_significance: float = 0.001,
    torque_lag: float | Literal["auto"] = 0.0,
    channel_delay: float | Literal["auto"] = "auto",
    friction: FrictionMethod = "whole",
    vertical: Literal["refuse", "warn"] = "refuse",
    low_speed_rows: bool | None = None,
    stribeck_prior: bool | Literal["select"] | None = None,
) -> Identification:
    """Identify inertia, friction and PDTV of a robot's joints from no-load logs.

    Every log is first sanitised (:func:`torquemap.sanitize.sanitize_log`: repeated time
    stamps dropped, implausible samples bridged and left out, the log cut at gaps the filters
    cannot bridge). Then the constant-speed passes are found and the PDTV lines picked from
    their position-domain spectrum (the paper's method, docs/identification.md). With
    ``friction="whole"`` friction, inertia, the PDTV lines' amplitudes and the torque
    channel's delay are then fitted to every sample of the logs at once
    (:func:`torquemap.identify_whole.fit_joint_whole`): friction through zero speed with a
    smooth transition whose width is identified, a parameter covariance and the residual noise
    recorded in the model's notes for estimation's sigmas. ``friction="passes"`` (default)
    keeps the paper's pass method (friction from the pass means, Eq 5).

    Parameters
    ----------
    robot
        The robot, or a model whose non-identified joints are kept.
    logs
        No-load logs read with :func:`torquemap.io.read_log` for this robot.
    joints
        Joint names to identify; default all.
    max_order
        Highest PDTV order [CPR]; default the resolvable limit of the slowest pass.
    window
        Differentiation window [s] (:func:`torquemap.filters.differentiate`).
    false_alarm
        Probability that noise alone yields a spurious PDTV line, per joint.
    stribeck
        Stribeck term: ``"auto"`` (F test), ``"never"`` or ``"always"``.
    direction_significance
        Level of the test that a line differs between directions (Bonferroni over lines).
    torque_lag
        Pass method only: time constant [s] of a first-order lag of the torque channel
        (``"auto"`` fits it, experimental).
    channel_delay
        Pure time delay [s] of the torque (current) channel behind the position channel;
        ``"auto"`` (default) estimates it (whole: searched in the whole-log fit, kept when
        significant; passes: :func:`torquemap.delay.estimate_delay`).
    friction
        ``"whole"`` (default) or ``"passes"``.
    vertical
        What to do when a joint's no-load torque holds a large component that depends on the
        joint angles (gravity: a vertical arm, which the model cannot represent): ``"refuse"``
        (InputError) or ``"warn"``.
    low_speed_rows
        ``friction="whole"``: fit the friction table also on the slow, steady rows below half
        the slowest pass (slow ramps; :func:`torquemap.identify_whole.fit_joint_whole`). None:
        :data:`torquemap.identify_whole.LOW_SPEED_ROWS` (on).
    stribeck_prior
        ``friction="whole"``: centre the friction table's smoothness prior on a generalized
        Stribeck curve per direction (:mod:`torquemap.friction_prior`). ``"select"``: per
        direction, only where, with the slowest steady pass left out, that fit predicts the
        pass better (:mod:`torquemap.prior_choice`). None:
        :data:`torquemap.identify_whole.STRIBECK_PRIOR` (``"select"``).

    Returns
    -------
    Identification
        The model and per-joint diagnostics.

    Raises
    ------
    InputError
        No log, an unknown joint, a log shorter than the differentiation window, no motion at
        all, ``max_order`` beyond what the slowest pass resolves, or a vertical arm.
    """
    from torquemap.sanitize import no_stretch_message, sanitize_log

    if friction not in FRICTION_METHODS:
        raise InputError(f"unknown friction method {friction!r} (choose whole or passes)")
    if not logs:
        raise InputError("no log given")
    if not (math.isfinite(window) and window > 0):
        raise InputError(f"differentiation window must be positive, got {window!r} s")
    rb = robot.robot if isinstance(robot, Model) else robot
    check_angle_units(logs, rb)
    pieces: list[Log] = []
    sound: list[NDArray[np.bool_]] = []
    cleaning: list[str] = []
    for log in logs:
        span = float(log.t[-1] - log.t[0]) if log.t.size else 0.0
        if span < window or log.t.size < 5:
            raise InputError(
                f"log lasts {span:.3g} s ({log.t.size} samples), shorter than the "
                f"differentiation window {window:.3g} s; record at least a few seconds of "
                "motion per joint (sweeps at several steady speeds, both directions)",
                path=log.path,
            )
        clean = sanitize_log(log, window=window)
        cleaning.extend(f"{log.path}: {w}" for w in clean.warnings)
        for piece in clean.pieces:
            pieces.append(piece.log)
            sound.append(~clean.implausible[piece.rows])
        if not clean.pieces:
            raise InputError(no_stretch_message(log.t, window), path=log.path)
    # the pieces' motor-angle derivatives, once: the pass fit and the vertical-arm check
    derivs = [_derivatives(piece, rb, window) for piece in pieces]
    p99 = _speed_p99(derivs, len(rb.joints))  # the pass method's and the whole fit's
    base = _identify_passes(
        robot,
        pieces,
        joints=joints,
        max_order=max_order,
        window=window,
        false_alarm=false_alarm,
        stribeck=stribeck,
        direction_significance=direction_significance,
        torque_lag=torque_lag,
        channel_delay=channel_delay,
        derivatives=derivs,
        check=friction == "passes",
        p99=p99,
    )
    one = logs[0].path if len(logs) == 1 else None
    signs = check_pass_torques(
        [(name, [p for _, p in j.passes]) for name, j in base.joints.items()], rb, path=one
    )
    cleaning += [f"{one}: {w}" if one else w for w in signs]
    quanta = {j.name: _motor_quantum(pieces, j.gear_ratio, k) for k, j in enumerate(rb.joints)}
    joint_notes = base.model.notes.get("joints", {})
    constants = {j.name: j.torque_constant for j in rb.joints}
    for name, entry in joint_notes.items():
        if isinstance(entry, dict) and quanta.get(name):
            entry["motor_angle_quantum"] = quanta[name]
        if isinstance(entry, dict) and name in constants:
            # the N m/A the logs' currents were read with: a model whose constant is edited
            # later is refused (torquemap.model), its N m being those of this one
            entry["torque_constant"] = constants[name]
    signals = None
    if friction == "passes":
        warnings = (*cleaning, *base.warnings)
        notes = dict(base.model.notes)
        notes["logs"] = [log.path for log in logs]
        notes["warnings"] = list(warnings)
        notes["friction_fit"] = "passes"
        model = Model(robot=rb, joints=base.model.joints, notes=notes)
        ident = Identification(model=model, joints=base.joints, warnings=warnings)
    else:
        ident, signals = _identify_whole(
            rb,
            base,
            pieces,
            sound,
            logs,
            window=window,
            stribeck=stribeck,
            direction_significance=direction_significance,
            channel_delay=channel_delay,
            cleaning=cleaning,
            vertical=vertical,
            derivatives=derivs,
            low_speed_rows=low_speed_rows,
            stribeck_prior=stribeck_prior,
            p99=p99,
        )
    # a vertical arm (gravity), for every friction method: torquemap.vertical
    from torquemap.vertical import checked_identification

    path = logs[0].path if len(logs) == 1 else None
    checked = checked_identification(
        ident,
        pieces,
        window=window,
        vertical=vertical,
        path=path,
        derivatives=derivs,
        residuals=signals,
    )
    unit = sub_revolution_line_warnings(checked.model)
    if not unit:
        return checked
    warnings = (*checked.warnings, *unit)
    notes = {**checked.model.notes, "warnings": list(warnings)}
    model = dataclasses.replace(checked.model, notes=notes)
    return dataclasses.replace(checked, model=model, warnings=warnings)


def _identify_whole(
    rb: Robot,
    base: Identification,
    pieces: Sequence[Log],
    sound: Sequence[NDArray[np.bool_]],
    logs: Sequence[Log],
    *,
    window: float,
    stribeck: Literal["auto", "never", "always"],
    direction_significance: float,
    channel_delay: float | Literal["auto"],
    cleaning: Sequence[str],
    vertical: Literal["refuse", "warn"],
    derivatives: Sequence[Sequence[Derivatives]],
    low_speed_rows: bool | None = None,
    stribeck_prior: bool | Literal["select"] | None = None,
    p99: Sequence[float] | None = None,
) -> tuple[Identification, dict[str, list[ResidualPiece]]]:
    """The whole-log fit of every joint the pass method identified, and the model's no-load
    residuals on ``pieces`` (:func:`torquemap.vertical.no_load_residuals`, every piece), which
    the noise levels and the vertical-arm check share. ``p99``: :func:`_speed_p99` of
    ``derivatives`` when already computed."""
    from torquemap import identify_whole as iw

    derivs = derivatives
    nj = len(rb.joints)
    if p99 is None:
        p99 = _speed_p99(derivs, nj)
    top = [
        float(np.max(np.concatenate([np.abs(d[k].velocity) for d in derivs]))) for k in range(nj)
    ]
    new_joints = dict(base.model.joints)
    notes = dict(base.model.notes)
    joint_notes = {k: dict(v) for k, v in notes.get("joints", {}).items()}
    results = dict(base.joints)
    warnings: list[str] = [*cleaning, *base.warnings]
    planar = rb.arm.kind == "planar2r"
    for name, res in base.joints.items():
        k = rb.joint_names.index(name)
        joint = rb.joints[k]
        elbow_k = _elbow_joint(rb, k)
        wp: list[iw.Piece] = []
        for log, d, ok in zip(pieces, derivs, sound, strict=True):
            use = _still_mask(d, k, p99) & ok
            elbow = log.q[:, elbow_k] if elbow_k is not None else np.zeros(log.t.size)
            wp.append(
                iw.Piece(
                    t=log.t,
                    theta=joint.gear_ratio * log.q[:, k],
                    velocity=d[k].velocity,
                    acceleration=d[k].acceleration,
                    torque=log.motor_torque[:, k],
                    elbow=elbow,
                    use=use,
                    joint_angles=log.q,
                )
            )
        resolution = _velocity_resolution(pieces, joint.gear_ratio, k, window)
        # at rest friction is anything within its band (static friction): such samples say
        # nothing about the law and would pull the Coulomb levels towards the holding torque
        for p in wp:
            p.use[np.abs(p.velocity) < 3.0 * resolution] = False
        # counted at speed: a joint held still (only encoder noise) has nothing to fit
        if sum(int(p.use.sum()) for p in wp) < 50 or top[k] <= 0:
            warnings.append(f"joint {name}: too few samples where it alone moves: left as it was")
            continue
        jm = base.model.joints[name]
        orders = sorted({ln.order for ln in jm.pdtv})
        elbow_term = False
        if elbow_k is not None:
            c = np.concatenate([np.cos(p.elbow[p.use]) for p in wp])
            elbow_term = bool(c.size and float(c.max() - c.min()) >= 0.2)
        both_ways = any(p.direction == "positive" for _, p in res.passes) and any(
            p.direction == "negative" for _, p in res.passes
        )
        fit = iw.fit_joint_whole(
            wp,
            orders,
            window=window,
            resolution=resolution,
            top_speed=top[k],
            elbow_term=elbow_term,
            stribeck=stribeck,
            delay=channel_delay,
            reference_delay=res.channel_delay if channel_delay == "auto" else None,
            joint=name,
            gravity_check=k if joint.gear_ratio > 1.0 else None,
            inertia=True,
            directional=both_ways,
            max_order=float(res.max_order),
            planar=planar,
            direction_significance=direction_significance,
            slowest_speed=min((abs(p.speed) for _, p in res.passes), default=0.0),
            steady_speeds=[abs(p.speed) for _, p in res.passes],
            held_inertia=_determined_inertia(res),
            pass_speeds=[p.speed for _, p in res.passes],
            held_speeds=[
                p.speed
                for li, p in res.passes
                if hold_share(derivs[li][k].velocity[p.start : p.stop], p.speed) >= HOLD_SHARE
            ],
            low_speed_rows=low_speed_rows,
            stribeck_prior=stribeck_prior,
            handed=_handed_lines(res),
        )
        # the pass method's friction law is replaced: its warnings (a Stribeck term it could
        # not use, a Coulomb level it clipped) no longer describe the model
        if res.friction is not None:
            dropped = set(res.friction.warnings)
            warnings = [w for w in warnings if w not in dropped]
        # nor its inertia's "no accelerating segment" when the whole fit found one (slow ramps
        # give the pass method no ramp that stands out of the passes' speed ripple; the whole
        # fit reads every row)
        if (
            res.inertia is not None
            and res.inertia.samples < 3
            and fit.value("inertia.constant") > 0
        ):
            dropped = set(res.inertia.warnings)
            warnings = [w for w in warnings if w not in dropped]
        warnings.extend(fit.warnings)
        coulomb = 0.5 * float(np.sum(fit.law.levels(np.array([fit.observed_speed]))))
        # a warning only: torquemap.vertical (every method, with nuisance columns for the
        # friction a model may miss) decides whether to refuse
        if fit.gravity_significant and fit.gravity_torque > 0.5 * max(coulomb, 1e-300):
            msg = (
                f"joint {name}: the no-load torque holds {fit.gravity_torque:.3g} N m (motor "
                "side, peak to peak) that depends on the joint angles, which PDTV of the motor "
                "angle cannot explain: a vertical arm (gravity)? The model has no gravity term; "
                "record the sweeps with the arm horizontal, or use a robot file that models "
                "gravity"
            )
            warnings.append(msg)
        new_joints[name] = _whole_joint_model(fit)
        entry = joint_notes.get(name, {})
        entry.update(_whole_notes(fit, resolution))
        joint_notes[name] = entry
        results[name] = dataclasses.replace(res, channel_delay=fit.delay)
    notes["joints"] = joint_notes
    notes["logs"] = [log.path for log in logs]
    notes["warnings"] = list(warnings)
    notes["friction_fit"] = "whole"
    model = Model(robot=rb, joints=new_joints, notes=notes)
    # the logs' noise level above the estimate's band, which estimation compares a log's with
    levels, tones, signals = _noise_levels(model, pieces, derivs, window)
    for name, high in levels.items():
        joint_notes[name]["uncertainty"]["noise_high_psd"] = high
    for name, found in tones.items():
        joint_notes[name]["uncertainty"]["tones"] = [[x.frequency, x.amplitude] for x in found]
    model = Model(robot=rb, joints=new_joints, notes=notes)
    return Identification(model=model, joints=results, warnings=tuple(warnings)), signals


def _handed_lines(
    res: JointIdentification,
) -> dict[float, tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """The pass method's PDTV lines (both directions together): order [CPR] -> (cosine and
    sine coefficients [N m], their covariance), which the whole fit tests its own against
    (:func:`torquemap.identify_whole._unearned_lines`)."""
    h = res.harmonics
    if h is None:
        return {}
    return {float(o): (h.cos_sin[i], h.covariance[i]) for i, o in enumerate(h.order)}


def _determined_inertia(res: JointIdentification) -> tuple[float, float] | None:
    """The pass method's inertia and its standard error [kg m^2] when its ramps determine it
    (2 standard errors above 0), else None."""
    fit = res.inertia
    if fit is None or fit.samples < 3:
        return None
    value, se = fit.inertia.constant, fit.standard_error[0]
    return (float(value), float(se)) if value > 2.0 * se else None


def _whole_joint_model(fit: Any) -> JointModel:
    """The joint model of a whole-log fit (:class:`torquemap.identify_whole.WholeFit`)."""
    inertia = InertiaModel(
        constant=fit.value("inertia.constant"), cos_elbow=fit.value("inertia.cos_elbow")
    )
    lines: list[PdtvLine] = []
    for order, directional in fit.orders:
        for direction in ("positive", "negative") if directional else ("both",):
            a = fit.value(f"pdtv.{order:g}.{direction}.a")
            b = fit.value(f"pdtv.{order:g}.{direction}.b")
            lines.append(
                PdtvLine(
                    order=float(order),
                    amplitude=float(math.hypot(a, b)),
                    phase=float(math.atan2(-b, a)),
                    direction=direction,
                )
            )
    return JointModel(inertia=inertia, friction=fit.law, pdtv=tuple(lines))


def _noise_levels(
    model: Model,
    pieces: Sequence[Log],
    derivs: Sequence[Sequence[Derivatives]],
    window: float,
) -> tuple[dict[str, float], dict[str, tuple[Any, ...]], dict[str, list[ResidualPiece]]]:
    """Per joint with a whole-fit uncertainty table, the white-noise PSD [N^2 m^2/Hz] above the
    estimate's band of the pieces' Eq 7 signal less PDTV (:func:`torquemap.uncertainty.
    noise_level`, the estimate's own signal: :func:`torquemap.vertical.no_load_residuals`),
    weighted by the pieces' sample counts, and the same signal's fixed-frequency lines
    (:func:`torquemap.tones.find_tones`, which a slower logger folds into the estimate); joints
    whose pieces cannot be measured (logs slower than 80 Hz, say) are left out; and the
    signals (:func:`torquemap.vertical.no_load_residuals` of every piece)."""
    from torquemap.tones import find_tones
    from torquemap.uncertainty import joint_uncertainty, noise_level
    from torquemap.vertical import no_load_residuals, with_free

    out: dict[str, float] = {}
    tones: dict[str, tuple[Any, ...]] = {}
    signals = no_load_residuals(model, pieces, window=window, shortest=0.0, derivatives=derivs)
    for name, parts in signals.items():
        table = joint_uncertainty(model, name)
        if table is None or "parameters" not in table:
            continue
        lines = model.joints[name].pdtv
        levels, counts = [], []
        residuals = []
        for at, piece in enumerate(parts):
            part, residual = with_free(piece, lines)
            parts[at] = part  # kept with its residual for the vertical-arm check
            residuals.append((part.t, residual, part.velocity))
            level = noise_level(model, name, t=part.t, residual=residual, velocity=part.velocity)
            if math.isfinite(level):
                levels.append(level)
                counts.append(part.t.size)
        if levels:
            out[name] = float(np.average(levels, weights=counts))
            tones[name] = find_tones(residuals)
    return out, tones, signals


def _whole_notes(fit: Any, resolution: float) -> dict[str, Any]:
    """``[identification.joints.<j>]`` entries of a whole-log fit (docs/formats.md)."""
    return {
        "friction_fit": "whole",
        "channel_delay": float(fit.delay),
        "channel_delay_interval": [float(x) for x in fit.delay_interval],
        "stribeck": bool(fit.stribeck),
        "whole_samples": int(fit.samples),
        "friction_observed_speed": float(fit.observed_speed),
        "velocity_resolution": float(resolution),
        "gravity_torque": float(fit.gravity_torque),
        **({"pdtv_held": [float(o) for o in fit.held_lines]} if fit.held_lines else {}),
        "uncertainty": {
            "parameters": list(fit.names),
            "covariance": [[float(x) for x in row] for row in fit.covariance],
            "residual_scale": float(fit.residual_scale),
            "residual_psd": float(fit.residual_psd),
            **({"residual": fit.residual} if fit.residual else {}),
            **({"interpolation": fit.interpolation} if fit.interpolation else {}),
        },
        **(
            {
                "friction_prior": {
                    "stribeck_velocity": [float(x) for x in fit.prior_curve.velocity],
                    "stribeck_exponent": [float(x) for x in fit.prior_curve.exponent],
                }
            }
            if fit.prior_curve is not None
            else {}
        ),
        **(
            {
                "prior_choice": {
                    "curved": [bool(x) for x in fit.prior_choice.curved],
                    "held_out_gain": [float(x) for x in fit.prior_choice.gain],
                    "held_out_z": [float(x) for x in fit.prior_choice.z],
                    "held_out_rows": [int(x) for x in fit.prior_choice.rows],
                    "stribeck_velocity": [float(x) for x in fit.prior_choice.velocity],
                }
            }
            if fit.prior_choice is not None
            else {}
        ),
    }


def _motor_quantum(logs: Sequence[Log], gear_ratio: float, k: int) -> float:
    """One encoder count at the motor [rad] when the logs move by whole counts, else 0."""
    steps = [np.abs(np.diff(gear_ratio * log.q[:, k])) for log in logs]
    step = np.concatenate(steps) if steps else np.zeros(0)
    step = step[step > 1e-12]
    if step.size < 20:
        return 0.0
    quantum = float(np.min(step))
    ratio = step / quantum
    whole = np.abs(ratio - np.round(ratio)) < 0.02 * np.maximum(1.0, ratio)
    return quantum if float(np.mean(whole)) > 0.95 else 0.0


# ``torquemap.identify(...)`` calls :func:`torquemap.api.identify` (the module stays a module).
_make_callable(__name__, "torquemap.api:identify")
