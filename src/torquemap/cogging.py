"""Verify an anti-cogging map: the ripple per CPR line in a sweep with the map applied.

Calibrate (``identify``, or ``identify --quasi-static`` from position holds), export the map
(``pdtv-map``), load it into the drive, then sweep again with the map applied and compare.
For every PDTV line of the model, at the line's order [CPR]:

torque ripple
    The amplitude of the torque the position loop still had to supply. Drives report the total
    current, feed-forward included (``current="total"``): the model's map at the measured angle
    is subtracted first. When the log holds only the loop's own output
    (``current="feedback"``) it is used as it is. "Before" is the same amplitude in a sweep
    without the map, or, with no such sweep, the model's line amplitude.
speed ripple
    The amplitude of the motor speed at the line's order [rad/s]: what a user feels and the
    check that the drive really applied the map (a map loaded with the wrong sign, offset or
    scale leaves the torque check unchanged, since that assumes the map was applied as
    exported, but raises the speed ripple). Needs the sweep without the map.

Amplitudes come from a least-squares harmonic fit in the position domain over the steady parts
of the sweep (:func:`torquemap.pdtv.fit_harmonics`, one offset per pass, so friction and the
pass's mean speed drop out).
"""

from __future__ import annotations

import itertools
import math
import os
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.filters import differentiate
from torquemap.io import Log
from torquemap.model import Model, PdtvLine
from torquemap.pdtv import fit_harmonics
from torquemap.pdtv_map import pdtv_map

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, slots=True, eq=False)
class LineRipple:
    """Ripple at one PDTV line before and after the map.

    Attributes
    ----------
    order
        [CPR].
    torque_before, torque_after
        Torque ripple amplitude [N m], motor side.
    speed_before, speed_after
        Speed ripple amplitude [rad/s], motor side (NaN without a sweep without the map).
    """

    order: float
    torque_before: float
    torque_after: float
    speed_before: float
    speed_after: float

    @property
    def torque_removed(self) -> float:
        """Fraction of the torque ripple removed, ``1 - after / before`` (NaN if none before)."""
        return _removed(self.torque_before, self.torque_after)

    @property
    def speed_removed(self) -> float:
        """Fraction of the speed ripple removed, ``1 - after / before``."""
        return _removed(self.speed_before, self.speed_after)


def _rss(values: Iterable[float]) -> float:
    """Root sum of squares (NaN propagates: a ripple not measured stays unknown)."""
    return float(np.sqrt(sum(v**2 for v in values)))


def _removed(before: float, after: float) -> float:
    if not (before > 0 and math.isfinite(after)):
        return math.nan
    return 1.0 - after / before


@dataclass(frozen=True, slots=True, eq=False)
class CoggingVerification:
    """Result of :func:`verify_cogging` for one joint.

    Attributes
    ----------
    joint
        Joint name.
    lines
        Per model line, in order of the model's amplitude.
    before_source
        ``"log"`` (a sweep without the map) or ``"model"`` (the model's amplitudes).
    speed
        Mean cruise speed of the sweeps [rad/s], motor side: ``(after, before)`` (before NaN
        without a before-log).
    warnings
        One line each.
    """

    joint: str
    lines: tuple[LineRipple, ...]
    before_source: Literal["log", "model"]
    speed: tuple[float, float]
    warnings: tuple[str, ...] = ()

    @property
    def torque_before(self) -> float:
        """Root sum of squares of the lines' torque ripple before [N m]."""
        return _rss(ln.torque_before for ln in self.lines)

    @property
    def torque_after(self) -> float:
        """Root sum of squares of the lines' torque ripple after [N m]."""
        return _rss(ln.torque_after for ln in self.lines)

    @property
    def speed_before(self) -> float:
        """Root sum of squares of the lines' speed ripple before [rad/s] (NaN: no before-log)."""
        return _rss(ln.speed_before for ln in self.lines)

    @property
    def speed_after(self) -> float:
        """Root sum of squares of the lines' speed ripple after [rad/s]."""
        return _rss(ln.speed_after for ln in self.lines)

    @property
    def torque_removed(self) -> float:
        """Fraction of the torque ripple (all lines) removed."""
        return _removed(self.torque_before, self.torque_after)

    @property
    def speed_removed(self) -> float:
        """Fraction of the speed ripple (all lines) removed (NaN: no before-log)."""
        return _removed(self.speed_before, self.speed_after)


@dataclass(frozen=True, slots=True, eq=False)
class _Ripple:
    torque: NDArray[np.float64]
    speed: NDArray[np.float64]
    mean_speed: float


def _model_amplitudes(lines: tuple[PdtvLine, ...], orders: list[float]) -> NDArray[np.float64]:
    out = []
    for o in orders:
        both = [ln for ln in lines if ln.order == o and ln.direction == "both"]
        if both:
            out.append(both[0].amplitude)
        else:
            amps = [ln.amplitude for ln in lines if ln.order == o]
            out.append(float(np.mean(amps)) if amps else 0.0)
    return np.asarray(out)


def _steady_runs(velocity: NDArray[np.float64], *, tolerance: float) -> NDArray[np.int64]:
    """Group label per sample: runs of one direction within ``tolerance`` of their median
    speed (-1: not steady)."""
    top = float(np.percentile(np.abs(velocity), 95))
    moving = np.abs(velocity) > 0.2 * top
    sign = np.where(moving, np.sign(velocity), 0).astype(np.int64)
    label = np.full(velocity.size, -1, dtype=np.int64)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], sign, [0]])))
    run = 0
    for a, b in itertools.pairwise(edges):
        if sign[a] == 0 or b - a < 16:
            continue
        med = float(np.median(np.abs(velocity[a:b])))
        steady = np.abs(np.abs(velocity[a:b]) - med) < tolerance * med
        label[a:b] = np.where(steady, run, -1)
        run += 1
    return label


def _ripple(
    model: Model,
    log: Log,
    joint: str,
    orders: list[float],
    *,
    subtract_map: bool,
    window: float,
) -> _Ripple:
    k = model.robot.joint_names.index(joint)
    gear = model.robot.joints[k].gear_ratio
    theta = gear * log.q[:, k]
    try:
        d = differentiate(log.t, theta, window=window)
    except InputError as exc:
        raise InputError(exc.message, path=log.path) from None
    torque = log.motor_torque[:, k].copy()
    if subtract_map:
        # what the drive applied: the exported table's lines (integer orders only)
        torque -= pdtv_map(model, joint, motor_angle=theta, table_lines=True).torque
    label = _steady_runs(d.velocity, tolerance=0.2)
    ok = label >= 0
    revs = float(np.sum(np.abs(np.diff(theta))[ok[1:]])) / TWO_PI
    if revs < 1.0:
        total = float(np.sum(np.abs(np.diff(theta)))) / TWO_PI
        raise InputError(
            f"joint {joint}: the log holds {revs:.2g} motor revolutions at a steady speed "
            f"(within 20 % of its pass's median speed; {total:.2g} revolutions in all); "
            "verification needs a sweep of at least one revolution",
            path=log.path,
        )
    ft = fit_harmonics(theta[ok], torque[ok], orders=orders, groups=label[ok])
    fw = fit_harmonics(theta[ok], d.velocity[ok], orders=orders, groups=label[ok])
    return _Ripple(
        torque=ft.amplitude,
        speed=fw.amplitude,
        mean_speed=float(np.mean(np.abs(d.velocity[ok]))),
    )


def verify_cogging(
    model: Model,
    after: Log,
    before: Log | None = None,
    *,
    joint: str | None = None,
    current: Literal["total", "feedback"] = "total",
    window: float = 0.05,
    path: str | os.PathLike[str] | None = None,
) -> CoggingVerification:
    """Compare the ripple at the model's PDTV lines in a sweep with the map and one without.

    Parameters
    ----------
    model
        The model whose map (:func:`torquemap.pdtv_map.pdtv_map`) the drive applied.
    after
        A sweep with the map applied (constant-speed passes, one revolution or more).
    before
        The same sweep without the map; default: the model's line amplitudes stand for the
        torque ripple before, and the speed ripple is not compared.
    joint
        The joint; default the only joint with PDTV lines.
    current
        ``"total"``: the log's current includes the map's feed-forward (drives report it so);
        ``"feedback"``: the log holds only the position loop's output.
    window
        Differentiator window [s] for the speed.
    path
        The model file, for error messages.

    Returns
    -------
    CoggingVerification
        Per line and overall, torque and speed ripple before and after.

    Raises
    ------
    InputError
        When the model has no PDTV line for the joint, the joint is ambiguous, or a log holds
        less than one motor revolution at a steady speed.
    """
    with_lines = [n for n, jm in model.joints.items() if jm.pdtv]
    if joint is None:
        if len(with_lines) != 1:
            raise InputError(
                "name the joint to verify (--joint): the model has PDTV lines for "
                f"{', '.join(with_lines) or 'no joint'}",
                path=path,
            )
        joint = with_lines[0]
    model.robot.joint(joint)
    lines = model.joints[joint].pdtv
    if not lines:
        raise InputError(
            f"joint {joint}: the model holds no PDTV line, so there is no map", path=path
        )
    orders = sorted({ln.order for ln in lines})
    amps = _model_amplitudes(lines, orders)
    rank = np.argsort(-amps, kind="stable")
    aft = _ripple(model, after, joint, orders, subtract_map=current == "total", window=window)
    warnings: list[str] = []
    if before is not None:
        bef = _ripple(model, before, joint, orders, subtract_map=False, window=window)
        t_before, s_before = bef.torque, bef.speed
        source: Literal["log", "model"] = "log"
        mean_before = bef.mean_speed
        if abs(bef.mean_speed - aft.mean_speed) > 0.2 * max(bef.mean_speed, aft.mean_speed):
            warnings.append(
                f"joint {joint}: the sweeps run at {aft.mean_speed:.3g} rad/s (after) and "
                f"{bef.mean_speed:.3g} rad/s (before); speed ripple compares only at one speed"
            )
    else:
        t_before, s_before = amps, np.full(amps.size, math.nan)
        source = "model"
        mean_before = math.nan
        if current == "total":
            warnings.append(
                f"joint {joint}: without a sweep taken before the map, the torque check assumes "
                "the drive applied the map as exported; a before-log also compares the speed "
                "ripple, which shows a map loaded with the wrong sign, offset or scale"
            )
    out = tuple(
        LineRipple(
            order=orders[i],
            torque_before=float(t_before[i]),
            torque_after=float(aft.torque[i]),
            speed_before=float(s_before[i]),
            speed_after=float(aft.speed[i]),
        )
        for i in rank
    )
    result = CoggingVerification(
        joint=joint,
        lines=out,
        before_source=source,
        speed=(aft.mean_speed, mean_before),
        warnings=tuple(warnings),
    )
    if before is not None and result.speed_removed < 0:
        warnings.append(
            f"joint {joint}: the speed ripple at the map's orders grew "
            f"({result.speed_before:.3g} -> {result.speed_after:.3g} rad/s): check the sign, "
            "angle origin and scale the drive applies the map with (docs/odrive.md, "
            "docs/moteus.md)"
        )
        result = CoggingVerification(
            joint=joint,
            lines=out,
            before_source=source,
            speed=result.speed,
            warnings=tuple(warnings),
        )
    return result
