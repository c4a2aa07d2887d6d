"""Quasi-static PDTV identification from position holds, like on-device anti-cogging calibration.

ODrive's and moteus's calibrations hold the motor at many positions over a revolution and
record the torque that holds it there. At rest there is no inertia torque and no
velocity-dependent friction, so the mean holding torque at motor angle ``theta_i`` is::

    torque_i = PDTV(theta_i) + offset(approach direction)

The offset is the friction left when the rotor came to rest (it depends on the side it came
from), so holds approached from each side get their own offset and the PDTV lines are fitted
to all holds by least squares (:func:`torquemap.pdtv.fit_harmonics`). Lines are kept where
their amplitude is significant against the scatter of the holds (a chi-square test of the
line's cosine and sine coefficients, Bonferroni over the orders searched), and the highest
order searched is below half the number of distinct hold positions per revolution (an order
``m`` and ``N - m`` alias on ``N`` evenly spaced holds).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError
from torquemap.io import Log
from torquemap.model import JointModel, Model, PdtvLine
from torquemap.pdtv import HarmonicFit, fit_harmonics
from torquemap.robot import Robot
from torquemap.sanitize import slow_time_warning

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, slots=True, eq=False)
class Holds:
    """The position holds found in one joint's data, one entry per hold.

    Attributes
    ----------
    start, stop
        Sample slice averaged (the settled part of each hold), shape (h,).
    motor_angle
        Mean motor angle [rad] over the slice, shape (h,).
    torque
        Mean motor torque [N m] over the slice, shape (h,).
    approach
        +1 when the motor came from below (moving forward), -1 from above, shape (h,).
    """

    start: NDArray[np.int64]
    stop: NDArray[np.int64]
    motor_angle: NDArray[np.float64]
    torque: NDArray[np.float64]
    approach: NDArray[np.int64]


def find_holds(
    t: ArrayLike,
    motor_angle: ArrayLike,
    torque: ArrayLike,
    *,
    tolerance: float | None = None,
    min_duration: float = 0.1,
    settle: float = 0.5,
    count: float | None = None,
) -> Holds:
    """Find the holds in a log: stretches where the motor angle stays within ``tolerance``.

    Parameters
    ----------
    t
        Time [s], shape (n,).
    motor_angle
        Motor angle [rad], shape (n,).
    torque
        Motor torque [N m], shape (n,).
    tolerance
        Largest motor-angle excursion [rad] within half ``min_duration`` for a sample to
        count as still; default four times the smallest step of the angle (four encoder
        counts).
    min_duration
        Shortest hold [s].
    settle
        Fraction of each hold discarded at its start (the rotor settling) before averaging.
    count
        One encoder count at the motor [rad], when known: the default tolerance is then at most
        four counts (an encoder that reads one count throughout each hold, the moves between
        holds done within a sample, has no step smaller than the moves: four of them spanned
        every move and the log was one hold). When the angle jitters about its holds, the
        default is widened to six times the jitter (scaled from the median step between rows)
        if that finds more holds and stays under half the distance between neighbouring holds.

    Returns
    -------
    Holds
        In time order.

    Examples
    --------
    >>> t = np.arange(300) * 0.01
    >>> theta = np.repeat([0.0, 0.5, 1.0], 100)
    >>> h = find_holds(t, theta, np.repeat([1.0, 2.0, 3.0], 100), tolerance=0.01, min_duration=0.5)
    >>> h.torque.tolist(), h.approach.tolist()
    ([1.0, 2.0, 3.0], [1, 1, 1])
    """
    tt = np.asarray(t, dtype=np.float64)
    th = np.asarray(motor_angle, dtype=np.float64)
    tq = np.asarray(torque, dtype=np.float64)
    if tolerance is not None:
        return _holds_within(tt, th, tq, tolerance, min_duration, settle)
    steps = np.abs(np.diff(th))
    moved = steps[steps > 1e-12]
    narrow = 4.0 * float(moved.min()) if moved.size else 1e-6
    if count is not None and count > 0:
        narrow = min(narrow, 4.0 * count)
    holds = _holds_within(tt, th, tq, narrow, min_duration, settle)
    # an angle that jitters about each hold (an encoder reading +-1 or 2 counts, a noisy
    # analogue sensor) left the four-count tolerance on some holds: 140 of 512 lost. Widen it to
    # six times the jitter (its scale from the rows' steps, most of them within holds) when the
    # wider tolerance finds more holds and stays under half the distance between neighbouring
    # holds (it then cannot join two of them)
    jitter = 1.4826 * float(np.median(steps)) / math.sqrt(2.0) if steps.size else 0.0
    wide = 6.0 * jitter
    if wide > narrow:
        more = _holds_within(tt, th, tq, wide, min_duration, settle)
        apart = [np.abs(np.diff(h.motor_angle)) for h in (holds, more) if h.motor_angle.size > 1]
        if (
            more.torque.size > holds.torque.size
            and apart
            and all(wide < 0.5 * float(a.min()) for a in apart)
        ):
            return more
    return holds


def _holds_within(
    tt: NDArray[np.float64],
    th: NDArray[np.float64],
    tq: NDArray[np.float64],
    tolerance: float,
    min_duration: float,
    settle: float,
) -> Holds:
    """:func:`find_holds` with a given tolerance [rad]."""
    from scipy.ndimage import maximum_filter1d, minimum_filter1d

    # still: the angle moves less than the tolerance within half the shortest hold around
    dt = float(np.median(np.diff(tt))) if tt.size > 1 else 1.0
    width = max(round(0.5 * min_duration / dt), 2)
    spread = maximum_filter1d(th, width) - minimum_filter1d(th, width)
    still = spread <= tolerance
    edges = np.flatnonzero(np.diff(np.concatenate([[0], still.astype(np.int8), [0]])))
    starts: list[int] = []
    stops: list[int] = []
    for s0, e0 in zip(edges[::2], edges[1::2], strict=True):
        if tt[e0 - 1] - tt[s0] >= min_duration:
            starts.append(int(s0))
            stops.append(int(e0))
    a = np.empty(len(starts), dtype=np.int64)
    b = np.empty(len(starts), dtype=np.int64)
    ang = np.empty(len(starts))
    tor = np.empty(len(starts))
    for k, (s, e) in enumerate(zip(starts, stops, strict=True)):
        s2 = s + int(settle * (e - s))
        a[k], b[k] = s2, e
        ang[k] = float(np.mean(th[s2:e]))
        tor[k] = float(np.mean(tq[s2:e]))
    approach = np.ones(len(starts), dtype=np.int64)
    for k in range(len(starts)):
        before = th[0] if k == 0 else ang[k - 1]
        approach[k] = -1 if ang[k] < before else 1
    return Holds(start=a, stop=b, motor_angle=ang, torque=tor, approach=approach)


@dataclass(frozen=True, slots=True, eq=False)
class QuasiStaticJoint:
    """Diagnostics of one joint's quasi-static identification.

    Attributes
    ----------
    name
        Joint name.
    holds
        The holds used.
    harmonics
        Least-squares fit of the kept lines (None when no line is significant).
    max_order
        Highest order searched [CPR].
    positions
        Distinct hold positions per motor revolution.
    offsets
        Friction offset per approach direction [N m]: ``{"positive": ..., "negative": ...}``.
    residual_rms
        RMS of the holds about the fit [N m].
    warnings
        One line each.
    """

    name: str
    holds: Holds
    harmonics: HarmonicFit | None
    max_order: int
    positions: int
    offsets: Mapping[str, float]
    residual_rms: float
    warnings: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True, eq=False)
class QuasiStaticIdentification:
    """Result of :func:`identify_quasi_static`.

    Attributes
    ----------
    model
        The model: the input's joints with their PDTV lines replaced by the identified ones
        (inertia and friction are not observable at rest and are kept).
    joints
        Diagnostics per identified joint.
    warnings
        Every joint's warnings, in order.
    """

    model: Model
    joints: Mapping[str, QuasiStaticJoint] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()


def _distinct_positions(angle: NDArray[np.float64]) -> int:
    """Hold positions per revolution: folded angles closer than a quarter of the even
    spacing of that many holds count as one (a position held on the way out and back)."""
    folded = np.sort(np.mod(angle, TWO_PI))
    if folded.size == 0:
        return 0
    tolerance = 0.25 * TWO_PI / folded.size
    gaps = np.diff(np.concatenate([folded, [folded[0] + TWO_PI]]))
    return int(np.sum(gaps > tolerance))


def fit_holds(
    holds: Holds,
    *,
    max_order: float | None = None,
    false_alarm: float = 0.01,
    name: str = "",
) -> QuasiStaticJoint:
    """Fit PDTV lines to the holds of one joint (module docstring).

    Parameters
    ----------
    holds
        From :func:`find_holds`.
    max_order
        Highest order [CPR]; default (and at most) ``positions // 2 - 1``.
    false_alarm
        Probability that noise alone yields a spurious line, over all orders searched.
    name
        Joint name for messages.

    Returns
    -------
    QuasiStaticJoint

    Raises
    ------
    InputError
        On fewer than 8 distinct hold positions per revolution.
    """
    from scipy import stats

    positions = _distinct_positions(holds.motor_angle)
    limit = positions // 2 - 1
    if positions < 8:
        raise InputError(
            f"joint {name}: {holds.motor_angle.size} holds at {positions} distinct positions "
            "per motor revolution; quasi-static identification needs at least 8"
        )
    top = limit if max_order is None else min(math.floor(max_order), limit)
    warnings: list[str] = []
    if max_order is not None and max_order > limit:
        warnings.append(
            f"joint {name}: {positions} hold positions per revolution resolve orders up to "
            f"{limit} CPR; max order {max_order:g} lowered to {limit}"
        )
    groups = (holds.approach > 0).astype(np.int64)
    n_groups = np.unique(groups).size
    # most orders the holds fit with some left to measure their scatter
    fits = (holds.torque.size - n_groups - 2) // 2
    if max_order is None and top > fits:
        # one pass at N positions (ODrive's calibration) resolves N / 2 orders but cannot fit
        # them all: search up to the order that leaves half the holds to measure the scatter
        top = max(1, (holds.torque.size // 2 - n_groups - 2) // 2)
        warnings.append(
            f"joint {name}: {holds.torque.size} holds fit orders up to {top} CPR (half the "
            f"holds measure their scatter); hold on the way back too to search up to {limit}"
        )
    orders = [float(o) for o in range(1, top + 1)]
    if holds.torque.size < 2 * len(orders) + n_groups + 2:
        raise InputError(
            f"joint {name}: {holds.torque.size} holds cannot fit {len(orders)} orders; "
            f"hold at more positions or give a max order of at most {max(fits, 0)}"
        )
    fit: HarmonicFit | None = fit_harmonics(
        holds.motor_angle, holds.torque, orders=orders, groups=groups
    )
    for _ in range(4):
        assert fit is not None
        crit = stats.chi2.ppf(1.0 - false_alarm / max(top, 1), 2)
        chi = np.array(
            [
                float(fit.cos_sin[i] @ np.linalg.pinv(fit.covariance[i]) @ fit.cos_sin[i])
                for i in range(fit.order.size)
            ]
        )
        keep = chi > crit
        if keep.all():
            break
        if not keep.any():
            fit = None
            break
        fit = fit_harmonics(
            holds.motor_angle, holds.torque, orders=list(fit.order[keep]), groups=groups
        )
    if fit is None:
        warnings.append(f"joint {name}: no PDTV line stands out of the holds' scatter")
        mean = float(np.mean(holds.torque))
        resid = float(np.sqrt(np.mean((holds.torque - mean) ** 2)))
        offsets = {"positive": mean, "negative": mean}
    else:
        resid = fit.residual_rms
        labels = np.unique(groups)
        offsets = {}
        for lab, off in zip(labels, fit.offsets, strict=True):
            offsets["positive" if lab == 1 else "negative"] = float(off)
    if np.unique(groups).size < 2:
        warnings.append(
            f"joint {name}: every hold approached from one side; the friction offset cannot be "
            "told from a constant torque (hold on the way back too)"
        )
    return QuasiStaticJoint(
        name=name,
        holds=holds,
        harmonics=fit,
        max_order=top,
        positions=positions,
        offsets=offsets,
        residual_rms=resid,
        warnings=tuple(warnings),
    )


def identify_quasi_static(
    robot: Robot | Model,
    logs: Sequence[Log],
    *,
    joints: Sequence[str] | None = None,
    max_order: float | None = None,
    false_alarm: float = 0.01,
    min_duration: float = 0.1,
    settle: float = 0.5,
    tolerance: float | None = None,
    direction: Literal["both"] = "both",
) -> QuasiStaticIdentification:
    """Identify PDTV lines from position holds (module docstring).

    Parameters
    ----------
    robot
        The robot, or a model whose friction and inertia are kept.
    logs
        Logs of holds (read with :func:`torquemap.io.read_log`).
    joints
        Joints to identify; default every joint that holds at 8 or more positions.
    max_order
        Highest PDTV order [CPR].
    false_alarm
        Probability of a spurious line per joint.
    min_duration
        Shortest hold [s].
    settle
        Fraction of each hold discarded at its start.
    tolerance
        Largest motor-angle excursion within a hold [rad] (:func:`find_holds`).
    direction
        Lines found at rest apply to both directions of motion.

    Returns
    -------
    QuasiStaticIdentification

    Raises
    ------
    InputError
        On no log, an unknown joint, or a requested joint with too few holds.

    Examples
    --------
    >>> from torquemap.robot import robot_from_dict
    >>> rb = robot_from_dict({"robot": {"kinematics": "none"},
    ...                       "joints": {"m": {"gear_ratio": 1, "torque_constant": 1}}})
    >>> k = np.repeat(np.r_[0:64, 62:-1:-1], 50)  # 127 holds of 50 samples, out and back
    >>> theta = k * (2 * np.pi / 64)
    >>> back = np.arange(k.size) >= 64 * 50
    >>> noise = np.random.default_rng(0).normal(0.0, 1e-4, k.size)
    >>> tau = 0.01 * np.cos(4 * theta + 0.5) + np.where(back, -0.03, 0.03) + noise
    >>> log = Log(t=np.arange(k.size) * 0.01, q=theta[:, None], motor_torque=tau[:, None],
    ...           joint_names=("m",))
    >>> ln = identify_quasi_static(rb, [log], tolerance=0.01).model.joints["m"].pdtv
    >>> [(l.order, round(l.amplitude, 4), round(l.phase, 2)) for l in ln]
    [(4.0, 0.01, 0.5)]
    """
    model_in = robot if isinstance(robot, Model) else None
    rb = robot.robot if isinstance(robot, Model) else robot
    if not logs:
        raise InputError("no log given")
    names = list(rb.joint_names) if joints is None else list(joints)
    for name in names:
        rb.joint(name)
    new_joints: dict[str, JointModel] = (
        dict(model_in.joints) if model_in else {j.name: JointModel() for j in rb.joints}
    )
    results: dict[str, QuasiStaticJoint] = {}
    warnings: list[str] = []
    slow = [(log, w) for log, w in ((log, slow_time_warning(log.t)) for log in logs) if w]
    warnings.extend(f"{log.path}: {w}" if log.path else w for log, w in slow)
    for name in names:
        k = rb.joint_names.index(name)
        gear = rb.joints[k].gear_ratio
        cpr = rb.joints[k].encoder_counts_per_rev
        parts = [
            find_holds(
                log.t,
                gear * log.q[:, k],
                log.motor_torque[:, k],
                tolerance=tolerance,
                min_duration=min_duration,
                settle=settle,
                count=TWO_PI / cpr if cpr else None,
            )
            for log in logs
        ]
        holds = Holds(
            start=np.concatenate([p.start for p in parts]),
            stop=np.concatenate([p.stop for p in parts]),
            motor_angle=np.concatenate([p.motor_angle for p in parts]),
            torque=np.concatenate([p.torque for p in parts]),
            approach=np.concatenate([p.approach for p in parts]),
        )
        if _distinct_positions(holds.motor_angle) < 8:
            if joints is None:
                continue
        try:
            res = fit_holds(holds, max_order=max_order, false_alarm=false_alarm, name=name)
        except InputError as exc:  # name the log(s) the holds came from
            paths = ", ".join(
                dict.fromkeys(str(log.path) for log in logs if not str(log.path).startswith("<"))
            )
            if exc.path is None and paths:
                raise InputError(exc.message, path=paths) from None
            raise
        results[name] = res
        warnings.extend(res.warnings)
        lines: tuple[PdtvLine, ...] = ()
        if res.harmonics is not None:
            h = res.harmonics
            lines = tuple(
                PdtvLine(order=float(o), amplitude=float(a), phase=float(p), direction=direction)
                for o, a, p in zip(h.order, h.amplitude, h.phase, strict=True)
            )
        old = new_joints.get(name, JointModel())
        new_joints[name] = JointModel(inertia=old.inertia, friction=old.friction, pdtv=lines)
    if not results:
        hint = f" ({slow[0][1]})" if slow else ""
        if slow and short_holds(slow[0][0].q):
            # a table of one averaged row per hold is not "t in ms" (its t is seconds)
            hint = (
                f" ({slow[0][1]}; or, as the angle stays at each position for only one or two "
                "rows, the log may hold one row per hold: quasi-static identification needs every "
                "sample of each hold, several rows per hold over 0.1 s or more)"
            )
        raise InputError(
            "no joint holds still at 8 or more positions per motor revolution; quasi-static "
            "identification needs position holds" + hint,
            path=logs[0].path if len(logs) == 1 else None,
        )
    notes = {
        "method": "quasi-static (position holds)",
        "logs": [log.path for log in logs],
        "false_alarm": false_alarm,
        "warnings": list(warnings),
        "joints": {
            n: {
                "holds": int(r.holds.torque.size),
                "positions": r.positions,
                "max_order": r.max_order,
                "residual_rms": r.residual_rms,
                "offsets": dict(r.offsets),
            }
            for n, r in results.items()
        },
    }
    model = Model(robot=rb, joints=new_joints, notes=notes)
    return QuasiStaticIdentification(model=model, joints=results, warnings=tuple(warnings))


def short_holds(q: NDArray[np.float64]) -> bool:
    """Whether some joint's angle ``q`` (shape (n, joints)) takes 8 or more positions and stays
    at each for a median of at most two rows (equal to within a millionth of its range): a
    table of one averaged row per hold, or a log whose time reads 1000 times slow.

    Examples
    --------
    >>> short_holds(np.repeat(np.arange(16.0), 2)[:, None])
    True
    >>> short_holds(np.repeat(np.arange(16.0), 20)[:, None])
    False
    """
    for column in np.asarray(q, dtype=np.float64).T:
        span = float(np.ptp(column)) if column.size else 0.0
        if not span > 0:
            continue
        change = np.flatnonzero(np.abs(np.diff(column)) > 1e-6 * span)
        runs = np.diff(np.concatenate([[0], change + 1, [column.size]]))
        if runs.size >= 8 and float(np.median(runs)) <= 2:
            return True
    return False
