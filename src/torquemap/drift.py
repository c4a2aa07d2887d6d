"""Drift of friction and PDTV over a fleet's days: trends, and flags beyond the uncertainty.

For every robot, joint and parameter (each friction law's linear parameters, each PDTV line's
amplitude) the values identified day by day (:func:`torquemap.fleet.identify_fleet`) are fitted
with a straight line in time by weighted least squares, each day weighted by its
identification's own standard error (``[identification.joints.<j>.standard_errors]`` of the day's
model), scaled up by Birge's ratio where the days scatter about the trend more than those
errors say. A parameter is flagged when its fitted change over the period exceeds three standard
errors of that change (a two-sided 0.3 % test), or when one day jumps away from the median of
the days before it by more than four of its standard errors (a loose belt, a worn tooth).

A PDTV line found strongly on some days and not at all on others is flagged as appearing or
vanishing (:data:`PRESENCE_Z`), even when it is found on one day only.

Where a day's model holds no standard error for a parameter, the scatter of the days about the
trend stands in (the regression's own residual variance, tested with Student's t at the same
0.3 % level): with few days that test is weak, and it says so by flagging little.

A series needs two days when the days' models hold standard errors (the change between them,
against the two errors combined) and three otherwise (a scatter needs a degree of freedom); a
robot with fewer is listed in :attr:`FleetDrift.too_few`, not dropped silently.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections import defaultdict
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.fleet import read_run
from torquemap.model import load_model

#: Change over the period, in standard errors, beyond which a trend is flagged.
TREND_Z = 3.0
#: Jump of one day from the median of the days before it, in standard errors.
STEP_Z = 4.0
#: Scatter of the days about the trend, in their standard errors (Birge's ratio), beyond which
#: a series is flagged whatever its trend: a log of another robot or setup on one day. A daily
#: sweep's pooled errors can be three to four times too small on a steady robot (motor fleets,
#: seeds 1-4); ten is beyond that.
SCATTER_MAX = 10.0
#: A PDTV line found on some identified days of a joint and not on others is flagged as
#: appearing (or vanishing) when its amplitude on the days it is found exceeds this many of
#: its standard errors: the line search's threshold (:func:`torquemap.pdtv.pick_lines`, a
#: Rayleigh multiple of the noise floor for a 1 % false alarm over the orders searched) is about
#: five, so a line this strong would have been found on the other days had it been there.
#: Weaker lines come and go with the noise and are trended over the days they are found.
PRESENCE_Z = 10.0
#: Orders [CPR] closer than this are one line from day to day (a fractional order is resolved
#: to 1 / revolutions of the sweep's passes; 4 revolutions resolve 0.25 CPR).
ORDER_MATCH = 0.25


@dataclass(frozen=True, slots=True, eq=False)
class DriftSeries:
    """One parameter of one joint of one robot over the days.

    Attributes
    ----------
    robot, joint, parameter
        Which one (``friction.<name>`` or ``pdtv.<order>[.<direction>].amplitude``).
    days
        Days since the first day of the series, shape (d,).
    dates
        ISO dates, length d.
    values
        Identified values, shape (d,) [N m, N m s/rad, ...].
    sigma
        Standard error used for each day, shape (d,).
    sigma_source
        ``"identification"`` or ``"scatter"`` (module docstring).
    slope, slope_se
        Fitted trend [unit per day] and its standard error.
    change, change_se
        Fitted change over the whole period and its standard error.
    flag
        True when the change or a step exceeds the uncertainty (module docstring).
    note
        Why it is flagged ("" otherwise).
    """

    robot: str
    joint: str
    parameter: str
    days: NDArray[np.float64]
    dates: tuple[str, ...]
    values: NDArray[np.float64]
    sigma: NDArray[np.float64]
    sigma_source: str
    slope: float
    slope_se: float
    change: float
    change_se: float
    flag: bool
    note: str


@dataclass(frozen=True, slots=True, eq=False)
class FleetDrift:
    """Result of :func:`fleet_drift`.

    Attributes
    ----------
    series
        Every parameter with enough days (module docstring), robots and joints in order.
    skipped
        Robot-days that failed identification, as ``robot date: reason``.
    too_few
        Robots with identified days but no series (too few days for a trend), as
        ``robot: n identified day(s)``.
    """

    series: tuple[DriftSeries, ...]
    skipped: tuple[str, ...]
    too_few: tuple[str, ...] = ()

    @property
    def flagged(self) -> tuple[DriftSeries, ...]:
        """The flagged series."""
        return tuple(s for s in self.series if s.flag)


def _parameters(model: Any, joint: str) -> dict[str, float]:
    jm = model.joints[joint]
    law = jm.friction
    out = {
        f"friction.{n}": float(v)
        for n, v in zip(law.linear_parameter_names, law.linear_parameters(), strict=True)
    }
    for line in jm.pdtv:
        key = f"pdtv.{line.order:g}" + ("" if line.direction == "both" else f".{line.direction}")
        out[f"{key}.amplitude"] = line.amplitude
    return out


def _standard_errors(model: Any, joint: str) -> dict[str, float]:
    joints = model.notes.get("joints", {})
    entry = joints.get(joint, {}) if isinstance(joints, Mapping) else {}
    table = entry.get("standard_errors", {}) if isinstance(entry, Mapping) else {}
    if not isinstance(table, Mapping):
        return {}
    return {
        str(k): float(v)
        for k, v in table.items()
        if isinstance(v, int | float) and math.isfinite(v) and v > 0
    }


def trend(
    days: NDArray[np.float64], values: NDArray[np.float64], sigma: NDArray[np.float64]
) -> tuple[float, float, float]:
    """Weighted straight-line fit ``value = a + slope * day``: ``(a, slope, slope_se)``.

    Examples
    --------
    >>> a, b, se = trend(np.arange(4.0), 2.0 + 0.5 * np.arange(4.0), np.ones(4))
    >>> round(a, 12), round(b, 12), round(se, 6)
    (2.0, 0.5, 0.447214)
    """
    w = 1.0 / sigma**2
    x = np.column_stack([np.ones_like(days), days])
    xtw = x.T * w
    cov = np.linalg.inv(xtw @ x)
    coef = cov @ (xtw @ values)
    return float(coef[0]), float(coef[1]), float(math.sqrt(cov[1, 1]))


def _series(
    robot: str,
    joint: str,
    parameter: str,
    dates: list[str],
    values: list[float],
    errors: list[float],
) -> DriftSeries | None:
    v = np.array(values)
    day0 = np.datetime64(dates[0])
    days = np.array([(np.datetime64(d) - day0).astype(float) for d in dates])
    err = np.array(errors)
    known = bool(np.all(np.isfinite(err) & (err > 0)))
    # two days are a change against their own errors; a scatter needs a third
    if v.size < (2 if known else 3) or np.ptp(days) <= 0:
        return None
    if not np.any(v):
        return None  # never identified (a term the data did not support)
    span = float(days[-1] - days[0])
    notes = []
    if known:
        source = "identification"
        # One day's standard error rests on few degrees of freedom (a daily sweep of two speeds
        # gives friction one): alone it can be ten times too small, and that day would steer
        # the trend and the step test. The days of one robot share the sweep, so their variances
        # are pooled (the degrees of freedom add up).
        err = np.full(v.size, math.sqrt(float(np.mean(err**2))))
        a, slope, slope_se = trend(days, v, err)
        # Standard errors from one day's fit assume white residuals; where the days scatter
        # about the trend more than they say (reduced chi-square above 1), scale them up
        # (Birge's ratio), never down.
        chi2 = float(np.sum(((v - a - slope * days) / err) ** 2))
        birge = math.sqrt(chi2 / (v.size - 2)) if v.size > 2 else 1.0
        scale = max(1.0, birge)
        sigma, slope_se = err * scale, slope_se * scale
        critical = TREND_Z
    else:
        from scipy.stats import t as student

        source = "scatter"
        _, slope, _ = trend(days, v, np.ones_like(v))
        dof = v.size - 2
        resid = v - np.polyval(np.polyfit(days, v, 1), days)
        scale = math.sqrt(float(np.sum(resid**2)) / dof)
        sigma = np.full(v.size, scale)
        slope_se = scale / math.sqrt(float(np.sum((days - days.mean()) ** 2)))
        critical = float(student.ppf(1.0 - 0.5 * math.erfc(TREND_Z / math.sqrt(2.0)), dof))
    change, change_se = slope * span, slope_se * span
    if change_se > 0 and abs(change) > critical * change_se:
        notes.append(
            f"changes {change:+.3g} over {span:g} day{'' if span == 1 else 's'} "
            f"({abs(change) / change_se:.1f} sigma)"
        )
    if source == "identification":
        step = _first_step(days, v, err, scale)
        if step is not None:
            k, ref = step
            notes.append(f"jumps to {v[k]:.3g} on {dates[k]} (from {ref:.3g} expected)")
        if scale > SCATTER_MAX:
            # an odd day masks a trend (its scatter inflates every error) and, in the middle of
            # three days, escapes the step test: say so rather than report a steady robot
            notes.append(
                f"the days scatter {scale:.0f} times their standard errors: a day of another "
                "robot or setup?"
            )
    return DriftSeries(
        robot=robot,
        joint=joint,
        parameter=parameter,
        days=days,
        dates=tuple(dates),
        values=v,
        sigma=sigma,
        sigma_source=source,
        slope=slope,
        slope_se=slope_se,
        change=change,
        change_se=change_se,
        flag=bool(notes),
        note="; ".join(notes),
    )


def _first_step(
    days: NDArray[np.float64], v: NDArray[np.float64], err: NDArray[np.float64], scale: float
) -> tuple[int, float] | None:
    """The first day that leaves the straight line of the days before it by more than
    ``STEP_Z`` standard errors of the difference (the day's error and the line's prediction's),
    as ``(index, expected value)``. The errors are scaled by Birge's ratio of the days before
    (a step after them cannot inflate it) where those leave two degrees of freedom, else by the
    whole series' ``scale``."""
    for k in range(2, v.size):
        a, slope, _ = trend(days[:k], v[:k], err[:k])
        x = np.column_stack([np.ones(k), days[:k]]) / err[:k, None]
        cov = np.linalg.inv(x.T @ x)
        point = np.array([1.0, days[k]])
        expected = a + slope * days[k]
        s = scale
        if k >= 4:
            chi2 = float(np.sum(((v[:k] - a - slope * days[:k]) / err[:k]) ** 2))
            s = max(1.0, math.sqrt(chi2 / (k - 2)))
        se = s * math.sqrt(err[k] ** 2 + float(point @ cov @ point))
        if abs(v[k] - expected) > STEP_Z * se:
            return k, float(expected)
    return None


def _presence(
    robot: str,
    joint: str,
    parameter: str,
    identified: dict[str, list[tuple[float, str]]],
    dates: list[str],
    values: list[float],
    errors: list[float],
) -> DriftSeries | None:
    """A PDTV line missing on some of the joint's identified days while strong on the days it
    is found (:data:`PRESENCE_Z`): a series over every identified day, the missing days at
    amplitude 0, flagged with the days it appears or vanishes. A day with a line of the same
    direction within :data:`ORDER_MATCH` of its order does not count as missing (a fractional
    order placed a little differently). ``None`` for anything else (friction, a line found
    every day, a weak line, no standard errors): :func:`_series`."""
    if not parameter.startswith("pdtv.") or len(dates) == len(identified):
        return None
    err = np.array(errors)
    if not np.all(np.isfinite(err) & (err > 0)):
        return None
    v = np.array(values)
    se = math.sqrt(float(np.mean(err**2)))
    if float(np.min(np.abs(v))) <= PRESENCE_Z * se:
        return None
    found = set(dates)
    key = parameter[len("pdtv.") : -len(".amplitude")]
    direction = "both"
    for suffix in ("positive", "negative"):
        if key.endswith("." + suffix):
            key, direction = key[: -len(suffix) - 1], suffix
    order = float(key)
    days_all = sorted(identified)
    present = [
        d in found
        or any(abs(o - order) <= ORDER_MATCH and dn == direction for o, dn in identified[d])
        for d in days_all
    ]
    if all(present):
        return None
    notes = []
    k = 0
    while k < len(days_all):
        if present[k]:
            k += 1
            continue
        end = k
        while end + 1 < len(days_all) and not present[end + 1]:
            end += 1
        gone = days_all[k] if end == k else f"{days_all[k]} to {days_all[end]}"
        if k == 0:
            first = days_all[end + 1]
            count = end + 1
            notes.append(
                f"appears on {first} at {values[dates.index(first)]:.3g} ({abs(v).min() / se:.0f}"
                f" standard errors; not found on the {count} identified "
                f"day{'' if count == 1 else 's'} before)"
            )
        elif end == len(days_all) - 1:
            notes.append(f"not found from {days_all[k]} on (last found on {days_all[k - 1]})")
        else:
            notes.append(f"not found on {gone} (found before and after)")
        k = end + 1
    # the trend over every identified day, the missing ones at 0; the notes say what happened
    by_date = dict(zip(dates, values, strict=True))
    full = [by_date.get(d, 0.0) for d in days_all]
    series = _series(robot, joint, parameter, days_all, full, [se] * len(days_all))
    assert series is not None  # two distinct days or more, a nonzero value
    return dataclasses.replace(series, flag=True, note="; ".join(notes))


def _one_speed_note(order: float, speeds: list[list[float]]) -> str:
    """What a line found or missed from day to day may be when every day's PDTV came from
    passes at one speed (speeds within :data:`torquemap.time_lines.LEVEL_TOLERANCE`): a ripple
    fixed in time at ``order |v| / 2 pi`` Hz sits at that order there, and identify cannot tell
    it from a line of the motor angle (docs/identification.md, "Lines fixed in time"); ``""``
    when some day had two speeds or none are recorded. No commas: the note is a CSV field."""
    from torquemap.time_lines import LEVEL_TOLERANCE

    if not speeds or any(not day for day in speeds):
        return ""
    magnitudes = np.abs(np.concatenate([np.asarray(day, dtype=float) for day in speeds]))
    low, high = float(magnitudes.min()), float(magnitudes.max())
    if not (low > 0.0 and high <= low * (1.0 + LEVEL_TOLERANCE)):
        return ""
    speed = float(np.median(magnitudes))
    return (
        f"every day's PDTV from passes at one speed ({speed:.3g} rad/s) where a ripple of "
        f"{order * speed / (2 * math.pi):.4g} Hz in time (current loop or PWM or mains) sits at "
        "this order too and cannot be told from a line of the motor angle: sweep a second speed "
        "10 % apart or more to tell"
    )


def fleet_drift(out_dir: str | os.PathLike[str]) -> FleetDrift:
    """Trends of every robot's friction and PDTV over the days of a fleet identification.

    Parameters
    ----------
    out_dir
        The output folder of :func:`torquemap.fleet.identify_fleet`.

    Returns
    -------
    FleetDrift
        One series per robot, joint and parameter present on enough days (two with standard
        errors, else three), and the robots that have none.

    Raises
    ------
    InputError
        When ``out_dir`` holds no ``fleet-run.toml`` or a model file is unreadable.
    """
    out = Path(out_dir)
    if not out.is_dir():
        raise InputError("not a fleet output folder (no such folder)", path=out)
    runs = read_run(out)
    skipped: list[str] = []
    # robot -> joint -> parameter -> (dates, values, errors)
    table: dict[str, dict[str, dict[str, tuple[list[str], list[float], list[float]]]]] = (
        defaultdict(lambda: defaultdict(dict))
    )
    order: list[str] = []
    days_of: dict[str, int] = defaultdict(int)
    # robot -> joint -> date identified -> its PDTV lines as (order, direction): a line's
    # absence on one of those days is information
    seen: dict[str, dict[str, dict[str, list[tuple[float, str]]]]] = defaultdict(
        lambda: defaultdict(dict)
    )
    # robot -> joint -> date identified -> the motor speeds its PDTV came from [rad/s]
    pdtv_speeds: dict[str, dict[str, dict[str, list[float]]]] = defaultdict(
        lambda: defaultdict(dict)
    )
    for entry in sorted(runs, key=lambda e: (str(e.get("robot")), str(e.get("date")))):
        robot, date = str(entry.get("robot")), str(entry.get("date"))
        if not entry.get("ok"):
            skipped.append(f"{robot} {date}: {entry.get('reason', 'failed')}")
            continue
        model = load_model(out / str(entry["model"]))
        if robot not in order:
            order.append(robot)
        days_of[robot] += 1
        for joint in model.robot.joint_names:
            seen[robot][joint][date] = [(ln.order, ln.direction) for ln in model.joints[joint].pdtv]
            notes = model.notes.get("joints", {}).get(joint, {})
            recorded = notes.get("pdtv_speeds", []) if isinstance(notes, Mapping) else []
            pdtv_speeds[robot][joint][date] = [
                float(v) for v in recorded if isinstance(v, int | float) and math.isfinite(v)
            ]
            errors = _standard_errors(model, joint)
            for parameter, value in _parameters(model, joint).items():
                dates, values, errs = table[robot][joint].setdefault(parameter, ([], [], []))
                dates.append(date)
                values.append(value)
                errs.append(errors.get(parameter, math.nan))
    series: list[DriftSeries] = []
    too_few = []
    for robot in order:
        count = len(series)
        for joint, params in table[robot].items():
            for parameter, (dates, values, errs) in params.items():
                s = _presence(robot, joint, parameter, seen[robot][joint], dates, values, errs)
                if s is not None:
                    key = parameter[len("pdtv.") : -len(".amplitude")]
                    order_cpr = float(key.removesuffix(".positive").removesuffix(".negative"))
                    speeds = list(pdtv_speeds[robot][joint].values())
                    caution = _one_speed_note(order_cpr, speeds)
                    if caution:
                        s = dataclasses.replace(s, note=f"{s.note}; {caution}")
                if s is None:
                    s = _series(robot, joint, parameter, dates, values, errs)
                if s is not None:
                    series.append(s)
        if len(series) == count:
            n = days_of[robot]
            too_few.append(f"{robot}: {n} identified day{'s' if n != 1 else ''}")
    return FleetDrift(series=tuple(series), skipped=tuple(skipped), too_few=tuple(too_few))


def drift_columns(drift: FleetDrift) -> dict[str, NDArray[Any]]:
    """The table ``fleet drift -o`` writes: one row per series."""
    s = drift.series
    return {
        "robot": np.array([x.robot for x in s], dtype=object),
        "joint": np.array([x.joint for x in s], dtype=object),
        "parameter": np.array([x.parameter for x in s], dtype=object),
        "days": np.array([x.values.size for x in s]),
        "first": np.array([x.values[0] for x in s]),
        "last": np.array([x.values[-1] for x in s]),
        "slope_per_day": np.array([x.slope for x in s]),
        "slope_se": np.array([x.slope_se for x in s]),
        "change": np.array([x.change for x in s]),
        "change_se": np.array([x.change_se for x in s]),
        "sigma_source": np.array([x.sigma_source for x in s], dtype=object),
        "flag": np.array([int(x.flag) for x in s]),
        "note": np.array([x.note for x in s], dtype=object),
    }
