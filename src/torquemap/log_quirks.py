"""Quirks of logs as real motor controllers and loggers write them (new-user QA, stop 36).

Each function recognises one quirk that a simulated bench does not produce and that, read as
written, gave a wrong number or a refusal that did not say why (docs/safety.md, "Log quirks
QA"): an encoder count register that overflows
(:func:`torquemap.log_quirks.register_overflow`), a time stamp counter that wraps or rows out of
order (:func:`torquemap.log_quirks.backwards_time_hint`), time stamps rounded to a few decimals
(:func:`torquemap.log_quirks.coarse_time_warning`), angles in another unit or on the other side
of the gear (:func:`torquemap.log_quirks.angle_unit_hint`), and a units row or decimal commas in
a CSV (:func:`torquemap.log_quirks.cell_hint`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.robot import Robot

if TYPE_CHECKING:
    from torquemap.friction import Pass
    from torquemap.io import Log
    from torquemap.model import Model

#: Widths [bits] of the count registers drives and encoder interfaces keep: 16-bit timers in
#: encoder mode, 32-bit shadow counts (ODrive's ``shadow_count``, CiA 402's position actual
#: value).
REGISTER_BITS = (16, 32)


def register_overflow(raw: NDArray[np.float64], cpr: float) -> tuple[int, int] | None:
    """``(bits, row)`` when encoder counts ``raw`` show a count register of ``bits`` bits
    overflowing (first between samples ``row - 1`` and ``row``), else None.

    A register of ``b`` bits that overflows steps by about ``2**b`` counts between two samples
    (from ``2**15 - 1`` to ``-2**15``, or from ``2**16 - 1`` to 0), far more than the motor
    turns in a sample: recognised when some step is within a quarter of ``2**b`` of it (and
    nearer it than a turn), 99 % of the other steps are under a quarter of ``2**b`` (a gap in
    time may hold a longer one), and the counts stay in the register's signed or unsigned
    range. Such a log holds the count modulo ``2**b``: unwrapped from its first row,
    the joint's angle is off by every overflow before it (a 16-bit register holds 8 motor turns
    of an 8000-count encoder, 0.5 rad of a 100:1 joint; it cannot hold one turn of a 2**17
    count encoder). Left to :func:`torquemap.io.unwrap_counts`, as before: a 16-bit register
    whose size is a whole number of turns (``2**16`` a multiple of ``cpr``, a single-turn 16-bit
    encoder among them: its overflows unwrap as turns), and an encoder of ``2**31`` counts or
    more.

    Before (new-user QA, stop 36), such an overflow was unwrapped by whole turns: each left
    1536 counts (0.19 turn) of an 8000-count encoder behind, an "encoder glitch" that cut the
    log, and every angle was off; the paper bench's forces were 10 to 35 N off (0.10 N clean),
    exit 0; random SCARA 7's (2**17 counts in a 16-bit register), 161 N.

    Parameters
    ----------
    raw
        Encoder counts as logged, shape (n,).
    cpr
        Encoder counts per motor revolution.

    Examples
    --------
    >>> counts = np.arange(0, 200_000, 1000.0)
    >>> register_overflow((counts + 2**15) % 2**16 - 2**15, 8000.0)
    (16, 33)
    >>> register_overflow((counts + 2**15) % 2**16 - 2**15, 16384.0) is None
    True
    >>> register_overflow((counts - 5000.0) % 2**32, 16384.0)
    (32, 5)
    """
    if raw.size < 2:
        return None
    step = np.abs(np.diff(raw))
    lo, hi = float(np.min(raw)), float(np.max(raw))
    largest = float(np.max(step))
    for bits in REGISTER_BITS:
        period = float(2**bits)
        if (bits == 16 and cpr > 0 and period % cpr == 0) or cpr >= 2.0**31:
            continue
        signed = lo >= -period / 2 and hi < period / 2
        unsigned = lo >= 0 and hi < period
        if not (signed or unsigned) or not largest > 0.75 * period:
            continue  # outside the register's range, or no step near its size: no pass over the log
        # nearer the register's size than a turn (a single-turn encoder's own wrap)
        wraps = (np.abs(step - period) < period / 4) & (np.abs(step - period) < np.abs(step - cpr))
        if not wraps.any():
            continue
        others = step[~wraps]
        if others.size and float(np.percentile(others, 99)) >= period / 4:
            continue
        return bits, int(np.argmax(wraps)) + 1
    return None


#: How close [relative] a ratio of angle steps must come to a unit mix-up to be named one.
UNIT_MATCH = 0.02


def angle_unit_hint(
    ratio: float, *, gear_ratio: float, column: str, counts_per_rev: float = 0.0
) -> str | None:
    """What a log's angle holds when its encoder count is ``ratio`` times the robot's, else None.

    ``ratio`` is the motor-angle step of one encoder count as the log reads (its angle times
    the gear ratio, as if in rad) over the robot's (``2 pi / encoder_counts_per_rev``): 1 for a
    joint angle in rad; ``gear_ratio`` for the motor angle (the gear not applied), ``1 /
    gear_ratio`` for the gear applied twice, ``gear_ratio / 2 pi`` for motor turns (ODrive's
    ``pos_estimate``), ``1 / 2 pi`` for joint turns, ``180 / pi`` for degrees, each within
    :data:`UNIT_MATCH`. Such a log, identified and estimated alike, gave exit 0 and forces 35 to
    39 N off (random SCARA 7, 1.2 N clean; new-user QA, stop 36). With ``counts_per_rev``
    (the robot file's ``encoder_counts_per_rev``), also ``gear_ratio * counts_per_rev / 2 pi``:
    raw encoder counts in a robot file that says rad (before, stop 39: the real ODrive sweep in
    whole counts was identified at 2130 rad/s, its cogging at 0.0054 CPR, exit 0).

    Examples
    --------
    >>> angle_unit_hint(46.2, gear_ratio=46.2, column="q_a")[:46]
    'q_a holds the motor angle, not the joint angle'
    >>> angle_unit_hint(1.0, gear_ratio=46.2, column="q_a") is None
    True
    >>> angle_unit_hint(8192 / (2 * np.pi), gear_ratio=1.0, column="q_a", counts_per_rev=8192)
    "q_a holds encoder counts, not rad: set position_unit = 'counts' in the robot file"
    """
    n = float(gear_ratio)
    deg = 180.0 / np.pi
    turn = 2.0 * np.pi
    candidates = (
        (n, f"{column} holds the motor angle, not the joint angle (the {n:g}:1 gear not applied): divide it by gear_ratio"),
        (1.0 / n, f"{column} holds the joint angle divided by the gear ratio once more ({n:g}:1 applied twice)"),
        (n / turn, f"{column} holds motor turns (as ODrive's pos_estimate), not the joint angle in rad: set position_unit = 'turns'"),
        (1.0 / turn, f"{column} holds joint turns, not rad: multiply it by 2 pi"),
        (deg, f"{column} holds degrees, not rad: convert it to rad"),
        (n * deg, f"{column} holds the motor angle in degrees, not the joint angle in rad"),
        (n * counts_per_rev / turn, f"{column} holds encoder counts, not rad: set position_unit = 'counts' in the robot file"),
    )  # fmt: skip
    for value, text in candidates:
        if value > 0 and value != 1.0 and abs(ratio / value - 1.0) < UNIT_MATCH:
            return text
    return None


def motor_angle_quantum(q: NDArray[np.float64], gear_ratio: float) -> float:
    """One encoder count at the motor [rad] when the joint angles ``q`` [rad] move by whole
    counts (95 % of the steps within 2 % of a whole number of the smallest), else 0 (as
    identification records ``motor_angle_quantum``).

    Examples
    --------
    >>> round(motor_angle_quantum(np.array([0.0, 1, 3, 4, 7, 8, 6, 5] * 4) * 1e-3, 10.0), 12)
    0.01
    """
    step = np.abs(np.diff(gear_ratio * np.asarray(q, dtype=np.float64)))
    step = step[step > 1e-12]
    if step.size < 20:
        return 0.0
    quantum = float(np.min(step))  # as torquemap.identify records it
    ratio = step / quantum
    whole = np.abs(ratio - np.round(ratio)) < 0.02 * np.maximum(1.0, ratio)
    return quantum if float(np.mean(whole)) > 0.95 else 0.0


def check_register_angles(log: Log, robot: Robot) -> None:
    """Refuse a log whose joint angles [rad] were computed from a count register that overflows.

    Where the robot file gives ``encoder_counts_per_rev``, the angle in counts,
    ``q * gear_ratio * cpr / 2 pi``, is tested as the counts are
    (:func:`register_overflow`): a drive that turns its 16-bit register into an angle writes
    the overflow as a jump of ``2**16`` counts' angle (0.51 rad of the paper bench's joint a).
    Before (new-user QA, stop 36) such jumps were taken as encoder glitches: the log was cut
    there and every later angle was off, the paper bench's forces 73.7 N off, exit 0.

    Raises
    ------
    InputError
        Naming the log, the joint, the time and the register's width.
    """
    for k, joint in enumerate(robot.joints):
        cpr = joint.encoder_counts_per_rev
        if not cpr or joint.position_unit != "rad":
            continue
        counts = log.q[:, k] * (joint.gear_ratio * cpr / (2.0 * math.pi))
        overflow = register_overflow(np.round(counts), float(cpr))
        if overflow is None:
            continue
        bits, at = overflow
        if abs(abs(log.q[at, k] - log.q[at - 1, k]) - 2.0 * math.pi) < 0.1 * math.pi:
            continue  # a joint turn: an angle wrapped to (-pi, pi] (sanitize names it)
        raise InputError(
            f"joint {joint.name}: q_{joint.name} steps by {log.q[at, k] - log.q[at - 1, k]:+.4g} "
            f"rad at t = {log.t[at]:.6g} s, {counts[at] - counts[at - 1]:+.0f} encoder counts: "
            f"a {bits}-bit count register overflowed before the angle was computed from it, so "
            "the log holds the angle only modulo that register; log the drive's count as a "
            "signed 64-bit number (position_unit = 'counts'), or an angle computed from one",
            path=log.path,
        )


def check_angle_units(logs: Sequence[Log], robot: Robot) -> None:
    """Refuse a log whose angles move by whole encoder counts of another unit or side of the
    gear than the robot file's (:func:`angle_unit_hint`): the motor angle, turns, degrees.

    Only joints in rad with ``encoder_counts_per_rev`` and quantised logs are checked (a drive's
    filtered estimate, ODrive's ``pos_estimate``, is no whole count: nothing to compare).
    Identified and estimated alike, such logs gave a model consistent with them and forces 35
    to 39 N off, exit 0 (random SCARA 7; new-user QA, stop 36).

    Raises
    ------
    InputError
        Naming the log, the joint and what its angle holds.
    """
    for log in logs:
        check_register_angles(log, robot)
    for k, joint in enumerate(robot.joints):
        cpr = joint.encoder_counts_per_rev
        if not cpr or joint.position_unit != "rad":
            continue
        for log in logs:
            quantum = motor_angle_quantum(log.q[:, k], joint.gear_ratio)
            if not quantum:
                continue
            ratio = quantum / (2.0 * math.pi / cpr)
            hint = angle_unit_hint(
                ratio, gear_ratio=joint.gear_ratio, column=f"q_{joint.name}", counts_per_rev=cpr
            )
            if hint is not None:
                raise InputError(
                    f"joint {joint.name}: the log's angle moves in steps of {ratio:.4g} encoder "
                    f"counts of the robot file ({cpr} per motor turn, {joint.gear_ratio:g}:1): "
                    f"{hint}",
                    path=log.path,
                )


#: Current [A] a joint's steady no-load passes may need (median over the passes) before
#: identification asks whether the log is in mA: a motor's no-load friction current is a few
#: per cent of its rating, and 50 A is that of a motor of kiloamperes.
NO_LOAD_CURRENT = 50.0
#: How many standard errors of the passes' mean below zero the torque that passes dissipate
#: must be before it is taken to oppose the motion.
OPPOSING_T = 3.0


def check_pass_torques(
    passes: Sequence[tuple[str, Sequence[Pass]]], robot: Robot, *, path: str | None = None
) -> list[str]:
    """Refuse no-load sweeps whose motor torque drives the motion instead of holding it back,
    and warn where the passes' current is that of no motor at no load.

    ``passes`` holds, per joint name, its steady passes (:class:`torquemap.friction.Pass`,
    motor side). On each pass friction dissipates: ``mean_torque * sign(speed) > 0``. A
    constant load (a spring, a weight) shifts both directions' torque alike, so it can make
    one direction's negative, never both: where every pass of both directions has the torque
    with the motion against it, significantly (the mean of ``mean_torque * sign(speed)`` at
    least :data:`OPPOSING_T` standard errors below 0), the current's sign is flipped against
    the angle (a motor wired or geared against its encoder): refused. Swept one way only, the
    same is a warning (a load driving the joint looks alike). Before (new-user QA, stop 39):
    the real ODrive sweep with its current negated gave exit 0, friction clipped to 0 (pass
    method) or held at 0 with a warning about loads (whole fit), and an anti-cogging map
    correlating -0.976 with the measured one: a table that doubles the cogging.

    A median pass torque beyond :data:`NO_LOAD_CURRENT` times the torque constant is warned
    (the current in mA: exit 0, 13 N m of friction on a 0.04 N m/A hobby motor, before).

    Parameters
    ----------
    passes
        ``(joint name, passes)`` per joint.
    robot
        The robot file (torque constants).
    path
        The log, for messages (None: several logs).

    Returns
    -------
    list of str
        Warnings, one line each.

    Raises
    ------
    InputError
        Where both directions' passes have the torque opposing the motion.
    """
    constants = {j.name: j.torque_constant for j in robot.joints}
    out: list[str] = []
    for name, joint_passes in passes:
        if not joint_passes:
            continue
        speed = np.array([p.speed for p in joint_passes], dtype=np.float64)
        torque = np.array([p.mean_torque for p in joint_passes], dtype=np.float64)
        held = torque * np.sign(speed)  # what friction dissipates: > 0 at no load
        n = held.size
        spread = float(np.std(held, ddof=1)) if n > 1 else 0.0
        significant = n == 1 or float(np.mean(held)) < -OPPOSING_T * spread / math.sqrt(n)
        directions = {bool(v > 0) for v in speed}
        level = float(np.median(np.abs(torque)))
        if bool(np.all(held < 0)) and significant:
            where = ", ".join(
                f"{float(np.median(torque[(speed > 0) == up])):+.4g} N m at "
                f"{'+' if up else '-'}{float(np.median(np.abs(speed[(speed > 0) == up]))):.3g} rad/s"
                for up in (True, False)
                if up in directions
            )
            if len(directions) == 2:
                raise InputError(
                    f"joint {name}: in every steady pass of the no-load sweeps the motor torque "
                    f"has the sign of the motion's opposite ({where} in the median): friction "
                    f"would be negative, which no load explains; the current's sign is flipped "
                    f"against q_{name} (a motor wired or geared against its encoder): negate "
                    f"i_{name} (or tau_{name}) in the logs (docs/formats.md)",
                    path=path,
                )
            out.append(
                f"joint {name}: in every steady pass the motor torque opposes the motion "
                f"({where} in the median; swept in one direction only): a load driving the "
                f"joint, or the current's sign flipped against q_{name}? With no load on it, "
                f"negate i_{name} (or tau_{name}): read as it is, its friction, inertia and "
                "PDTV come out inverted"
            )
        kt = constants.get(name)
        if kt and level > NO_LOAD_CURRENT * kt:
            out.append(
                f"joint {name}: its steady no-load passes need {level / kt:.3g} A in the median "
                f"({level:.3g} N m over the torque constant {kt:g} N m/A), more than any motor "
                f"draws with no load: is i_{name} in mA (or tau_{name} in N mm)? torquemap "
                "reads A and N m; friction and PDTV are as much too large"
            )
    return out


#: Order [CPR] below which the strongest PDTV line of a joint without a gear is warned of.
SUB_REVOLUTION_ORDER = 0.9


def sub_revolution_line_warnings(model: Model) -> list[str]:
    """One line per joint without a gear (``gear_ratio`` 1) whose strongest PDTV line has an
    order below :data:`SUB_REVOLUTION_ORDER` CPR: a period longer than a motor revolution,
    which nothing on a motor without a gear has, but an angle in another unit than the robot
    file's does (degrees read as rad put the ODrive motor's 7 CPR cogging at 7 pi / 180 =
    0.122 CPR), or a gear missing from the robot file. Before (new-user QA, stop 39): exit 0
    and lines at 0.12, 0.25 and 0.49 CPR, an anti-cogging table of zeros (warned by
    ``pdtv-map`` alone, as non-integer orders).

    Examples
    --------
    >>> from torquemap.model import JointModel, Model, PdtvLine
    >>> from torquemap.robot import robot_from_dict
    >>> rb = robot_from_dict({"robot": {"kinematics": "none"}, "joints": {"a": {
    ...     "gear_ratio": 1.0, "torque_constant": 0.04}}})
    >>> line = PdtvLine(order=7 * np.pi / 180, amplitude=0.035, phase=0.0)
    >>> sub_revolution_line_warnings(Model(robot=rb, joints={"a": JointModel(pdtv=(line,))}))[0][:56]
    'joint a: its strongest PDTV line sits at 0.122 CPR, less'
    """
    out: list[str] = []
    for joint in model.robot.joints:
        jm = model.joints.get(joint.name)
        if joint.gear_ratio != 1.0 or jm is None or not jm.pdtv:
            continue
        top = max(jm.pdtv, key=lambda line: abs(line.amplitude))
        if top.order < SUB_REVOLUTION_ORDER:
            out.append(
                f"joint {joint.name}: its strongest PDTV line sits at {top.order:.3g} CPR, less "
                f"than once a motor revolution, on a joint without a gear (gear_ratio 1): is "
                f"q_{joint.name} in the unit the robot file says ({joint.position_unit}; "
                f"degrees read as rad put a 7 CPR line at 0.122 CPR), or a gear missing from it?"
            )
    return out


#: Time stamp counters: (bits, tick [s], name). A counter of ``bits`` bits that counts ticks
#: wraps every ``2**bits`` ticks: a 32-bit microsecond counter every 71.6 min, a 16-bit
#: millisecond counter every 65.5 s.
TIME_COUNTERS = (
    (16, 1e-6, "microsecond"),
    (16, 1e-3, "millisecond"),
    (32, 1e-9, "nanosecond"),
    (32, 1e-6, "microsecond"),
    (32, 1e-3, "millisecond"),
)


def backwards_time_hint(t: NDArray[np.float64], at: int, *, first_row: int = 0) -> str:
    """What makes time ``t`` [s] go back between samples ``at`` and ``at + 1``, as ``": ..."``
    to add to the refusal, or "" when nothing is recognised.

    Recognised: a time stamp counter that wrapped (:data:`TIME_COUNTERS`: ``t`` falls by its
    period less about one step); time stamps of two clocks interleaved, or rows not in time
    order (``t`` goes back on more than one step in a hundred); two rows out of order (swapping
    them puts ``t`` in order); one fall of more than 100 steps (two logs joined, or a logger
    restarted into the same file: stop 39, before which it was refused with no hint).
    ``first_row`` is the data row (0-based) of ``t[0]`` in its file. Before (new-user QA, stop
    36), each of these was refused as "time 't' goes backwards (at data row 2789)" alone.

    Examples
    --------
    >>> t = (np.arange(100) * 1e-3 + 4294.9 ) % 4294.967296
    >>> backwards_time_hint(t, int(np.argmax(np.diff(t) < 0)))[:66]
    ': t falls by 4294.97 s: a 32-bit microsecond time stamp counter wr'
    >>> backwards_time_hint(np.array([0.0, 1, 3, 2, 4, 5]), 2)[:49]
    ': data rows 3 and 4 are out of order (t 3 then 2)'
    """
    step = np.diff(t)
    forward = step[step > 0]
    typical = float(np.median(forward)) if forward.size else 0.0
    drop = float(t[at] - t[at + 1])
    for bits, tick, name in TIME_COUNTERS:
        period = 2.0**bits * tick
        if period > 10.0 * typical and abs(drop + typical - period) <= max(3.0 * typical, tick):
            return (
                f": t falls by {drop:.6g} s: a {bits}-bit {name} time stamp counter wrapped "
                f"(every {period:.10g} s); add {period:.10g} s to t from data row "
                f"{first_row + at + 2} on (and at each later wrap)"
            )
    back = int(np.count_nonzero(step < 0))
    if back > max(1, step.size // 100):
        drops = -step[step < 0]
        return (
            f": t goes back on {back} of its {step.size} steps (by {float(np.median(drops)):.3g} "
            "s in the median): time stamps of two clocks interleaved (the host's and the "
            "device's?) or rows not in time order; keep one clock's stamps, in order"
        )
    before = t[at - 1] if at > 0 else -np.inf
    after = t[at + 2] if at + 2 < t.size else np.inf
    if before <= t[at + 1] <= t[at] <= after:
        return (
            f": data rows {first_row + at + 1} and {first_row + at + 2} are out of order (t "
            f"{t[at]:.10g} then {t[at + 1]:.10g}); sort the rows by t"
        )
    if back == 1 and drop > 100.0 * typical:
        # one fall of many steps, forward before and after: a logger restarted in one file
        return (
            f": t falls by {drop:.6g} s (from {t[at]:.10g} to {t[at + 1]:.10g}) once and runs "
            "on: two logs joined (files appended, or a logger restarted into the same file)? "
            f"split it before data row {first_row + at + 2} into two logs"
        )
    return ""


#: A time stamp's decimal quantum this large against the median time step [fraction] is warned
#: of (:func:`coarse_time_warning`).
COARSE_TIME = 0.25


def time_decimals(t: NDArray[np.float64]) -> int | None:
    """The fewest decimals (0 to 9) that hold 99 % of the time stamps ``t`` [s] exactly (as
    written to a CSV with a fixed format), else None.

    Examples
    --------
    >>> time_decimals(np.round(np.arange(100) / 400.0, 3))
    3
    >>> time_decimals(np.arange(100) / 3.0) is None
    True
    """
    t = np.asarray(t, dtype=np.float64)
    every = t[::16]  # every 16th stamp's misses are misses of the whole: a cheap refusal first
    for digits in range(10):
        if _inexact(every, digits).sum() > 0.01 * t.size:
            continue
        if float(np.mean(~_inexact(t, digits))) >= 0.99:
            return digits
    return None


def _inexact(t: NDArray[np.float64], digits: int) -> NDArray[np.bool_]:
    """Whether each stamp of ``t`` [s] is not a whole number of ``10^-digits`` s."""
    scaled = t * 10.0**digits
    off = np.abs(scaled - np.round(scaled))
    return np.asarray(~(off <= 1e-6 * np.maximum(1.0, np.abs(scaled) * 1e-9)))


def coarse_time_warning(t: NDArray[np.float64]) -> str | None:
    """A warning when the time stamps ``t`` [s] are rounded to a decimal that is a large part
    (:data:`COARSE_TIME`) of the time step and the steps vary by it, else None.

    A 400 Hz log whose ``t`` was written with 3 decimals steps 2 and 3 ms in turn: each stamp
    is off by up to 0.5 ms, noise the differentiator reads as speed and acceleration (random
    SCARA 7: force error 1.41 N against 1.20 N, exit 0 and no word; new-user QA, stop 36). A log
    whose steps are all the same whole number of such decimals (1 kHz in whole ms) is exact:
    None. Rounding that repeats stamps is named by :func:`torquemap.sanitize.sanitize_log`.

    Examples
    --------
    >>> coarse_time_warning(np.round(np.arange(100) / 400.0, 3))[:62]
    "'t' is written with 3 decimals (steps of 0.001 s, 40% of its t"
    >>> coarse_time_warning(np.arange(100) / 1000.0) is None
    True
    """
    step = np.diff(t)
    step = step[step > 0]
    if step.size < 10:
        return None
    digits = time_decimals(t)
    if digits is None:
        return None
    median = float(np.median(step))
    typical = float(np.mean(step[step <= 2.0 * median]))  # the rate's step, gaps left out
    quantum = 10.0**-digits
    if quantum < COARSE_TIME * typical or float(np.ptp(step)) < 0.5 * quantum:
        return None
    return (
        f"'t' is written with {digits} decimals (steps of {quantum:g} s, {quantum / typical:.0%} "
        f"of its time step {typical:.3g} s): each stamp may be off by up to "
        f"{quantum / 2:g} s, which the differentiator reads as speed and acceleration noise; "
        "write t with all its digits"
    )


_DECIMAL_COMMA = re.compile(r"^\s*[+-]?\d+,\d+([eE][+-]?\d+)?\s*$")
_UNIT = re.compile(r"^\s*[\[(]?\s*[A-Za-z%°µ][A-Za-z0-9%°µ/*.^ _-]*[\])]?\s*$")


def cell_hint(cell: object, data_row: int) -> str:
    """What a text cell of a numeric column says about the file, as ``": ..."``, or "".

    A number with a decimal comma (``'0,0025'``, a spreadsheet's export in a European locale);
    a unit (``'s'``, ``'[rad]'``) on the first data row, the units row some loggers write under
    the header. ``data_row`` is the cell's data row, 1-based. Before (new-user QA, stop 36):
    "column 't' is not numeric (data row 1: 's')" alone.

    Examples
    --------
    >>> cell_hint("0,0025", 7)
    ': decimal commas: write numbers with a decimal point'
    >>> cell_hint("[rad]", 1)
    ': a units row under the header? delete it (the names carry no unit: t in s, q in rad, i in A)'
    >>> cell_hint("rad", 5)
    ''
    """
    if not isinstance(cell, str):
        return ""
    if _DECIMAL_COMMA.match(cell):
        return ": decimal commas: write numbers with a decimal point"
    if data_row == 1 and _UNIT.match(cell):
        return (
            ": a units row under the header? delete it (the names carry no unit: t in s, q in "
            "rad, i in A)"
        )
    return ""


#: Ticks [s] in which loggers write Unix time stamps as integers, with their names.
EPOCH_TICKS = ((1e-3, "milliseconds"), (1e-6, "microseconds"), (1e-9, "nanoseconds"))
#: Unix time [s] a stamp read in one of :data:`EPOCH_TICKS` must land in to be taken for one:
#: 2001-09-09 to 2286-11-20.
EPOCH_SECONDS = (1e9, 1e10)


def epoch_time_hint(value: float) -> str:
    """What a time stamp ``value`` beyond the log's time limit is, as ``": ..."``, or "".

    A stamp that, read as milliseconds, microseconds or nanoseconds, falls in Unix time
    (:data:`EPOCH_SECONDS`) is one: ROS and most loggers write ``t`` as integer nanoseconds
    since 1970. Before (new-user QA, stop 39): "column 't' value 1.7643e+18 s at data row 1
    is beyond +-1e+10 s" alone.

    Examples
    --------
    >>> epoch_time_hint(1.7643e18)
    ': Unix time in nanoseconds? write t in seconds (divide it by 1e+09), or from the first stamp'
    >>> epoch_time_hint(1.7643e12)[:34]
    ': Unix time in milliseconds? write'
    >>> epoch_time_hint(1e29)
    ''
    """
    lo, hi = EPOCH_SECONDS
    for tick, name in EPOCH_TICKS:
        if lo <= abs(value) * tick <= hi:
            return (
                f": Unix time in {name}? write t in seconds (divide it by {1 / tick:g}), or "
                "from the first stamp"
            )
    return ""


def decimal_comma_rows(line: str, header: str) -> bool:
    """Whether a CSV data ``line`` holds more commas than its comma-separated ``header``
    because its numbers have decimal commas (``0,0025,-0,168`` under ``t,q_a``).

    Examples
    --------
    >>> decimal_comma_rows("0,0025,-0,168", "t,q_a")
    True
    >>> decimal_comma_rows("0.0025,-0.168", "t,q_a")
    False
    """
    fields = line.count(",") + 1
    names = header.count(",") + 1
    return fields > names and "." not in line and re.search(r"\d,\d", line) is not None


def narrow_float_column(path: str, column: str) -> str | None:
    """The type name (``"float"``: float32, ``"halffloat"``) of ``column`` in the Parquet file
    ``path`` when it is a float narrower than float64, else None (a CSV, another type, an
    unreadable file).

    float32 holds 24 bits: a joint angle of 0.84 rad to 6e-8 rad, 0.06 of one count of a
    2**17-count encoder behind a 46:1 gear (random SCARA 7), whose steps are then whole counts
    only to that; such a log was refused as "a log from another robot?" (new-user QA, stop 36).
    """
    if not path.lower().endswith(".parquet"):
        return None
    try:
        import pyarrow.parquet as pq

        schema = pq.read_schema(path)
        kind = str(schema.field(column).type)
    except Exception:  # the answer is a hint on a refusal: never a new failure
        return None
    return kind if kind in ("float", "halffloat") else None
